"""The cases a new or careless user hit (docs/hardening.md has the catalogue).
Each test names what happened before the fix. Rule: a user error is one line, exit 2, no
traceback, before any work; a failure during work has its own exit code and a remedy;
nothing on disk is damaged and no temporary file outlives the process."""

import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

import jamflow
from jamflow.cli.app import EXIT_JAMMING, EXIT_LAMMPS, EXIT_PLUGIN, EXIT_TERMINATED, main
from jamflow.io.packing_file import load_packing, read_attrs, read_checks, read_history, save_packing

JAMFLOW = [sys.executable, "-m", "jamflow.cli"]


def no_traceback(err: str) -> bool:
    return "Traceback" not in err and len(err.strip().splitlines()) >= 1


@pytest.fixture(scope="module")
def packing_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("packing") / "p.h5"
    assert main(["jam", "--n", "32", "--seed", "3", "--out", str(out), "--quiet"]) == 0
    return out


def run_jam(tmp_path, capsys, *args):
    code = main(["jam", "--quiet", *args])
    return code, capsys.readouterr().err


# --- jam: what is refused before work -------------------------------------------------------
@pytest.mark.parametrize("args,message", [
    (["--vtol", "1e-30"], "vtol 1e-30 is not resolvable.*use vtol"),  # was: exit 0, a packing that is not jammed
    (["--potential", "spring:10"], "alpha = 10.*2 <= ALPHA <= 3"),  # was: traceback, "start from a lower phi0"
    (["--ftol", "1"], "force tolerance 1.0e\\+00.*--ftol\\) <="),  # was: traceback, "start from a lower phi0"
    (["--seed", "99999999999999999999999"], "seed must be an integer in \\[0, 2\\^63 - 1\\]"),  # was: result lost at save
    (["--n", "1000000000"], "needs about .* GB of memory"),  # was: grew to 24 GB, killed by the kernel
    (["--potential", "spring:1.5"], "alpha = 1.5"),  # was: exit 0, net forces 0.4 of the contact forces
    (["--potential", "spring:4"], "alpha = 4"),  # was: exit 0, net forces 7% of the contact forces
])
def test_jam_refuses_before_work(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, *args, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1
    import re

    assert re.search(message, err), err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("dim", [2, 3])
def test_jam_repulsive_lj_from_the_command_line(tmp_path, capsys, dim):
    """Was: never worked (the CLI's start skipped the overlap removal)."""
    out = tmp_path / "rlj.h5"
    code, err = run_jam(tmp_path, capsys, "--potential", "rlj", "--dim", str(dim), "--n", "32" if dim == 2 else "16",
                        "--out", str(out))
    assert code == 0, err
    p = load_packing(out)
    assert p.potential.spec == "rlj" and read_checks(out).passed


def test_jam_stores_its_checks(packing_file):
    checks = read_checks(packing_file)
    assert checks.passed and checks.in_window and checks.force_ratio < 1e-4 and checks.excess_contacts >= 0
    assert checks.v_tol == 1e-16 and checks.energy_per_particle == read_attrs(packing_file)["energy_per_particle"]


def test_a_packing_that_fails_its_checks_is_not_written(tmp_path, capsys, monkeypatch, packing_file):
    """Was: written silently (spring:1.5: net forces 0.4 of the contact forces; vtol 1e-30)."""
    good = jamflow.jam(n=32, seed=3)
    squeezed = good.packing.scaled_to_phi(good.phi_j / 0.95**2)
    fake = type(good)(**{**good.__dict__, "packing": squeezed})
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: fake)
    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    code, err = run_jam(tmp_path, capsys, "--n", "32", "--seed", "3", "--out", str(out))
    assert code == EXIT_JAMMING and no_traceback(err)
    assert "failed its checks: not at an energy minimum" in err and "not at an energy minimum" in err and "Nothing was written" in err
    assert out.read_bytes() == packing_file.read_bytes()


def test_jamming_failed_exits_3_with_its_remedy(tmp_path, capsys):
    """Was: exit 1 with a traceback."""
    code, err = run_jam(tmp_path, capsys, "--potential", "rlj", "--n", "16", "--phi0", "0.88",
                        "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_JAMMING and no_traceback(err) and "phi0 is above jamming; use a lower phi0" in err


def test_lammps_failure_exits_4(tmp_path, capsys, monkeypatch):
    """Was: exit 1 with a traceback."""
    from jamflow.engines.lammps.engine import LammpsError

    def fail(*a, **k):
        raise LammpsError("run 0", "ERROR: Lost atoms: original 16 current 4")

    monkeypatch.setattr("jamflow.protocols.spec.jam", fail)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_LAMMPS and no_traceback(err) and "Lost atoms" in err and "diverged" in err


@pytest.mark.parametrize("cxx,message", [("/nonexistent/g++", "CXX=/nonexistent/g++ does not name an executable"),
                                         ("false", "compiling the jamflow LAMMPS plugin failed")])
def test_a_bad_cxx_exits_5_naming_it(tmp_path, capsys, monkeypatch, cxx, message):
    """Was: 'no C++ compiler found' although g++ is installed, then 12x slower on lepton;
    a compiler error was a RuntimeError traceback with exit 1."""
    monkeypatch.setenv("JAMFLOW_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CXX", cxx)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--potential", "hertz", "--engine", "lammps",
                        "--out", str(tmp_path / "x.h5"))
    assert code == EXIT_PLUGIN and message in err and "Traceback" not in err


def test_help_says_the_engines_differ(capsys):
    """Was: README and --help implied the engines reach the same minima."""
    with pytest.raises(SystemExit):
        main(["jam", "--help"])
    assert "different" in " ".join(capsys.readouterr().out.split())


# --- output paths ---------------------------------------------------------------------------
def special_paths(tmp_path):
    """A device node (as root; else a FIFO), a symlink, a read-only file."""
    node = tmp_path / "node"
    if os.geteuid() == 0:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 3))  # like /dev/null
    else:
        os.mkfifo(node)
    target = tmp_path / "target.h5"
    target.write_text("keep me")
    link = tmp_path / "link.h5"
    link.symlink_to(target)
    readonly = tmp_path / "readonly.h5"
    readonly.write_text("keep me too")
    readonly.chmod(0o444)
    return {"node": node, "link": link, "readonly": readonly}


@pytest.mark.parametrize("kind,message", [("node", "not a regular file"), ("link", "symbolic link"),
                                          ("readonly", "read-only")])
