"""``python -m jamflow.cli ARGS``: the ``jamflow`` command (as the console script runs it)."""

import sys

from jamflow.cli.console import main

sys.exit(main())
