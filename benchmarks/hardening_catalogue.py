"""Rerun the issue-18 catalogue of bad input, bad files, signals and environment cases
against the installed ``jamflow`` command and Python API, and count what still misbehaves:
a traceback, a wrong or unchecked packing written, a damaged or left-over file (including
/tmp/jamflow-* scratch directories and hidden .*.tmp files), a wrong exit code, or advice
that does not apply. docs/hardening.md has the table with what happened before.

    python benchmarks/hardening_catalogue.py            (prints the table; docs/hardening-catalogue.csv)
    python benchmarks/hardening_catalogue.py 44 45      (only those cases; no CSV written)

Every case runs in its own scratch directory with its own TMPDIR and plugin cache.
Interrupt timing cases (Ctrl-C during start-up) are run at several delays.
"""

from __future__ import annotations

import csv
import importlib.util
import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent / "jamflow"
CSV = ROOT / "docs" / "hardening-catalogue.csv"
CASES = []


def case(number, title):
    def register(fn):
        CASES.append((number, title, fn))
        return fn
    return register


class Scratch:
    """A working directory, TMPDIR and plugin cache for one case (removed after the case)."""

    made: list[Path] = []

    def __init__(self):
        self.dir = Path(tempfile.mkdtemp(prefix="hardening-"))
        Scratch.made.append(self.dir)
        self.tmp = self.dir / "tmp"
        self.tmp.mkdir()
        self.env = {**os.environ, "TMPDIR": str(self.tmp), "JAMFLOW_CACHE_DIR": str(self.dir / "cache")}

    def run(self, *args, env=None, timeout=900, **kwargs):
        return subprocess.run([str(BIN), *map(str, args)], cwd=self.dir, env={**self.env, **(env or {})},
                              capture_output=True, text=True, timeout=timeout, **kwargs)

    def python(self, code, env=None, timeout=900):
        return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=self.dir,
                              env={**self.env, **(env or {})}, capture_output=True, text=True, timeout=timeout)

    def leftovers(self) -> list[str]:
        hidden = [p.name for p in self.dir.rglob(".*.tmp")]
        return hidden + [p.name for p in self.tmp.iterdir()]

    def packing(self, name="p.h5", n=32):
        done = self.run("jam", "--n", n, "--seed", 3, "--quiet", "--out", name)
        assert done.returncode == 0, done.stderr
        return self.dir / name


def outcome(*parts) -> str:
    """'ok' when every part is 'ok' or empty, else the problems joined."""
    problems = [p for p in parts if p and p != "ok"]
    return "ok" if not problems else "; ".join(problems)


def verdict(done, code, must=(), scratch=None, written=()):
    """'ok' or what misbehaves: exit code, traceback, missing words, leftovers, files written."""
    problems = []
    err = done.stderr
    if "Traceback" in err:
        problems.append("traceback")
    if done.returncode != code:
        problems.append(f"exit {done.returncode}, expected {code}")
    problems += [f"message lacks {m!r}" for m in must if not re.search(m, err + done.stdout)]
    if scratch is not None and scratch.leftovers():
        problems.append(f"left {scratch.leftovers()}")
    problems += [f"wrote {w.name}" for w in written if w.exists()]
    return "ok" if not problems else "; ".join(problems)


def refused(args, must, n=32):
    s = Scratch()
    done = s.run("jam", "--n", n, "--quiet", *args, "--out", "x.h5")
    one_line = len(done.stderr.strip().splitlines()) == 1
    return outcome(verdict(done, 2, must, s, [s.dir / "x.h5"]), "" if one_line else "more than one line")


# --- jam ------------------------------------------------------------------------------------
@case(1, "jam --potential rlj (2D, N = 32)")
def _():
    s = Scratch()
    done = s.run("jam", "--n", 32, "--potential", "rlj", "--quiet", "--out", "r.h5")
    return outcome(verdict(done, 0, ["phi_J"], s), "" if _passed(s, "r.h5") else "packing not checked/passed")


@case(2, "jam --potential rlj --dim 3 (N = 16)")
def _():
    s = Scratch()
    done = s.run("jam", "--n", 16, "--dim", 3, "--potential", "rlj", "--quiet", "--out", "r.h5")
    return outcome(verdict(done, 0, ["phi_J"], s), "" if _passed(s, "r.h5") else "packing not checked/passed")


