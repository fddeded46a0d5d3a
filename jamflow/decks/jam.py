"""The compression protocol as a LAMMPS input deck: write it, run it with ``lmp``, read it back.

The deck (``jamflow.decks.jam_script``; rendered with the defaults as ``lammps_inputs/jam.lmp``)
runs chapter section 2.1 in the LAMMPS input language alone and mirrors the Python
controller (``jamflow.protocols.compression``) command for command. It covers the chapter's
protocol with the linear spring (alpha = 2, eps = 1) for one or two discrete diameters,
which LAMMPS's built-in ``harmonic/cut`` computes exactly, so any LAMMPS build runs it.

Units: small diameter 1, epsilon 1, mass 1; V is the energy per particle.
"""

from __future__ import annotations

import math
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from jamflow import __version__
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.minimize.settings import MinimizerSettings
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.potentials import Potential, Spring, parse_potential
from jamflow.model.sizes import parse_sizes
from jamflow.protocols.settings import CompressionSettings
from jamflow.support.files import atomic_path

DECK_NAME = "jam.lmp"
OPTIONAL = ("data", "phi0", "ftol", "plugin")
PROTOCOL_COLUMNS = ("step", "phi", "energy_per_particle", "pressure", "dphi", "iterations", "max_force", "reason")


class DeckFailed(RuntimeError):
    """The deck stopped without a jammed packing; the message is the deck's reason."""


# --- parameters --------------------------------------------------------------------------------
def _num(x) -> str:
    """Shortest text that parses back to the same float64 (LAMMPS and Python agree on it)."""
    return repr(float(x)) if not float(x).is_integer() or abs(x) >= 1e16 else str(int(x))


def deck_variables(n: int = 256, dim: int = 2, sizes="bi:1.4:0.5", seed: int = 0,
                   settings: CompressionSettings | None = None, *, potential: str | Potential = "spring",
                   data=None, phi0: float | None = None, out: str = "jammed", walls=None) -> dict:
    """The deck's variables for a jamflow run; ValueError for what the deck cannot run.

    ``phi0`` overrides ``settings.phi0``; with ``data`` it should be the data file's
    packing fraction as jamflow computes it (``Packing.phi``), passed at full precision.
    ``walls``: smooth walls on these axes (``"y"``, ``"x,y"``; ``jamflow.model.walls``).
    """
    from jamflow.model.walls import parse_walls

    settings = settings or CompressionSettings()
    d2, fsmall = system_values(sizes, potential)
    values = dict(dim=int(dim), N=int(n), d1=1, d2=_num(d2), fsmall=_num(fsmall), seed=int(seed),
                  **protocol_values(settings), out=str(out),
                  walls="".join("xyz"[a] for a in parse_walls(walls, int(dim))) or "none")
    values.update(start_values(settings, data, phi0))
    values.update(optional_values(settings))
    return values


def start_values(settings: CompressionSettings, data=None, phi0: float | None = None) -> dict:
    """The deck's start variables that are set (data file, phi0 at full precision)."""
    start_phi = phi0 if phi0 is not None else settings.phi0
    optional = {"data": None if data is None else str(data),
                "phi0": None if start_phi is None else repr(float(start_phi))}
    return {k: v for k, v in optional.items() if v is not None}


def system_values(sizes, potential) -> tuple[float, float]:
    """(large diameter d2, small fraction) of what the decks run: the linear spring (alpha 2,
    eps 1) with one or two diameters; ValueError otherwise."""
    pot = parse_potential(potential) if isinstance(potential, str) else potential
    if not (pot.name == "spring" and pot.alpha == 2.0 and pot.epsilon == 1.0):
        raise ValueError(f"the deck runs the linear spring (alpha = 2, eps = 1) only, got {pot.spec}; "
                         "run other potentials with the Python controller (jamflow jam)")
    spec = parse_sizes(sizes) if isinstance(sizes, str) else sizes
    if spec.kind not in ("mono", "bi"):
        raise ValueError(f"the deck runs mono or bi sizes only (atom types), got {spec.spec}; "
                         "run polydisperse sizes with the Python controller (jamflow jam)")
    return (1.0, 1.0) if spec.kind == "mono" else spec.params


