"""Where the particles start at the next packing fraction of a compression (issue 17, item 2).

``affine`` (the seed's ``change_box ... remap``): positions scale with the box. ``secant``:
above jamming the minimum moves with phi along a smooth branch while the contact network
does not change, so the last two force-balanced jammed states (phi_0, u_0), (phi_1, u_1)
give a first-order prediction of the next one,

    u(phi) = u_1 + (u_1 - u_0) (phi - phi_1) / (phi_1 - phi_0),

in coordinates u = x / (box scale) of the base box (the periodic difference u_1 - u_0 in
its minimum image), i.e. the affine remap plus the extrapolated non-affine relaxation (the
secant form of the linear response H^-1 dF/dphi). It is used only where it is safe: both
states jammed, the same contact network in both, and the predicted state keeps it (no
contact broken or formed); everywhere else the affine remap (``Prediction.kind`` says which
was used; docs/speed-2.md measures what it saves).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

PREDICTORS = ("affine", "secant")
# the contact networks compared may differ by this fraction of contacts: with 0 (an exact match)
# 8 seeds at N = 256 took 727 824 iterations, with 0.005 / 0.02 / 0.05 712 735 / 710 529 /
# 698 859 (affine 758 593), every phi_J the affine one to 10 digits (docs/speed-2.md)
MAX_NETWORK_CHANGE = 0.05


@dataclass(frozen=True)
class _Jammed:
    phi: float
    u: np.ndarray  # positions in base-box units
    contacts: np.ndarray  # sorted pair ids i * N + j of overlapping pairs


class SecantPredictor:
    """Remembers the last two jammed states of one compression and predicts the next start."""

    def __init__(self, base_box, base_phi: float, dim: int, max_change: float | None = None):
        self.base_box, self.base_phi, self.dim = base_box, base_phi, dim
        self.max_change = MAX_NETWORK_CHANGE if max_change is None else max_change
        self.states: list[_Jammed] = []

    def _scale(self, phi: float) -> float:
        return (self.base_phi / phi) ** (1.0 / self.dim)

    def record(self, phi: float, packing, jammed: bool) -> None:
        """After a minimisation: keep a converged jammed state, forget them all at an unjammed one."""
        if not jammed:
            self.states.clear()
            return
        keep = [s for s in self.states[-1:] if s.phi != phi]  # a state minimised again in place replaces itself
        self.states = [*keep, _Jammed(phi, packing.positions / self._scale(phi), contact_ids(packing))]

    def predict(self, phi: float, template) -> tuple[str, np.ndarray | None]:
        """("secant", positions at ``phi``) where the secant applies, else (reason, None)."""
        if len(self.states) < 2:
            return "affine: fewer than two jammed states", None
        old, new = self.states
        if network_change(old.contacts, new.contacts) > self.max_change:
            return "affine: the contact network changed between the last two states", None
        du = self.base_box.minimum_image(new.u - old.u)
        u = new.u + du * ((phi - new.phi) / (new.phi - old.phi))
        scale = self._scale(phi)
        predicted = template.with_positions(self.base_box.scaled(scale).wrap(u * scale),
                                            box=self.base_box.scaled(scale))
        if network_change(contact_ids(predicted), new.contacts) > self.max_change:
            return "affine: the predicted state breaks or forms contacts", None
        return "secant", predicted.positions


def network_change(a: np.ndarray, b: np.ndarray) -> float:
    """Contacts in one network and not the other, as a fraction of the larger network."""
    return len(np.setxor1d(a, b, assume_unique=True)) / max(len(a), len(b), 1)


def contact_ids(packing) -> np.ndarray:
    """Sorted ids i * N + j of the overlapping pairs (the contact network)."""
    from ..pairs import overlapping_pairs

    i, j = overlapping_pairs(packing)[:2]
    return np.sort(i.astype(np.int64) * packing.n + j)