def test_outputs_that_are_not_regular_files_are_refused_unless_forced(tmp_path, capsys, kind, message):
    """Was: /dev/full (as root) replaced by an HDF5 file; a symlink replaced; a read-only file
    overwritten and made 644."""
    path = special_paths(tmp_path)[kind]
    before = os.lstat(path)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(path))
    assert code == 2 and message in err and "--force" in err and no_traceback(err)
    after = os.lstat(path)
    assert (after.st_mode, after.st_ino) == (before.st_mode, before.st_ino)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(path), "--force")
    assert code == 0, err
    assert load_packing(path).n == 16 and not path.is_symlink()
    if kind == "readonly":
        assert stat.S_IMODE(path.stat().st_mode) == 0o444  # the file keeps its permissions
    assert (tmp_path / "target.h5").read_text() == "keep me"


# --- bad input files ------------------------------------------------------------------------
def bad_files(tmp_path, good):
    files = {"empty": b"", "truncated": good.read_bytes()[:3000], "text": b"hello\n"}
    out = {}
    for name, content in files.items():
        out[name] = tmp_path / f"{name}.h5"
        out[name].write_bytes(content)
    out["incomplete"] = tmp_path / "incomplete.h5"
    with h5py.File(out["incomplete"], "w") as f:
        f.attrs.update(schema="jamflow.packing", schema_version=1)
        f["positions"] = np.zeros((2, 2))
    out["badjson"] = tmp_path / "badjson.h5"
    out["badjson"].write_bytes(good.read_bytes())
    with h5py.File(out["badjson"], "r+") as f:
        f.attrs["shape"] = '{"kind": "sph'  # a damaged JSON attribute (was: a JSONDecodeError traceback, exit 1)
    return out


EXPECTED = {"empty": "is empty", "truncated": "truncated or damaged", "text": "not an HDF5 file",
            "incomplete": "incomplete jamflow packing file: can't locate attribute: 'potential'",
            "badjson": "damaged jamflow packing file: an attribute is not valid JSON"}


@pytest.mark.parametrize("kind", sorted(EXPECTED))
@pytest.mark.parametrize("command", [["modes"], ["analyze"], ["draw"], ["export", "--format", "xyz"]])
def test_bad_input_files_give_one_line(tmp_path, capsys, packing_file, kind, command):
    """Was: raw h5py tracebacks without the file name (modes, analyze)."""
    path = bad_files(tmp_path, packing_file)[kind]
    code = main([command[0], str(path), *command[1:], *(["--out", str(tmp_path / "s.h5")] if command[0] == "analyze" else [])])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and str(path) in err and EXPECTED[kind] in err


@pytest.mark.parametrize("kind,reader", [(k, r) for k in sorted(EXPECTED) for r in (load_packing, read_attrs, read_history)
                                         if k not in ("incomplete", "badjson") or r is load_packing])
def test_bad_files_raise_clear_errors_in_python(tmp_path, packing_file, kind, reader):
    path = bad_files(tmp_path, packing_file)[kind]
    with pytest.raises(ValueError, match=EXPECTED[kind]) as info:
        reader(path)
    assert str(path) in str(info.value)


def test_read_history_names_a_missing_group(tmp_path, packing_file):
    path = bad_files(tmp_path, packing_file)["incomplete"]
    with pytest.raises(ValueError, match="incomplete jamflow packing file.*history"):
        read_history(path)


# --- packings that are not at a minimum -----------------------------------------------------
@pytest.fixture(scope="module")
def squeezed_file(packing_file, tmp_path_factory):
    p = load_packing(packing_file)
    out = tmp_path_factory.mktemp("squeezed") / "squeezed.h5"
    return save_packing(out, p.scaled_to_phi(p.phi / 0.95**2))  # box 5% smaller: max force ~0.05


def test_modes_warns_when_not_at_a_minimum(squeezed_file, capsys):
    """Was: a stability class without saying the state is not force balanced."""
    assert main(["modes", str(squeezed_file), "--no-figure"]) == 0
    out, err = capsys.readouterr()
    assert "warning" in err and "not at an energy minimum" in err and "[NOT FORCE BALANCED]" in out
    with h5py.File(squeezed_file.with_name("squeezed.modes.h5")) as f:
        assert not f.attrs["force_balanced"] and not f["checks"].attrs["passed"]


def test_modes_on_a_jammed_packing_does_not_warn(packing_file, capsys):
    assert main(["modes", str(packing_file), "--no-figure"]) == 0
    out, err = capsys.readouterr()
    assert "warning" not in err and "NOT FORCE BALANCED" not in out
    with h5py.File(packing_file.with_name("p.modes.h5")) as f:
        assert f.attrs["force_balanced"]


def test_analyze_warns_when_not_at_a_minimum(squeezed_file, packing_file, tmp_path, capsys):
    out = tmp_path / "s.h5"
    assert main(["analyze", str(packing_file), str(squeezed_file), "--out", str(out), "--r-min", "1.3"]) == 0
    assert "squeezed.h5 is not at an energy minimum" in capsys.readouterr().err
    with h5py.File(out) as f:
        assert list(f["order/force_balanced"][...]) == [1, 0]


