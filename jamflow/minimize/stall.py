"""Early decisions: a minimisation that only decides "jammed" stops once its energy has stalled
far above the energy window (issue 27 item 1).

The chapter (section 2.1, steps 2-3) decides the side of each compression step at a local
minimum: below jamming if V < V_tol, above if V > 2 V_tol, with the minimum found to its rule
(a), a relative energy change below delta = 1e-16 between steps, or rule (b), V < V_min. An
approach minimisation of the fast protocol needs less: its state is either unjammed, which rule
(b) already decides at the first iteration with V < V_min <= V_tol (the compiled FIRE checks it
every iteration), or jammed, and then it only feeds a Newton jump that shrinks phi - phi_J by at
most ``newton_ratio`` (``protocols.compression.PhiStepper``). ``StallWatch`` is rule (a) at a
coarser accuracy, with guards:

- it decides only while V > ``above`` (the fast protocol: ``STALL_ABOVE`` x 2 V_tol), so a
  stalled state is far above the window and never feeds the final jump to it (which starts at
  V <= ~54 V_tol: phi - phi_J <= 6x the window's, V ~ (phi - phi_J)^2);
- stalled means V fell by less than ``floor`` x V over the last ``span`` iterations (at least),
  sampled every ``every`` iterations; a minimisation younger than ``span`` never stalls. The
  span and floor were chosen on energy traces of default jams (N = 256 and 1024, seeds 1-5), where
  FIRE pauses on plateaus that fall by ~0.75 % per 2000 iterations before falling again by 4x
  (N = 1024 seed 2; a 1 % per 1000 rule stopped there); at 0.3 % per 2000 the stopped V was within
  5 % of the converged one on those traces.

Minimisations that decide the window (V near V_tol .. 2 V_tol) never stop this way: the rule is
off there by ``above``, and the protocol runs them at full force accuracy.

Measured (``CompressionSettings.early_decisions``, docs/notes/speed-3.md): it saves few
iterations (-1.3 % at N = 256, -3.1 % at N = 1024) -- the relaxation a stalled state leaves
undone is done in the next minimisation, and the Newton jump, which removes ~90 % of
phi - phi_J, magnifies its error ~10x -- and a state creeping just above a threshold can be
called jammed where it would have unjammed (3 of 12 onsets at N = 1024 moved), so the fast
protocol does not use it by default.
"""

from __future__ import annotations

STALL_ABOVE = 1e3  # the fast protocol decides "jammed" early only at V > 1e3 x 2 V_tol
EVERY = 500  # iterations between energy samples
SPAN = 2000  # iterations over which a stalled energy must have fallen by less than FLOOR x V
FLOOR = 3e-3


class StallWatch:
    """Energy samples of one minimisation of ``n`` mobile particles; ``sample`` says when it has
    stalled above ``above`` (energies per particle, eps). Engines call the watch itself every
    ``every`` iterations of a window (``Engine.minimizer_session``), ``minimize`` at each window's
    end; ``offset`` is the minimisation's iteration count when the window began."""

    def __init__(self, above: float, n: int, span: int = SPAN, floor: float = FLOOR, every: int = EVERY):
        self.above, self.n, self.span, self.floor, self.every = above, n, span, floor, every
        self.offset = 0
        self.samples: list[tuple[int, float]] = []  # (iteration of the minimisation, V per particle)
        self.stalled = False

    def __call__(self, iterations: int, objective: float) -> bool:
        """``sample`` at ``iterations`` into the current window, of the total energy ``objective``."""
        return self.sample(self.offset + iterations, objective / self.n)

    def sample(self, iteration: int, energy: float) -> bool:
        """Record V at ``iteration``; True once the minimisation has stalled far above the window."""
        if not self.stalled and (not self.samples or iteration > self.samples[-1][0]):  # a window's end comes twice
            self.samples.append((iteration, energy))
            self.stalled = stalled(self.samples, self.above, self.span, self.floor)
        return self.stalled


def stalled(samples, above: float, span: int, floor: float) -> bool:
    """True if the last sample's V > ``above`` and V fell by less than ``floor`` x V since the
    latest sample at least ``span`` iterations earlier. ``samples``: (iteration, V) in order."""
    now, v = samples[-1]
    if not v > above:
        return False
    before = [e for it, e in samples if it <= now - span]
    return bool(before) and before[-1] - v < floor * v
