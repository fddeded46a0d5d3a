"""The ``jamflow`` console script (pyproject ``[project.scripts]``). Importing this module (the
script's first step) points Ctrl-C at a one-line exit 130, which holds while the script goes
on and ``jamflow.cli.app`` is imported, until ``jamflow.cli.app.main`` takes over (it turns Ctrl-C into
the same exit, after cleaning up). Before, a Ctrl-C in those milliseconds was a traceback.
What is left is the interpreter's own start-up before this module runs (docs/hardening.md,
case 63)."""

import signal
import sys

EXIT_INTERRUPTED = 130  # jamflow.cli.app.EXIT_INTERRUPTED, not imported: that is what this module guards


def _interrupted(signum, frame):
    print("jamflow: interrupted while starting; nothing was done", file=sys.stderr)
    raise SystemExit(EXIT_INTERRUPTED)


signal.signal(signal.SIGINT, _interrupted)


def main() -> int:
    from jamflow.cli.app import main as cli_main

    signal.signal(signal.SIGINT, signal.default_int_handler)  # KeyboardInterrupt again, caught by cli.main
    return cli_main()