def _passed(s, name):
    done = s.python(f"from jamflow.io.packing_file import read_checks; c = read_checks('{name}'); print(c is not None and c.passed)")
    return done.stdout.strip() == "True"


@case(3, "jam --vtol 1e-30")
def _():
    return refused(["--vtol", "1e-30"], ["not resolvable", "use vtol"], n=64)


def _special_output(kind):
    s = Scratch()
    path = s.dir / "out.h5"
    if kind == "device":
        os.mknod(path, stat.S_IFCHR | 0o666, os.makedev(1, 7))  # a copy of /dev/full
    elif kind == "symlink":
        (s.dir / "target.h5").write_text("keep")
        path.symlink_to(s.dir / "target.h5")
    else:
        path.write_text("keep")
        path.chmod(0o444)
    before = os.lstat(path)
    done = s.run("jam", "--n", 16, "--quiet", "--out", path.name)
    after = os.lstat(path)
    damaged = (after.st_ino, after.st_mode) != (before.st_ino, before.st_mode)
    result = outcome(verdict(done, 2, ["--force"], s), "output path replaced" if damaged else "")
    forced = s.run("jam", "--n", 16, "--quiet", "--out", path.name, "--force")
    return outcome(result, "" if forced.returncode == 0 else f"--force failed: {forced.stderr.strip()[:80]}")


@case(4, "jam --out DEVICE (copy of /dev/full, as root)")
def _():
    return _special_output("device") if os.geteuid() == 0 else "not run (needs root)"


@case(5, "jam --out SYMLINK")
def _():
    return _special_output("symlink")


@case(6, "jam --out READ-ONLY-FILE")
def _():
    return _special_output("readonly")


for number, title, args, words in [
        (7, "jam --n 1000000000", ["--n", "1000000000"], ["GB of memory"]),
        (8, "jam --potential spring:10", ["--potential", "spring:10"], ["alpha = 10", "2 <= ALPHA <= 3"]),
        (9, "jam --ftol 1", ["--ftol", "1"], ["--ftol\\) <="]),
        (10, "jam --seed 99999999999999999999999", ["--seed", "99999999999999999999999"], ["seed must be an integer in"]),
        (11, "jam --potential spring:1.5 (found here: wrote a packing with net forces 0.4-0.7 of contact forces)",
         ["--potential", "spring:1.5"], ["alpha = 1.5"]),
        (12, "jam --potential spring:4 (found here: wrote a packing with net forces 7% of contact forces)",
         ["--potential", "spring:4"], ["alpha = 4"])]:
    case(number, title)(lambda args=args, words=words: refused(args, words))


# --- bad files ------------------------------------------------------------------------------
def _bad_file(kind, s, good):
    path = s.dir / f"{kind}.h5"
    if kind == "empty":
        path.write_bytes(b"")
    elif kind == "truncated":
        path.write_bytes(good.read_bytes()[:3000])
    elif kind == "text":
        path.write_text("hello\n")
    else:
        s.python(f"""
            import h5py
            with h5py.File('{path.name}', 'w') as f:
                f.attrs['schema'] = 'jamflow.packing'; f.attrs['schema_version'] = 1; f['positions'] = [[0.0, 0.0]]""")
    return path


BAD = {"empty": "is empty", "truncated": "truncated or damaged", "text": "not an HDF5 file", "incomplete": "incomplete"}
number = 13
for _how in ("modes", "analyze", "load_packing"):
    for _kind in BAD:
        def _make(kind=_kind, how=_how):
            s = Scratch()
            path = _bad_file(kind, s, s.packing())
            if how == "load_packing":
                done = s.python(f"""
                    import jamflow
                    try:
                        jamflow.load_packing('{path.name}')
                    except ValueError as err:
                        print('ValueError:', err)""")
                return verdict(done, 0, [f"ValueError: .*{path.name}.*{BAD[kind]}"], s)
            done = s.run(how, path.name, *(["--out", "s.h5"] if how == "analyze" else []))
            return verdict(done, 2, [path.name, BAD[kind]], s)
        case(number, f"{_how} on an {_kind} file" if _kind[0] in "ei" else f"{_how} on a {_kind} file")(_make)
        number += 1


