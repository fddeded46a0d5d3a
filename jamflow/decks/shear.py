"""The quasistatic shear protocol as a LAMMPS input deck (``lammps_inputs/shear.lmp``).

The deck (``jamflow.decks.jam_script.SHEAR_BODY``) runs ``jamflow.protocols.shear.shear`` with the
chapter's bisection after each step, in the LAMMPS input language alone, from a packing written as
a data file: step 0 brings it into the energy window at its own strain, step k sets the tilt to
gamma_k l_y (x_i -> x_i + dgamma y_i, with the reduced cell flipped at |xy| = l_x / 2 as
``LammpsEngine.set_box`` does) and runs the compression loop of ``jam.lmp`` at that strain. From
the same start, on the same LAMMPS build and one rank, it executes the controller's
floating-point operations (``jamflow crosscheck --shear`` checks this).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from jamflow.decks.jam import (DeckFailed, PROTOCOL_COLUMNS, _num, check_workdir, lammps_error, optional_values,
                               protocol_values, read_data_file, render, run_lmp, system_values)
from jamflow.support.files import atomic_path
from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.model.packing import Packing
from jamflow.protocols.settings import CompressionSettings, chapter_protocol
from jamflow.protocols.shear import shear_strains

SHEAR_DECK_NAME = "shear.lmp"
SHEAR_OPTIONAL = ("xy0", "steps", "vsum", "ftol", "plugin")
STATIC_COLUMNS = ("step", "gamma", "phi_j", "energy_per_particle", "pressure", "pxy", "minimizations", "iterations")


def shear_deck_variables(settings: CompressionSettings | None = None, *, dim: int = 2, sizes="bi:1.4:0.5",
                         potential="spring", data="start.data", dgamma: float = 0.002, to: float = 0.3,
                         xy0: float | None = None, steps: int | None = None, vsum: float | None = None,
                         out: str = "path") -> dict:
    """The shear deck's variables; ValueError for what it cannot run. ``xy0`` (the start's
    accumulated tilt), ``steps`` and ``vsum`` (total particle volume) are passed by jamflow at
    full precision so the deck repeats the controller's arithmetic; the deck computes them
    itself when they are left out."""
    settings = settings or chapter_protocol(dphi0=1e-6)
    d2, _ = system_values(sizes, potential)
    for name, value in (("dgamma", dgamma), ("to", to)):
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
    values = dict(dim=int(dim), data=str(data), dgamma=_num(dgamma), to=_num(to), d1=1, d2=_num(d2),
                  **protocol_values(settings), out=str(out))
    optional = {"xy0": None if xy0 is None else repr(float(xy0)), "steps": None if steps is None else int(steps),
                "vsum": None if vsum is None else repr(float(vsum))}
    values.update({k: v for k, v in optional.items() if v is not None})
    values.update(optional_values(settings))
    return values


def shear_deck_text(variables: dict | None = None) -> str:
    """The shear deck with ``variables`` (from ``shear_deck_variables``) as its defaults."""
    from jamflow.decks.jam_script import SHEAR_BODY, SHEAR_HEADER

    return render(SHEAR_HEADER, SHEAR_BODY, SHEAR_OPTIONAL, shear_deck_variables() if variables is None else variables)


def write_shear_deck(path, variables: dict | None = None) -> Path:
    """Write the shear deck (``shear_deck_text(variables)``) atomically to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(shear_deck_text(variables))
    return Path(path)


def default_shear_deck_path() -> Path:
    """``lammps_inputs/shear.lmp`` in a source checkout."""
    return Path(__file__).resolve().parents[2] / "lammps_inputs" / SHEAR_DECK_NAME


def start_variables(start: Packing, dgamma: float, to: float, settings: CompressionSettings | None = None,
                    data: str = "start.data", out: str = "path") -> dict:
    """Variables that make the deck repeat ``shear(start, dgamma, to, settings, engine="lammps")``."""
    values = start.species()[0]
    if values[0] != 1.0:
        raise ValueError(f"the deck's small diameter is 1, got {values[0]}; rescale the packing")
    strains = shear_strains(start.box.shear_strain, dgamma, to)
    return shear_deck_variables(settings, dim=start.dim, sizes=start.metadata.get("sizes") or _sizes(values),
                                potential=start.potential, data=data, dgamma=dgamma, to=to,
                                xy0=float(start.box.h[0, 1]), steps=len(strains) - 1,
                                vsum=float(start.volumes.sum()), out=out)


