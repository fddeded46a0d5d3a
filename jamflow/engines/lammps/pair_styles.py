"""Choose the LAMMPS pair style that is exact for a packing's potential.

- Spring(alpha=2) with a few discrete diameters: built-in ``harmonic/cut``,
  E = k (rc - r)^2 with k = eps / (2 sigma_ij^2), rc = sigma_ij, every i-j pair set
  explicitly (LAMMPS would mix cutoffs geometrically, not additively).
- Anything else (other alpha, repulsive LJ, continuous polydispersity): jamflow's own
  plugin styles ``jamflow/spring`` and ``jamflow/rlj`` (per-atom radius), compiled on
  first use; without a compiler, LAMMPS's ``lepton/sphere`` (exact, ~10x slower).
- Ellipses/spheroids (``atom_style ellipsoid``): the plugin's ``jamflow/ellipsoid`` with the
  packing's contact-distance method (no fallback: LAMMPS has no exact ellipsoid contact).
"""

from __future__ import annotations

from jamflow.model.packing import Packing

MAX_DISCRETE_SPECIES = 8


def uses_harmonic_cut(packing: Packing) -> bool:
    pot = packing.potential
    return pot.name == "spring" and pot.alpha == 2.0 and len(packing.species()[0]) <= MAX_DISCRETE_SPECIES


def pair_setup(packing: Packing, lmp=None) -> list[str]:
    """LAMMPS commands that define the pair interaction for ``packing``."""
    if packing.shape.elliptic:
        return ellipsoid_commands(packing, lmp)
    if uses_harmonic_cut(packing):
        return harmonic_cut_commands(packing)
    from jamflow.engines.lammps.plugin_build import pair_style_commands, plugin_library

    library = plugin_library()
    cutoff = float(packing.diameters.max())
    lines = pair_style_commands(packing.potential, cutoff, plugin=library is not None)
    if library is not None and not (lmp is not None and lmp.has_style("pair", "jamflow/spring")):
        lines.insert(0, f'plugin load "{library}"')
    return lines


def harmonic_cut_commands(packing: Packing) -> list[str]:
    values, _ = packing.species()
    eps = packing.potential.epsilon
    lines = ["pair_style harmonic/cut"]
    for a in range(len(values)):
        for b in range(a, len(values)):
            sigma = 0.5 * (values[a] + values[b])
            lines.append(f"pair_coeff {a + 1} {b + 1} {eps / (2 * sigma**2):.17g} {sigma:.17g}")
    return lines


def ellipsoid_commands(packing: Packing, lmp=None) -> list[str]:
    """``jamflow/ellipsoid`` with the packing's law and contact method; the cutoff is the longest axis."""
    from jamflow.engines.lammps.plugin_build import plugin_library

    library = plugin_library()
    if library is None:
        raise RuntimeError("LAMMPS runs ellipses/spheroids only with jamflow's plugin pair style, which needs a "
                           "C++ compiler (install g++ or set CXX); or use the compiled engine (--engine numba, FIRE)")
    cutoff = float(2.0 * packing.shape.reach(packing.diameters).max())
    law = packing.potential.plugin_style(cutoff).split("/", 1)[1]  # "spring ALPHA CUTOFF" | "rlj CUTOFF"
    lines = [f"pair_style jamflow/ellipsoid {packing.shape.contact} {law}",
             f"pair_coeff * * {float(packing.potential.epsilon)!r}"]
    if not (lmp is not None and lmp.has_style("pair", "jamflow/ellipsoid")):
        lines.insert(0, f'plugin load "{library}"')
    return lines
