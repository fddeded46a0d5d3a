"""Cross-check: the LAMMPS deck and the Python controller from the same start.

Both start from one data file (jamflow's random start at phi0) with the same parameters;
the deck runs in a separate ``lmp`` process (any LAMMPS build), the controller through the
LAMMPS Python module. On the same build and one rank they execute the same floating-point
operations, so their histories agree bit for bit; another build or MPI ranks sum forces
in another order, and FIRE trajectories near jamming can then part from round-off.
``CrossCheck`` reports the phi_J difference, the contact networks (pairs with r < sigma,
no tolerance), the largest displacement between the two final packings and the first
minimisation at which the histories differ.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from jamflow.decks.jam import DeckResult, deck_variables, run_deck
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.model.packing import Packing
from jamflow.model.pairs import overlapping_pairs
from jamflow.protocols.compression import compress, initial_packing
from jamflow.protocols.outcome import JamResult
from jamflow.protocols.settings import CompressionSettings


@dataclass(frozen=True)
class CrossCheck:
    """Controller against deck; lengths in small diameters."""

    controller: JamResult  #: the jam run by jamflow's controller (LAMMPS engine)
    deck: DeckResult  #: the same jam run by the deck in lmp alone
    contacts_both: int  #: contacts found in both packings
    contacts_only_controller: int  #: contacts only in the controller's packing
    contacts_only_deck: int  #: contacts only in the deck's packing
    max_displacement: float  #: largest minimum-image distance between a particle's two positions
    first_difference: int | None  #: first minimisation whose phi, V, iterations or reason differ
    tolerance: float  #: the largest phi_J difference that counts as agreement

    @property
    def phi_j_difference(self) -> float:
        """phi_J(deck) - phi_J(controller)."""
        return self.deck.phi_j - self.controller.phi_j

    @property
    def same_contacts(self) -> bool:
        """Both packings have the same contacts."""
        return self.contacts_only_controller == 0 and self.contacts_only_deck == 0

    @property
    def agree(self) -> bool:
        """phi_J within ``tolerance`` and the same contacts."""
        return abs(self.phi_j_difference) <= self.tolerance and self.same_contacts

    def report(self) -> str:
        """The comparison as lines of text: both runs, the phi_J difference, contacts, displacement, histories, verdict."""
        c, d = self.controller, self.deck
        history = ("identical (phi, V, iterations, stop reason) over all "
                   f"{c.minimizations} minimisations" if self.first_difference is None
                   else f"first differ at minimisation {self.first_difference}")
        return "\n".join([
            f"controller  phi_J = {c.phi_j:.17g}  V = {c.energy_per_particle:.3e}  "
            f"{c.minimizations} minimisations  {c.seconds:.2f} s",
            f"deck (lmp)  phi_J = {d.phi_j:.17g}  V = {d.energy_per_particle:.3e}  "
            f"{d.minimizations} minimisations  {d.seconds:.2f} s",
            f"phi_J difference (deck - controller) = {self.phi_j_difference:.3e}  (tolerance {self.tolerance:g})",
            *_closing_lines(self, history, "")])


def _closing_lines(check, history: str, which: str) -> list[str]:
    """The report lines on contacts, displacement, histories and the verdict."""
    return [f"{which}contacts: {check.contacts_both} in both, {check.contacts_only_controller} only in the "
            f"controller's, {check.contacts_only_deck} only in the deck's",
            f"largest displacement between the two {'last ' if which else ''}packings = {check.max_displacement:.3e}",
            f"histories: {history}",
            "AGREE" if check.agree else "DISAGREE"]


def crosscheck(n: int = 32, dim: int = 2, sizes: str = "bi:1.4:0.5", seed: int = 0,
               settings: CompressionSettings | None = None, *, workdir=None, lmp=None, ranks: int = 1,
               tolerance: float = 1e-8, timeout: float | None = None, walls=None) -> CrossCheck:
    """Jam one random start twice, with the deck (``lmp``) and with the controller.

    ``workdir`` keeps the deck, start.data and the deck's outputs (default: a temporary
    directory, removed afterwards). Parameters are checked before any LAMMPS work.
    """
    settings = settings or CompressionSettings()
    if not tolerance > 0:
        raise ValueError(f"tolerance must be positive, got {tolerance}")
    start = initial_packing(n, dim, sizes, "spring", seed, settings.start_phi(dim), walls=walls)
    variables = deck_variables(n, dim, sizes, seed, settings, data="start.data", phi0=start.phi, out="deck",
                               walls=walls)
    deck = run_from(workdir, start, lambda where: run_deck(where, variables, lmp=lmp, ranks=ranks, timeout=timeout))
    controller = compress(start, settings, engine="lammps")  # the deck runs LAMMPS: same engine
    return compare(controller, deck, tolerance)


def run_from(workdir, start: Packing, run):
    """Write ``start`` as start.data into ``workdir`` (default: a temporary directory, removed
    afterwards) and return ``run(directory)``."""
    if workdir is not None and not Path(workdir).is_dir():
        raise ValueError(f"work directory {workdir} does not exist; create it first")
    from jamflow.engines.lammps.library import scratch_directory

    with scratch_directory("jamflow-crosscheck-") as tmp:
        where = Path(workdir) if workdir is not None else Path(tmp)
        write_lammps_data(where / "start.data", start)
        return run(where)


def compare(controller: JamResult, deck: DeckResult, tolerance: float = 1e-8) -> CrossCheck:
    """Compare two runs from the same start."""
    a, b = contact_set(controller.packing), contact_set(deck.packing)
    return CrossCheck(controller, deck, len(a & b), len(a - b), len(b - a),
                      max_displacement(controller.packing, deck.packing),
                      first_difference(controller.history, deck.history), tolerance)


def contact_set(packing: Packing) -> set:
    """Pairs (i, j), i < j, with r_ij < sigma_ij."""
    i, j, *_ = overlapping_pairs(packing)
    return set(zip(i.tolist(), j.tolist()))


def max_displacement(a: Packing, b: Packing) -> float:
    """Largest minimum-image distance between a particle's positions in ``a`` and ``b`` (diameters)."""
    if a.n != b.n:
        raise ValueError(f"packings differ in size ({a.n} and {b.n} particles)")
    return float(np.max(np.linalg.norm(a.box.minimum_image(b.positions - a.positions), axis=1)))