def _sizes(values) -> str:
    return "mono" if len(values) == 1 else f"bi:{values[1]!r}:0.5"


def emit_shear_deck(path, start: Packing, dgamma: float, to: float, settings: CompressionSettings | None = None,
                    *, out: str = "path"):
    """Write the deck that runs this shear in ``lmp`` alone and its start as PATH_STEM.start.data
    beside it (named relative to the deck's directory: run it there). Returns (deck, data)."""
    path = Path(path)
    data = path.with_name(path.stem + ".start.data")
    variables = start_variables(start, dgamma, to, settings, data=data.name, out=out)
    write_lammps_data(data, start)
    return write_shear_deck(path, variables), data


@dataclass(frozen=True)
class ShearDeckResult:
    """What one shear deck run produced: ``static`` columns (STATIC_COLUMNS, one entry per
    shear step), the minimisation history of each step and the last packing."""

    static: dict  #: STATIC_COLUMNS -> np.ndarray, one entry per shear step
    histories: list  #: per step: PROTOCOL_COLUMNS -> np.ndarray
    packing: Packing  #: the last step, its box carrying the accumulated strain
    seconds: float  #: wall time of the lmp process
    prefix: Path  #: PREFIX.data, PREFIX.protocol.txt, PREFIX.lammps.log


def run_shear_deck(workdir, variables: dict, *, deck=None, lmp=None, ranks: int = 1,
                   timeout: float | None = None) -> ShearDeckResult:
    """Run the shear deck with ``lmp`` in ``workdir``; DeckFailed unless every step reached the window."""
    workdir = check_workdir(workdir)
    deck = Path(deck) if deck else write_shear_deck(workdir / SHEAR_DECK_NAME)
    return read_shear_deck_result(*run_lmp(workdir, deck, variables, "path", lmp, ranks, timeout))


def read_shear_deck_result(prefix, seconds: float = math.nan, proc=None) -> ShearDeckResult:
    """The result a shear deck run left at ``prefix``; DeckFailed when it wrote no protocol log or did not finish."""
    prefix = Path(prefix)
    log = Path(f"{prefix}.protocol.txt")
    if not log.is_file():
        raise DeckFailed(f"the shear deck wrote no protocol log {log}: {lammps_error(prefix, proc)}")
    static, histories, result = read_shear_protocol(log)
    if result.get("status") != "sheared":
        raise DeckFailed(f"the shear deck failed: {result.get('message', 'no result line in ' + str(log))}")
    packing = read_data_file(f"{prefix}.data")
    box = packing.box.with_shear_strain(float(result["gamma"]))
    return ShearDeckResult(static, histories, packing.with_positions(packing.positions, box=box), seconds, prefix)


def read_shear_protocol(path) -> tuple[dict, list, dict]:
    """(static columns, per-step minimisation histories, result fields) of a shear deck log."""
    histories, static_rows, result = [], [], {}
    for line in Path(path).read_text().splitlines():
        words = line.split()
        if line.startswith("# shear step"):
            histories.append([])
        elif line.startswith("# static") and len(words) == 2 + len(STATIC_COLUMNS):
            static_rows.append(words[2:])
        elif line.startswith("# result"):
            result = ({"status": "failed", "message": " ".join(words[4:])} if words[2:4] == ["status", "failed:"]
                      else dict(zip(words[2::2], words[3::2])))
        elif words and not line.startswith("#") and histories:
            histories[-1].append(words)
    static = {name: np.array([float(r[k]) for r in static_rows]) for k, name in enumerate(STATIC_COLUMNS)}
    for name in ("step", "minimizations", "iterations"):
        static[name] = static[name].astype(np.int64)
    columns = [{name: np.array([r[k] for r in rows] if name == "reason" else [float(r[k]) for r in rows])
                for k, name in enumerate(PROTOCOL_COLUMNS)} for rows in histories]
    return static, columns, result