def protocol_values(settings: CompressionSettings) -> dict:
    """The bisection's and minimiser's deck variables (the chapter's protocol only)."""
    _check_chapter_protocol(settings)
    m: MinimizerSettings = settings.minimizer
    return dict(vtol=_num(settings.v_tol), dphi0=_num(settings.dphi0), minimizer=m.method, vmin=_num(m.v_min),
                delta=_num(m.delta), window=m.window, maxiter=m.max_iterations, dt=_num(m.timestep),
                mddt=_num(m.md_timestep), damping=_num(m.damping), mddamping=m.md_damping,
                mdsample=m.md_sample_every, maxsteps=settings.max_steps, skin=_num(0.3))


def optional_values(settings: CompressionSettings) -> dict:
    """The minimiser's optional deck variables that are set (ftol; plugin for pairwise MD)."""
    m: MinimizerSettings = settings.minimizer
    optional = {"ftol": None if m.force_tol is None else repr(float(m.force_tol)),
                "plugin": _plugin_path() if m.method == "md" and m.md_damping == "pairwise" else None}
    return {k: v for k, v in optional.items() if v is not None}


def _plugin_path() -> str:
    """The compiled jamflow plugin (fix jamflow/damping) that a pairwise-damping deck loads."""
    from jamflow.engines.lammps.plugin_build import plugin_library

    library = plugin_library()
    if library is None:
        raise ValueError("a deck with md_damping 'pairwise' loads jamflow's LAMMPS plugin, which needs a C++ "
                         "compiler to build; install one or use md_damping 'viscous'")
    return str(library)


def _check_chapter_protocol(settings: CompressionSettings) -> None:
    """The deck mirrors the chapter's bisection; optional speed-ups of the controller are refused."""
    defaults = CompressionSettings()
    extra = [f.name for f in fields(CompressionSettings)
             if f.name not in ("phi0", "dphi0", "v_tol", "max_steps", "minimizer")
             and getattr(settings, f.name) != getattr(defaults, f.name)]
    if extra:
        raise ValueError(f"the deck runs the chapter's bisection only, without the controller's shortcuts "
                         f"({', '.join(extra)}): use --protocol chapter (jamflow.protocols.settings.chapter_protocol)")


# --- the deck text -------------------------------------------------------------------------------
def deck_text(variables: dict | None = None) -> str:
    """The deck with ``variables`` (from ``deck_variables``) as its defaults."""
    from jamflow.decks.jam_script import BODY, HEADER

    return render(HEADER, BODY, OPTIONAL, deck_variables() if variables is None else variables)


def render(header: str, body: str, optional_names, variables: dict) -> str:
    """A deck: ``header`` formatted with ``variables`` (the optional ones, if given, as extra
    ``index`` lines), then ``body``."""
    values = {k: deck_word(v) for k, v in variables.items()}
    optional = "".join(f"variable {k:<9} index {values.pop(k)}\n" for k in optional_names if k in values)
    return header.format(version=__version__, optional=optional, **values) + body


_SPECIAL = "\"'#$&"  # quotes, comment, variable, continuation: LAMMPS reads them in a command


def plain_word(text: str) -> bool:
    """Does ``text`` stay one word in a LAMMPS command, unquoted?"""
    return bool(text) and not any(c.isspace() or c in _SPECIAL for c in text)


def deck_word(value) -> str:
    """A deck variable's value as written on its ``variable NAME index VALUE`` line. A file name
    with a space (``jam deck.start.data``) is written "'jam deck.start.data'": LAMMPS strips the
    outer quotes when it stores the value, and ``read_data ${data}`` then reads one quoted word
    (unquoted, the space made it an index variable of two values and read_data opened "jam")."""
    text = str(value)
    if plain_word(text):
        return text
    from jamflow.engines.lammps.library import readable_by_lammps

    if not readable_by_lammps(text) or "'" in text or '"' in text:
        raise ValueError(f"{text!r} cannot be a file name in a LAMMPS deck (LAMMPS cannot read quotes, non-ASCII or "
                         "control characters in it); rename it")
    return f"\"'{text}'\""


