"""Bulk and shear moduli of a jammed packing, two ways (chapter section 4.5, eq. 2.34).

- Strain sweeps (``analysis.sweeps``): B = phi dP/dphi from small isotropic compressions and
  decompressions, G = dSigma/dgamma (Sigma = -P_xy) from small simple shears x -> x + gamma y with
  the shear-periodic cell, each relaxed at fixed strain; linear-regime fit with its error, yield.
- The Hessian (``analysis.elastic``): affine term minus the non-affine relaxation Xi^T H^+ Xi,
  on the same state the sweeps start from (the input relaxed at zero strain by the sweeps'
  minimiser: the input's residual forces, ~1e-14, move a soft packing by f / e_min, which shifts
  Hertzian moduli near onset by ~1e-6 relative).

``Moduli.check`` refuses, before any work, a packing the moduli are not defined for (walls,
gravity or fixed particles; V below the chapter's V_min = 1e-16, i.e. not jammed; every particle a
floater; a scene no engine relaxes) and a sweep
whose smallest amplitude lies below the round-off scale of the response
(``sweeps.roundoff_amplitude``, from the Hessian moduli of the input). The measurement is of the packing as
it is: nothing is compressed or re-jammed (``jamflow jam --above`` makes the packings).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from jamflow.engines.choose import engine_name
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.packing import Packing, warn_float64_only
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.elastic import HessianModuli, HessianModuliResult
from jamflow.mechanics.strains import BULK, SHEAR, STRAINS
from jamflow.protocols.sweeps import StrainSweep, SweepResult, SweepSettings, roundoff_amplitude, touching

V_MIN = MinimizerSettings().v_min  # energy per particle below which a packing is not jammed (seed)


@dataclass(frozen=True)
class ModuliResult:
    """Both sweeps, the Hessian route and the base state."""

    shear: SweepResult  #: the simple-shear sweep: Sigma against gamma, slope G
    bulk: SweepResult  #: the compression sweep: P against the volume strain, slope B
    hessian: HessianModuliResult  #: G and B from the dynamical matrix, on the sweeps' base state
    roundoff: dict  #: modulus name -> round-off amplitude of its sweep
    phi: float  #: packing fraction of the input packing
    energy_per_particle: float  #: eps, of the input packing
    n_contacts: int  #: contacts among non-floaters of the input packing
    n_floaters: int  #: floaters of the input packing

    def __repr__(self) -> str:
        """One line: N, phi, G and B by both routes, the yield strain, contacts, floaters."""
        return (f"ModuliResult(N={self.shear.base.n}, phi={self.phi:.10f}, G={self.G:.6e}, G_hessian={self.G_hessian:.6e}, "
                f"B={self.B:.6e}, B_hessian={self.B_hessian:.6e}, yield_strain={self.yield_strain:.2g}, "
                f"N_c={self.n_contacts}, floaters={self.n_floaters})")

    def sweep(self, strain) -> SweepResult:
        """The sweep of ``strain`` (``SHEAR`` or ``BULK``)."""
        return self.shear if strain.modulus == "G" else self.bulk

    @property
    def G(self) -> float:
        """Shear modulus from the sweep, eps / diameter^d (NaN without a linear regime)."""
        return self.shear.modulus

    @property
    def B(self) -> float:
        """Bulk modulus from the sweep, eps / diameter^d (NaN without a linear regime)."""
        return self.bulk.modulus

    @property
    def G_hessian(self) -> float:
        """Shear modulus by the Hessian route, eps / diameter^d."""
        return self.hessian.G

    @property
    def B_hessian(self) -> float:
        """Bulk modulus by the Hessian route, eps / diameter^d."""
        return self.hessian.B

    @property
    def yield_strain(self) -> float:
        """Shear yield strain (NaN if no yield was seen in the sweep)."""
        return self.shear.yield_strain

    @property
    def pressure(self) -> float:
        """P of the base state (zero strain), eps / diameter^d."""
        return self.bulk.base_response

    @property
    def shear_stress(self) -> float:
        """Sigma = -P_xy of the base state, eps / diameter^d."""
        return self.shear.base_response

    def agreement(self, strain) -> float:
        """sweep / Hessian - 1."""
        return self.sweep(strain).modulus / self.hessian.modulus(strain) - 1.0


class Moduli:
    """``sweeps``: amplitudes, tolerances, minimiser (``SweepSettings``); ``engine`` runs the
    relaxations (auto, lammps, numba; ``engine_options`` to its constructor); ``hessian``: the
    ``HessianModuli`` of the second route.

    Parameters
    ----------
    sweeps : SweepSettings, optional
        Strain amplitudes (dimensionless), tolerances and minimiser (default ``SweepSettings()``).
    engine : {"auto", "numba", "lammps"}, default "auto"
        The engine of the relaxations.
    engine_options : dict, optional
        Options for the engine's constructor.
    hessian : HessianModuli, optional
        The Hessian route (default ``HessianModuli()``).
    contacts : Contacts, optional
        The floater search of the input checks (default ``Contacts()``).
    """

    def __init__(self, sweeps: SweepSettings | None = None, engine: str = "auto", engine_options=None,
                 hessian: HessianModuli | None = None, contacts: Contacts | None = None):
        self.sweeps = sweeps or SweepSettings()
        self.engine, self.engine_options = engine, engine_options
        self.contacts = contacts or Contacts()
        self.hessian = hessian or HessianModuli()

    def check(self, packing: Packing) -> tuple[HessianModuliResult, dict, tuple]:
        """Refuse what has no moduli or no engine to relax it, before any relaxation; returns the
        Hessian route on the input, the round-off amplitudes and (energy per particle, contacts,
        floaters)."""
        if packing.box.walls or packing.fixed is not None or packing.gravity > 0:
            raise ValueError("the moduli are measured in a periodic box: this packing has walls, fixed particles or "
                             "gravity (jam it without --walls / --gravity)")
        energy = _energy_per_particle(packing)
        if energy < V_MIN:
            raise ValueError(f"the packing is not jammed: V = {energy:.3g} per particle < V_min = {V_MIN:g} (no "
                             "overlaps to carry stress); jam it and compress it above onset first: jamflow jam --above 1e-4")
        found = self.contacts.compute(packing)
        if found.n_kept == 0:
            raise ValueError("every particle is a floater: the packing has no rigid contact network and no moduli; "
                             "compress it above onset first (jamflow jam --above 1e-4)")
        engine_name(packing, (self.sweeps.minimizer or MinimizerSettings()).method, self.engine)  # who relaxes
        warn_float64_only(packing, "the strain sweeps (float64 relaxations; the Hessian route reads hi + lo)")
        hessian = self._hessian(packing)
        roundoff = {}
        for strain in STRAINS:
            roundoff[strain.modulus] = roundoff_amplitude(packing, hessian.modulus(strain))
            smallest = self.sweeps.amplitudes[0]
            if smallest < roundoff[strain.modulus]:
                raise ValueError(f"the smallest {strain.kind} amplitude {smallest:g} is below the round-off scale "
                                 f"{roundoff[strain.modulus]:.1e} of this packing (the {strain.response_name} change "
                                 f"{strain.modulus} a would be smaller than its float64 error); start the sweep at "
                                 f"{10 * roundoff[strain.modulus]:.0e} or above")
        return hessian, roundoff, (energy, int(len(found.i)), int(found.n_floaters))

    def _hessian(self, packing: Packing) -> HessianModuliResult:
        result = self.hessian.compute(packing)
        if result.n_negative:
            warnings.warn(f"the dynamical matrix has {result.n_negative} negative eigenvalue(s): the packing is not at a "
                          "stable minimum, and its moduli are those of a saddle", stacklevel=3)
        return result

    def total_relaxations(self) -> int:
        """Relaxations of both sweeps if neither stops at a yield (progress bars)."""
        return len(STRAINS) * (1 + 2 * len(self.sweeps.amplitudes))

    def compute(self, packing: Packing, observers=(), checked=None) -> ModuliResult:
        """Both sweeps and the Hessian route; ``checked``: what ``check`` returned for this
        packing (else it is checked here).

        Parameters
        ----------
        packing : jamflow.Packing
            A jammed packing above onset in a periodic box (no walls, fixed particles or gravity).
        observers : iterable of callable, optional
            Each called with a dict (strain, amplitude, point) after every relaxation.
        checked : tuple, optional
            What ``check(packing)`` returned.

        Returns
        -------
        ModuliResult
            G and B by the sweeps and by the Hessian (eps / diameter^d), with the sweeps.

        Raises
        ------
        ValueError
            Walls, fixed particles or gravity, a packing that is not jammed (V < V_min) or has
            only floaters, no engine for the scene, or a smallest amplitude below round-off.
        """
        hessian, roundoff, (energy, n_contacts, n_floaters) = checked or self.check(packing)
        sweep = StrainSweep(self.sweeps, self.engine, self.engine_options)
        shear = sweep.compute(packing, SHEAR, observers)
        bulk = sweep.compute(shear.base, BULK, observers)  # the same base state (relaxed once more: ~0 iterations)
        hessian = self._hessian(shear.base)  # on the state the sweeps start from: the input relaxed at zero strain
        return ModuliResult(shear, bulk, hessian, roundoff, packing.phi, energy, n_contacts, n_floaters)


def _energy_per_particle(packing: Packing) -> float:
    """Total pair energy / N from the overlapping pairs (sites for rigid bodies), eps."""
    r, sigma = touching(packing)[2:]
    return float(np.sum(packing.potential.energy(r, sigma)) / packing.n) if len(r) else 0.0