def first_difference(controller: dict, deck: dict) -> int | None:
    """Index of the first minimisation where phi, V, iterations or stop reason differ."""
    reasons = [r.decode() if isinstance(r, bytes) else str(r) for r in controller["reason"]]
    mine = list(zip(controller["phi"], controller["energy_per_particle"], controller["iterations"], reasons))
    theirs = list(zip(deck["phi"], deck["energy_per_particle"], deck["iterations"], deck["reason"]))
    for k, (x, y) in enumerate(zip(mine, theirs)):
        if not _same(x, y):
            return k
    return None if len(mine) == len(theirs) else min(len(mine), len(theirs))


def _same(x, y) -> bool:
    return float(x[0]) == float(y[0]) and float(x[1]) == float(y[1]) and int(x[2]) == int(y[2]) and x[3] == y[3]


# --- the shear deck -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShearCrossCheck:
    """Controller (``protocols.shear.shear`` on LAMMPS) against the shear deck from one start."""

    controller: object  #: ShearPath
    deck: object  #: ShearDeckResult
    contacts_both: int  #: last step
    contacts_only_controller: int  #: last step: contacts only in the controller's packing
    contacts_only_deck: int  #: last step: contacts only in the deck's packing
    max_displacement: float  #: last step
    first_difference: tuple | None  #: (shear step, minimisation) where the histories first differ
    tolerance: float  #: the largest phi_J difference at any step that counts as agreement

    @property
    def phi_j_difference(self) -> np.ndarray:
        """phi_J(deck) - phi_J(controller) at every shear step (NaN where a side has no step)."""
        a, b = self.controller.phi_j, self.deck.static["phi_j"]
        out = np.full(max(len(a), len(b)), np.nan)
        out[:min(len(a), len(b))] = b[:len(a)] - a[:len(b)]
        return out

    @property
    def agree(self) -> bool:
        """phi_J within ``tolerance`` at every step and the same contacts at the last."""
        diff = self.phi_j_difference
        return bool(np.all(np.abs(diff) <= self.tolerance)) and self.contacts_only_controller == 0 \
            and self.contacts_only_deck == 0

    def report(self) -> str:
        """The comparison as lines of text, as ``CrossCheck.report``."""
        c, d, diff = self.controller, self.deck, self.phi_j_difference
        history = ("identical (phi, V, iterations, stop reason) over all "
                   f"{sum(s.jam.minimizations for s in c.steps)} minimisations of {len(c.steps)} steps"
                   if self.first_difference is None
                   else f"first differ at shear step {self.first_difference[0]}, minimisation {self.first_difference[1]}")
        return "\n".join([
            f"controller  gamma {c.gamma[0]:.6g} -> {c.gamma[-1]:.6g} in {len(c.steps) - 1} steps, "
            f"phi_J {c.phi_j[0]:.12f} -> {c.phi_j[-1]:.12f}, {c.n_changes} network changes  {c.seconds:.2f} s",
            f"deck (lmp)  {len(d.static['phi_j']) - 1} steps, phi_J {d.static['phi_j'][0]:.12f} -> "
            f"{d.static['phi_j'][-1]:.12f}  {d.seconds:.2f} s",
            f"largest |phi_J difference| over the steps = {np.nanmax(np.abs(diff)):.3e}  (tolerance {self.tolerance:g})",
            *_closing_lines(self, history, "last step ")])


