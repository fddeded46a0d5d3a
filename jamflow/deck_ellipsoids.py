"""Jamming ellipses and spheroids as a LAMMPS input deck: write it, run it with ``lmp``, read
the packing back.

The deck (``jamflow.deck_ellipsoids_script``; rendered with the defaults as
``lammps_inputs/jam-ellipses.lmp``) runs the seed protocol (section 2.1) with jamflow's plugin pair
style ``jamflow/ellipsoid`` and minimises by damped dynamics over positions and orientations, as
``LammpsEngine`` does for ellipsoids, stopping on forces and generalized torques. It covers the
linear spring (alpha = 2, eps = 1), one or two sizes, every contact-distance method.
``jamflow.deck.run_deck`` runs it (``reader=read_ellipsoid_data``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .box import Box
from .deck import OPTIONAL, _num, optional_values, protocol_values, render, start_values, system_values
from .io import atomic_path, write_lammps_data
from .packing import Packing
from .potentials import Potential, Spring
from .protocols.compression import CompressionSettings
from .shapes.shape import Ellipsoid

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
    from .deck_ellipsoids_script import BODY, HEADER

    # the plugin is a required variable of this deck (an optional one of the disk deck)
    return render(HEADER, BODY, tuple(k for k in OPTIONAL if k != "plugin"),
                  deck_variables() if variables is None else variables)


def write_deck(path, variables: dict | None = None) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_text(deck_text(variables))
    return Path(path)


def emit_deck(path, start: Packing, settings: CompressionSettings | None = None, *, out: str = "jammed"):
    """Write the deck that jams ``start`` (ellipses/spheroids) in ``lmp`` alone, its start as
    PATH_STEM.start.data, and point it at the compiled plugin. Returns (deck path, data path)."""
    from .engine.plugin_build import plugin_library

    path = Path(path)
    data = path.with_name(path.stem + ".start.data")
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
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no LAMMPS data file {path}")
    lines = path.read_text().splitlines()
    bounds, tilts = {}, (0.0, 0.0, 0.0)
    for line in lines[1:]:
        words = line.split("#")[0].split()
        if len(words) == 4 and words[2][1:] == "lo":
            bounds[words[2][0]] = (float(words[0]), float(words[1]))
        elif len(words) == 6 and words[3:] == ["xy", "xz", "yz"]:
            tilts = tuple(float(w) for w in words[:3])
    atoms, shapes = _section(lines, "Atoms", 7), _section(lines, "Ellipsoids", 8)
    if atoms is None or shapes is None:
        raise ValueError(f"{path} needs 'Atoms # ellipsoid' and 'Ellipsoids' sections (atom_style ellipsoid)")
    atoms, shapes = atoms[np.argsort(atoms[:, 0])], shapes[np.argsort(shapes[:, 0])]
    dim = 2 if np.all(atoms[:, 6] == 0.0) else 3
    a, b = shapes[:, 1], shapes[:, 2]
    ratio = a / b
    if np.ptp(ratio) > 1e-12 * ratio.max():
        raise ValueError(f"{path}: particles of different aspect ratios ({ratio.min()} .. {ratio.max()})")
    alpha = float(np.round(ratio[0], 12))
    quat = shapes[:, 4:8] / np.linalg.norm(shapes[:, 4:8], axis=1, keepdims=True)
    orientations = 2.0 * np.arctan2(quat[:, 3], quat[:, 0]) if dim == 2 else quat
    box = Box.from_lammps(dim, [bounds[x][1] - bounds[x][0] for x in "xyz"[:dim]], tilts)
    positions = atoms[:, 4:4 + dim] - np.array([bounds[x][0] for x in "xyz"[:dim]])
    return Packing(positions, b, box, potential or Spring(), {"source": str(path)}, shape=Ellipsoid(alpha, contact),
                   orientations=orientations)


def _section(lines, title: str, width: int):
    """The numeric table under a data-file section header (its first ``width`` columns)."""
    start = next((k for k, line in enumerate(lines) if line.strip().split("#")[0].strip() == title), None)
    if start is None:
        return None
    rows = []
    for line in lines[start + 1:]:
        words = line.split()
        if not words:
            if rows:
                break
            continue
        rows.append(words[:width])
    return np.array(rows, dtype=float)


def default_deck_path() -> Path:
    """``lammps_inputs/jam-ellipses.lmp`` in a source checkout."""
    return Path(__file__).resolve().parents[1] / "lammps_inputs" / DECK_NAME
