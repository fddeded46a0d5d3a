"""An ensemble store: a directory with one packing file per task.

    DIR/ensemble.json            the parameters every packing shares and the grid axes (n, ...)
    DIR/n64_seed000017.h5        one packing (schema of jamflow.io.packing_file), named by its grid point and seed
    DIR/failed/n64_seed000017.json   a packing that could not be made, with the reason
    DIR/summary.csv              one row per task, rebuilt from the files above
    DIR/corrupt/                 unreadable files found by a rerun, moved aside (then redone)

Every file is written to a temporary sibling and renamed (``jamflow.support.files.atomic_path``), so a
killed task leaves at most a ``.NAME.*.tmp`` file, removed when the store is next opened.
"""

from __future__ import annotations

import csv
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

from jamflow import __version__
from jamflow.ensemble.checks import packing_row
from jamflow.io.names import packing_files
from jamflow.support.files import DirectoryLocked, atomic_path, lock_directory, read_json

MANIFEST, SUMMARY, FAILED, CORRUPT = "ensemble.json", "summary.csv", "failed", "corrupt"
SCHEMA = "jamflow.ensemble"
BOOKKEEPING = ("file", "reason", "file_size", "file_mtime_ns")


@dataclass(frozen=True)
class Task:
    """One packing to make: a grid point ((axis, value), ...) and a seed."""

    point: tuple  #: ((axis, value), ...), e.g. (("n", 64),)
    seed: int  #: the packing's seed

    @property
    def stem(self) -> str:
        """The file name without suffix, e.g. ``n64_seed000007``."""
        return "_".join([f"{axis}{_token(value)}" for axis, value in self.point] + [f"seed{self.seed:06d}"])

    @property
    def name(self) -> str:
        """The packing file's name, ``stem`` + ".h5"."""
        return self.stem + ".h5"

    def options(self, fixed: dict) -> dict:
        """The jam options of this task: the store's ``fixed`` parameters, the grid point and the seed."""
        return {**fixed, **dict(self.point), "seed": self.seed}


def _token(value) -> str:
    return re.sub(r"[^A-Za-z0-9.+-]", "-", str(value))


StoreLocked = DirectoryLocked  # the store's lock is support.files.lock_directory's


