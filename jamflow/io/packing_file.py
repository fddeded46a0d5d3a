"""Packing files: a versioned HDF5 schema, MDAnalysis Universes (LAMMPS data files:
``jamflow.engines.lammps.data_file``).

HDF5 schema ``jamflow.packing`` version 2 (all lengths in small diameters, energies in
epsilon, pressures in epsilon / diameter^d)::

    /                       attrs: schema, schema_version, jamflow_version, lammps_version,
                                   dim, n, phi, energy_per_particle, pressure, potential,
                                   alpha, epsilon, seed, sizes, created (ISO time),
                                   shape (JSON: kind and parameters, e.g.
                                   {"kind": "ellipsoid", "alpha": 1.5, "contact": "exact"}),
                                   shape_spec (text, e.g. "ellipse:1.5"), gamma (shear strain
                                   xy / ly of the box, accumulated);
                                   walls (walled axes, "" | "y" | "x,y" | ...), wall_type
                                   ("" | "smooth" | "rough"), gravity (g, 0 without),
                                   target_pressure (NaN at fixed box), stress ("" | "iso" |
                                   "aniso" | "tri"), dphi_above (NaN, or the step by
                                   which ``jamflow jam --above`` compressed the onset
                                   packing: phi = phi_J + dphi_above), phi_j (the onset
                                   ``jamflow jam`` reports: phi_J of a compression, the
                                   pile's fraction under gravity, phi_J(P->0) at constant
                                   pressure, NaN where none is known: one pressure, or a
                                   packing saved without one), start_orientations
                                   (how the start's orientations were drawn: "random",
                                   "aligned" or "nematic:S", ``jamflow jam --orientations``; "" unknown
                                   or round particles)
    /positions  (N, d)      float64, Cartesian, wrapped into the cell: the packing's positions bit
                            for bit (``stored_packing``: wrapped once if they lay outside)
    /positions_lo (N, d)    float64, double-double packings only (root attribute precision =
                            "double-double", else "double"; ``jamflow refine``): the true
                            position is positions + positions_lo, wrapped in double-double
    /box_lo     (d,)        float64, with positions_lo: the low parts of the box side lengths
                            (orthogonal box; true side = diagonal of box + box_lo)
    /diameters  (N,)        float64, each particle's size scale (jamflow.model.packing)
    /box        (d, d)      float64, upper-triangular, columns = cell vectors (LAMMPS tilt)
    /pressure_tensor (d, d) float64, virial part (athermal), if known
    /orientations (N,) | (N, 4)   2D angle (radians) | 3D unit quaternion (w, x, y, z);
                                  every shape that is not round
    /directors  (N, d)      unit vector of each particle's body x-axis: the long axis of
                            ellipses, prolate spheroids and linear bodies, the symmetry
                            axis of oblate spheroids
    /axes       (N, 2)      ellipses/spheroids: full lengths along and across the director
                            (major, minor for ellipses and prolate spheroids)
    /sites (N, S, d), /site_diameters (N, S)   rigid bodies: world positions and diameters
                                               of each body's sites
    /fixed (N,)             uint8, 1 for fixed particles (rough walls: they sit on the faces)
    /wall_forces (k, 2, d)  force of the particles on the lower and upper face of each of
                            the k walled axes (in the order of the walls attribute)
    /wall_pressure (k, 2)   outward normal component of wall_forces over the face area
    /protocol               attrs: every protocol and minimiser parameter
    /history/<column> (M,)  one dataset per recorded column (phi, energy, pressure, ...)
    /checks                 attrs: jamflow.mechanics.checks.PackingChecks (if the writer checked it)

Version 1 files (disks and spheres, no shape attributes) still load; files without the
walls attributes and datasets (added within version 2) load as periodic packings. The derived datasets
(directors, axes, sites, site_diameters) are written for other tools; loading rebuilds the
packing from positions, diameters, orientations and the shape attribute.

Every file is written to a temporary sibling and renamed onto its name, so an interrupted
run never leaves a half-written file. Paths that are symlinks, device nodes, FIFOs or
read-only files are refused unless forced (``check_writable``, ``replacing``); unreadable
files give one-line ValueErrors naming the file (``open_hdf5``).
"""

