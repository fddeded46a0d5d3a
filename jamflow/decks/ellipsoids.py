"""Jamming ellipses and spheroids as a LAMMPS input deck: write it, run it with ``lmp``, read
the packing back.

The deck (``jamflow.decks.ellipsoids_script``; rendered with the defaults as
``lammps_inputs/jam-ellipses.lmp``) runs the chapter's protocol (section 2.1) with jamflow's plugin pair
style ``jamflow/ellipsoid`` and minimises by damped dynamics over positions and orientations, as
``LammpsEngine`` does for ellipsoids, stopping on forces and generalized torques. It covers the
linear spring (alpha = 2, eps = 1), one or two sizes, every contact-distance method.
``jamflow.decks.jam.run_deck`` runs it (``reader=read_ellipsoid_data``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from jamflow.decks.jam import (
    OPTIONAL,
    _atoms_table,
    _data_box,
    _num,
    _section_rows,
    check_output_name,
    optional_values,
    protocol_values,
    render,
    start_values,
    system_values,
)
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.model.packing import Packing
from jamflow.model.potentials import Potential, Spring
from jamflow.model.shapes.shape import Ellipsoid
from jamflow.protocols.settings import CompressionSettings
from jamflow.support.files import atomic_path

DECK_NAME = "jam-ellipses.lmp"
DEFAULT_PLUGIN = "jamflow_pairs.so"


def deck_variables(n: int = 64, dim: int = 2, alpha: float = 1.6, sizes="bi:1.4:0.6667", seed: int = 0,
                   settings: CompressionSettings | None = None, *, contact: str = "exact",
                   potential: str | Potential = "spring", plugin=None, data=None, phi0: float | None = None,
                   out: str = "jammed") -> dict:
    """The deck's variables; ValueError for what it cannot run (checked as ``Ellipsoid`` and
    ``Packing`` check them, before any work). ``plugin``: the library path the deck loads
    (default ``jamflow_pairs.so``; pass ``plugin_build.plugin_library()``)."""
    settings = settings or CompressionSettings()
    shape = Ellipsoid(float(alpha), contact)
    shape.check(dim)
    d2, fsmall = system_values(sizes, potential)
    shape.check_sizes(np.array([1.0, d2]), dim)
    protocol = protocol_values(settings)  # refuses the controller's protocol shortcuts
    m = settings.minimizer
    values = dict(plugin=str(plugin or DEFAULT_PLUGIN), dim=int(dim), N=int(n), alpha=_num(alpha), contact=contact,
                  d1=1, d2=_num(d2), fsmall=_num(fsmall), seed=int(seed),
                  **{k: protocol[k] for k in ("vtol", "dphi0", "vmin", "delta", "window", "maxiter", "mddt")},
                  damping=_num(m.rotating_damping), maxsteps=protocol["maxsteps"], skin=protocol["skin"], out=str(out))
    return {**optional_values(settings), **values, **start_values(settings, data, phi0)}


def deck_text(variables: dict | None = None) -> str:
    """The deck with ``variables`` (from ``deck_variables``) as its defaults."""
    from jamflow.decks.ellipsoids_script import BODY, HEADER

    # the plugin is a required variable of this deck (an optional one of the disk deck)
    return render(HEADER, BODY, tuple(k for k in OPTIONAL if k != "plugin"),
                  deck_variables() if variables is None else variables)


def write_deck(path, variables: dict | None = None) -> Path:
    """Write the ellipsoid deck (``deck_text(variables)``) atomically to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(deck_text(variables))
    return Path(path)


def emit_deck(path, start: Packing, settings: CompressionSettings | None = None, *, out: str = "jammed"):
    """Write the deck that jams ``start`` (ellipses/spheroids) in ``lmp`` alone, its start as
    PATH_STEM.start.data, and point it at the compiled plugin. Returns (deck path, data path)."""
    from jamflow.engines.lammps.plugin_build import plugin_library

    path = Path(path)
    data = path.with_name(path.stem + ".start.data")
    check_output_name(out)
    values = start.species()[0]
    if values[0] != 1.0 or len(values) > 2:
        raise ValueError(f"the deck's small size is 1 with at most one other, got {values}")
    library = plugin_library()
    if library is None:
        raise ValueError("the ellipse deck needs jamflow's LAMMPS plugin, which needs a C++ compiler (g++ or $CXX)")
    variables = deck_variables(start.n, start.dim, start.shape.alpha, start.metadata.get("sizes", "bi:1.4:0.6667"),
                               start.metadata.get("seed", 0), settings, contact=start.shape.contact,
                               potential=start.potential, plugin=library, data=data.name, phi0=start.phi, out=out)
    write_lammps_data(data, start)
    return write_deck(path, variables), data


def read_ellipsoid_data(path, potential: Potential | None = None, contact: str = "exact") -> Packing:
    """A packing of ellipses/spheroids from a LAMMPS data file of ``atom_style ellipsoid`` (as
    ``write_data`` writes it: Atoms id type ellipsoidflag density x y z, Ellipsoids id a b c qw qx
    qy qz, full axis lengths), float64, atom-ID order; 2D when every z is 0. ``contact``: the
    method to attach (a data file does not say)."""
    bounds, tilts, atoms = _atoms_table(path, "ellipsoid", "ellipsoid", 7)
    lines = Path(path).read_text().splitlines()
    k = next((k for k, line in enumerate(lines) if line.split("#")[0].strip() == "Ellipsoids"), None)
    if k is None:
        raise ValueError(f"{path} has no 'Ellipsoids' section; write it with atom_style ellipsoid")
    shapes = np.array(_section_rows(lines, k, 8), dtype=float)
    atoms, shapes = atoms[np.argsort(atoms[:, 0])], shapes[np.argsort(shapes[:, 0])]
    box, origin = _data_box(bounds, tilts, atoms[:, 6])
    a, b = shapes[:, 1], shapes[:, 2]
    ratio = a / b
    if np.ptp(ratio) > 1e-12 * ratio.max():
        raise ValueError(f"{path}: particles of different aspect ratios ({ratio.min()} .. {ratio.max()})")
    alpha = float(np.round(ratio[0], 12))
    quat = shapes[:, 4:8] / np.linalg.norm(shapes[:, 4:8], axis=1, keepdims=True)
    orientations = 2.0 * np.arctan2(quat[:, 3], quat[:, 0]) if box.dim == 2 else quat
    positions = atoms[:, 4:4 + box.dim] - origin
    return Packing(positions, b, box, potential or Spring(), {"source": str(path)}, shape=Ellipsoid(alpha, contact),
                   orientations=orientations)


def default_deck_path() -> Path:
    """``lammps_inputs/jam-ellipses.lmp`` in a source checkout."""
    return Path(__file__).resolve().parents[2] / "lammps_inputs" / DECK_NAME
