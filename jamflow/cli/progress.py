"""Progress display for protocols (an observer: called once per minimisation): a tqdm bar on
a terminal, plain infrequent lines (``jamflow.support.progress.PlainProgress``) in pipes and logs."""

from __future__ import annotations

import functools

from jamflow.support.progress import PlainProgress, is_terminal

QUIET_UNTIL_WORK = 1e-3  # tqdm's delay (s): > 0 and above the round-off of time.time(), so nothing draws early


class HiddenBar:
    """What a disabled bar does (counts, draws nothing), without importing tqdm: a ``--quiet``
    run's start-up (measured in docs/notes/speed-2.md) does not pay for it."""

    def __init__(self, total=None):
        self.n, self.total = 0, total

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def set_postfix_str(self, *args, **kwargs):
        pass

    def update(self, k=1):
        self.n += k

    def close(self):
        pass


def progress_bar(disable: bool = False, **kwargs):
    """A tqdm bar (rate, ETA) that draws nothing before its first update: a run refused before
    any work prints its one error line only (tqdm draws a delayed bar neither on creation nor,
    if never drawn, on close). Like every tqdm bar it draws at most every 0.1 s; a bar updated
    but closed before its first draw (a run shorter than 0.1 s) draws its final line on close.
    Disabled: a ``HiddenBar``. Where the stream (``file``, default stderr) is not a terminal:
    ``PlainProgress``, plain lines without carriage returns or cursor codes."""
    if disable:
        return HiddenBar(kwargs.get("total"))
    if not is_terminal(kwargs.get("file")):
        return PlainProgress(**kwargs)
    return _shown_bar_class()(delay=QUIET_UNTIL_WORK, dynamic_ncols=True, **kwargs)


@functools.cache
def _shown_bar_class():
    from tqdm import tqdm

    class ShownBar(tqdm):
        def close(self):
            never_drawn = not self.disable and self.last_print_t < self.start_t + self.delay
            if never_drawn and self.n > 0:
                self.last_print_t = self.start_t + self.delay  # tqdm's close() then writes the final line
            super().close()

    return ShownBar


class CompressionProgress:
    """A tqdm bar over minimisations with rate, phi, V and the current increment.

    The number of minimisations is unknown in advance (the bisection ends when V lands in the
    window, and the fast protocol grows its increments again after each reversal), so while the
    run goes the bar counts minimisations without a total, and the postfix's dphi tells how far
    the bisection has come. An estimated total (from the halvings still needed) moved up and down
    and made the percentage jump back (60% 59/98, then 70% 91/130). A run that ends sets
    the total to the minimisations it made, so its last line reads 100 %; a run that fails leaves
    the bar where it stopped.
    """

    def __init__(self, disable: bool = False):
        self.bar = progress_bar(desc="jam", unit="min", disable=disable)

    def __enter__(self):
        return self

    def __exit__(self, exc_type, *exc):
        if exc_type is None and self.bar.n > 0:
            self.bar.total = self.bar.n  # the count is known now: the final line reads 100 %
        self.bar.close()

    def __call__(self, step: dict) -> None:
        res = step["result"]
        self.bar.set_postfix_str(f"phi={step['phi']:.9f} V={res.energy_per_particle:.2e} dphi={step['dphi']:.1e}",
                                 refresh=False)
        self.bar.update(1)


class ShearProgress:
    """A tqdm bar over the steps of a shear path (total known) with gamma, phi_J and the
    number of steps whose contact network changed so far."""

    def __init__(self, disable: bool = False):
        self.bar = progress_bar(desc="shear", unit="step", disable=disable)
        self.changes = 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.bar.close()

    def __call__(self, step, k: int, total: int) -> None:
        self.bar.total = total
        self.changes += bool(step.changed)
        self.bar.set_postfix_str(f"gamma={step.gamma:.5f} phi_J={step.phi_j:.8f} changes={self.changes}",
                                 refresh=False)
        self.bar.update(1)