from __future__ import annotations

import contextlib
import datetime
import io
import json
import math
from pathlib import Path

import h5py
import numpy as np

from jamflow import __version__
from jamflow.model.box import Box
from jamflow.model.packing import Packing, warn_float64_only
from jamflow.model.potentials import potential_from_attrs
from jamflow.model.shapes.shape import shape_from_attrs
from jamflow.model.walls import face_pressures, parse_walls, wall_type
from jamflow.support.files import atomic_path, check_writable, replacing

SCHEMA = "jamflow.packing"
SCHEMA_VERSION = 2
























def save_packing(path, packing: Packing, *, energy_per_particle=None, pressure_tensor=None,
                 protocol: dict | None = None, history: dict | None = None, lammps_version=None,
                 wall_forces=None, target_pressure=None, stress=None, checks=None,
                 dphi_above=None, tables=None, phi_j=None) -> Path:
    """Write ``packing`` (and optional results) atomically to the HDF5 file ``path``.

    Every optional result left None is not written (a number is stored as NaN).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write (replaced atomically when it exists).
    packing : jamflow.Packing
        Positions, diameters and box in diameters; wrapped into the cell once when outside it.
    energy_per_particle : float, optional
        V, in eps.
    pressure_tensor : array_like, optional
        (d, d), in eps / diameter^d; the attribute ``pressure`` is its trace / d.
    protocol : dict, optional
        Stored as the attributes of group ``protocol`` (settings, engine, seconds...).
    history : dict, optional
        {name: column}, stored as the datasets of group ``history``.
    lammps_version : str, optional
        The LAMMPS version that made the packing ("" when None).
    wall_forces : array_like, optional
        (d, 2, d), eps / diameter: the force on each face (``jamflow.model.walls.wall_loads``);
        written only when the box has walls, with the pressure on each face.
    target_pressure : float, optional
        The pressure a constant-pressure run aimed at, eps / diameter^d.
    stress : str, optional
        The stress the target pressure applies (``iso`` ...).
    checks : PackingChecks, optional
        ``jamflow.mechanics.checks.PackingChecks``, stored as the attributes of group ``checks``.
    dphi_above : float, optional
        The compression above onset (``jamflow.protocols.above``), dimensionless.
    tables : dict, optional
        {group: {name: column}}, more groups of datasets (e.g. ``anneal``).
    phi_j : float, optional
        The onset packing fraction the run reports (attribute ``phi_j``).

    Returns
    -------
    pathlib.Path
        ``path``.
    """
    pot = packing.potential
    attrs = dict(
        schema=SCHEMA, schema_version=SCHEMA_VERSION, jamflow_version=__version__,
        lammps_version=str(lammps_version or ""), dim=packing.dim, n=packing.n, phi=packing.phi,
        energy_per_particle=_num(energy_per_particle), potential=pot.spec,
        alpha=float(getattr(pot, "alpha", math.nan)), epsilon=float(pot.epsilon),
        seed=int(packing.metadata.get("seed", -1)), sizes=str(packing.metadata.get("sizes", "")),
        created=datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        shape=json.dumps(packing.shape.attrs()), shape_spec=packing.shape.spec(packing.dim),
        gamma=packing.box.shear_strain,
        walls=packing.box.wall_spec, wall_type=wall_type(packing), gravity=float(packing.gravity),
        target_pressure=_num(target_pressure), stress=str(stress or ""), dphi_above=_num(dphi_above),
        phi_j=_num(phi_j), start_orientations=str(packing.metadata.get("orientations", "")),
    )
    ptensor = None if pressure_tensor is None else np.asarray(pressure_tensor, float)
    attrs["pressure"] = math.nan if ptensor is None else float(np.trace(ptensor) / packing.dim)
    with hdf5_output(path) as f:
        f.attrs.update(attrs)
        f.attrs["precision"] = packing.precision
        stored = stored_packing(packing)
        f["positions"] = stored.positions
        if stored.extended is not None:  # hi + lo as they are (wrapped in double-double by the refinement)
            f["positions_lo"] = stored.positions_lo
            f["box_lo"] = stored.lengths_lo
        f["diameters"] = stored.diameters
        f["box"] = stored.box.h
        for name, data in shape_datasets(stored).items():
            f[name] = data
        if ptensor is not None:
            f["pressure_tensor"] = ptensor
        if packing.fixed is not None:
            f["fixed"] = packing.fixed.astype(np.uint8)
        if wall_forces is not None and packing.box.walls:
            loads = np.asarray(wall_forces, float)
            f["wall_forces"] = loads[list(packing.box.walls)]
            f["wall_pressure"] = face_pressures(packing.box, loads)
        f.create_group("protocol").attrs.update({k: _attr(v) for k, v in (protocol or {}).items()})
        hist = f.create_group("history")
        for name, column in (history or {}).items():
            hist[name] = np.asarray(column)
        if checks is not None:
            f.create_group("checks").attrs.update(checks.as_attrs())
        for group, columns in (tables or {}).items():
            g = f.create_group(group)
            for name, column in columns.items():
                g[name] = np.asarray(column)
    return Path(path)