class Store:
    """The files of one ensemble directory; open it with ``with Store(dir).open(fixed, axes):``."""

    def __init__(self, directory):
        self.dir = Path(directory)
        self._lock = None

    # -- opening -----------------------------------------------------------------------
    def open(self, fixed: dict, axes: list[str], defaults: dict | None = None) -> "Store":
        """Create or reopen the store for these parameters; refuse a store made by others.
        ``defaults``: the value of a parameter the store does not record (an option added later)."""
        self._make_directory()
        self._acquire_lock()
        try:
            self._check_manifest(fixed, axes, defaults or {})
        except Exception:
            self.close()
            raise
        self.remove_debris()
        return self

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        """Release the store's lock (``open`` takes it)."""
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def _make_directory(self):
        if self.dir.exists() and not self.dir.is_dir():
            raise ValueError(f"--out {self.dir} is a file; give a directory for the ensemble store")
        try:
            (self.dir / FAILED).mkdir(parents=True, exist_ok=True)
            probe = self.dir / f".write-test-{os.getpid()}"
            probe.write_bytes(b"")
            probe.unlink()
        except OSError as err:
            raise ValueError(f"cannot write the ensemble store {self.dir}: {err.strerror}; "
                             "choose a writable --out directory") from None

    def _acquire_lock(self):
        self._lock = lock_directory(self.dir, f"another jamflow ensemble is writing {self.dir}; wait for it to end "
                                              "or use another --out")

    def _check_manifest(self, fixed: dict, axes: list[str], defaults: dict):
        path = self.dir / MANIFEST
        wanted = {"schema": SCHEMA, "schema_version": 1, "axes": list(axes), "parameters": fixed}
        if not path.exists():
            if packing_files(self.dir):
                raise ValueError(f"{self.dir} holds .h5 files but no {MANIFEST}: it is not a jamflow ensemble "
                                 "store; use another --out")
            with atomic_path(path) as tmp:
                tmp.write_text(json.dumps({**wanted, "jamflow_version": __version__}, indent=1) + "\n")
            return
        have = read_json(path, "jamflow ensemble manifest")
        if have.get("schema") != SCHEMA:
            raise ValueError(f"{path} is not a jamflow ensemble manifest; use another --out")
        if have["axes"] != list(axes):
            raise ValueError(f"{self.dir} was made varying {', '.join(have['axes'])}; this run varies "
                             f"{', '.join(axes)}: use another --out or the same grid options")
        for key in sorted(set(have["parameters"]) | set(fixed)):
            old = have["parameters"].get(key, defaults.get(key, fixed.get(key)))
            new = fixed.get(key, have["parameters"].get(key))
            if old != new:
                raise ValueError(f"{self.dir} was made with --{key.replace('_', '-')} {old}, this run asks "
                                 f"{new}: refusing to mix ensembles; use another --out or --{key.replace('_', '-')} {old}")

    def remove_debris(self) -> int:
        """Delete temporary files left by killed tasks (only while this store is locked)."""
        removed = 0
        for folder in (self.dir, self.dir / FAILED):
            for tmp in folder.glob(".*.tmp"):
                tmp.unlink(missing_ok=True)
                removed += 1
        return removed

    # -- paths -------------------------------------------------------------------------
    def packing_path(self, task: Task) -> Path:
        """Where the packing of ``task`` is written."""
        return self.dir / task.name

    def failure_path(self, task: Task) -> Path:
        """Where the failure record (JSON) of ``task`` is written."""
        return self.dir / FAILED / (task.stem + ".json")

    # -- what is done ------------------------------------------------------------------
    def summary_rows(self) -> dict:
        """The rows of summary.csv by file name."""
        return {row["file"]: row for row in self.read_summary()}

    def classify(self, tasks, fixed: dict, retry_failed: bool = False, cached: dict | None = None):
        """Split ``tasks`` into rows of finished packings, rows of recorded failures and the
        tasks still to do. Existing files are checked (re-read unless summary.csv -- or
        ``cached``, its ``summary_rows()`` read once -- holds a row for the same size and
        modification time); unreadable ones go to corrupt/ and are redone."""
        cached = self.summary_rows() if cached is None else cached
        done, failed, todo, corrupt = {}, {}, [], []
        for task in tasks:
            path, fail = self.packing_path(task), self.failure_path(task)
            if path.exists():
                row = self._cached_row(cached.get(task.name), path) or self._row_or_none(task, fixed)
                if row is not None:
                    done[task.name] = row
                    continue
                corrupt.append(self._move_corrupt(path))
            if fail.exists() and not retry_failed:
                row = self._failure_row_or_none(task, fixed)
                if row is not None:
                    failed[task.name] = row
                    continue
            fail.unlink(missing_ok=True)
            todo.append(task)
        return done, failed, todo, corrupt

    @staticmethod
    def _cached_row(row, path):
        if row is None or row.get("status") != "ok":
            return None
        st = path.stat()
        return row if (str(st.st_size), str(st.st_mtime_ns)) == (row["file_size"], row["file_mtime_ns"]) else None

    def _row_or_none(self, task, fixed):
        try:
            return packing_row(self.packing_path(task), task, fixed)
        except (OSError, KeyError, ValueError):
            return None

    def _failure_row_or_none(self, task, fixed):
        try:
            return failure_row(self.failure_path(task), task, fixed)
        except (OSError, KeyError, ValueError):
            return None

    def _move_corrupt(self, path: Path) -> Path:
        (self.dir / CORRUPT).mkdir(exist_ok=True)
        target = self.dir / CORRUPT / f"{path.name}.{path.stat().st_mtime_ns}"
        os.replace(path, target)
        return target

    # -- summary -----------------------------------------------------------------------
    def read_summary(self) -> list[dict]:
        """The rows of summary.csv (empty when there is none yet)."""
        path = self.dir / SUMMARY
        if not path.exists():
            return []
        with path.open(newline="") as fh:
            return list(csv.DictReader(fh))

    def write_summary(self, rows) -> Path:
        """Atomically write summary.csv, rows sorted by grid point and seed."""
        rows = sorted(rows, key=lambda r: (r["file"]))
        columns = _columns(rows)
        path = self.dir / SUMMARY
        with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
            writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
            writer.writeheader()
            writer.writerows(rows)
        return path

    def rebuild_summary(self) -> Path:
        """summary.csv from the packing and failure files alone (no cached rows)."""
        manifest = read_json(self.dir / MANIFEST, "jamflow ensemble manifest")
        rows = []
        for path in packing_files(self.dir) + sorted((self.dir / FAILED).glob("*.json")):
            task = task_from_name(path.stem, manifest["axes"])
            read = packing_row if path.suffix == ".h5" else failure_row
            rows.append(read(path, task, manifest["parameters"]))
        return self.write_summary(rows)


def _columns(rows) -> list[str]:
    first = ["n", "seed", "status", "phi_j", "phi", "V", "P", "mean_z", "floaters", "n_contacts", "iterations",
             "minimizations", "seconds", "engine", "jamflow_version", "max_force", "in_window", "balanced"]
    seen = list(dict.fromkeys(k for r in rows for k in r))
    rest = [k for k in seen if k not in first and k not in BOOKKEEPING]
    return [k for k in first if k in seen or k in ("n", "seed", "phi_j")] + rest + list(BOOKKEEPING)


def task_from_name(stem: str, axes: list[str]) -> Task:
    """Invert Task.stem for the n axis and seed (other axes are read back as text)."""
    parts = stem.split("_")
    if len(parts) != len(axes) + 1 or not parts[-1].startswith("seed"):
        raise ValueError(f"{stem}: not a store file name for axes {axes}")
    point = tuple((axis, int(part[len(axis):]) if axis == "n" else part[len(axis):])
                  for axis, part in zip(axes, parts[:-1]))
    return Task(point, int(parts[-1][4:]))


def failure_row(path: Path, task: Task, fixed: dict) -> dict:
    """The summary row of a failed task, from its failure record at ``path``."""
    record = read_json(path, "failure record of a jamflow ensemble")
    return {**task.options(fixed), "status": "failed", "reason": record["reason"], "file": task.name,
            "seconds": record.get("seconds", ""), "jamflow_version": record.get("jamflow_version", "")}


def write_failure(path, reason: str, seconds: float) -> None:
    """Write a failure record (reason, seconds, jamflow version) atomically to ``path`` as JSON."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps({"reason": reason, "seconds": seconds, "jamflow_version": __version__}) + "\n")
