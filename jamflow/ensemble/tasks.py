"""What one Dask task runs on a worker: jam one packing, write its file, return its row."""

from __future__ import annotations

import argparse
import time
import warnings

from ..commands.jam import jam_from_args, save_result
from ..protocols.compression import JammingFailed
from .checks import packing_row
from .store import Task, failure_row, write_failure

TASK_ONLY = {"out": None, "quiet": True, "emit_deck": None}  # jam options an ensemble task sets itself


def make_packing(fixed: dict, task: Task, path: str, failure_path: str) -> dict:
    """Jam ``task`` with the jam options ``fixed``; write ``path`` (or the failure record) atomically."""
    args = argparse.Namespace(**{**task.options(fixed), **TASK_ONLY, "out": path})
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a final-cap warning is in the file's history/reason
            result = jam_from_args(args)
    except JammingFailed as err:
        write_failure(failure_path, str(err), time.perf_counter() - t0)
        return failure_row(failure_path, task, fixed)
    save_result(path, result, seconds=round(time.perf_counter() - t0, 3))
    return packing_row(path, task, fixed)