def _squeezed(s):
    good = s.packing()
    s.python("""
        import jamflow
        from jamflow.io.packing_file import save_packing
        p = jamflow.load_packing('p.h5')
        save_packing('sq.h5', p.scaled_to_phi(p.phi / 0.95**2))""")
    return s.dir / "sq.h5", good


@case(25, "modes on a packing not at a minimum (box 5% smaller)")
def _():
    s = Scratch()
    sq, _ = _squeezed(s)
    done = s.run("modes", sq.name, "--no-figure")
    return verdict(done, 0, ["not at an energy minimum", "NOT FORCE BALANCED"], s)


@case(26, "analyze on a packing not at a minimum")
def _():
    s = Scratch()
    sq, _ = _squeezed(s)
    done = s.run("analyze", sq.name, "--out", "s.h5", "--r-min", "1.3")
    return verdict(done, 0, ["not at an energy minimum"], s)


# --- signals, pipes -------------------------------------------------------------------------
@case(27, "SIGTERM during jam (LAMMPS engine, N = 2048): scratch start.data, old output")
def _():
    s = Scratch()
    good = s.packing("out.h5")
    before = good.read_bytes()
    proc = subprocess.Popen([str(BIN), "jam", "--n", "2048", "--engine", "lammps", "--quiet", "--out", "out.h5"],
                            cwd=s.dir, env=s.env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not list(s.tmp.glob("jamflow-*/start.data")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=300)
    done = subprocess.CompletedProcess(proc.args, proc.returncode, out, err)
    return outcome(verdict(done, 143, ["terminated"], s), "" if good.read_bytes() == before else "old output damaged")


@case(28, "SIGTERM while modes writes its figure: hidden .*.tmp files")
def _():
    s = Scratch()
    s.packing()
    code = """
        import sys, time
        from matplotlib.figure import Figure
        original = Figure.savefig
        def slow(self, target, **kwargs):
            original(self, target, **kwargs)
            time.sleep(60)
        Figure.savefig = slow
        from jamflow.cli.app import main
        sys.exit(main(["modes", "p.h5"]))"""
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], cwd=s.dir, env=s.env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not list(s.dir.glob(".*.tmp")) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=300)
    return verdict(subprocess.CompletedProcess(proc.args, proc.returncode, out, err), 143, ["terminated"], s)


@case(29, "Ctrl-C during start-up (SIGINT after 0.3, 0.6, 1.0, 2.0 s)")
def _():
    results = []
    for delay in (0.3, 0.6, 1.0, 2.0):
        s = Scratch()
        proc = subprocess.Popen([str(BIN), "jam", "--n", "64", "--out", "x.h5"], cwd=s.dir, env=s.env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(delay)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=300)
        v = verdict(subprocess.CompletedProcess(proc.args, proc.returncode, out, err), 130, ["interrupted"], s)
        if proc.returncode == 0 and "Traceback" not in err:
            v = "ok (finished before the signal)"
        results.append(f"{delay} s: {v}")
    bad = [r for r in results if ": ok" not in r]
    return "ok" if not bad else "; ".join(bad)