IN_CELL_SLACK = 1e-12  # fractional coordinates in [-slack, 1 + slack) count as inside the cell (round-off of a wrap)


def in_cell(box: Box, positions) -> bool:
    """True when every position lies in the primary reduced cell along the periodic axes, up to
    the round-off of ``Box.wrap`` (``IN_CELL_SLACK`` in fractional coordinates)."""
    s = box.reduced().to_fractional(positions)[:, list(np.flatnonzero(box.periodic))]
    return bool(np.all((s >= -IN_CELL_SLACK) & (s < 1.0 + IN_CELL_SLACK)))


def stored_packing(packing: Packing) -> Packing:
    """The packing a file holds for ``packing``: the packing itself, bit for bit, when its
    positions lie in the cell (every engine and protocol wraps its packings once) or when it
    carries double-double low parts (hi + lo are wrapped together by the refinement; wrapping hi
    alone would break the sum); else the packing with its positions wrapped once. Wrapping again
    positions that are already in the cell is not the identity (the fractional round trip moves
    them by an ulp), so ``save_packing`` then ``load_packing`` returns the same bits."""
    if packing.extended is not None or in_cell(packing.box, packing.positions):
        return packing
    return packing.with_positions(packing.box.wrap(packing.positions))


def save_jam_result(path, result, checks, *, target_pressure=None, stress=None, force: bool = False, **run_info):
    """Write a checked jam result (``protocols.spec.run_jam``) as a packing file: its settings and
    engine in the protocol group with ``run_info`` (e.g. seconds), its history and checks;
    ``stress`` is recorded with a ``target_pressure``; ``force`` lets it replace a symlink,
    device node or read-only file."""
    with replacing([path] if force else []):
        return save_packing(path, result.packing, energy_per_particle=result.energy_per_particle,
                            pressure_tensor=result.pressure_tensor,
                            protocol={**result.settings.as_dict(), "engine": result.engine, **run_info},
                            history=result.history, lammps_version=result.lammps_version,
                            wall_forces=getattr(result, "wall_forces", None), target_pressure=target_pressure,
                            stress=stress if target_pressure is not None else None, checks=checks,
                            phi_j=result.phi_j)


