"""Geometric-family files (``jamflow families``): the static packings met (points.h5) and the family table."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from jamflow import __version__
from jamflow.io.packing_file import _attr, hdf5_output, open_hdf5

FAMILY_SCHEMA, FAMILY_SCHEMA_VERSION = "jamflow.families", 1


def save_family_points(out, plan, points: dict, failures=()) -> Path:
    """The sampled points of ``jamflow.protocols.families.sample``, the plan and the failed jams
    and paths (schema ``jamflow.families`` v1, group /points: one dataset per POINT_FIELDS
    column; root attribute ``failures``: JSON list of messages)."""
    with hdf5_output(out) as f:
        f.attrs.update(schema=FAMILY_SCHEMA, schema_version=FAMILY_SCHEMA_VERSION, jamflow_version=__version__,
                       rounds=int(len(np.unique(points["start"]))), failures=json.dumps(list(failures)))
        f.create_group("plan").attrs.update({k: _attr(v) for k, v in plan.as_dict().items()})
        g = f.create_group("points")
        for name, column in points.items():
            g[name] = column
    return Path(out)


def load_family_points(path, remedy: str | None = None) -> tuple[dict, dict, list]:
    """(plan attributes, point columns, failures) of a points file; a damaged or foreign file is
    a one-line ValueError naming it (ending with ``remedy``, what to do)."""
    also = f"; {remedy}" if remedy else ""
    with open_hdf5(path, "jamflow families points file", remedy) as f:
        if f.attrs.get("schema") != FAMILY_SCHEMA:
            raise ValueError(f"{path} is not a jamflow families file (schema {f.attrs.get('schema')!r}){also}")
        plan = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f["plan"].attrs.items()}
        points = {k: v[...] for k, v in f["points"].items()}
        try:
            failures = json.loads(f.attrs.get("failures", "[]"))
        except ValueError as err:
            raise ValueError(f"{path} is damaged (its failures attribute is not JSON: {err}){also}") from None
    if len({len(column) for column in points.values()}) > 1:
        raise ValueError(f"{path} is damaged (its point columns differ in length){also}")
    return plan, points, failures


def save_family_table(out, plan, families, convergence, mirror, richness) -> Path:
    """The family table (/table, one dataset per column), each point's family (/point_family),
    phi_J(gamma) of every family (/curves: family, gamma, phi_j, phi_j_spread), the count against
    the number of starts (/convergence), the mirror check and the richness estimate (attributes)."""
    rows = families.table()
    with hdf5_output(out) as f:
        f.attrs.update(schema=FAMILY_SCHEMA, schema_version=FAMILY_SCHEMA_VERSION, jamflow_version=__version__,
                       families=families.count, mirror_matched=mirror.matched(), mirror_unpaired=len(mirror.unpaired),
                       mirror_worst_phi=mirror.worst_phi,
                       mirror_worst_mu=mirror.worst_mu, **{f"richness_{k}": v for k, v in richness.items()})
        f.create_group("plan").attrs.update({k: _attr(v) for k, v in plan.as_dict().items()})
        t = f.create_group("table")
        for name in (rows[0] if rows else {}):
            values = [r[name] for r in rows]
            t[name] = np.array(values, dtype="S") if name == "signature" else np.array(values)
        f["point_family"] = families.family
        curves = [(f_, g, phi, spread) for f_ in range(families.count) for g, phi, spread in zip(*families.curve(f_))]
        c = f.create_group("curves")  # phi_J(gamma) of every family: one row per family and strain met
        for k, name in enumerate(("family", "gamma", "phi_j", "phi_j_spread")):
            c[name] = np.array([row[k] for row in curves], dtype=np.int64 if k == 0 else float)
        f["mirror_partner"] = np.array([min(mirror.partner[r["family"]], default=-1) for r in rows], dtype=np.int64)
        f["convergence"] = np.array(convergence, dtype=np.int64).reshape(-1, 3)  # K, met in [0, 1/2], met anywhere
    return Path(out)