@case(30, "jamflow modes x.h5 | head -1 (reader gone)")
def _():
    s = Scratch()
    s.packing()
    proc = subprocess.Popen([str(BIN), "modes", "p.h5"], cwd=s.dir, env=s.env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    proc.stdout.close()
    err = proc.stderr.read()
    proc.wait(timeout=300)
    done = subprocess.CompletedProcess(proc.args, proc.returncode, "", err)
    missing = [] if (s.dir / "p.modes.png").is_file() and (s.dir / "p.modes.hdf5").is_file() else ["outputs missing"]
    return outcome(verdict(done, 0, [], s), *missing)


# --- plugin and compiler --------------------------------------------------------------------
HERTZ_LAMMPS = ("jam", "--n", 16, "--potential", "hertz", "--engine", "lammps", "--quiet", "--out", "h.h5")


@case(31, "corrupt cached plugin")
def _():
    s = Scratch()
    first = s.run(*HERTZ_LAMMPS)
    if first.returncode != 0:
        return f"set-up failed: {first.stderr.strip()[:80]}"
    (library,) = (s.dir / "cache").rglob("jamflow_pairs.so")
    library.write_text("garbage\n")
    return verdict(s.run(*HERTZ_LAMMPS), 0, [re.escape(str(library)), "damaged", "rebuilding"], s)


for number, title, cxx, words in [
        (32, "CXX=/nonexistent/g++ with g++ installed", "/nonexistent/g++",
         ["CXX=/nonexistent/g\\+\\+ does not name an executable", "unset CXX"]),
        (33, "compiler failure (CXX=false)", "false", ["compiling the jamflow LAMMPS plugin failed", "Fix the compiler"])]:
    def _make(cxx=cxx, words=words):
        s = Scratch()
        return verdict(s.run(*HERTZ_LAMMPS, env={"CXX": cxx}), 5, words, s)
    case(number, title)(_make)


# --- Python API -----------------------------------------------------------------------------
for number, call, words in [(34, "jam(n=16, dim=2.0)", "dim must be the integer"),
                            (35, "jam(n=16, sizes=None)", "sizes must be a spec string"),
                            (36, "jam(n=16, potential=3)", "potential must be a spec string"),
                            (37, 'jam(n=16, settings="fast")', "settings must be a CompressionSettings")]:
    def _make(call=call, words=words):
        s = Scratch()
        done = s.python(f"""
            from jamflow import jam
            try:
                {call}
            except (TypeError, ValueError) as err:
                import traceback
                print(type(err).__name__, err, 'raised in', traceback.extract_tb(err.__traceback__)[-1].filename)""")
        raiser = re.search(r"raised in (\S+)", done.stdout)
        return outcome(verdict(done, 0, [words], s), "" if raiser and raiser.group(1).endswith("compression.py")
                       else f"raised from {raiser.group(1) if raiser else '?'}, not by jam's own checks")
    case(number, f"Python {call}")(_make)


# --- failures during work -------------------------------------------------------------------
@case(38, "JammingFailed from the command line (rlj, phi0 above jamming)")
def _():
    s = Scratch()
    done = s.run("jam", "--n", 16, "--potential", "rlj", "--phi0", "0.88", "--quiet", "--out", "x.h5")
    return verdict(done, 3, ["jamming failed", "use a lower phi0"], s, [s.dir / "x.h5"])


@case(39, "LAMMPS error from the command line (a LAMMPS command rejected)")
def _():
    s = Scratch()
    done = s.python("""
        import sys
        import jamflow.engines.lammps.engine as L
        original = L.LammpsEngine._setup
        def broken(self, packing, skin):
            original(self, packing, skin)
            self.command("pair_style no/such/style")
        L.LammpsEngine._setup = broken
        from jamflow.cli.app import main
        sys.exit(main(["jam", "--n", "16", "--engine", "lammps", "--quiet", "--out", "x.h5"]))""")
    return verdict(done, 4, ["LAMMPS failed", "no/such/style"], s, [s.dir / "x.h5"])


# --- docs, examples, pictures ---------------------------------------------------------------
@case(40, "README / --help on engines reaching the same minima")
def _():
    s = Scratch()
    done = s.run("jam", "--help")
    readme = (ROOT / "README.md").read_text()
    wrong = "same minima from the same start" in readme
    says = "different" in " ".join(done.stdout.split())
    return outcome(verdict(done, 0, [], s), "README still claims the same minima" if wrong else "",
                   "" if says else "--help does not say the engines differ")


@case(41, "examples/ folder, each producing a figure")
def _():
    scripts = sorted((ROOT / "examples").glob("*.py"))
    return "ok" if len(scripts) >= 4 else f"only {len(scripts)} examples"


@case(42, "a picture of a packing (jamflow draw)")
def _():
    s = Scratch()
    s.packing()
    done = s.run("draw", "p.h5", "-o", "p.png")
    ok = (s.dir / "p.png").is_file() and (s.dir / "p.png").read_bytes()[:4] == b"\x89PNG"
    return outcome(verdict(done, 0, [], s), "" if ok else "no PNG")


@case(43, "an OVITO-readable file (jamflow export)")
def _():
    s = Scratch()
    s.packing()
    results = []
    for fmt in ("lammps-dump", "xyz"):
        done = s.run("export", "p.h5", "--format", fmt)
        results.append(verdict(done, 0, [], s))
    if importlib.util.find_spec("ovito") is None:  # optional: pip install ovito
        return "; ".join(r for r in results if r != "ok") or "ok (written; OVITO not installed to open them)"
    check = s.python("""
        from ovito.io import import_file
        for name in ("p.dump", "p.xyz"):
            data = import_file(name).compute()
            print(name, data.particles.count, "Radius" in data.particles.keys())""")
    opened = check.stdout.split()
    good = check.returncode == 0 and opened.count("True") == 2 and opened.count("32") == 2
    return "; ".join(r for r in results if r != "ok") or ("ok (OVITO opens both with radii)" if good
                                                          else f"OVITO: {check.stderr.strip()[-120:]}")


# --- issue 18 follow-up: commands and options added since (shear, families, moduli, anneal) ----
def _signalled(s, args, signum, wait_for=None, delay=3.0):
    """Run ``jamflow ARGS``, send ``signum`` after ``delay`` s (or once ``wait_for`` exists)."""
    proc = subprocess.Popen([str(BIN), *map(str, args)], cwd=s.dir, env=s.env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + (300 if wait_for else delay)
    while time.monotonic() < deadline and not (wait_for and wait_for.exists()):
        time.sleep(0.01)
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=300)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)