def save_result(result, path, checks=None, *, force: bool = False) -> Path:
    """Write a jam result (``jamflow.jam``, ``run_jam``: a ``JamResult``, or a constant-pressure
    ``PressureResult``) to ``path`` as ``jamflow jam --out`` does: the same file, with its checks
    group and the protocol group (settings and engine). ``checks`` None: the packing is checked
    here as the command checks it (``protocols.spec.checked``: the energy window of
    ``settings.v_tol``, none under gravity or at constant pressure); a result that fails its checks
    is refused (``JammingFailed``, nothing written), so no file holds an unchecked packing as if it
    were jammed. ``force``: replace a symlink, device node or read-only file. ``JamResult.save``
    and ``PressureResult.save`` call this.

    Parameters
    ----------
    result : jamflow.JamResult or PressureResult
        The run to write.
    path : str or os.PathLike
        The packing file to write.
    checks : PackingChecks, optional
        Checks already made (``jamflow.check_packing``); None: checked here.
    force : bool, default False
        Replace a symlink, device node or read-only file at ``path``.

    Returns
    -------
    pathlib.Path
        ``path``.

    Raises
    ------
    ValueError
        ``path`` cannot be written (checked before any work: ``support.files.check_writable``).
    jamflow.JammingFailed
        The packing fails its checks (nothing is written).
    """
    from jamflow.protocols.outcome import JammingFailed
    from jamflow.protocols.spec import checked

    check_writable(path, force)
    settings = result.settings
    pressures = getattr(settings, "pressures", None)  # PressureSettings: the last target is the one reached
    if checks is None:
        window = None if pressures is not None or result.packing.gravity else settings.v_tol
        checks = checked(result, settings.minimizer, window, destination=path)
    elif not checks.passed:
        raise JammingFailed(f"the packing failed its checks: {'; '.join(checks.problems())}. Nothing was written to "
                            f"{path}; a packing that fails its checks is not written as jammed")
    return save_jam_result(path, result, checks, target_pressure=None if pressures is None else pressures[-1],
                           stress=getattr(settings, "stress", None), force=force)


def save_refined(result, path, *, force: bool = False) -> Path:
    """Write a ``jamflow.refine`` result (``RefineResult``): hi + lo positions and box, precision =
    "double-double", its settings, history and double-double checks. One that fails its checks is
    refused (``JammingFailed``, nothing written)."""
    from jamflow.protocols.outcome import JammingFailed

    check_writable(path, force)
    checks = result.checks()
    if not checks.passed:
        raise JammingFailed(f"the refined packing failed its checks: {'; '.join(checks.problems())}. Nothing was "
                            f"written to {path}")
    with replacing([path] if force else []):
        return save_packing(path, result.packing, energy_per_particle=result.energy_per_particle,
                            pressure_tensor=result.pressure_tensor,
                            protocol={**result.settings.as_dict(), "engine": "numba", "seconds": result.seconds,
                                      "refines": result.refines},
                            history=result.history, target_pressure=result.settings.pressure, stress="iso",
                            checks=checks)


@contextlib.contextmanager
def open_hdf5(path, what: str = "jamflow packing file", remedy: str | None = None):
    """``h5py.File(path, "r")`` whose failures are one-line ValueErrors naming the file and
    what is wrong with it: missing, empty, not HDF5, truncated or damaged, or lacking an
    attribute or dataset that ``what`` needs (KeyError inside the block); ``remedy`` (what to do)
    ends every message (default: rerun the command that wrote it, where that is the remedy)."""
    path = Path(path)
    rerun = remedy or "rerun the command that wrote it"
    also = f"; {remedy}" if remedy else ""
    if not path.is_file():
        raise FileNotFoundError(f"no {what} {path}" if not path.exists() else f"{path} is not a file; give a {what}")
    if path.stat().st_size == 0:
        raise ValueError(f"{path} is empty (0 bytes), not a {what}; {remedy or 'rerun the command that writes it'}")
    if not h5py.is_hdf5(path):
        raise ValueError(f"{path} is not an HDF5 file (no HDF5 signature), so not a {what}{also}")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise ValueError(f"{path} is truncated or damaged ({_h5_reason(err)}); {rerun}") from None
    try:
        with f:
            yield f
    except KeyError as err:
        raise ValueError(f"{path} is an incomplete {what}: {_h5_reason(err)}{also}") from None
    except json.JSONDecodeError as err:
        raise ValueError(f"{path} is a damaged {what}: an attribute is not valid JSON ({err}); rerun the command "
                         "that wrote it") from None
    except OSError as err:
        raise ValueError(f"{path} is damaged ({_h5_reason(err)}); {rerun}") from None


