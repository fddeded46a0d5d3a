"""Strain sweeps: the moduli from the relaxed stress at small strains (chapter section 4.5).

For each strain of ``analysis.strains`` (simple shear with the shear-periodic cell, isotropic
compression) and each amplitude a of the sweep, both signs, the packing is strained affinely from
the base state (``Strain.cell``: box and centres, the engine's ``set_box``), relaxed by the
minimiser at that fixed strain, and its stress response R (Sigma = -P_xy or P) is measured. The
base state is the input packing relaxed by the same minimiser at a = 0 (for a minimised packing
that is a few iterations), so every response is measured on equal terms.

- Central slopes c(a) = (R(a) - R(-a)) / 2a (no even-order terms); one-sided slopes
  (R(+-a) - R(0)) / +-a.
- Yield: the first amplitude at which the contact network differs from the base state's
  (contacts removed or added, ``pairs.particle_contacts``) or a one-sided slope jumps away from the
  reference slope (median central slope of the first three amplitudes) by more than ``jump_tol``.
  ``yield_strain`` is that amplitude (NaN if none is seen).
- Linear regime and fit: the amplitudes below the yield whose central slope lies within
  ``linear_tol`` of the fitted modulus M, where M and kappa fit c(a) = M + kappa a^2 (the odd
  part of R(a) = R(0) + M a + kappa a^3 + ...) by least squares over those amplitudes (iterated
  until the set is stable), each weighted by a^2 because the relaxed response carries an
  amplitude-independent error (the minimiser's residual forces and round-off), so c errs by
  ~1/a. The error is the standard error of M from the fit residuals.
- Round-off: at amplitude a the response changes by M a while the response itself carries a
  floating-point error of about eps sqrt(N_c) k sigma L / V (every separation is known to
  eps L; k the contact stiffness, N_c contacts); ``roundoff_amplitude`` is their ratio, and a
  sweep below it is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jamflow.engines.choose import open_engine
from jamflow.mechanics.force_floor import FORCE_TOL_BASE
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs, overlapping_sites
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.strains import Strain
from jamflow.minimize.rules import minimize
from jamflow.support.reprs import changed_fields_repr
from jamflow.support.settings_errors import SettingError

DEFAULT_AMPLITUDES = tuple(float(a) for a in np.logspace(-9, -3, 13))  # two per decade, 1e-9 .. 1e-3
LINEAR_TOL = 1e-4  # relative deviation of a central slope from M that still counts as linear
JUMP_TOL = 0.5  # relative deviation of a one-sided slope that counts as a yield (for good: a stress drop)
PAST_YIELD = 2  # amplitudes measured beyond the first yield (for the stress-strain curve), then stop
FLOOR_FACTOR = 0.01  # sweep force tolerance / the default one: below the round-off floor, so every
# relaxation runs until it stops making progress (the floor), checked every SWEEP_WINDOW iterations
SWEEP_WINDOW = 10000
SWEEP_MAX_ITERATIONS = 200_000  # a relaxation still running by then is near an instability: not in the fit
NEAR_TOL = Contacts().near_tol  # |r / sigma - 1| below this: touching at round-off, not a firm contact


def sweep_minimizer(packing: Packing) -> MinimizerSettings:
    """FIRE relaxing to the round-off floor: at the default tolerance (1e-14 eps/diameter) the
    response of N = 256 disks errs by ~4e-15 eps/diameter^2, at the floor by ~4e-16."""
    # the disks' base for every shape, on purpose: the tolerance is to lie below the round-off floor
    # so that each relaxation runs to 'no-progress'. The ellipses' base (5e-13) is no round-off floor
    # but a cap on the creep of jamming near onset; FLOOR_FACTOR of it (5e-15) could end ellipse
    # relaxations above their floor and blur the responses the moduli are fitted to.
    tol = MinimizerSettings().resolved_force_tol(packing.box, packing.potential.contact_stiffness, base=FORCE_TOL_BASE)
    return MinimizerSettings(force_tol=FLOOR_FACTOR * tol, window=SWEEP_WINDOW, max_iterations=SWEEP_MAX_ITERATIONS)


@dataclass(frozen=True)
class SweepSettings:
    """Amplitudes (dimensionless strains, ascending), tolerances and the minimiser of the sweeps."""

    amplitudes: tuple = DEFAULT_AMPLITUDES  #: strains, ascending, > 0 and < 0.5 (default 1e-9 .. 1e-3, two per decade)
    linear_tol: float = LINEAR_TOL  #: relative deviation of a central slope from the modulus that still counts as linear
    jump_tol: float = JUMP_TOL  #: relative jump of a one-sided slope that counts as a yield
    past_yield: int = PAST_YIELD  #: amplitudes measured beyond the first yield, then the sweep stops
    minimizer: MinimizerSettings | None = None  #: None: ``sweep_minimizer`` (FIRE to the round-off floor)

    __repr__ = changed_fields_repr  # only the fields that differ from their defaults

    def __post_init__(self):
        amps = np.asarray(self.amplitudes, float)
        if amps.ndim != 1 or len(amps) < 1 or not np.all(np.isfinite(amps)) or np.any(amps <= 0):
            raise ValueError(f"sweep amplitudes must be finite positive strains, got {self.amplitudes!r}")
        if np.any(np.diff(amps) <= 0):
            raise ValueError("sweep amplitudes must be strictly increasing")
        if amps[-1] >= 0.5:
            raise ValueError(f"the largest amplitude {amps[-1]:g} is not a small strain; keep amplitudes below 0.5")
        for name in ("linear_tol", "jump_tol"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 < value < 1):
                raise SettingError(name, f"must lie in (0, 1), got {value!r}")
        if not (isinstance(self.past_yield, (int, np.integer)) and self.past_yield >= 0):
            raise SettingError("past_yield", f"must be an integer >= 0, got {self.past_yield!r}")
        if self.minimizer is not None and self.minimizer.pressure is not None:
            raise ValueError("the sweeps relax at fixed strain; the minimiser takes no target pressure")
        object.__setattr__(self, "amplitudes", tuple(float(a) for a in amps))


@dataclass(frozen=True)
class SweepResult:
    """One strain's sweep: every relaxed point and the fit."""

    strain: Strain  #: the deformation swept (``mechanics.strains.SHEAR`` or ``BULK``)
    strains: np.ndarray  #: (M,) signed amplitudes measured, ascending, with 0 (the base state)
    responses: np.ndarray  #: (M,) R: Sigma or P, eps / diameter^d
    energies: np.ndarray  #: (M,) energy per particle, eps
    iterations: np.ndarray  #: (M,) minimiser iterations
    max_forces: np.ndarray  #: (M,) largest force component after relaxation
    reasons: np.ndarray  #: (M,) minimiser stop reasons
    added: np.ndarray  #: (M,) backbone contacts present that the base state does not have
    removed: np.ndarray  #: (M,) backbone contacts of the base state that are gone
    rattler_changes: np.ndarray  #: (M,) contacts of base-state floaters that appeared or went
    amplitudes: np.ndarray  #: (K,) positive amplitudes measured
    central_slopes: np.ndarray  #: (K,) (R(a) - R(-a)) / 2a of each amplitude, eps / diameter^d
    reference_slope: float  #: median central slope of the first three amplitudes (the yield test's reference)
    linear: np.ndarray  #: (K,) bool: in the linear regime
    modulus: float  #: NaN without a linear regime
    error: float  #: standard error of the modulus (NaN with one amplitude)
    curvature: float  #: kappa of c(a) = M + kappa a^2 (0 with fewer than three linear amplitudes)
    yield_strain: float  #: NaN if none seen
    yield_reason: str  #: "contacts", "stress" or ""
    base: Packing  #: the base state: the input relaxed at zero strain by the sweep's minimiser

    def __repr__(self) -> str:
        """One line: strain, points, modulus and error, linear range, the yield."""
        return (f"SweepResult(strain={self.strain.kind!r}, points={len(self.strains)}, modulus={self.modulus:.6e}, "
                f"error={self.error:.1e}, linear={int(np.sum(self.linear))}/{len(self.linear)}, "
                f"yield_strain={self.yield_strain:.2g}, yield_reason={self.yield_reason!r}, N={self.base.n})")

    @property
    def base_response(self) -> float:
        """R of the base state (zero strain): Sigma or P, eps / diameter^d."""
        return float(self.responses[self.strains == 0][0])

    @property
    def linear_max(self) -> float:
        """Largest amplitude of the linear regime (NaN without one)."""
        return float(self.amplitudes[self.linear].max()) if self.linear.any() else math.nan