def write_deck(path, variables: dict | None = None) -> Path:
    """Write the deck atomically to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(deck_text(variables))
    return Path(path)


# --- running it -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class DeckResult:
    """What one deck run produced (read back from its files)."""

    packing: Packing  #: the jammed packing the deck wrote (PREFIX.data)
    phi_j: float  #: its packing fraction
    energy_per_particle: float  #: V, eps
    pressure: float  #: P, eps / diameter^d
    max_force: float  #: largest force component, eps / diameter
    history: dict  #: PROTOCOL_COLUMNS -> np.ndarray, one entry per minimisation
    seconds: float  #: wall time of the lmp process
    prefix: Path  #: PREFIX.data, PREFIX.protocol.txt, PREFIX.lammps.log

    @property
    def minimizations(self) -> int:
        """Minimisations the deck ran."""
        return len(self.history["phi"])


def lmp_command(lmp=None, ranks: int = 1) -> list[str]:
    """argv prefix for the ``lmp`` executable, under ``mpirun -np ranks`` if ranks > 1."""
    from jamflow.engines.lammps.library import lmp_executable

    if not isinstance(ranks, int) or ranks < 1:
        raise ValueError(f"ranks must be a positive integer, got {ranks!r}")
    exe = str(lmp) if lmp else lmp_executable()
    if lmp and shutil.which(exe) is None:
        raise ValueError(f"LAMMPS executable {lmp} not found or not executable; give the path of your lmp")
    if ranks == 1:
        return [exe]
    mpirun = Path(sys.prefix) / "bin" / "mpirun"
    mpirun = str(mpirun) if mpirun.is_file() else shutil.which("mpirun")
    if mpirun is None:
        raise ValueError("ranks > 1 needs mpirun (the mpich wheel installs it in the environment's bin)")
    return [mpirun, "-np", str(ranks), exe]


def _walls_of(variables: dict) -> tuple:
    """The periodicity the deck's ``walls`` variable gives its box."""
    walls, dim = str(variables.get("walls", "none")), int(variables.get("dim", 2))
    if dim not in (2, 3):
        return None  # the deck refuses it
    return tuple("xyz"[a] not in walls.replace("none", "") for a in range(dim))


def run_deck(workdir, variables: dict | None = None, *, deck=None, lmp=None, ranks: int = 1,
             timeout: float | None = None, reader=None) -> DeckResult:
    """Run the deck with ``lmp`` in ``workdir``; raise DeckFailed unless it jammed.

    ``deck`` defaults to a fresh copy written into ``workdir``; ``variables`` become
    ``-var`` arguments (paths in them are used as given, relative to ``workdir``);
    ``reader(path) -> Packing`` reads the final data file (default ``read_data_file``; the ellipse
    deck's is ``jamflow.decks.ellipsoids.read_ellipsoid_data``).
    """
    workdir = check_workdir(workdir)
    deck = Path(deck) if deck else write_deck(workdir / DECK_NAME)
    prefix, seconds, proc = run_lmp(workdir, deck, variables, "jammed", lmp, ranks, timeout)
    return read_deck_result(prefix, seconds, proc, periodic=_walls_of(variables or {}), reader=reader)


def check_workdir(workdir) -> Path:
    workdir = Path(workdir)
    if not workdir.is_dir():
        raise ValueError(f"work directory {workdir} does not exist; create it first")
    return workdir


def run_lmp(workdir: Path, deck: Path, variables, out_default: str, lmp=None, ranks: int = 1, timeout=None):
    """Run ``lmp -in deck -var ...`` in ``workdir``; return (output prefix, seconds, process)."""
    from jamflow.engines.lammps.library import lammps_env

    variables = dict(variables or {})
    out = str(variables.setdefault("out", out_default))
    command = lmp_command(lmp, ranks)
    args = [*command, "-in", str(Path(deck).resolve()), "-log", f"{out}.lammps.log", "-screen", "none", "-nocite"]
    for name, value in variables.items():
        args += ["-var", name, str(value)]
    start = time.perf_counter()
    proc = subprocess.run(args, cwd=workdir, env=lammps_env(), capture_output=True, text=True, timeout=timeout)
    return workdir / out, time.perf_counter() - start, proc


