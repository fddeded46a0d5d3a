"""``python -m benchmarks``: list and run the maintained benchmarks (run from the repository root).

    python -m benchmarks list                      # name, kind, quick mode, description
    python -m benchmarks run NAME [NAME ...]       # full runs (each benchmark's own defaults)
    python -m benchmarks run NAME -- ARGS ...      # one benchmark with its own arguments
    python -m benchmarks run --quick NAME ...      # the named ones in their quick mode
    python -m benchmarks --quick                   # every quick mode (the others: import only); exit 1 if any fails

Benchmarks run in this process, one after another (``main(argv)`` of benchmarks/NAME.py); a
failure is reported and the next one runs. Quick modes write into a scratch directory, never
into docs/notes/, and check no timing.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import tempfile
import time
import traceback
from pathlib import Path

from benchmarks import BENCHMARKS, KINDS

HERE = Path(__file__).resolve().parent


def listing() -> str:
    lines = []
    for kind in KINDS:
        for name, b in BENCHMARKS.items():
            if b.kind == kind:
                quick = "quick" if b.quick is not None else "no quick mode"
                lines.append(f"{name:24s} {kind:9s} {quick:14s} {b.description}")
    return "\n".join(lines)


def run_one(name: str, argv: list[str]) -> bool:
    """benchmarks/NAME.py's main(argv) in this process; True if it ended without error."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))  # the scripts import ``common`` as their sibling
    print(f"=== {name} {' '.join(argv)}", flush=True)
    t0 = time.perf_counter()
    try:
        code = importlib.import_module(name).main(argv)
    except SystemExit as stop:
        code = stop.code
    except Exception:
        traceback.print_exc()
        code = 1
    ok = code in (None, 0)
    print(f"=== {name}: {'ok' if ok else f'FAILED ({code})'} in {time.perf_counter() - t0:.1f} s", flush=True)
    return ok


def imports(name: str) -> bool:
    """True if benchmarks/NAME.py imports (the check of a benchmark without a quick mode)."""
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))
    try:
        importlib.import_module(name)
        return True
    except Exception:
        print(f"=== {name}: FAILED to import", flush=True)
        traceback.print_exc()
        return False


def run(names: list[str], extra: list[str] | None, quick: bool) -> int:
    """Run ``names`` (quick modes, or each with ``extra`` -- the arguments after ``--`` -- or its
    defaults); 0 if all ended without error."""
    unknown = [n for n in names if n not in BENCHMARKS]
    if unknown:
        print(f"unknown benchmark(s): {' '.join(unknown)} (python -m benchmarks list)", file=sys.stderr)
        return 2
    if extra is not None and (len(names) != 1 or quick):
        print("arguments after -- need exactly one benchmark and no --quick", file=sys.stderr)
        return 2
    failed, skipped, t0 = [], [], time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="jamflow-bench-") as tmp:
        for name in names:
            b = BENCHMARKS[name]
            if quick and b.quick is None:
                skipped.append(name)  # no quick mode: only check that the script still imports
                if not imports(name):
                    failed.append(name)
                continue
            argv = [a.replace("{tmp}", tmp) for a in b.quick] if quick else (extra or [])
            if not run_one(name, argv):
                failed.append(name)
    ran = len(names) - len(skipped)
    print(f"\n{ran - len(set(failed) - set(skipped))} of {ran} benchmark(s) ok in {time.perf_counter() - t0:.1f} s"
          + (f"; failed: {' '.join(failed)}" if failed else "")
          + (f"; no quick mode (imported only): {len(skipped)}" if skipped else ""))
    return 1 if failed else 0


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    extra = None
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser(prog="python -m benchmarks", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="without a command: every benchmark's quick mode")
    sub = ap.add_subparsers(dest="command")
    sub.add_parser("list", help="the maintained benchmarks")
    r = sub.add_parser("run", help="run benchmarks by name")
    r.add_argument("names", nargs="+", metavar="NAME")
    r.add_argument("--quick", action="store_true", dest="run_quick", help="their quick modes")
    args = ap.parse_args(argv)
    if args.command == "list":
        print(listing())
        return 0
    if args.command == "run":
        return run(args.names, extra, args.quick or args.run_quick)
    if args.quick:
        return run(list(BENCHMARKS), None, True)
    ap.print_help()
    return 2


if __name__ == "__main__":
    sys.exit(main())