# --- interruptions, pipes, temporary files --------------------------------------------------
def test_sigterm_removes_temporary_files_and_keeps_the_old_output(tmp_path, packing_file):
    """Was: /tmp/jamflow-*/start.data left behind on SIGTERM."""
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    proc = subprocess.Popen([*JAMFLOW, "jam", "--n", "2048", "--engine", "lammps", "--quiet", "--out", str(out)],
                            env={**os.environ, "TMPDIR": str(scratch)}, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not list(scratch.glob("jamflow-*/start.data")) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert list(scratch.glob("jamflow-*/start.data")), "LAMMPS never started"
    proc.send_signal(signal.SIGTERM)
    err = proc.communicate(timeout=120)[1]
    assert proc.returncode == EXIT_TERMINATED and no_traceback(err) and "terminated" in err
    assert list(scratch.iterdir()) == []
    assert out.read_bytes() == packing_file.read_bytes() and sorted(p.name for p in tmp_path.iterdir()) == ["p.h5", "tmp"]


def test_sigterm_while_a_figure_is_written_leaves_no_hidden_file(tmp_path, packing_file, monkeypatch):
    """Was: hidden .*.tmp figure files left behind."""
    from matplotlib.figure import Figure

    def savefig(self, target, **kwargs):
        Path(target).write_bytes(b"half a png")
        os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(Figure, "savefig", savefig)
    p = tmp_path / "p.h5"
    p.write_bytes(packing_file.read_bytes())
    assert main(["modes", str(p)]) == EXIT_TERMINATED
    assert not [f for f in tmp_path.iterdir() if f.name.startswith(".")] and not (tmp_path / "p.modes.png").exists()


def test_ctrl_c_during_start_up(capsys, monkeypatch):
    """Was: a traceback from inside the imports."""
    def interrupted(name):
        raise KeyboardInterrupt

    monkeypatch.setattr("jamflow.cli.app.import_module", interrupted)
    assert main(["jam"]) == 130
    assert "interrupted" in capsys.readouterr().err


def test_output_into_a_closed_pipe(tmp_path, packing_file):
    """Was: BrokenPipeError traceback (jamflow modes x.h5 | head -1). Now the command
    finishes its work (results and figure) and drops the lines nobody reads."""
    p = tmp_path / "p.h5"
    p.write_bytes(packing_file.read_bytes())
    proc = subprocess.Popen([*JAMFLOW, "modes", str(p)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # the reader is gone before the first line
    err = proc.stderr.read()
    proc.wait(timeout=120)
    assert proc.returncode == 0 and "Traceback" not in err and "Broken" not in err
    assert (tmp_path / "p.modes.h5").is_file() and (tmp_path / "p.modes.png").is_file()


# --- Python API -----------------------------------------------------------------------------
@pytest.mark.parametrize("kwargs,error,message", [
    (dict(dim=2.0), ValueError, "dim must be the integer 2 or 3"),
    (dict(sizes=None), TypeError, "sizes must be a spec string"),
    (dict(potential=3), TypeError, "potential must be a spec string"),
    (dict(settings="fast"), TypeError, "settings must be a CompressionSettings"),
    (dict(seed=2**70), ValueError, "seed must be an integer in"),
    (dict(start=np.zeros((3, 2))), TypeError, "start must be a Packing"),
])
def test_python_jam_rejects_bad_arguments_clearly(kwargs, error, message, monkeypatch):
    """Was: TypeError/AttributeError from deep inside (dim=2.0, sizes=None, potential=3, settings='fast')."""
    monkeypatch.setattr("jamflow.protocols.compression.compress", lambda *a, **k: pytest.fail("work started"))
    with pytest.raises(error, match=message):
        jamflow.jam(n=16, **kwargs)


# --- the commands added later: shear, families, moduli, anneal, jam options -------------------
def test_negative_values_with_an_exponent_are_values():
    # was: `jamflow shear --dgamma -1e-3` "expected one argument" (argparse read -1e-3 as an option)
    from jamflow.cli.app import build_parser

    args = build_parser("shear").parse_args(["shear", "p.h5", "--dgamma", "-1e-3", "--to", "-2e-3", "--out", "d"])
    assert (args.dgamma, args.to) == (-1e-3, -2e-3)
    assert build_parser("jam").parse_args(["jam", "--gamma", "-1e-2"]).gamma == -1e-2


def test_anneal_refuses_before_work(tmp_path, capsys, monkeypatch, packing_file):
    monkeypatch.setattr("jamflow.cli.commands.anneal.anneal", lambda *a, **k: pytest.fail("work started"))
    base = ["anneal", str(packing_file), "--dalpha", "0.05", "--out", str(tmp_path / "a.h5"), "--quiet"]
    # was: the whole anneal ran, then a TypeError traceback at the save (result lost)
    assert main([*base, "--to", "1.1", "--seed", "99999999999999999999999"]) == 2
    assert "--seed must be a non-negative integer below 2^63" in capsys.readouterr().err
    # was: "use ellipse:2", an option anneal does not have
    assert main([*base, "--to", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "use --to 2" in err and "ellipse:2" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["anneal", "refine"])
def test_an_output_that_is_the_input_is_refused_before_work(command, tmp_path, capsys, monkeypatch, packing_file):
    """Was: ``jamflow refine p.h5 --out p.h5`` (and ``anneal``) replaced the float64 onset it started
    from with the refined packing; now one line, exit 2, the input byte for byte as it was."""
    work = {"anneal": "jamflow.cli.commands.anneal.anneal", "refine": "jamflow.protocols.refine.refine"}[command]
    monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    source = tmp_path / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    link = tmp_path / "link.h5"
    link.symlink_to(source)
    options = {"anneal": ["--to", "1.1", "--dalpha", "0.05", "--quiet"], "refine": ["--pressure", "1e-12"]}[command]
    for out in (source, link):
        assert main([command, str(source), *options, "--out", str(out), "--force"]) == 2
        assert f"is the input {source}" in capsys.readouterr().err
    assert source.read_bytes() == packing_file.read_bytes()


@pytest.mark.parametrize("command", ["shear-refused", "shear-interrupted", "families-refused", "families-interrupted"])
def test_a_failed_run_leaves_no_empty_out_directory(tmp_path, capsys, monkeypatch, packing_file, command):
    # was: shear --vtol 1e-30, families --n 1 / --seed -1 / --sizes x and Ctrl-C left an empty --out DIR
    out = tmp_path / "out"
    name, how = command.split("-")
    if how == "interrupted":
        def interrupt(*a, **k):
            raise KeyboardInterrupt
        monkeypatch.setattr(f"jamflow.cli.commands.{name}.{'shear' if name == 'shear' else 'sample'}", interrupt)
    args = {"shear": ["shear", str(packing_file), "--dgamma", "1e-3", "--to", "2e-3"],
            "families": ["families", "--n", "6", "--starts", "1", "--gamma-max", "0.02"]}[name]
    bad = {"shear": ["--vtol", "1e-30"], "families": ["--n", "1"]}[name] if how == "refused" else []
    code = main([*args, *bad, "--out", str(out), "--quiet"])
    assert code == (2 if how == "refused" else 130) and no_traceback(capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.parametrize("command", ["shear", "families", "moduli"])
def test_commands_refuse_a_symlinked_output_before_work_and_force_it(tmp_path, capsys, monkeypatch, packing_file,
                                                                     command):
    # was: "... or --force" advice where the command had no --force; families refused only after all its work
    work = {"shear": "jamflow.cli.commands.shear.shear", "families": "jamflow.cli.commands.families.sample",
            "moduli": "jamflow.protocols.moduli.Moduli.compute"}[command]
    monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "out"
    out.mkdir()
    source = out / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    args, link = {"shear": (["shear", str(source), "--dgamma", "1e-3", "--to", "2e-3", "--out", str(out)], "p.shear.h5"),
                  "families": (["families", "--n", "8", "--out", str(out)], "families.h5"),
                  "moduli": (["moduli", str(source)], "p.moduli.h5")}[command]
    (out / link).symlink_to(tmp_path / "elsewhere.h5")
    assert main([*args, "--quiet", "--no-figure"] if command != "families" else [*args, "--quiet"]) == 2
    assert "symbolic link" in capsys.readouterr().err
    assert (out / link).is_symlink()
    from jamflow.cli.app import build_parser

    assert build_parser(command).parse_args([*args, "--force"]).force


def test_shear_force_replaces_a_symlinked_path_file(tmp_path, capsys, packing_file):
    out = tmp_path / "out"
    out.mkdir()
    (out / "p.shear.h5").symlink_to(tmp_path / "elsewhere.h5")
    args = ["shear", str(packing_file), "--dgamma", "1e-3", "--to", "2e-3", "--out", str(out), "--quiet", "--no-figure"]
    assert main([*args, "--force"]) == 0
    assert (out / "p.shear.h5").is_file() and not (out / "p.shear.h5").is_symlink()
    assert not (tmp_path / "elsewhere.h5").exists()


def test_emit_deck_force_replaces_a_read_only_deck(tmp_path, capsys):
    # was: refused with "or --force to replace it", and refused again with --force
    deck = tmp_path / "deck.lmp"
    deck.write_text("keep")
    deck.chmod(0o444)
    args = ["jam", "--n", "10", "--emit-deck", str(deck), "--out", str(tmp_path / "p.h5")]
    assert main(args) == 2 and "--force" in capsys.readouterr().err
    assert main([*args, "--force"]) == 0
    assert deck.read_text() != "keep" and (tmp_path / "deck.start.data").is_file()


def test_moduli_warns_when_a_sweep_has_no_linear_amplitude(tmp_path, capsys, packing_file):
    # was: "B = nan +- nan", exit 0, nothing said (an onset packing yields at the first amplitude 1e-6)
    source = tmp_path / "p.h5"
    source.write_bytes(packing_file.read_bytes())
    args = ["moduli", str(source), "--min-amplitude", "1e-6", "--max-amplitude", "1e-5", "--per-decade", "1"]
    assert main([*args, "--quiet", "--no-figure"]) == 0
    err = capsys.readouterr().err
    assert "no bulk amplitude stayed linear" in err and "--min-amplitude" in err


def test_jam_above_one_does_not_quote_an_onset_not_yet_known(tmp_path, capsys, monkeypatch):
    # was: "phi_J + dphi = 0.000000 + 2 >= 1"
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    assert main(["jam", "--n", "10", "--above", "2", "--quiet", "--out", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err
    assert "--above 2 >= 1" in err and "0.000000" not in err


# --- option names, quiet refusals, --contact, SIGKILL debris, Ctrl-C at start -------------------
@pytest.mark.parametrize("args,option", [
    (["families", "--spacing", "nan"], "--spacing"), (["families", "--gamma-min", "nan"], "--gamma-min"),
    (["families", "--gamma-max", "inf"], "--gamma-max"), (["shear", "P", "--dgamma", "nan", "--to", "1e-3"], "--dgamma"),
    (["shear", "P", "--dgamma", "1e-3", "--to", "inf"], "--to"),
])
def test_a_strain_that_is_not_finite_is_refused_naming_its_option(tmp_path, capsys, monkeypatch, packing_file, args,
                                                                   option):
    # was: "shear strain gamma must be a finite number, got nan" (the check of the grid's strains)
    for work in ("jamflow.cli.commands.families.sample", "jamflow.cli.commands.shear.shear"):
        monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    args = [str(packing_file) if a == "P" else a for a in args]
    assert main([*args, "--out", str(tmp_path / "d"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert option in err and "finite" in err and "shear strain gamma" not in err and len(err.strip().splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("args", [["jam", "--walls", "y", "--gamma", "0.1"], ["jam", "--vtol", "1e-30"],
                                  ["shear", "P", "--vtol", "1e-30", "--dgamma", "1e-3", "--to", "2e-3"],
                                  ["families", "--n", "1"]])
def test_a_refusal_without_quiet_prints_only_its_error(tmp_path, capsys, packing_file, args):
    # was: an empty progress bar ("jam: 0min [00:00, ?min/s]") drawn on stderr before the error
    args = [str(packing_file) if a == "P" else a for a in args]
    assert main([*args, "--out", str(tmp_path / "d")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"jamflow {args[0]}: error:"), lines


def test_a_run_without_quiet_still_shows_its_progress(tmp_path, capsys):
    assert main(["jam", "--n", "64", "--out", str(tmp_path / "p.h5")]) == 0
    err = capsys.readouterr().err
    assert "jam:" in err and "min/s" in err and "phi=" in err


@pytest.mark.parametrize("shape,dim,contact", [("disk", 2, "gaussian"), ("sphere", 3, "cleaver"),
                                               ("ellipse:1", 2, "linear"), ("nmer:2:1.5", 2, "gaussian")])
def test_jam_refuses_a_contact_method_for_shapes_without_one(tmp_path, capsys, monkeypatch, shape, dim, contact):
    # was: accepted and silently ignored (disks, spheres and rigid bodies of round sites have no approximation)
    monkeypatch.setattr("jamflow.protocols.spec.jam", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--shape", shape, "--dim", str(dim), "--contact", contact,
                        "--out", str(tmp_path / "x.h5"))
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"--contact {contact} applies to ellipses/spheroids" in err and "leave --contact out" in err
    assert list(tmp_path.iterdir()) == []


def test_jam_keeps_a_contact_method_for_ellipses():
    from jamflow.cli.app import build_parser
    from jamflow.cli.commands.jam import spec_from_args
    from jamflow.protocols.spec import prepare

    args = build_parser("jam").parse_args(["jam", "--shape", "ellipse:1.5", "--sizes", "mono", "--contact", "gaussian",
                                           "--n", "16"])
    assert prepare(spec_from_args(args))[1].shape.contact == "gaussian"


def test_a_write_killed_by_sigkill_leaves_debris_that_the_next_run_removes(tmp_path, capsys):
    # was: the hidden .p.h5.*.tmp of a SIGKILLed write stayed beside the output for good
    from jamflow.support.files import _temporary_prefix

    out = tmp_path / "p.h5"
    killed = subprocess.run([sys.executable, "-c", "import os, signal\nfrom jamflow.io.packing_file import atomic_path\n"
                             f"with atomic_path({str(out)!r}) as tmp:\n    tmp.write_bytes(b'half a file')\n"
                             "    os.kill(os.getpid(), signal.SIGKILL)"], cwd=tmp_path)
    assert killed.returncode == -signal.SIGKILL
    debris = list(tmp_path.glob(".p.h5.*.tmp"))
    assert len(debris) == 1 and debris[0].read_bytes() == b"half a file"
    live = tmp_path / f"{_temporary_prefix(out, os.getpid())}abcdefgh.tmp"  # a writer still running: kept
    others = [tmp_path / ".p.h5.notes.tmp",  # not atomic_path's pattern; below, another output's debris
              tmp_path / f"{_temporary_prefix(tmp_path / 'q.h5', 999_999_999)}abcdefgh.tmp"]
    for path in [live, *others]:
        path.write_bytes(b"not debris of this run")
    assert main(["jam", "--n", "16", "--quiet", "--out", str(out)]) == 0  # the same command again
    assert not debris[0].exists() and live.exists() and all(p.exists() for p in others)
    assert read_checks(out).passed


def test_ctrl_c_while_the_command_starts(tmp_path):
    # was: a KeyboardInterrupt traceback while the console script imported jamflow.cli.app (about 10 ms)
    import re

    text = (Path(__file__).resolve().parents[1] / "pyproject.toml").read_text()
    module, function = re.search(r'^jamflow = "([\w.]+):(\w+)"', text, re.M).groups()
    script = ("import importlib.abc, os, signal, sys\n"
              "class Interrupt(importlib.abc.MetaPathFinder):  # Ctrl-C as jamflow.cli.app starts to load\n"
              "    def find_spec(self, name, path, target=None):\n"
              "        if name == 'jamflow.cli.app':\n            os.kill(os.getpid(), signal.SIGINT)\n"
              "sys.meta_path.insert(0, Interrupt())\n"
              f"from {module} import {function}\nsys.exit({function}())\n")  # what pip's console script does
    done = subprocess.run([sys.executable, "-c", script, "jam"], cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 130 and no_traceback(done.stderr), done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and "interrupted" in done.stderr
    assert list(tmp_path.iterdir()) == []


# --- wrong physics or silently wrong data ---------------------------------------------------
def half_period_strains():
    """gamma = +-(k + 1/2), k = 0..3, and its two float64 neighbours on each side."""
    strains = []
    for centre in (0.5, 1.5, 2.5, 3.5, -0.5, -1.5, -2.5, -3.5):
        below = np.nextafter(centre, -np.inf)
        above = np.nextafter(centre, np.inf)
        strains += [np.nextafter(below, -np.inf), below, centre, above, np.nextafter(above, np.inf)]
    return strains


HALF_PERIODS = half_period_strains()


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("side", [5.123456789, 7.3, 3.3333333333])
def test_a_half_period_strain_folds_into_range_and_stays_reduced(dim, side):
    # was: gamma = 2.5 (L = 5.123456789) folded to xy = -0.5000000000000002 L, outside [-L/2, L/2):
    # the reduced cell folded once more under its own reduction, and the pair search lost pairs
    from jamflow.model.box import Box

    for gamma in HALF_PERIODS:
        h = np.eye(dim) * side
        h[0, 1] = gamma * side
        if dim == 3:
            h[0, 2], h[1, 2] = -gamma * side, gamma * side
        box = Box(h)
        red, fold = box.reduction()
        assert all(-side / 2 <= t < side / 2 for t in red.tilts), (gamma, red.tilts)
        assert red.reduction()[0] is red, gamma  # reduced: its own reduction
        assert np.allclose(red.h, box.h @ fold, rtol=0, atol=1e-12 * np.abs(box.h).max())


def all_pairs_minimum_image(x, box, rmax):
    """(i, j) of every pair i < j whose shortest image over shifts of up to 5 cells of the
    *accumulated* cell (no reduction) is below rmax."""
    from itertools import product

    i, j = np.triu_indices(len(x), 1)
    dr = x[i] - x[j]
    shifts = np.array(list(product(range(-5, 6), repeat=box.dim)), float) @ box.h.T
    best = np.min(np.linalg.norm(dr[:, None, :] + shifts[None, :, :], axis=2), axis=1)
    keep = best < rmax
    return i[keep], j[keep]


@pytest.mark.parametrize("dim", [2, 3])
def test_pair_search_at_half_period_strains_matches_all_pairs(dim):
    # was: at gamma = k + 1/2 (and ulps off it) whole sets of pairs were missing -> "every particle is a floater"
    from jamflow.model.box import Box
    from jamflow.model.pairs import neighbor_pairs

    side = 5.123456789
    rng = np.random.default_rng(29)
    x = rng.uniform(0, side, (60 if dim == 2 else 80, dim))
    for gamma in HALF_PERIODS:
        box = Box.cube(side, dim).with_shear_strain(gamma)
        rmax = 0.45 * box.widths.min()
        i, j, image = neighbor_pairs(x, box, rmax)
        bi, bj = all_pairs_minimum_image(x, box, rmax)
        assert len(bi) > 20 and np.array_equal(i, bi) and np.array_equal(j, bj), gamma
        sep = x[i] - x[j] + image @ box.h.T
        assert np.all(np.linalg.norm(sep, axis=1) < rmax), gamma


@pytest.fixture(scope="module")
def half_period_packing():
    """A packing jammed through the API at gamma = 1/2 (N = 32)."""
    return jamflow.jam(n=32, seed=4, gamma=0.5).packing


def test_contacts_and_floaters_at_half_period_strains_are_those_at_one_half(half_period_packing):
    # was: a packing at gamma = 2.5 made through the API was "all floaters" to `jamflow modes`
    from jamflow.mechanics.checks import check_packing
    from jamflow.mechanics.contacts import Contacts

    base = Contacts().compute(half_period_packing)
    assert base.floater.sum() < half_period_packing.n / 2
    pairs = set(zip(base.i.tolist(), base.j.tolist()))
    for gamma in HALF_PERIODS:
        box = half_period_packing.box.with_shear_strain(gamma)
        packing = half_period_packing.with_positions(half_period_packing.positions, box=box)
        got = Contacts().compute(packing)
        assert np.array_equal(got.floater, base.floater) and set(zip(got.i.tolist(), got.j.tolist())) == pairs, gamma
        assert check_packing(packing).jammed, gamma


def test_jam_at_gamma_two_and_a_half_passes_its_checks(tmp_path, capsys):
    # was: exit 3, "not jammed: every particle is a floater (no contact network)", nothing written
    out = tmp_path / "g.h5"
    code, err = run_jam(tmp_path, capsys, "--n", "32", "--gamma", "2.5", "--out", str(out))
    assert code == 0, err
    checks = read_checks(out)
    assert checks.passed and checks.jammed
    assert read_attrs(out)["gamma"] == 2.5


def test_ensemble_of_piles_records_each_piles_fraction_and_onsets_refuse_a_zero_width(tmp_path, capsys):
    # was: summary.csv phi_j = phi0 = 0.5 for every pile (sd 0), while jam printed each pile's own
    # fraction; `jamflow onsets` then printed LAPACK noise and "SVD did not converge"
    from jamflow.ensemble import Store

    store = tmp_path / "piles"
    args = ["--n", "16", "--gravity", "1e-3", "--walls", "y", "--quiet"]
    assert main(["ensemble", "--seeds", "0:3", "--workers", "1", "--out", str(store), *args]) == 0
    rows = sorted(Store(store).read_summary(), key=lambda r: int(r["seed"]))
    capsys.readouterr()
    for row in rows:
        out = tmp_path / f"jam{row['seed']}.h5"
        assert main(["jam", "--seed", row["seed"], "--out", str(out), *args]) == 0
        printed = float(capsys.readouterr().out.split("phi_J = ")[1].split()[0])
        assert float(row["phi_j"]) == pytest.approx(printed, abs=1e-9)  # what jam reports: the pile's fraction
        assert float(row["phi"]) == 0.5 and float(row["phi_j"]) > 0.6  # the box's phi is the start's
    assert np.std([float(r["phi_j"]) for r in rows]) > 1e-3
    # a store summarised the old way (every phi_j the same): one clear line, no numerical noise
    from jamflow.ensemble.onsets import onset_statistics

    with pytest.raises(ValueError, match="N = 16: all 3 packings have phi_J = 0.5, a distribution of zero width"):
        onset_statistics([{**r, "phi_j": "0.5"} for r in rows], n_bootstrap=50)
    with pytest.raises(ValueError, match="N = 16: 1 of 3 packings have no phi_J"):
        onset_statistics([{**r, "phi_j": "nan" if r["seed"] == "0" else r["phi_j"]} for r in rows], n_bootstrap=50)


def test_onsets_command_refuses_a_zero_width_store_in_one_line(tmp_path, capsys):
    import csv

    from jamflow.ensemble import Store

    store = tmp_path / "flat"
    assert main(["ensemble", "--seeds", "0:3", "--workers", "1", "--n", "16", "--out", str(store), "--quiet"]) == 0
    rows = Store(store).read_summary()
    with (store / "summary.csv").open("w", newline="") as fh:  # the summary an older jamflow wrote for piles
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows({**r, "phi_j": "0.5"} for r in rows)
    capsys.readouterr()
    code = main(["onsets", str(store)])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1 and "zero width" in err
    assert "SVD" not in err and not (store / "onsets.csv").exists()


def test_jam_at_one_pressure_reports_no_extrapolated_onset(tmp_path, capsys):
    # was: "phi_J(P->0) = 0.8763408138", the phi at P = 1e-2 itself (one pressure extrapolates nothing)
    out = tmp_path / "p.h5"
    assert main(["jam", "--n", "32", "--pressure", "1e-2", "--out", str(out), "--quiet"]) == 0
    text = capsys.readouterr().out
    assert "phi_J(P->0) n/a: one pressure" in text and "phi_J(P->0) =" not in text
    attrs = read_attrs(out)
    assert np.isnan(attrs["phi_j"]) and attrs["phi"] > 0.85  # the file: phi at P, no phi_J
    several = tmp_path / "p6.h5"
    assert main(["jam", "--n", "32", "--pressure", "1e-6", "--out", str(several), "--quiet"]) == 0
    printed = float(capsys.readouterr().out.split("phi_J(P->0) = ")[1].split()[0])
    attrs = read_attrs(several)
    assert attrs["phi_j"] == pytest.approx(printed, abs=1e-10) and attrs["phi_j"] < attrs["phi"]


@pytest.mark.parametrize("command", ["modes", "analyze", "moduli"])
def test_the_same_file_twice_is_refused(tmp_path, capsys, monkeypatch, packing_file, command):
    # was: `modes p.h5 ./p.h5` / `analyze p.h5 p.h5` averaged the one packing as two (exit 0)
    import shutil

    (tmp_path / "store").mkdir()
    packing_file = Path(shutil.copy(packing_file, tmp_path / "store" / "p.h5"))  # a directory of its own
    link = tmp_path / "same.h5"
    link.symlink_to(packing_file)
    monkeypatch.chdir(packing_file.parent)
    extra = ["--out", str(tmp_path / "a.h5")] if command == "analyze" else []
    pairs = [[str(packing_file), f"./{packing_file.name}"], [str(packing_file), str(link)]]
    if command != "moduli":  # modes and analyze take a store directory for its files
        pairs.append([str(packing_file.parent), str(packing_file)])
    for pair in pairs:
        code = main([command, *pair, *extra])
        err = capsys.readouterr().err
        assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
        assert "it would count as two packings; give each packing file once" in err
    assert [p.name for p in packing_file.parent.iterdir()] == ["p.h5"]  # nothing written beside it


PARTNERLESS = [  # (options, the option, its partner): was exit 0, the option silently ignored
    (["--stress", "aniso"], "--stress aniso", "--pressure"),
    (["--wall-type", "rough"], "--wall-type rough", "--walls"),
    (["--damping", "2"], "--damping 2.0", "--minimizer md"),
    (["--md-damping", "pairwise"], "--md-damping pairwise", "--minimizer md"),
    (["--dphi0", "1e-3", "--pressure", "1e-3"], "--dphi0 0.001", "a compression run"),
    (["--dphi0", "1e-3", "--gravity", "1e-3", "--walls", "y"], "--dphi0 0.001", "a compression run"),
    (["--vtol", "1e-3", "--gravity", "1e-3", "--walls", "y"], "--vtol 0.001", "a compression run"),
    (["--vtol", "1e-10", "--pressure", "1e-3"], "--vtol 1e-10", "a compression run"),
]


@pytest.mark.parametrize("args,option,partner", PARTNERLESS)
def test_an_option_without_its_partner_is_refused_before_work(tmp_path, capsys, monkeypatch, args, option, partner):
    for work in ("jamflow.protocols.spec.jam", "jamflow.protocols.pressure.jam_at_pressure"):
        monkeypatch.setattr(work, lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--n", "16", *args, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"{option} applies to {partner} only" in err and "leave" in err
    assert list(tmp_path.iterdir()) == []


def test_library_refuses_a_non_default_value_without_its_partner():
    from jamflow.protocols.spec import PARTNERS, JamSpec, check_boundaries

    values = dict(stress="tri", wall_type="rough", damping=3.0, md_damping="pairwise", dphi0=2e-4, vtol=1e-10)
    assert set(values) == set(PARTNERS)
    for name, value in values.items():
        check_boundaries(JamSpec(**{name: getattr(JamSpec(), name)}))  # the default alone: accepted
        with pytest.raises(ValueError, match=f"--{name.replace('_', '-')} .* applies to"):
            check_boundaries(JamSpec(**{name: value}, pressure=1e-3 if name in ("dphi0", "vtol") else None))
    check_boundaries(JamSpec(stress="tri", pressure=1e-3))  # with the partner: accepted
    check_boundaries(JamSpec(wall_type="rough", walls="y"))
    check_boundaries(JamSpec(damping=3.0, md_damping="pairwise", minimizer="md"))
    check_boundaries(JamSpec(dphi0=2e-4))


@pytest.mark.parametrize("contact", ["linear", "quadratic"])
@pytest.mark.parametrize("shape,dim", [("ellipse:1.5", 2), ("spheroid:1.5", 3)])
def test_a_contact_method_without_second_derivatives_is_refused_before_work(tmp_path, capsys, monkeypatch, contact,
                                                                            shape, dim):
    # was: the whole jam ran, then every packing failed: "the dynamical matrix needs the contact-distance
    # method's derivatives; the 'linear' method's lambda ... has none here"
    from jamflow.protocols.spec import JamSpec, prepare

    monkeypatch.setattr("jamflow.protocols.compression.open_engine", lambda *a, **k: pytest.fail("work started"))
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--sizes", "mono", "--shape", shape, "--dim", str(dim),
                        "--contact", contact, "--out", str(tmp_path / "x.h5"))
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"--contact {contact} cannot make a checked packing" in err and "exact | cleaver | gaussian" in err
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="cannot make a checked packing"):
        prepare(JamSpec(n=16, sizes="mono", shape=shape, dim=dim, contact=contact))


# --- crashes, hangs, concurrency, paths and environment ---------------------------------------
ENOSPC_TEXT = os.strerror(28)
H5_FLUSH_FAILED = ("Can't decrement id ref count (file write failed: time = Thu Dec  3 11:48:15 2026, filename = "
                   "'x.tmp', file descriptor = 3, errno = 28, error message = 'No space left on device')")


def one_line_disk_full(code, err, path):
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"cannot write {path}" in err and "no space left" in err and "free space and rerun" in err, err


@pytest.mark.parametrize("where", ["h5py-oserror", "h5py-flush", "fsync"])
def test_a_full_disk_is_one_line_and_keeps_the_earlier_file(tmp_path, capsys, monkeypatch, packing_file, where):
    """Was: h5py tracebacks (OSError [Errno 28], RuntimeError '... errno = 28 ...') and, for
    analyze, a segmentation fault; now one line, exit 2, the earlier file intact, no temporary file."""
    import errno

    out = tmp_path / "p.h5"
    out.write_bytes(packing_file.read_bytes())
    before = out.read_bytes()
    if where == "h5py-oserror":  # a dataset write that hits the full disk
        def full(self, name, value):
            raise OSError(errno.ENOSPC, f"Can't synchronously write data ({ENOSPC_TEXT})")
        monkeypatch.setattr(h5py.Group, "__setitem__", full)
    elif where == "h5py-flush":  # HDF5's flush at close: a RuntimeError that carries errno = 28 in its text
        def full(self, name, value):
            raise RuntimeError(H5_FLUSH_FAILED)
        monkeypatch.setattr(h5py.Group, "__setitem__", full)
    else:  # the file layer under every writer
        def full(fd):
            raise OSError(errno.ENOSPC, ENOSPC_TEXT)
        monkeypatch.setattr("jamflow.support.files.os.fsync", full)
    code, err = run_jam(tmp_path, capsys, "--n", "16", "--out", str(out), "--force")
    one_line_disk_full(code, err, out)
    assert out.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["p.h5"]


def test_a_figure_on_a_full_disk_is_one_line(tmp_path, capsys, monkeypatch, packing_file):
    import errno

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, ENOSPC_TEXT)

    monkeypatch.setattr("matplotlib.figure.Figure.savefig", full)
    out = tmp_path / "pic.png"
    code = main(["draw", str(packing_file), "-o", str(out)])
    one_line_disk_full(code, capsys.readouterr().err, out)
    assert list(tmp_path.iterdir()) == []


@pytest.fixture
def tiny_tmpfs(tmp_path):
    """A 64 kB tmpfs (as root): a disk that really fills."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    where = tmp_path / "full"
    where.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(where)]).returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    try:
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=True)


def test_analyze_onto_a_really_full_disk(tiny_tmpfs, packing_file):
    """Was (N = 64 and 32): h5py tracebacks, then 'Fatal Python error: Segmentation fault' (exit 139),
    and the hidden temporary file left on the full disk."""
    out = tiny_tmpfs / "s.h5"
    out.write_bytes(b"the earlier result")
    (tiny_tmpfs / "filler").write_bytes(bytes(48 * 1024))  # ~12 kB left: less than the results file
    plots = tiny_tmpfs.parent / "plots"
    plots.mkdir()
    done = subprocess.run([*JAMFLOW, "analyze", str(packing_file), "--out", str(out), "--plots", str(plots)],
                          capture_output=True, text=True, timeout=300)
    one_line_disk_full(done.returncode, done.stderr, out)
    assert out.read_bytes() == b"the earlier result"
    assert sorted(p.name for p in tiny_tmpfs.iterdir()) == ["filler", "s.h5"]


def test_a_full_numba_cache_warns_once_and_runs(tmp_path, monkeypatch):
    """Was: numba's OSError [Errno 28] traceback out of the first call of a kernel (a full
    JAMFLOW_CACHE_DIR); now the kernels run from memory after one warning."""
    import errno
    import warnings

    import numba.core.caching

    from jamflow.engines import compiled

    compiled.start_numba()
    monkeypatch.setattr(compiled, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(compiled, "_cache_unwritable", False)

    def full(self, name, data):
        raise OSError(errno.ENOSPC, ENOSPC_TEXT)

    monkeypatch.setattr(numba.core.caching.IndexDataCacheFile, "_save_data", full)

    def twice(x):
        return 2 * x

    def thrice(x):
        return 3 * x

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert compiled.jit(twice)(2) == 4 and compiled.jit(thrice)(2) == 6 and compiled.jit(twice)(2.5) == 5.0
    messages = [str(w.message) for w in caught if "cannot be cached" in str(w.message)]
    assert len(messages) == 1 and str(tmp_path) in messages[0] and "No space left" in messages[0], messages


FAMILIES = ["families", "--n", "10", "--spacing", "0.5", "--starts", "1", "--quiet"]


def test_families_resume_of_a_damaged_points_file(tmp_path, capsys, monkeypatch):
    """Was: OSError traceback 'Unable to synchronously open file (truncated file ...)', no advice."""
    monkeypatch.setattr("jamflow.cli.commands.families.sample", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "fam"
    out.mkdir()
    with h5py.File(out / "whole.h5", "w") as f:
        f["points/gamma"] = np.zeros(4000)
    (out / "points.h5").write_bytes((out / "whole.h5").read_bytes()[:3000])
    (out / "whole.h5").unlink()
    code = main([*FAMILIES, "--out", str(out), "--resume"])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    assert f"{out / 'points.h5'} is truncated or damaged" in err and "cannot --resume it: delete" in err


def test_two_families_runs_into_one_out(tmp_path, capsys, monkeypatch):
    """Was: both exited 0 and the later one's files replaced the other's. Now the directory is
    locked (support.files.lock_directory, the ensemble store's lock); a new directory that a
    failed run made is removed, its lock file with it."""
    from jamflow.support.files import lock_directory

    monkeypatch.setattr("jamflow.cli.commands.families.sample", lambda *a, **k: pytest.fail("work started"))
    out = tmp_path / "fam"
    out.mkdir()
    with lock_directory(out, "held by the test"):  # as a first run still sampling
        code = main([*FAMILIES, "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and f"another jamflow families run is writing {out}" in err, err

    def broken(*args, **kwargs):
        raise RuntimeError("injected")

    monkeypatch.setattr("jamflow.cli.commands.families.sample", broken)
    with pytest.raises(RuntimeError, match="injected"):
        main([*FAMILIES, "--out", str(tmp_path / "new")])
    assert not (tmp_path / "new").exists()


def test_families_lock_between_processes(tmp_path):
    """Two real runs into one new --out: the second is refused while the first samples."""
    out = tmp_path / "fam"
    first = subprocess.Popen([*JAMFLOW, *FAMILIES, "--starts", "2", "--out", str(out)], stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.time() + 60
        while not (out / ".lock").exists() and time.time() < deadline:
            time.sleep(0.05)
        second = subprocess.run([*JAMFLOW, *FAMILIES, "--starts", "2", "--out", str(out)], capture_output=True,
                                text=True, timeout=120)
    finally:
        assert first.wait(timeout=300) == 0, first.stderr.read()
    assert second.returncode == 2 and "another jamflow families run is writing" in second.stderr, second.stderr
    assert (out / "families.h5").exists()


@pytest.mark.parametrize("seeds", ["0:9223372036854775808", "9223372036854775808:9223372036854775810"])
def test_ensemble_seeds_past_int64_are_refused_before_work(tmp_path, seeds):
    """Was: the task list for every seed was built first (memory without bound), then an
    OverflowError traceback. Run with 2 GB of address space, so a regression fails, not the machine."""
    import resource

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))

    done = subprocess.run([*JAMFLOW, "ensemble", "--seeds", seeds, "--out", str(tmp_path / "s"), "--quiet"],
                          capture_output=True, text=True, timeout=120, preexec_fn=limit)
    assert done.returncode == 2 and no_traceback(done.stderr) and "past 2^63 - 1" in done.stderr, done.stderr
    assert not (tmp_path / "s").exists()


def test_analyze_k_max_too_large_is_refused_with_what_fits(tmp_path, capsys, monkeypatch, packing_file):
    """Was: numpy's 'Unable to allocate 471. GiB' traceback (--k-max 100000). The value named as
    fitting does fit: with it S(k) is computed."""
    import re

    from jamflow.analysis import structure

    monkeypatch.setattr(structure, "physical_memory", lambda: 200e6)  # a machine of 200 MB
    monkeypatch.setattr("jamflow.analysis.structure.RDF.compute", lambda *a, **k: pytest.fail("work started"))
    code = main(["analyze", str(packing_file), "--out", str(tmp_path / "s.h5"), "--k-max", "100000"])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and len(err.strip().splitlines()) == 1, err
    largest = float(re.search(r"use k_max \(--k-max\) <= ([0-9.e+]+)", err).group(1))
    assert 20 < largest < 100000 and list(tmp_path.iterdir()) == []
    packing = load_packing(packing_file)
    assert structure.StructureFactor(k_max=largest).compute(packing).k.max() <= largest
    with pytest.raises(ValueError, match="needs about"):
        structure.StructureFactor(k_max=largest * 1.5).compute(packing)


def test_jam_repulsive_lj_at_a_target_pressure(tmp_path, capsys):
    """Was: exit 2 'array is too big; arr.size * arr.dtype.itemsize is larger than the maximum
    possible size' (numpy's ValueError shown as bad input): the random start's deep overlaps gave
    RLJ forces that blew the box up. The start is now relaxed first, as at fixed volume."""
    out = tmp_path / "rlj.h5"
    code, err = run_jam(tmp_path, capsys, "--pressure", "1e-3", "--potential", "rlj", "--n", "32", "--out", str(out))
    assert code == 0, err
    assert load_packing(out).potential.spec == "rlj" and read_checks(out).passed
    assert abs(read_attrs(out)["pressure"] / 1e-3 - 1) < 1e-6


@pytest.mark.parametrize("tmpdir", ["a b", "a b/é"])
def test_lammps_with_a_tmpdir_holding_a_space_or_non_ascii(tmp_path, tmpdir):
    """Was: exit 4 'LAMMPS rejected read_data /tmp/a b/é/...' and advice to reinstall LAMMPS: the
    path was unquoted (a space) and LAMMPS's parser drops bytes of non-ASCII characters."""
    scratch = tmp_path / tmpdir
    scratch.mkdir(parents=True)
    out = tmp_path / "p.h5"
    done = subprocess.run([*JAMFLOW, "jam", "--engine", "lammps", "--n", "16", "--quiet", "--out", str(out)],
                          env={**os.environ, "TMPDIR": str(scratch)}, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert read_checks(out).passed and list(scratch.iterdir()) == []


def test_lammps_file_names_are_quoted_or_refused():
    from jamflow.engines.lammps.library import lammps_quote

    assert lammps_quote("/tmp/a b/x.data") == '"/tmp/a b/x.data"'
    assert lammps_quote('/tmp/"q"/x') == "'/tmp/\"q\"/x'"
    with pytest.raises(ValueError, match="non-ASCII"):
        lammps_quote("/tmp/é/x.data")


def test_an_emitted_deck_with_a_space_in_its_name_runs(tmp_path, capsys):
    """Was: `variable data index jam deck.start.data` (an index variable of two values): lmp read
    the file 'jam' and failed."""
    from jamflow.decks.jam import run_deck

    deck = tmp_path / "dir" / "jam deck.lmp"
    deck.parent.mkdir()
    assert main(["jam", "--n", "16", "--protocol", "chapter", "--emit-deck", str(deck),
                 "--out", str(tmp_path / "jammed.h5")]) == 0
    assert "run: cd " in capsys.readouterr().out
    result = run_deck(deck.parent, deck=deck, timeout=300)
    assert result.packing.n == 16 and (deck.parent / "jammed.data").exists()


def test_an_emitted_deck_refuses_an_out_that_lammps_cannot_write(tmp_path, capsys):
    code = main(["jam", "--n", "16", "--protocol", "chapter", "--emit-deck", str(tmp_path / "d.lmp"),
                 "--out", str(tmp_path / "my run.h5")])
    err = capsys.readouterr().err
    assert code == 2 and "choose an --out without them" in err and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("suffix, magic", [(".svg", b"<?xml"), (".pdf", b"%PDF"), (".png", b"\x89PNG")])
def test_draw_writes_the_format_its_suffix_asks_for(tmp_path, packing_file, suffix, magic):
    # was: PNG bytes in pic.svg and pic.pdf
    out = tmp_path / f"pic{suffix}"
    assert main(["draw", str(packing_file), "-o", str(out)]) == 0
    assert out.read_bytes().startswith(magic)


def test_draw_refuses_a_suffix_it_cannot_write(tmp_path, capsys, packing_file, monkeypatch):
    monkeypatch.setattr("jamflow.cli.commands.draw.load_input", lambda *a: pytest.fail("work started"))
    code = main(["draw", str(packing_file), "-o", str(tmp_path / "pic.jpg")])
    err = capsys.readouterr().err
    assert code == 2 and no_traceback(err) and "not .jpg" in err and list(tmp_path.iterdir()) == []
