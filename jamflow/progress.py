"""Progress display for protocols (an observer: called once per minimisation)."""

from __future__ import annotations

import math


class _Hidden:
    """What a disabled bar does (nothing), without importing tqdm: ``--quiet`` start-up."""

    n, total = 0, None

    def set_postfix_str(self, *args, **kwargs):
        pass

    def update(self, k=1):
        self.n += k

    def close(self):
        pass


def _bar(desc: str, unit: str, disable: bool):
    """A tqdm bar with rate and ETA, or a hidden one."""
    if disable:
        return _Hidden()
    from tqdm import tqdm

    return tqdm(desc=desc, unit=unit, dynamic_ncols=True)


class CompressionProgress:
    """A tqdm bar over minimisations with rate, phi, V and the current increment.

    The total is unknown in advance (the bisection ends when V lands in the window), so
    the bar's ETA estimates it from the halvings still needed to shrink dphi to ~1e-9.
    """

    def __init__(self, disable: bool = False):
        self.bar = _bar("jam", "min", disable)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.bar.close()

    def __call__(self, step: dict) -> None:
        res = step["result"]
        halvings_left = max(0.0, math.log2(max(step["dphi"], 1e-300) / 1e-9))
        self.bar.total = max(self.bar.n + 1, int(self.bar.n + 1 + 2 * halvings_left))
        self.bar.set_postfix_str(f"phi={step['phi']:.9f} V={res.energy_per_particle:.2e} dphi={step['dphi']:.1e}",
                                 refresh=False)
        self.bar.update(1)


class ShearProgress:
    """A tqdm bar over the steps of a shear path (total known) with gamma, phi_J and the
    number of steps whose contact network changed so far."""

    def __init__(self, disable: bool = False):
        self.bar = _bar("shear", "step", disable)
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