def read_deck_result(prefix, seconds: float = math.nan, proc=None, periodic=None, reader=None) -> DeckResult:
    """Read PREFIX.protocol.txt and PREFIX.data (``periodic``: per axis, False where the deck
    had walls; ``reader``: how to read the data file, e.g. ``read_body_data`` for a body deck);
    raise DeckFailed with the deck's reason."""
    prefix = Path(prefix)
    log = Path(f"{prefix}.protocol.txt")
    if not log.is_file():
        raise DeckFailed(f"the deck wrote no protocol log {log}: {lammps_error(prefix, proc)}")
    history, result = read_protocol(log)
    if result.get("status") != "jammed":
        raise DeckFailed(f"the deck did not jam: {result.get('message', 'no result line in ' + str(log))}")
    packing = reader(f"{prefix}.data") if reader else read_data_file(f"{prefix}.data", periodic=periodic)
    return DeckResult(packing, float(result["phi_J"]), float(result["V"]), float(result["P"]),
                      float(result["max_force"]), history, seconds, prefix)


def lammps_error(prefix, proc) -> str:
    lines = []
    for source in (Path(f"{prefix}.lammps.log"),):
        if source.is_file():
            lines += [ln for ln in source.read_text(errors="replace").splitlines() if "ERROR" in ln]
    if proc is not None:
        lines += [ln for ln in (proc.stdout + proc.stderr).splitlines() if ln.strip()][-3:]
    return "; ".join(lines[-3:]) or "LAMMPS printed nothing (is lmp a LAMMPS executable?)"


def read_protocol(path) -> tuple[dict, dict]:
    """(history columns, result fields) of a deck's PREFIX.protocol.txt."""
    rows, result = [], {}
    for line in Path(path).read_text().splitlines():
        if line.startswith("# result"):
            words = line.split()[2:]
            if words[:2] == ["status", "failed:"]:
                result = {"status": "failed", "message": " ".join(words[2:])}
            else:
                result = dict(zip(words[::2], words[1::2]))
        elif line.strip() and not line.startswith("#"):
            rows.append(line.split())
    history = {}
    for k, name in enumerate(PROTOCOL_COLUMNS):
        column = [r[k] for r in rows]
        history[name] = np.array(column if name == "reason" else
                                 [int(c) for c in column] if name in ("step", "iterations") else
                                 [float(c) for c in column])
    return history, result


# --- LAMMPS data files at full precision ---------------------------------------------------------------
def read_data_file(path, potential: Potential | None = None, periodic=None) -> Packing:
    """A packing from a LAMMPS data file of ``atom_style sphere`` (as ``write_data`` writes
    it), in float64 and atom-ID order, positions as written; the dimension is 2 when every
    z is 0; ``periodic`` per axis (data files do not say: False for walled axes).
    (jamflow.io.readers goes through MDAnalysis, which keeps float32.)"""
    bounds, tilts, table = _atoms_table(path, "sphere", "sphere", 7)
    table = table[np.argsort(table[:, 0])]
    box, origin = _data_box(bounds, tilts, table[:, 6], periodic)
    positions = table[:, 4:4 + box.dim] - origin  # write_data writes them inside the cell
    meta = {"source": str(path)}
    return Packing(positions, table[:, 2], box, potential or Spring(), meta)


