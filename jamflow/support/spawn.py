"""Refusing work in a process that re-imports the main script (stdlib only).

multiprocessing's spawn and forkserver start methods, which Dask's local workers use, start each
worker by running the parent's main script again under the name ``__mp_main__``. A script that
calls an ensemble at its top level, without ``if __name__ == "__main__":``, would then start the
ensemble again in every worker (which finds the store locked by the parent, and the worker dies).
"""

from __future__ import annotations

import sys

GUARD = 'if __name__ == "__main__":'


class SpawnedReimport(SystemExit):
    """A call at the top level of a script that a worker process is re-importing. A SystemExit:
    the worker prints the one-line message, without a traceback, and exits with status 1."""


def refuse_spawned_reimport(call: str) -> None:
    """Raise ``SpawnedReimport`` if ``call`` (e.g. ``"jamflow.run_ensemble"``) was reached from
    the top level of a main script being re-imported as ``__mp_main__`` by a worker process; a
    call from a function, or from the script run as itself, passes."""
    frame = sys._getframe(1)
    while frame is not None:
        if frame.f_code.co_name == "<module>" and frame.f_globals.get("__name__") == "__mp_main__":
            script = frame.f_globals.get("__file__", "the main script")
            raise SpawnedReimport(f"jamflow: {call} was called again while a worker process imported {script}: "
                                  f"put the call under {GUARD} (Dask's workers import the script that starts them)")
        frame = frame.f_back