def _gone(path):
    return "" if not path.exists() else f"left {path.name}/ behind"


SHEAR = ("shear", "p.h5", "--dgamma", "1e-3", "--to", "2e-3", "--quiet", "--no-figure")
FAMILIES = ("families", "--n", 6, "--starts", 1, "--gamma-max", 0.02, "--quiet")
MODULI = ("moduli", "p.h5", "--min-amplitude", "1e-7", "--max-amplitude", "1e-5", "--per-decade", 1, "--quiet",
          "--no-figure")


@case(44, "shear --dgamma -1e-3 (its help: either sign)")
def _():
    s = Scratch()
    s.packing()
    done = s.run("shear", "p.h5", "--dgamma", "-1e-3", "--to", "-2e-3", "--out", "d", "--quiet", "--no-figure")
    return outcome(verdict(done, 0, ["gamma 0 -> -0.002"], s), "" if (s.dir / "d/p.shear.h5").is_file() else "no path file")


@case(45, "shear --vtol 1e-30 --out NEW_DIR (refused): no empty DIR left")
def _():
    s = Scratch()
    s.packing()
    done = s.run(*SHEAR, "--vtol", "1e-30", "--out", "d")
    return outcome(verdict(done, 2, ["not resolvable"], s), _gone(s.dir / "d"))


@case(46, "SIGTERM during shear --out NEW_DIR (N = 64, before the first write)")
def _():
    s = Scratch()
    s.packing(n=64)
    done = _signalled(s, ["shear", "p.h5", "--dgamma", "1e-3", "--to", "0.5", "--out", "d", "--quiet"], signal.SIGTERM)
    return outcome(verdict(done, 143, ["terminated"], s), _gone(s.dir / "d"))


@case(47, "families --n 1 --out NEW_DIR (refused): no empty DIR left")
def _():
    s = Scratch()
    done = s.run("families", "--n", 1, "--out", "d", "--quiet")
    return outcome(verdict(done, 2, ["n must be an integer >= 2"], s), _gone(s.dir / "d"))


@case(48, "Ctrl-C during families --out NEW_DIR (as soon as DIR exists)")
def _():
    s = Scratch()
    out = s.dir / "d"
    done = _signalled(s, ["families", "--n", 10, "--starts", 20, "--out", "d", "--quiet"], signal.SIGINT, wait_for=out)
    kept = out.exists() and [p.name for p in out.iterdir()] == ["points.h5"]  # a checkpoint came first: kept
    return outcome(verdict(done, 130, ["interrupted"], s), "" if kept else _gone(out))


def _symlinked_output(args, link, before_work):
    """A symlinked output is refused (exit 2, before work) naming --force; --force replaces the link."""
    s = Scratch()
    s.packing()
    (s.dir / "d").mkdir(exist_ok=True)
    (s.dir / link).symlink_to(s.dir / "elsewhere")
    done = s.run(*args)
    worked = [w for w in before_work if (s.dir / w).exists()]
    result = outcome(verdict(done, 2, ["symbolic link", "--force"], s), f"work done first ({worked})" if worked else "")
    forced = s.run(*args, "--force")
    replaced = (s.dir / link).is_file() and not (s.dir / link).is_symlink()
    return outcome(result, "" if forced.returncode == 0 and replaced else f"--force: {forced.stderr.strip()[-100:]}")


