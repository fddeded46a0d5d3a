"""The ``jamflow`` command line: one subcommand per module in ``jamflow.commands``."""

from __future__ import annotations

import argparse
import sys
from importlib import import_module

from . import __version__

SUBCOMMANDS = {
    "jam": ("jamflow.commands.jam", "jam particles at onset by isotropic compression"),
    "modes": ("jamflow.commands.modes", "contacts, floaters, normal modes, D(omega) and stability class of packing files"),
    "analyze": ("jamflow.commands.analyze", "structure: g(r), S(k), Q6, G, correlation lengths"),
    "moduli": ("jamflow.commands.moduli", "bulk and shear moduli: strain sweeps and the Hessian route"),
    "crosscheck": ("jamflow.commands.crosscheck", "run the LAMMPS deck and the Python controller from one start and compare"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="jamflow", description=__doc__)
    parser.add_argument("--version", action="version", version=f"jamflow {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module, help_text) in SUBCOMMANDS.items():
        mod = import_module(module)
        p = sub.add_parser(name, help=help_text, description=mod.__doc__,
                           formatter_class=argparse.ArgumentDefaultsHelpFormatter)
        mod.add_arguments(p)
        p.set_defaults(run=mod.run)
    return parser


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except (ValueError, FileNotFoundError) as err:
        print(f"jamflow {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"jamflow {args.command}: interrupted; no partial output was written", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
