"""The ``jamflow`` console script (pyproject ``[project.scripts]``): it imports nothing, so a
Ctrl-C while the command starts (importing ``jamflow.cli``) is one line and exit 130 like a
Ctrl-C later on, not a traceback. What is left is the interpreter's own start-up before this
module runs (docs/hardening.md, case 59)."""

import sys

EXIT_INTERRUPTED = 130  # jamflow.cli.EXIT_INTERRUPTED, which cannot be imported before the guard


def main() -> int:
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        print("jamflow: interrupted while starting; nothing was done", file=sys.stderr)
        return EXIT_INTERRUPTED
    return cli_main()