@case(49, "families --out DIR with DIR/families.h5 a symlink")
def _():
    return _symlinked_output([*FAMILIES, "--out", "d"], "d/families.h5", ["d/points.h5"])


@case(50, "moduli IN.h5 with IN.moduli.h5 a symlink")
def _():
    return _symlinked_output(MODULI, "p.moduli.h5", [])


@case(51, "shear --out DIR with DIR/IN.shear.h5 a symlink")
def _():
    return _symlinked_output([*SHEAR, "--out", "d"], "d/p.shear.h5", [])


@case(52, "jam --emit-deck D.lmp onto a read-only D.lmp, then --force")
def _():
    s = Scratch()
    (s.dir / "d.lmp").write_text("keep")
    (s.dir / "d.lmp").chmod(0o444)
    done = s.run("jam", "--n", 10, "--emit-deck", "d.lmp")
    forced = s.run("jam", "--n", 10, "--emit-deck", "d.lmp", "--force")
    return outcome(verdict(done, 2, ["read-only", "--force"], s),
                   "" if forced.returncode == 0 and (s.dir / "d.lmp").read_text() != "keep" else "--force refused")


@case(53, "anneal --seed 99999999999999999999999")
def _():
    s = Scratch()
    s.packing()
    done = s.run("anneal", "p.h5", "--to", "1.1", "--dalpha", "0.05", "--seed", "99999999999999999999999",
                 "--out", "a.h5", "--quiet")
    return verdict(done, 2, ["seed must be a non-negative integer below 2\\^63"], s, [s.dir / "a.h5"])


@case(54, "anneal --to 0.5 (disks)")
def _():
    s = Scratch()
    s.packing()
    done = s.run("anneal", "p.h5", "--to", "0.5", "--dalpha", "0.05", "--out", "a.h5", "--quiet")
    return outcome(verdict(done, 2, ["use --to 2"], s), "advises ellipse:2 (no such anneal option)"
                   if "ellipse:2" in done.stderr else "")


@case(55, "moduli on an onset packing, sweep from 1e-7 (the bulk sweep yields at once)")
def _():
    s = Scratch()
    s.packing()
    done = s.run(*MODULI)
    nan = "B = nan" in done.stdout
    return verdict(done, 0, ["no bulk amplitude stayed linear"] if nan else [], s)


@case(56, "jam --above 2")
def _():
    s = Scratch()
    done = s.run("jam", "--n", 10, "--above", 2, "--quiet", "--out", "x.h5")
    return outcome(verdict(done, 2, ["--above 2 >= 1"], s, [s.dir / "x.h5"]),
                   "quotes phi_J = 0.000000 (not yet known)" if "0.000000" in done.stderr else "")


@case(57, "shear/moduli/anneal/export/draw/modes on a missing, empty, text or truncated file, or a file of "
          "another kind (a shear path, a moduli results file)")
def _():
    s = Scratch()
    good = s.packing()
    for kind in ("empty", "text", "truncated"):
        _bad_file(kind, s, good)
    s.run("shear", "p.h5", "--dgamma", "1e-3", "--to", "1e-3", "--out", ".", "--quiet", "--no-figure")
    s.run(*MODULI)
    problems = []
    commands = {"shear": ["--dgamma", "1e-3", "--to", "2e-3", "--out", "d", "--quiet"], "moduli": ["--quiet"],
                "anneal": ["--to", "1.1", "--dalpha", "0.05", "--out", "a.h5", "--quiet"],
                "export": ["--format", "xyz"], "draw": ["-o", "x.png"], "modes": ["--no-figure"]}
    for name, extra in commands.items():
        for source in ("missing.h5", "empty.h5", "text.h5", "truncated.h5", "p.shear.h5", "p.moduli.h5"):
            done = s.run(name, source, *extra)
            one_line = len(done.stderr.strip().splitlines()) == 1
            v = outcome(verdict(done, 2, [re.escape(source)], s), "" if one_line else "more than one line")
            if v != "ok":
                problems.append(f"{name} {source}: {v}")
    return "; ".join(problems) or "ok"