@contextlib.contextmanager
def hdf5_output(path):
    """An HDF5 file open for writing whose bytes go to ``path`` atomically on success. HDF5 is
    built in memory and written with plain file writes: a full disk is then a Python OSError
    (``support.files.DiskFull``: one line), where HDF5 writing to disk itself raised from inside
    its flush at close and could crash the process (segmentation fault)."""
    with atomic_path(path) as tmp:
        buffer = io.BytesIO()
        with h5py.File(buffer, "w") as f:
            yield f
        with open(tmp, "wb") as fh:
            fh.write(buffer.getbuffer())


def _h5_reason(err) -> str:
    """h5py's message without its 'Unable to synchronously ...' wrapper."""
    text = str(err.args[0] if err.args else err).strip("\"'")
    return text.split("(", 1)[1].rstrip(")") if "(" in text else text


def load_packing(path) -> Packing:
    """Read a jamflow HDF5 packing file (any schema version up to the current one).

    Parameters
    ----------
    path : str or os.PathLike
        The file ``save_packing`` (``jamflow jam --out``) wrote.

    Returns
    -------
    jamflow.Packing
        Positions and box in diameters, with the potential, shape, orientations, fixed
        particles and gravity the file holds, double-double low parts when it has them;
        ``metadata`` has ``seed``, ``sizes`` and ``source`` (the path).

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ValueError
        Not a jamflow packing file, a newer schema version, empty, truncated or damaged, or an
        invalid packing (box, walls, low parts); one line naming the file.
    """
    path = Path(path)
    with open_hdf5(path) as f:
        schema = f.attrs.get("schema")
        if schema != SCHEMA:
            raise ValueError(f"{path} is not a jamflow packing file (schema {schema!r})")
        if int(f.attrs["schema_version"]) > SCHEMA_VERSION:
            raise ValueError(f"{path} has schema version {f.attrs['schema_version']}, newer than this "
                             f"jamflow reads (up to {SCHEMA_VERSION}); upgrade jamflow")
        pot = potential_from_attrs(str(f.attrs["potential"]), float(f.attrs["alpha"]), float(f.attrs["epsilon"]))
        shape = shape_from_attrs(json.loads(_text(f.attrs.get("shape", '{"kind": "sphere"}'))))
        orientations = f["orientations"][...] if "orientations" in f else None
        meta = {"seed": int(f.attrs["seed"]), "sizes": str(f.attrs["sizes"]), "source": str(path)}
        if _text(f.attrs.get("start_orientations", "")):
            meta["orientations"] = _text(f.attrs["start_orientations"])
        h = f["box"][...]
        fixed = f["fixed"][...].astype(bool) if "fixed" in f else None
        try:
            check_box(h)
            walls = parse_walls(_text(f.attrs.get("walls", "")), len(h))
            box = Box(h, tuple(a not in walls for a in range(len(h))))
            packing = Packing(f["positions"][...], f["diameters"][...], box, pot, meta, shape, orientations, fixed,
                              float(f.attrs.get("gravity", 0.0)))
            if "positions_lo" in f or "box_lo" in f:
                if "positions_lo" not in f:
                    raise ValueError("dataset box_lo without positions_lo: the double-double positions are missing")
                lo = check_low_parts("positions_lo", packing.positions, f["positions_lo"][...])
                box_lo = check_low_parts("box_lo", box.lengths, f["box_lo"][...]) if "box_lo" in f else None
                packing = packing.with_low_parts(lo, box_lo)
            return _with_stored_orientations(packing, orientations)
        except ValueError as err:
            raise ValueError(f"{path} holds an invalid packing: {err}") from None


