"""Per-packing analysis of many files on the ensemble's Dask engine (``jamflow modes`` and
``jamflow analyze`` over a store): directories expand to their packing files, and one task
per file runs on a local cluster or an existing scheduler."""

from __future__ import annotations

import contextlib
import warnings
from pathlib import Path

from tqdm import tqdm

from jamflow.io.names import packing_files, without_derived
from jamflow.support.files import check_distinct
from jamflow.support.progress import PlainProgress, is_terminal


def progress(iterable=None, **kwargs):
    """A tqdm bar on a terminal; elsewhere (a pipe, a batch log) plain infrequent lines
    (``PlainProgress``; ``bar_format="{desc}"``, a status line, writes its text when it changes)."""
    if is_terminal(kwargs.get("file")):
        return tqdm(iterable, **kwargs)
    return PlainProgress(iterable, status=kwargs.get("bar_format") == "{desc}", **kwargs)


def skip_derived(paths) -> list:
    """The paths but result files named ``NAME.KIND.h5`` (``jamflow.io.names``), with a warning
    naming what was left out; a ValueError if nothing is left."""
    kept, skipped = without_derived(paths)
    if skipped and not kept:
        raise ValueError(f"{skipped[0]} is a result file (NAME.KIND.h5, jamflow.io.names), not a packing; "
                         "give the packing files")
    if skipped:
        warnings.warn(f"skipped {len(skipped)} result file(s) named NAME.KIND.h5 (e.g. {skipped[0]}): not packings",
                      stacklevel=2)
    return kept


def expand_inputs(paths) -> list[str]:
    """Files as given; a directory (an ensemble store) stands for its ``*.h5`` packing files,
    without the result files derived from them (``jamflow.io.names``: ``NAME.modes.h5``,
    ``NAME.moduli.h5``, ...); so are such files given by name, with a warning (``skip_derived``).
    A file named twice is refused (``check_distinct``)."""
    out = []
    for path in map(Path, skip_derived(paths)):
        if path.is_dir():
            files = packing_files(path)
            if not files:
                raise FileNotFoundError(f"directory {path} holds no *.h5 packing files (result files such as "
                                        "NAME.modes.h5 do not count)")
            out += [str(f) for f in files]
        else:
            out.append(str(path))
    return check_distinct(out)



def add_engine_arguments(p) -> None:
    """--workers / --scheduler, as in ``jamflow ensemble``."""
    p.add_argument("--workers", type=int, default=None,
                   help="run one task per file on a local Dask cluster of this many processes")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run one task per file on an existing Dask scheduler (tcp://HOST:PORT or a scheduler file)")


_bar = progress  # file_mapper's argument ``progress`` hides the function's name


@contextlib.contextmanager
def file_mapper(workers=None, scheduler=None, progress=True):
    """A function ``run(func, files, *args, desc=...)`` = ``[func(f, *args) for f in files]``,
    one Dask task per file when ``workers`` or ``scheduler`` is given (results in input order;
    the first task error is raised), else in this process. One cluster serves every call."""
    if workers is not None and workers < 1:
        raise ValueError(f"--workers must be at least 1, got {workers}")
    if workers is None and scheduler is None:
        yield lambda func, files, *args, desc="packings": [
            func(f, *args) for f in _bar(files, desc=desc, disable=not progress or len(files) < 2)]
        return
    from distributed import as_completed

    from jamflow.ensemble.cluster import dask_client

    with dask_client(workers, scheduler) as client:
        def run(func, files, *args, desc="packings"):
            futures = [client.submit(func, f, *args, pure=False) for f in files]
            with _bar(total=len(files), desc=desc, disable=not progress) as bar:
                for _ in as_completed(futures):
                    bar.update(1)
            return client.gather(futures)

        yield run


def map_files(func, files, *args, workers=None, scheduler=None, progress=True, desc="packings") -> list:
    """One ``file_mapper`` call: ``[func(f, *args) for f in files]``, on Dask if asked."""
    with file_mapper(workers, scheduler, progress) as run:
        return run(func, files, *args, desc=desc)