@case(58, "bad numbers and shapes for the new options (not finite, zero, negative, wrong dim)")
def _():
    s = Scratch()
    s.packing()
    probes = [["shear", "p.h5", "--dgamma", v, "--to", "0.01", "--out", "d"] for v in ("nan", "0", "inf")]
    probes += [["shear", "p.h5", "--dgamma", "1e-3", "--to", "0.01", "--out", "d", "--ftol", v] for v in ("-1", "nan")]
    probes += [["families", opt, v, "--out", "d"] for opt, v in (("--n", "0"), ("--spacing", "0"), ("--spacing", "-0.01"),
               ("--gamma-max", "nan"), ("--substeps", "0"), ("--starts", "0"), ("--seed", "-1"), ("--sizes", "x"))]
    probes += [["moduli", "p.h5", opt, v] for opt, v in (("--min-amplitude", "nan"), ("--max-amplitude", "2"),
               ("--per-decade", "0"), ("--linear-tol", "-1"), ("--jump-tol", "0"), ("--past-yield", "-1"), ("--ftol", "inf"))]
    probes += [["anneal", "p.h5", "--to", to, "--dalpha", d, "--out", "a.h5"] for to, d in
               (("nan", "0.05"), ("1.1", "0"), ("1.1", "-0.05"), ("1.1", "inf"))]
    probes += [["jam", "--n", 10, *a, "--out", "x.h5"] for a in (["--gamma", "nan"], ["--above", "0"], ["--above", "nan"],
               ["--shape", "ellipse:0"], ["--shape", "ellipse:nan"], ["--shape", "ellipse:-2"], ["--shape", "ellipse:"],
               ["--shape", "ellipse:2", "--dim", 3], ["--shape", "spheroid:2"], ["--shape", "blob"],
               ["--md-damping", "pairwise"], ["--shape", "ellipse:1.5", "--emit-deck", "no/d.lmp"])]
    problems = []
    for args in probes:
        done = s.run(*args, "--quiet")
        one_line = len(done.stderr.strip().splitlines()) == 1
        v = outcome(verdict(done, 2, [], s, [s.dir / "x.h5", s.dir / "a.h5", s.dir / "d"]),
                    "" if one_line else "more than one line")
        if v != "ok":
            problems.append(f"{' '.join(map(str, args))}: {v}")
        shutil.rmtree(s.dir / "d", ignore_errors=True)  # each probe is judged on its own
        for name in ("x.h5", "a.h5"):
            (s.dir / name).unlink(missing_ok=True)
    return "; ".join(problems) or f"ok ({len(probes)} probes)"


@case(59, "not-finite strains: families --spacing/--gamma-min/--gamma-max, shear --dgamma/--to (message names the option)")
def _():
    s = Scratch()
    s.packing()
    probes = [(["families", opt, v], opt) for opt, v in (("--spacing", "nan"), ("--gamma-min", "nan"), ("--gamma-max", "inf"))]
    probes += [(["shear", "p.h5", "--dgamma", "nan", "--to", "1e-3"], "--dgamma"),
               (["shear", "p.h5", "--dgamma", "1e-3", "--to", "inf"], "--to")]
    problems = []
    for args, option in probes:
        v = verdict(s.run(*args, "--out", "d", "--quiet"), 2, [re.escape(option) + ".*finite"], s, [s.dir / "d"])
        if v != "ok":
            problems.append(f"{' '.join(args)}: {v}")
    return "; ".join(problems) or f"ok ({len(probes)} probes)"


@case(60, "a refusal without --quiet (jam, shear, families): stderr holds only the error line")
def _():
    s = Scratch()
    s.packing()
    probes = [["jam", "--vtol", "1e-30", "--out", "x.h5"], ["jam", "--walls", "y", "--gamma", "0.1", "--out", "x.h5"],
              ["shear", "p.h5", "--vtol", "1e-30", "--dgamma", "1e-3", "--to", "2e-3", "--out", "d"],
              ["families", "--n", "1", "--out", "d"]]
    problems = []
    for args in probes:
        done = s.run(*args)
        lines = done.stderr.strip().splitlines()
        extra = "" if len(lines) == 1 else f"{len(lines) - 1} lines before the error ({lines[0][:40]!r})"
        v = outcome(verdict(done, 2, ["error:"], s), extra)
        if v != "ok":
            problems.append(f"{args[0]} {args[1]}: {v}")
    return "; ".join(problems) or f"ok ({len(probes)} probes)"