UNIT_ROUNDOFF = 8 * np.finfo(float).eps  # | |q| - 1 | of a quaternion normalised in float64
LOW_PART_ULPS = 1.0  # |lo| <= this many ulp(hi): a normalised double-double pair has |lo| <= ulp(hi) / 2


def check_box(h) -> None:
    """The ``box`` dataset ``h`` is a finite 2x2 or 3x3 cell with positive side lengths; a one-line
    ValueError naming the dataset otherwise."""
    h = np.asarray(h)
    if h.ndim != 2 or h.shape[0] != h.shape[1] or h.shape[0] not in (2, 3):
        raise ValueError(f"dataset box must be a 2x2 or 3x3 cell matrix, got shape {h.shape}")
    if not np.issubdtype(h.dtype, np.number) or not np.all(np.isfinite(h)):
        raise ValueError("dataset box has non-finite entries")
    if np.any(np.diag(h) <= 0):
        raise ValueError(f"dataset box has side lengths that are not positive: {np.diag(h).tolist()}")


def check_low_parts(name: str, hi: np.ndarray, lo) -> np.ndarray:
    """The low parts ``lo`` of the double-double values hi + lo read from dataset ``name``: finite,
    of hi's shape, each at most ``LOW_PART_ULPS`` ulp(hi) in size (a normalised pair has |lo| <= ulp(hi)
    / 2; a larger low part is no low part but damage, and would be believed by every double-double
    computation). A one-line ValueError naming the dataset and the worst entry otherwise."""
    arr = np.asarray(lo)
    if arr.shape != hi.shape:
        raise ValueError(f"dataset {name} must have shape {hi.shape} (one low part per value), got {arr.shape}")
    if not np.issubdtype(arr.dtype, np.floating):
        raise ValueError(f"dataset {name} must hold floating-point numbers, got {arr.dtype}")
    arr = arr.astype(float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"dataset {name} must be finite (it holds NaN or inf)")
    limit = LOW_PART_ULPS * np.spacing(np.abs(hi))
    excess = np.abs(arr) > limit
    if np.any(excess):
        k = np.unravel_index(int(np.argmax(np.where(excess, np.abs(arr), -1.0))), arr.shape)  # the largest offender
        where = f"[{', '.join(map(str, k))}]"
        raise ValueError(f"dataset {name} has low parts larger than the ulp of their high parts ({int(excess.sum())} "
                         f"of {arr.size}; worst {name}{where} = {arr[k]:.3g}, ulp {limit[k] / LOW_PART_ULPS:.3g}): "
                         "not a double-double value; the file is damaged")
    return arr


def _with_stored_orientations(packing: Packing, stored) -> Packing:
    """``packing`` holding the file's orientations bit for bit. The Packing renormalises unit
    quaternions, and renormalising quaternions already unit to round-off moves some by an ulp, so
    without this a packing read back would differ from the one saved. Quaternions unit to round-off
    (``UNIT_ROUNDOFF``, as every normalised one is) are kept as stored; others, within the unit check
    of ``rotations.check_orientations``, are renormalised as before."""
    if stored is None or packing.orientations is None or packing.dim != 3:
        return packing
    exact = np.array(stored, dtype=float)
    unit = np.abs(np.linalg.norm(exact, axis=1) - 1.0) <= UNIT_ROUNDOFF  # others: renormalised, as given
    exact[~unit] = packing.orientations[~unit]
    if np.array_equal(exact, packing.orientations):
        return packing
    exact.setflags(write=False)
    object.__setattr__(packing, "orientations", exact)  # a fresh, frozen Packing: nothing else refers to it yet
    return packing