def roundoff_amplitude(packing: Packing, modulus: float) -> float:
    """The strain at which the response change |M| a equals the response's floating-point error
    eps sqrt(N_c) k sigma L / V (module docstring). ``modulus`` M in eps / diameter^d."""
    _, _, r, sigma = touching(packing)
    if not len(r):
        return math.inf
    stiffness = float(np.median(np.abs(packing.potential.d2v_dr2(r, sigma))))
    noise = np.finfo(float).eps * math.sqrt(len(r)) * stiffness * float(np.median(sigma)) \
        * float(packing.box.lengths.max()) / packing.box.volume
    return noise / abs(modulus) if modulus else math.inf


class StrainSweep:
    """Sweep one strain over ``settings.amplitudes`` with an engine (``engine``: auto, lammps,
    numba; ``engine_options`` to its constructor). ``observers``: callables f(point: dict) after
    every relaxation (progress bars)."""

    def __init__(self, settings: SweepSettings | None = None, engine: str = "auto", engine_options=None):
        self.settings = settings or SweepSettings()
        self.engine, self.engine_options = engine, dict(engine_options or {})

    def compute(self, packing: Packing, strain: Strain, observers=()) -> SweepResult:
        """Relax ``packing`` at zero strain (the base state), then at +-a for each amplitude a
        (from the base state), until ``past_yield`` amplitudes past a yield; fit the modulus.

        Parameters
        ----------
        packing : jamflow.Packing
            A jammed packing in a periodic box.
        strain : Strain
            ``SHEAR`` (R = Sigma, modulus G) or ``BULK`` (R = P, modulus B).
        observers : iterable of callable, optional
            Each called with {"strain", "amplitude", "point"} after every relaxation.

        Returns
        -------
        SweepResult
            Every relaxed point, the linear regime, the modulus (eps / diameter^d) and the yield.
        """
        s = self.settings
        minimizer = s.minimizer or sweep_minimizer(packing)
        with open_engine(packing, minimizer.method, self.engine, **self.engine_options) as sim:
            base = _relax(sim, packing, strain, 0.0, minimizer, None)
            points = {0.0: base}
            for observe in observers:
                observe({"strain": strain, "amplitude": 0.0, "point": base})
            for a in s.amplitudes:
                for signed in (a, -a):
                    point = _relax(sim, base["packing"], strain, signed, minimizer, base["contacts"])
                    points[signed] = point
                    for observe in observers:
                        observe({"strain": strain, "amplitude": signed, "point": point})
                fit = _fit(strain, points, s)
                beyond = int(np.sum(fit["amplitudes"] > fit["yield_strain"]))  # amplitudes past the yield
                if fit["yield_reason"] and beyond >= s.past_yield:
                    break
        return _result(strain, points, fit)