@case(61, "jam --contact gaussian/cleaver on disks, spheres, ellipse:1, n-mers (ignored before)")
def _():
    probes = [["--contact", "gaussian"], ["--contact", "cleaver", "--dim", 3], ["--contact", "linear", "--shape", "ellipse:1"],
              ["--contact", "gaussian", "--shape", "nmer:2:1.5"]]
    problems = [f"{' '.join(map(str, a))}: {v}" for a in probes
                if (v := refused(a, ["applies to ellipses/spheroids"], n=16)) != "ok"]
    return "; ".join(problems) or f"ok ({len(probes)} probes)"


@case(62, "SIGKILL during the write of --out leaves .NAME.*.tmp; the same command again removes it")
def _():
    s = Scratch()
    killed = s.python("""
        import os, signal
        from jamflow.io.packing_file import atomic_path
        with atomic_path("p.h5") as tmp:
            tmp.write_bytes(b"half a file")
            os.kill(os.getpid(), signal.SIGKILL)
    """)
    debris = sorted(p.name for p in s.dir.glob(".p.h5.*.tmp"))
    if killed.returncode != -signal.SIGKILL or not debris:
        return f"the SIGKILLed write left no debris (exit {killed.returncode}): case not set up"
    done = s.run("jam", "--n", 16, "--quiet", "--out", "p.h5")
    return verdict(done, 0, ["phi_J"], s)  # leftovers() includes .*.tmp


@case(63, "Ctrl-C during start-up: SIGINT 4-60 ms after the start, 5 runs at each of 15 delays")
def _():
    counts = {"exit 130, one line": 0, "killed before Python's handler": 0, "finished": 0,
              "traceback in Python's own start-up": 0}
    jamflow_tracebacks = []
    for k in range(75):
        s = Scratch()
        proc = subprocess.Popen([str(BIN), "jam", "--n", "64", "--out", "x.h5"], cwd=s.dir, env=s.env,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        time.sleep(0.004 * (1 + k % 15))
        proc.send_signal(signal.SIGINT)
        err = proc.communicate(timeout=300)[1]
        frames = [line.strip() for line in err.splitlines() if line.strip().startswith("File ")]
        if "Traceback" not in err:
            key = {130: "exit 130, one line", -signal.SIGINT: "killed before Python's handler", 0: "finished"}.get(
                proc.returncode, f"exit {proc.returncode}")
            counts[key] = counts.get(key, 0) + 1
        elif frames and (str(BIN) in frames[0] or f"{os.sep}jamflow{os.sep}" in frames[0]):
            jamflow_tracebacks.append(frames[0][:80])  # in the console script or jamflow's modules
        else:
            counts["traceback in Python's own start-up"] += 1  # site, .pth files: before any jamflow code
    summary = ", ".join(f"{v} {k}" for k, v in counts.items())
    if jamflow_tracebacks:
        return f"{len(jamflow_tracebacks)} tracebacks in jamflow's start-up ({jamflow_tracebacks[0]}); {summary}"
    return f"ok ({summary})"


def main(only=()) -> int:
    rows = []
    for number, title, fn in CASES:
        if only and number not in only:
            continue
        start = time.perf_counter()
        try:
            outcome = fn()
        except Exception as err:  # a broken case is reported, not hidden
            outcome = f"case failed to run: {type(err).__name__}: {err}"
        while Scratch.made:
            shutil.rmtree(Scratch.made.pop(), ignore_errors=True)
        rows.append({"case": number, "title": title, "outcome": outcome, "seconds": f"{time.perf_counter() - start:.1f}"})
        print(f"{number:3d}  {title:70s}  {outcome}", flush=True)
    bad = [r for r in rows if not (r["outcome"] == "ok" or r["outcome"].startswith(("ok (", "not run")))]
    print(f"\n{len(rows)} cases, {len(bad)} still misbehave")
    if only:
        return 1 if bad else 0
    with open(CSV, "w", newline="") as fh:
        writer = csv.DictWriter(fh, ["case", "title", "outcome", "seconds"])
        writer.writeheader()
        writer.writerows(rows)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main({int(a) for a in sys.argv[1:]}))