def shape_datasets(packing: Packing) -> dict:
    """The orientation and shape datasets of schema v2 that this packing has."""
    out = {}
    if packing.orientations is not None:
        out["orientations"] = packing.orientations
        out["directors"] = packing.directors
    out.update(packing.shape.datasets(packing.positions, packing.orientations, packing.diameters))
    return out


def read_history(path) -> dict:
    """The protocol history columns of a packing file as numpy arrays."""
    return read_table(path, "history")


def read_table(path, group: str) -> dict:
    """The datasets of ``group`` in a packing file (``history``, ``anneal``) as numpy arrays."""
    with open_hdf5(path) as f:  # a missing group: "incomplete jamflow packing file" naming it
        return {k: v[...] for k, v in f[group].items()}


def read_protocol(path) -> dict:
    """The ``protocol`` group's attributes (protocol, minimiser and run parameters) of a packing file."""
    with h5py.File(path, "r") as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["protocol"].attrs.items()}


def read_attrs(path) -> dict:
    """Root attributes (phi, energy_per_particle, pressure, versions, ...) of a packing file."""
    with open_hdf5(path) as f:
        return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}


def read_phi_j(path) -> float:
    """The onset ``jamflow jam`` reported for the packing in ``path`` (the ``phi_j`` attribute):
    the pile's fraction under gravity (not the box's phi), phi_J(P->0) at constant pressure (NaN
    with one pressure), the onset of an ``--above`` packing. Files written before that attribute:
    the same, from the history (the pile's fraction is its last phi; the pressures' phis
    extrapolate) and the protocol (``phi_onset``)."""
    attrs = read_attrs(path)
    if "phi_j" in attrs:
        return float(attrs["phi_j"])
    if float(attrs.get("gravity", 0.0)) > 0:
        return float(read_history(path)["phi"][-1])
    if math.isfinite(float(attrs.get("target_pressure", math.nan))):
        from jamflow.protocols.pressure import extrapolate_phi_j

        history = read_history(path)
        potential = potential_from_attrs(str(attrs["potential"]), float(attrs["alpha"]), float(attrs["epsilon"]))
        return extrapolate_phi_j(history["target_pressure"], history["phi"], potential.onset_exponent)
    if math.isfinite(float(attrs.get("dphi_above", math.nan))):
        return float(read_protocol(path)["phi_onset"])
    return float(attrs["phi"])


def read_checks(path):
    """The ``jamflow.mechanics.checks.PackingChecks`` stored in a packing file, or None if it has none."""
    from jamflow.mechanics.checks import PackingChecks

    with open_hdf5(path) as f:
        return PackingChecks.from_attrs(f["checks"].attrs) if "checks" in f else None


def to_universe(packing: Packing):
    """An MDAnalysis Universe with positions, radii and the (triclinic) box."""
    import MDAnalysis as mda
    from MDAnalysis.lib.mdamath import triclinic_box

    warn_float64_only(packing, "an MDAnalysis Universe")
    u = mda.Universe.empty(packing.n, trajectory=True)
    _, types = packing.species()
    u.add_TopologyAttr("types", [str(t + 1) for t in types])
    u.add_TopologyAttr("radii", packing.diameters / 2.0)
    cell = packing.box.reduced().h  # the same lattice with the tilt folded in, as MDAnalysis expects
    h = cell if packing.dim == 3 else np.diag([*np.diag(cell), 1.0])
    if packing.dim == 2:
        h[0, 1] = cell[0, 1]
    pos = packing.box.wrap(packing.positions)
    u.atoms.positions = pos if packing.dim == 3 else np.column_stack([pos, np.zeros(packing.n)])
    u.dimensions = triclinic_box(*h.T)
    return u


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _num(x):
    return math.nan if x is None else float(x)


def _attr(value):
    if value is None:
        return "None"
    if isinstance(value, (bool, int, float, str, np.number)):
        return value
    return str(value)