def read_body_data(path, shape, potential: Potential | None = None) -> Packing:
    """A packing of rigid bodies of ``shape`` from a LAMMPS data file of ``atom_style hybrid
    sphere molecular`` as ``write_data`` writes it (id type x y z diameter density molecule ix iy
    iz; one molecule per body, its atoms in id order = the shape's sites). Sites are unwrapped
    with their image flags, centres are the mass-weighted site centres (``site_masses``: the
    union's centre of mass), orientations the best rotation of the body frame onto the sites
    (``shapes.rotations.fit_orientations``), scales the site diameters over the shape's."""
    from jamflow.model.shapes.rotations import fit_orientations

    bounds, tilts, table = _atoms_table(path, "hybrid", "hybrid sphere molecular", 11)
    table = table[np.lexsort((table[:, 0], table[:, 7]))]  # by molecule, then atom id
    box, origin = _data_box(bounds, tilts, table[:, 4])
    dim, n_sites = box.dim, shape.n_sites
    if len(table) % n_sites:
        raise ValueError(f"{path} has {len(table)} atoms, not a multiple of the {n_sites} sites of {shape.label}")
    sites = (table[:, 2:2 + dim] - origin + box.to_cartesian(table[:, 8:8 + dim])).reshape(-1, n_sites, dim)
    scale = table[::n_sites, 5] / shape.site_diameters[0]
    local = scale[:, None, None] * shape.sites[None]
    internal = lambda x: np.linalg.norm(x[:, :, None] - x[:, None, :], axis=-1)
    worst = float(np.abs(internal(sites) - internal(local)).max())
    if worst > 1e-9 * max(1.0, float(scale.max())):
        raise ValueError(f"{path}: site distances inside a body differ from {shape.label}'s by up to {worst:.3g}; "
                         "the file's bodies are not rigid copies of this shape (or their image flags are wrong)")
    centres = np.einsum("s,nsa->na", shape.site_masses, sites)
    orientations = fit_orientations(local, sites - centres[:, None, :], shape.site_masses)
    return Packing(box.wrap(centres), scale, box, potential or Spring(), {"source": str(path)}, shape, orientations)