def _relax(sim, base: Packing, strain: Strain, amplitude: float, minimizer, base_contacts) -> dict:
    """Strain the base packing affinely by ``amplitude``, relax, measure."""
    sim.set_box(base.box)
    sim.set_positions(base.positions, base.orientations)
    if amplitude:
        sim.set_box(strain.cell(base.box, amplitude))
    result = minimize(sim, minimizer)
    if result.reason == "blown-up":
        raise RuntimeError(f"the relaxation at {strain.kind} strain {amplitude:g} diverged (max force "
                           f"{result.max_force:.3g}); lower the minimiser timestep")
    state = sim.state()
    relaxed = sim.packing()
    contacts = _contact_set(relaxed)
    added = removed = rattler = 0
    if base_contacts is None:  # the base state: its floaters (rattlers) are found once
        floater = Contacts().compute(relaxed).floater
    else:
        floater = base_contacts["floater"]
        changed = contacts ^ base_contacts["set"]
        backbone = {(i, j) for i, j in changed if not (floater[i] or floater[j])}
        added, removed = len(backbone & contacts), len(backbone - contacts)
        rattler = len(changed) - len(backbone)
    return dict(packing=relaxed, contacts={"set": contacts, "floater": floater},
                response=strain.response(state.pressure_tensor), energy=result.energy_per_particle,
                iterations=result.iterations, max_force=result.max_force, reason=result.reason, added=added,
                removed=removed, rattler=rattler)


def touching(packing: Packing):
    """(i, j, r, sigma) of every overlapping pair (of sites of different bodies for rigid bodies,
    reported by body)."""
    if packing.shape.made_of_sites:
        i, j, _, _, _, r, sigma = overlapping_sites(packing)
    else:
        i, j, _, r, sigma = overlapping_pairs(packing)
    return i, j, r, sigma


def _contact_set(packing: Packing, tol: float = NEAR_TOL) -> set:
    """Pairs (i < j) in firm contact: r < (1 - tol) sigma (for rigid bodies any of their site
    pairs). A pair within ``tol`` of touching carries a force at round-off level and may flicker
    at any strain (a rattler resting on a neighbour at r / sigma - 1 = -1e-16): it is no
    contact change (``Contacts`` counts such pairs as near-contacts, the same tolerance)."""
    i, j, r, sigma = touching(packing)
    firm = r < (1.0 - tol) * sigma
    lo, hi = np.minimum(i, j)[firm], np.maximum(i, j)[firm]
    return set(zip(lo.tolist(), hi.tolist()))