def crosscheck_shear(n: int = 10, dim: int = 2, sizes: str = "bi:1.4:0.5", seed: int = 0,
                     settings: CompressionSettings | None = None, *, gamma: float = 0.2, dgamma: float = 0.002,
                     to: float = 0.21, workdir=None, lmp=None, ranks: int = 1, tolerance: float = 1e-8,
                     timeout: float | None = None) -> ShearCrossCheck:
    """Jam one random start at strain ``gamma`` (controller, LAMMPS, chapter protocol), then shear it
    to ``to`` in steps of ``dgamma`` twice: with the shear deck (``lmp``) and with the controller.
    ``settings``: the bisection after each step (the chapter's protocol; default dphi0 = 1e-6)."""
    from jamflow.decks.shear import run_shear_deck, start_variables
    from jamflow.protocols.compression import jam
    from jamflow.protocols.settings import chapter_protocol
    from jamflow.protocols.shear import shear, shear_strains

    settings = settings or chapter_protocol(dphi0=1e-6)
    if not tolerance > 0:
        raise ValueError(f"tolerance must be positive, got {tolerance}")
    shear_strains(gamma, dgamma, to)  # bad strains refused before any work
    start = jam(n=n, dim=dim, sizes=sizes, seed=seed, gamma=gamma, engine="lammps",
                settings=replace(settings, dphi0=CompressionSettings().dphi0)).packing
    variables = start_variables(start, dgamma, to, settings, data="start.data", out="path")
    deck = run_from(workdir, start,
                    lambda where: run_shear_deck(where, variables, lmp=lmp, ranks=ranks, timeout=timeout))
    controller = shear(start, dgamma, to, settings, engine="lammps")
    return compare_shear(controller, deck, tolerance)


def compare_shear(controller, deck, tolerance: float = 1e-8) -> ShearCrossCheck:
    """Compare a ``ShearPath`` run on LAMMPS with a ``ShearDeckResult`` from the same start."""
    last = controller.steps[-1].packing
    a, b = contact_set(last), contact_set(deck.packing)
    first = None
    for k, (step, theirs) in enumerate(zip(controller.steps, deck.histories)):
        where = first_difference(step.jam.history, theirs)
        if where is not None:
            first = (k, where)
            break
    if first is None and len(controller.steps) != len(deck.histories):
        first = (min(len(controller.steps), len(deck.histories)), 0)
    return ShearCrossCheck(controller, deck, len(a & b), len(a - b), len(b - a), max_displacement(last, deck.packing),
                           first, tolerance)