def _atoms_table(path, section: str, style: str, width: int) -> tuple[dict, tuple, np.ndarray]:
    """(bounds, tilts, the first ``width`` columns of the 'Atoms # SECTION' rows) of a data file."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no LAMMPS data file {path}")
    lines = path.read_text().splitlines()
    bounds, tilts, k = _data_header(lines)
    if k == len(lines) or section not in lines[k]:
        raise ValueError(f"{path} has no 'Atoms # {section}' section; write it with atom_style {style}")
    return bounds, tilts, np.array(_section_rows(lines, k, width), dtype=float)


def _data_header(lines) -> tuple[dict, tuple, int]:
    """(bounds {axis: (lo, hi)}, tilts (xy, xz, yz), index of the Atoms line) of a LAMMPS data file."""
    bounds, tilts, k = {}, (0.0, 0.0, 0.0), 1
    while k < len(lines) and not lines[k].strip().startswith("Atoms"):
        words = lines[k].split("#")[0].split()
        if len(words) == 4 and words[2][1:] == "lo":
            bounds[words[2][0]] = (float(words[0]), float(words[1]))
        elif len(words) == 6 and words[3:] == ["xy", "xz", "yz"]:
            tilts = tuple(float(w) for w in words[:3])
        k += 1
    return bounds, tilts, k


def _data_box(bounds: dict, tilts: tuple, z: np.ndarray, periodic=None) -> tuple[Box, np.ndarray]:
    """(box, origin) of a data file; the dimension is 2 when every z is 0."""
    dim = 2 if np.all(z == 0.0) else 3
    lengths = [bounds[a][1] - bounds[a][0] for a in "xyz"[:dim]]
    return Box.from_lammps(dim, lengths, tilts, periodic), np.array([bounds[a][0] for a in "xyz"[:dim]])


def _section_rows(lines, k: int, width: int) -> list:
    """The first ``width`` words of every row of the section whose title is lines[k]."""
    rows = []
    for line in lines[k + 1:]:
        words = line.split()
        if not words:
            if rows:
                break
            continue
        rows.append(words[:width])
    return rows


def emit_deck(path, start: Packing, settings: CompressionSettings | None = None, *, out: str = "jammed"):
    """Write the deck that runs ``compress(start, settings)`` in ``lmp`` alone, and its start
    as the data file PATH_STEM.start.data beside it (the deck names it relative to its own
    directory: run it there). Returns (deck path, data path)."""
    path = Path(path)
    data = path.with_name(path.stem + ".start.data")
    check_output_name(out)
    if start.fixed is not None or start.gravity > 0:
        raise ValueError("the deck runs smooth walls at most: no rough walls (fixed particles) or gravity")
    variables = deck_variables(start.n, start.dim, start.metadata.get("sizes", "bi:1.4:0.5"),
                               start.metadata.get("seed", 0), settings, potential=start.potential,
                               data=data.name, phi0=start.phi, out=out, walls=start.box.walls)
    values = start.species()[0]
    if values[0] != 1.0:
        raise ValueError(f"the deck's small diameter is 1, got {values[0]}; rescale the packing")
    write_lammps_data(data, start)
    return write_deck(path, variables), data


def check_output_name(out: str) -> None:
    """The deck names its outputs ``${out}.data``, ``${out}.protocol.txt``: a quoted name cannot be
    joined to a suffix in LAMMPS, so ``out`` must be one plain word."""
    if not plain_word(str(out)):
        raise ValueError(f"the deck names its outputs {out}.data and {out}.protocol.txt, which LAMMPS cannot write "
                         "with spaces, quotes, '#', '$' or '&' in the name; choose an --out without them")


# --- the constant-pressure deck (lammps_inputs/pressure.lmp, written by hand) ------------------------
PRESSURE_DECK_NAME = "pressure.lmp"
PRESSURE_COLUMNS = ("target_pressure", "phi", "pressure", "pxy", "energy_per_particle", "iterations", "max_force")


def run_pressure_deck(workdir, start: Packing, pressures, *, stress: str = "iso", lmp=None,
                      out: str = "pressed", timeout: float | None = None) -> tuple[dict, Packing]:
    """Run ``lammps_inputs/pressure.lmp`` from ``start`` (written as start.data in ``workdir``)
    through the decreasing target ``pressures``; return (history, the packing at the last one).
    Linear spring (eps = 1), one or two sizes with the small one 1, periodic box."""
    from jamflow.engines.lammps.library import lammps_env

    values = start.species()[0]
    pot = start.potential
    if not (pot.name == "spring" and pot.alpha == 2.0 and pot.epsilon == 1.0) or len(values) > 2 or values[0] != 1.0:
        raise ValueError("the pressure deck runs the linear spring (eps = 1) with diameters 1 and one other")
    if start.box.walls or start.gravity > 0 or start.fixed is not None:
        raise ValueError("the pressure deck relaxes a periodic box (no walls, gravity or fixed particles)")
    workdir = Path(workdir)
    write_lammps_data(workdir / "start.data", start)
    deck = default_deck_path().with_name(PRESSURE_DECK_NAME)
    args = [*lmp_command(lmp), "-in", str(deck), "-log", f"{out}.lammps.log", "-screen", "none", "-nocite",
            "-var", "dim", str(start.dim), "-var", "data", "start.data", "-var", "d2", _num(values[-1]),
            "-var", "stress", stress, "-var", "out", out, "-var", "P", *[repr(float(p)) for p in pressures]]
    proc = subprocess.run(args, cwd=workdir, env=lammps_env(), capture_output=True, text=True, timeout=timeout)
    log = workdir / f"{out}.pressure.txt"
    if proc.returncode != 0 or not log.is_file():
        raise DeckFailed(f"the pressure deck failed: {lammps_error(workdir / out, proc)}")
    rows = np.array([ln.split() for ln in log.read_text().splitlines() if ln.strip() and not ln.startswith("#")],
                    dtype=float).reshape(-1, len(PRESSURE_COLUMNS))
    history = {name: rows[:, k] for k, name in enumerate(PRESSURE_COLUMNS)}
    return history, read_data_file(workdir / f"{out}.data")


def default_deck_path() -> Path:
    """``lammps_inputs/jam.lmp`` in a source checkout (not installed with the package)."""
    return Path(__file__).resolve().parents[2] / "lammps_inputs" / DECK_NAME


__all__ = ["DeckFailed", "DeckResult", "deck_text", "deck_variables", "write_deck", "run_deck",
           "read_deck_result", "read_protocol", "read_data_file", "read_body_data", "lmp_command", "emit_deck",
           "default_deck_path", "run_pressure_deck"]