def _fit(strain: Strain, points: dict, s: SweepSettings) -> dict:
    """Central slopes, yield and linear-regime fit of the amplitudes measured so far."""
    r0 = points[0.0]["response"]
    amps = np.array(sorted(a for a in points if a > 0))
    plus = np.array([points[a]["response"] for a in amps])
    minus = np.array([points[-a]["response"] for a in amps])
    central = (plus - minus) / (2 * amps)
    one_sided = np.stack([(plus - r0) / amps, (r0 - minus) / amps], axis=1)
    changed = np.array([sum(points[x][k] for x in (a, -a) for k in ("added", "removed")) > 0 for a in amps])
    n_first = 0  # the reference: the first (up to three) amplitudes, while the contacts stay
    while n_first < min(3, len(amps)) and not changed[n_first]:
        n_first += 1
    reference = float(np.median(central[:n_first])) if n_first else math.nan
    off = np.abs(one_sided - reference).max(axis=1) > s.jump_tol * abs(reference) if n_first else changed
    jumped = np.flip(np.logical_and.accumulate(np.flip(off)))  # off here and at every larger amplitude
    yielded = changed | jumped
    k_yield = int(np.argmax(yielded)) if yielded.any() else len(amps)
    capped = np.array([any(points[x]["reason"] == "iteration-cap" for x in (a, -a)) for a in amps])
    modulus, error, curvature, linear = _linear_fit(amps, central, k_yield, s.linear_tol, ~capped)
    y_strain = float(amps[k_yield]) if k_yield < len(amps) else math.nan
    reason = "" if k_yield == len(amps) else ("contacts" if changed[k_yield] else "stress")
    return dict(amplitudes=amps, central=central, reference=reference, linear=linear, modulus=modulus,
                error=error, curvature=curvature, yield_strain=y_strain, yield_reason=reason)


def _linear_fit(amps, central, k_yield, linear_tol, relaxed):
    """(M, error, kappa, linear mask): c(a) = M + kappa a^2 (R = R0 + M a + kappa a^3 + even
    terms) fitted by weighted least squares to the central slopes below the yield whose distance
    from M is within ``linear_tol`` |M| (iterated), weights a^2 (the round-off of c is ~1/a);
    ``relaxed``: amplitudes whose relaxations both ended before the iteration cap."""
    candidates = (np.arange(len(amps)) < k_yield) & relaxed
    index = np.flatnonzero(candidates)
    if not len(index):
        return math.nan, math.nan, math.nan, candidates
    steps = np.abs(np.diff(central[index]))  # the flattest neighbours start the iteration
    flat = int(np.argmin(steps)) if len(steps) else 0
    modulus = float(np.mean(central[index[flat:flat + 2]]))
    linear, error, curvature = candidates, math.nan, math.nan
    for _ in range(8):
        within = (np.abs(central - modulus) <= linear_tol * abs(modulus)) & candidates
        if not within.any():
            return math.nan, math.nan, math.nan, within
        if np.array_equal(within, linear) and np.isfinite(curvature):
            break
        linear = within
        modulus, error, curvature = _weighted_fit(amps[linear], central[linear])
    return modulus, error, curvature, linear


def _weighted_fit(a, c):
    """(M, standard error of M, kappa) of c = M + kappa a^2 with weights a^2; with fewer than
    three points kappa = 0 (and with one point no error)."""
    if len(a) < 3:
        m = float(np.average(c, weights=a**2))
        err = float(abs(c[1] - c[0]) / 2) if len(a) == 2 else math.nan
        return m, err, 0.0
    x = np.column_stack([np.ones_like(a), a**2]) * a[:, None]
    coef, *_ = np.linalg.lstsq(x, c * a, rcond=None)
    resid = c * a - x @ coef
    cov = np.linalg.inv(x.T @ x) * float(resid @ resid) / (len(a) - 2)
    return float(coef[0]), float(math.sqrt(cov[0, 0])), float(coef[1])


def _result(strain: Strain, points: dict, fit: dict) -> SweepResult:
    order = sorted(points)

    def col(key, dtype=float):
        return np.array([points[a][key] for a in order], dtype=dtype)

    return SweepResult(strain, np.array(order), col("response"), col("energy"), col("iterations", int),
                       col("max_force"), col("reason", object).astype(str), col("added", int), col("removed", int),
                       col("rattler", int), fit["amplitudes"], fit["central"], fit["reference"], fit["linear"],
                       fit["modulus"], fit["error"], fit["curvature"], fit["yield_strain"], fit["yield_reason"],
                       points[0.0]["packing"])
