"""File-system refusals, sizes that cannot fit, output names that look derived, benchmark outputs
that must not overwrite curated data, temporary files left behind (Dask, ahead-of-time build),
settings refused before work in the words of the option that set them."""

from __future__ import annotations

import errno
import os
import tempfile

import pytest

from jamflow.cli.app import main

EXIT_USER = 2


@pytest.fixture(scope="module")
def packing_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("packing") / "p.h5"
    assert main(["jam", "--n", "16", "--seed", "1", "--out", str(out), "--quiet"]) == 0
    return out


def one_line(err: str) -> str:
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def read_only(code):
    """A stand-in for a mount that refuses writes with ``code`` (root ignores chmod)."""
    def refuse(*args, **kwargs):
        raise OSError(code, os.strerror(code), str(kwargs.get("dir") or (args[0] if args else "")))
    return refuse


@pytest.mark.parametrize("code, words", [(errno.EROFS, "read-only file system"), (errno.EACCES, "permission denied"),
                                         (errno.ENOSPC, "no space left")])
def test_jam_refuses_an_unwritable_directory_before_work(tmp_path, capsys, monkeypatch, code, words):
    monkeypatch.setattr(tempfile, "mkstemp", read_only(code))
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "x.h5"), "--quiet"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert words in line and "--out" in line


def test_an_output_directory_on_a_read_only_mount_is_one_line(tmp_path, capsys, monkeypatch, packing_file):
    monkeypatch.setattr(os, "mkdir", read_only(errno.EROFS))
    code = main(["shear", str(packing_file), "--dgamma", "1e-3", "--to", "2e-3", "--out", str(tmp_path / "s"), "--quiet"])
    assert code == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "read-only file system" in line and "--out" in line


def test_output_directory_turns_the_errno_into_a_refusal(tmp_path, monkeypatch):
    from jamflow.support.files import output_directory

    monkeypatch.setattr(os, "mkdir", read_only(errno.EROFS))
    with pytest.raises(ValueError, match="read-only file system"):
        with output_directory(tmp_path / "d"):
            pass


def test_a_real_unwritable_path_is_refused(tmp_path, capsys):
    target = "/sys/jamflow-test.h5" if os.path.isdir("/sys") else "/proc/jamflow-test/x.h5"
    assert main(["jam", "--n", "16", "--out", target, "--quiet"]) == EXIT_USER
    assert "--out" in one_line(capsys.readouterr().err)


def test_a_write_that_fails_during_work_is_one_line(tmp_path, capsys, monkeypatch):
    def fail(*a, **k):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(tmp_path / "x.h5"))
    monkeypatch.setattr("jamflow.io.packing_file.save_packing", fail)
    assert main(["jam", "--n", "16", "--out", str(tmp_path / "x.h5"), "--quiet"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "read-only file system" in line and str(tmp_path / "x.h5") in line


@pytest.mark.parametrize("command", ["modes", "moduli"])
def test_outputs_beside_the_input_name_no_option_the_command_lacks(tmp_path, capsys, monkeypatch, packing_file, command):
    monkeypatch.setattr(tempfile, "mkstemp", read_only(errno.EROFS))
    assert main([command, str(packing_file), "--no-figure"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "read-only file system" in line and "--out" not in line


def test_modes_refuses_bins_that_cannot_fit(packing_file, capsys):
    assert main(["modes", str(packing_file), "--bins", "100000000000", "--no-figure"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--bins" in line and "10,000,000" in line


@pytest.mark.parametrize("option", ["--dr", "--q6-dr"])
def test_analyze_refuses_bin_widths_that_cannot_fit(packing_file, tmp_path, capsys, option):
    assert main(["analyze", str(packing_file), option, "1e-11", "--out", str(tmp_path / "s.structure.h5")]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert option in line and "10,000,000" in line
    assert not list(tmp_path.iterdir())


def test_onsets_refuses_bins_that_cannot_fit(tmp_path, capsys):
    store = tmp_path / "store"
    store.mkdir()
    (store / "summary.csv").write_text("n,seed,phi_J,z\n16,1,0.84,4.0\n16,2,0.83,4.0\n")
    assert main(["onsets", str(store), "--bins", "100000000000"]) == EXIT_USER
    assert "--bins" in one_line(capsys.readouterr().err)


@pytest.mark.parametrize("name", ["x.shear.h5", "x.modes.h5", "x.moduli.hdf5", "x.structure.h5"])
def test_jam_refuses_a_derived_output_name_before_work(tmp_path, capsys, name):
    assert main(["jam", "--n", "16", "--out", str(tmp_path / name), "--quiet"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--out" in line and "derived" in line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("command, options", [("refine", ["--pressure", "1e-12"]),
                                              ("anneal", ["--to", "1.1", "--dalpha", "0.05", "--quiet"])])
def test_packing_writers_refuse_a_derived_output_name(tmp_path, capsys, packing_file, command, options):
    assert main([command, str(packing_file), *options, "--out", str(tmp_path / "y.shear.h5")]) == EXIT_USER
    assert "derived" in one_line(capsys.readouterr().err)
    assert not list(tmp_path.iterdir())


def test_a_packing_named_so_is_read_back(tmp_path, capsys):
    from jamflow.io.names import is_derived

    out = tmp_path / "x-shear.h5"
    assert not is_derived(out)
    assert main(["jam", "--n", "16", "--out", str(out), "--quiet"]) == 0



BENCH = __import__("pathlib").Path(__file__).resolve().parents[1] / "benchmarks"
OUTPUT_OPTIONS = ("--out", "--out-dir", "--png", "--figure", "--figures", "--docs")


def benchmark_sources():
    return sorted(p for p in BENCH.glob("*.py") if p.name not in ("__init__.py", "__main__.py"))


def test_no_benchmark_writes_into_docs_notes_by_default():
    import re

    bad = []
    for path in benchmark_sources():
        for number, line in enumerate(path.read_text().splitlines(), 1):
            option = re.search(r'add_argument\("(--[\w-]+)"', line)
            if option and option.group(1) in OUTPUT_OPTIONS and re.search(r'default=[^,)]*(docs/notes|DOCS\b)', line):
                bad.append(f"{path.name}:{number}: {line.strip()}")
    assert not bad, "\n".join(bad)


def test_no_benchmark_truncates_its_results_table():
    import re

    bad = [f"{p.name}:{n}" for p in benchmark_sources() if p.name != "common.py"
           for n, line in enumerate(p.read_text().splitlines(), 1)
           if re.search(r'open\([^)]*"w"', line) and ".csv" in line]
    bad += [f"{p.name}: DictWriter on a file opened for writing" for p in benchmark_sources() if p.name != "common.py"
            and re.search(r'open\([^)]*"w"[^)]*\)[^\n]*\n[^\n]*csv\.(Dict)?[Ww]riter', p.read_text())]
    assert not bad, "\n".join(bad)


@pytest.fixture
def common(monkeypatch):
    import sys

    monkeypatch.syspath_prepend(str(BENCH))
    sys.modules.pop("common", None)
    import common as module

    yield module
    sys.modules.pop("common", None)


def test_merge_rows_keeps_earlier_rows_and_comments(tmp_path, common):
    out = tmp_path / "t.csv"
    common.merge_rows(out, [{"n": 1, "t": 0.5}], comment="# machine A")
    common.merge_rows(out, [{"n": 2, "t": 0.7, "load": 1.0}], comment="# machine A")
    text = out.read_text().splitlines()
    assert text[0] == "# machine A" and text.count("# machine A") == 1
    rows = common.read_rows(tmp_path / "plain.csv")
    assert rows == []
    import csv

    rows = list(csv.DictReader(text[1:]))
    assert [r["n"] for r in rows] == ["1", "2"] and rows[1]["load"] == "1.0" and rows[0]["load"] == ""


def test_benchmark_defaults_are_in_the_scratch_directory(tmp_path, monkeypatch, common):
    monkeypatch.setenv("JAMFLOW_BENCHMARK_OUT", str(tmp_path / "scratch"))
    import importlib
    import sys

    sys.modules.pop("common", None)
    module = importlib.import_module("common")
    assert module.scratch("x.csv") == tmp_path / "scratch" / "x.csv"
    assert (tmp_path / "scratch").is_dir()


def test_pressure_ladder_adds_rows(tmp_path, common):
    import importlib
    import sys

    sys.modules.pop("pressure_ladder", None)
    ladder = importlib.import_module("pressure_ladder")
    out = tmp_path / "ladder.csv"
    ladder.write(out, [{"dim": 2, "n": 16, "seed": 1}])
    ladder.write(out, [{"dim": 2, "n": 16, "seed": 2}])
    assert len(common.read_rows(out)) == 2


ENSEMBLE_SCRIPT = """
import sys
from jamflow.ensemble import run_ensemble
if __name__ == "__main__":
    report = run_ensemble(sys.argv[1], "0:2", 16, workers=1, progress=False)
    assert report.made == 2, report
"""


def test_a_dask_ensemble_leaves_nothing_in_tmpdir(tmp_path):
    import subprocess
    import sys
    from pathlib import Path

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    script = tmp_path / "ensemble_run.py"
    script.write_text(ENSEMBLE_SCRIPT)
    root = str(Path(__file__).resolve().parents[1])
    env = {**os.environ, "TMPDIR": str(scratch), "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    done = subprocess.run([sys.executable, str(script), str(tmp_path / "store")], env=env, capture_output=True,
                          text=True, timeout=240)
    assert done.returncode == 0, done.stderr[-2000:]
    assert sorted(p.name for p in (tmp_path / "store").glob("*.h5")) == ["n16_seed000000.h5", "n16_seed000001.h5"]
    assert list(scratch.rglob("*")) == []


DEBRIS = ("import sys, tempfile, pathlib; d = pathlib.Path(tempfile.mkdtemp(prefix='pycc-build-')); "
          "(d / 'x.o').write_bytes(b'0'); sys.exit('CompilerError: simulated')")


def test_a_failed_ahead_of_time_build_leaves_nothing_in_tmpdir(tmp_path, monkeypatch):
    import sys

    from jamflow.engines.compiled import aot

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setenv("TMPDIR", str(scratch))
    monkeypatch.setattr(aot, "build_command", lambda out_dir: [sys.executable, "-c", DEBRIS])
    cache = tmp_path / "cache"
    target, failed = cache / "module.so", cache / "module.failed"
    aot._build_locked(target, failed)
    assert "simulated" in failed.read_text()
    assert list(scratch.rglob("*")) == []
    assert sorted(p.name for p in cache.iterdir()) == ["build.lock", "module.failed"]


def test_families_refuses_a_grid_that_cannot_fit(tmp_path, capsys):
    assert main(["families", "--n", "16", "--spacing", "1e-12", "--out", str(tmp_path / "f")]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--spacing" in line and "100,000" in line
    assert not (tmp_path / "f").exists()


def test_anneal_refuses_steps_that_cannot_fit(tmp_path, capsys, packing_file):
    assert main(["anneal", str(packing_file), "--to", "2", "--dalpha", "1e-13", "--out", str(tmp_path / "a.h5")]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--dalpha" in line and "1,000,000" in line


def test_refine_refuses_a_pressure_no_box_reaches_before_work(packing_file, capsys, tmp_path, monkeypatch):
    import jamflow.protocols.refine as refine

    monkeypatch.setattr(refine, "balance", lambda *a, **k: pytest.fail("the refinement started"))
    assert main(["refine", str(packing_file), "--pressure", "10", "--out", str(tmp_path / "r.h5")]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--pressure 10 is above" in line and "smaller --pressure" in line
    assert not list(tmp_path.iterdir())


def test_refine_reaches_a_pressure_near_the_densest_box(packing_file, tmp_path):
    from jamflow.io.packing_file import load_packing
    from jamflow.mechanics.reference import energy_forces_pressure

    out = tmp_path / "r.h5"  # 0.5: two thirds of what these 16 disks carry in their densest box, ~0.75
    assert main(["refine", str(packing_file), "--pressure", "0.5", "--out", str(out)]) == 0
    assert energy_forces_pressure(load_packing(out)).pressure == pytest.approx(0.5, rel=1e-3)


def test_jam_refuses_a_pressure_no_box_reaches_before_work(capsys, tmp_path, monkeypatch):
    import jamflow.protocols.pressure as pressure

    monkeypatch.setattr(pressure, "jam_at_pressure", lambda *a, **k: pytest.fail("the jam started"))
    assert main(["jam", "--n", "16", "--pressure", "1000", "--out", str(tmp_path / "j.h5"), "--quiet"]) == EXIT_USER
    assert "--pressure 1000 is above" in one_line(capsys.readouterr().err)


def test_the_fast_protocol_runs_a_large_vtol(tmp_path):
    from jamflow.io.packing_file import load_packing
    from jamflow.protocols.settings import CompressionSettings, fast_protocol

    assert fast_protocol(v_tol=1e-3).coarse_v_min is None and fast_protocol().coarse_v_min == 1e-10
    with pytest.raises(ValueError, match="coarse_v_min"):
        CompressionSettings(v_tol=1e-3, coarse_v_min=1e-10)
    assert main(["jam", "--n", "16", "--vtol", "1e-3", "--out", str(tmp_path / "j.h5"), "--quiet"]) == 0
    import h5py

    with h5py.File(tmp_path / "j.h5") as f:
        v = float(f.attrs["energy_per_particle"])
    assert 1e-3 < v < 2e-3 and load_packing(tmp_path / "j.h5").n == 16


@pytest.mark.parametrize("command, option", [
    (["jam", "--n", "16", "--ftol", "-1"], "--ftol"),
    (["jam", "--n", "16", "--minimizer", "md", "--damping", "-1"], "--damping"),
    (["jam", "--n", "16", "--gravity", "1e-3", "--walls", "y", "--vtol", "1e-3"], "--vtol"),
    (["jam", "--n", "16", "--gamma", "1e300"], "--gamma"),
    (["refine", "PACKING", "--pressure", "1e-3", "--force-tol", "2"], "--force-tol"),
    (["refine", "PACKING", "--pressure", "-1"], "--pressure"),
    (["shear", "PACKING", "--dgamma", "1e-3", "--to", "2e-3", "--dphi0", "0.5"], "--dphi0"),
    (["moduli", "PACKING", "--linear-tol", "2", "--no-figure"], "--linear-tol"),
    (["modes", "PACKING", "--e-min", "-1", "--no-figure"], "--e-min"),
    (["modes", "PACKING", "--mass", "-1", "--no-figure"], "--mass"),
    (["draw", "PACKING", "--slice", "2"], "--slice"),
    (["families", "--n", "16", "--starts", "0"], "--starts"),
])
def test_bad_settings_are_named_by_their_option(packing_file, capsys, tmp_path, command, option):
    argv = [str(packing_file) if w == "PACKING" else w for w in command]
    suffix = {"shear": "", "families": "", "draw": ".png"}.get(command[0], ".h5")
    out = [] if command[0] in ("moduli", "modes") else ["--out", str(tmp_path / f"o{suffix}")]
    assert main(argv + out) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"jamflow {command[0]}: error: {option} "), line
    assert not list(tmp_path.iterdir())


def test_a_cut_density_of_states_says_which_fraction_it_holds(packing_file, tmp_path, capsys):
    import csv

    import numpy as np

    from jamflow.analysis.modes import Spectrum
    from jamflow.io.packing_file import load_packing

    omegas = np.sort(Spectrum().compute(load_packing(packing_file)).frequencies)
    top = 0.5 * (omegas[len(omegas) // 2] + omegas[len(omegas) // 2 + 1])  # between two modes: half of them in range
    figure = tmp_path / "f.png"
    argv = ["modes", str(packing_file), "--figure", str(figure), "--omega-max", repr(float(top)), "--bins", "8"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    inside = int(np.sum(omegas <= top))
    assert "--omega-max" in err and f"leaves {len(omegas) - inside} of {len(omegas)} nonzero modes" in err
    rows = list(csv.DictReader(open(tmp_path / "f-dos.csv")))
    widths = np.array([float(r["omega_high"]) - float(r["omega_low"]) for r in rows])
    d = np.array([float(r["D"]) for r in rows])
    counts = np.histogram(omegas, np.linspace(0.0, top, 9))[0]
    assert np.allclose(d, counts / widths / len(omegas), rtol=1e-12)  # normalised over all modes
    assert {float(r["fraction_in_range"]) for r in rows} == {inside / len(omegas)}
    assert np.sum(d * widths) == pytest.approx(inside / len(omegas), rel=1e-12)


def test_an_uncut_density_of_states_integrates_to_one_without_a_warning(packing_file, tmp_path, capsys):
    import csv

    assert main(["modes", str(packing_file), "--figure", str(tmp_path / "f.png")]) == 0
    assert "warning" not in capsys.readouterr().err
    assert {r["fraction_in_range"] for r in csv.DictReader(open(tmp_path / "f-dos.csv"))} == {"1.0"}


def test_the_density_of_states_options_are_named(packing_file, capsys):
    assert main(["modes", str(packing_file), "--omega-max", "nan", "--no-figure"]) == EXIT_USER
    assert one_line(capsys.readouterr().err).startswith("jamflow modes: error: --omega-max ")


@pytest.fixture(scope="module")
def exported_scenes(tmp_path_factory):
    """A jammed packing of 16 dimers (sites stick out of the cell) and 16 disks jammed at a shear
    strain of 2.5 (positions kept in the reduced cell, the file's box tilted by 2.5 L)."""
    from jamflow.io.packing_file import load_packing

    root = tmp_path_factory.mktemp("scenes")
    for name, extra in (("dimers", ["--shape", "dimer:1.5:1"]), ("sheared", ["--gamma", "2.5"])):
        assert main(["jam", "--n", "16", "--seed", "1", *extra, "--out", str(root / f"{name}.h5"), "--quiet"]) == 0
    return {name: load_packing(root / f"{name}.h5") for name in ("dimers", "sheared")}


def _gsd_box(path):
    import gsd.hoomd
    import numpy as np

    with gsd.hoomd.open(str(path)) as f:
        frame = f[0]
    lx, ly, lz, xy, xz, yz = (float(v) for v in frame.configuration.box)
    h = np.array([[lx, xy * ly, xz * lz], [0.0, ly, yz * lz], [0.0, 0.0, lz or 1.0]])
    origin = -0.5 * h.sum(axis=1)  # HOOMD's cell is centred on the origin
    return h, origin, frame.particles.position.astype(float), frame.particles.image.astype(float)


def _dump_box(path):
    import numpy as np

    lines = path.read_text().splitlines()
    k = lines.index(next(line for line in lines if line.startswith("ITEM: BOX BOUNDS")))
    bounds = np.array([[float(v) for v in line.split()] for line in lines[k + 1:k + 4]])
    xy, xz, yz = bounds[:, 2] if bounds.shape[1] == 3 else (0.0, 0.0, 0.0)
    lo = bounds[:, 0] - [min(0.0, xy, xz, xy + xz), min(0.0, yz), 0.0]
    hi = bounds[:, 1] - [max(0.0, xy, xz, xy + xz), max(0.0, yz), 0.0]
    h = np.array([[hi[0] - lo[0], xy, xz], [0.0, hi[1] - lo[1], yz], [0.0, 0.0, hi[2] - lo[2]]])
    names = lines[k + 4].split()[2:]
    rows = np.array([[float(v) for v in line.split()] for line in lines[k + 5:]])
    column = {name: rows[:, c] for c, name in enumerate(names)}
    image = np.column_stack([column[c] for c in ("ix", "iy", "iz")]) if "ix" in column else None
    return h, lo, np.column_stack([column[c] for c in "xyz"]), image


def _xyz_box(path):
    import numpy as np

    lines = path.read_text().splitlines()
    h = np.reshape([float(v) for v in lines[1].split('Lattice="')[1].split('"')[0].split()], (3, 3)).T
    props = lines[1].split("Properties=")[1].split()[0].split(":")
    widths = {props[k]: int(props[k + 2]) for k in range(0, len(props), 3)}
    start = {}
    at = 0
    for name, width in widths.items():
        start[name] = at
        at += width
    rows = np.array([[float(v) for v in line.split()[1:]] for line in lines[2:]])
    image = rows[:, start["image"] - 1:start["image"] + 2] if "image" in start else None
    return h, np.zeros(3), rows[:, start["pos"] - 1:start["pos"] + 2], image


@pytest.mark.parametrize("scene", ["dimers", "sheared"])
@pytest.mark.parametrize("fmt, read", [("gsd", _gsd_box), ("lammps-dump", _dump_box), ("xyz", _xyz_box)])
def test_every_exported_position_is_in_its_box_and_image_flags_restore_it(exported_scenes, tmp_path, scene, fmt, read):
    import numpy as np

    from jamflow.io.export import SUFFIXES, export_packing

    packing = exported_scenes[scene]
    h, origin, position, image = read(export_packing(packing, tmp_path / f"x{SUFFIXES[fmt]}", fmt))
    d = packing.dim
    s = np.linalg.solve(h, (position - origin).T).T[:, :d]
    outside = np.any((s < -1e-6) | (s >= 1 + 1e-6), axis=1)
    assert not outside.any(), f"{outside.sum()} outside"
    assert image is not None, "no image flags"
    unwrapped = (position + image @ h.T)[:, :d]
    if packing.shape.kind == "rigid":  # the sites about their centre's wrapped position, each body whole
        centres = packing.box.images(packing.positions)[0]
        expected = packing.shape.world_sites(centres, packing.orientations, packing.diameters).reshape(-1, d)
        unwrapped = unwrapped[packing.n:] if fmt == "gsd" else unwrapped  # GSD: centres first, then sites
    else:
        expected = packing.positions
    shift = origin[:d] if fmt == "gsd" else 0.0
    assert np.abs(unwrapped - (expected + shift)).max() < (1e-5 if fmt == "gsd" else 1e-12)
    assert np.any(image != 0)


@pytest.mark.parametrize("phi0", [[], ["--phi0", "0.05"]])
def test_repulsive_lj_piles_settle_under_gravity(tmp_path, phi0):
    """The start's overlaps are removed without the weights, which pressed any start into overlaps;
    a written packing passed its checks (one that fails them is not written)."""
    from jamflow.io.packing_file import load_packing

    out = tmp_path / "pile.h5"
    assert main(["jam", "--n", "32", "--potential", "rlj", "--gravity", "1e-3", "--walls", "y", *phi0,
                 "--out", str(out), "--quiet"]) == 0
    pile = load_packing(out)
    assert pile.potential.name == "rlj" and pile.gravity == 1e-3 and pile.n == 32


@pytest.mark.parametrize("gravity, pressure, v_tol, option", [(1e-3, None, None, "--gravity"),
                                                             (0.0, 1e-3, None, "--pressure"),
                                                             (0.0, None, 1e-16, "--vtol")])
@pytest.mark.parametrize("balanced", [True, False])
def test_failed_checks_advise_the_option_of_the_scene(monkeypatch, gravity, pressure, v_tol, option, balanced):
    import dataclasses

    import numpy as np

    import jamflow.protocols.spec as spec
    from jamflow.model.box import Box
    from jamflow.model.packing import Packing
    from jamflow.protocols.outcome import JammingFailed

    class Failed:
        passed, force_balanced = False, balanced

        def problems(self):
            return ["not at an energy minimum"]

    box = Box(6.0 * np.eye(2), periodic=(True, gravity == 0))  # a pile needs its floor
    packing = Packing(np.array([[1.0, 1.0], [3.0, 3.0]]), np.ones(2), box, gravity=gravity)
    result = type("R", (), {"packing": packing, "phi_j": float("nan"), "energy_per_particle": 0.0,
                            "history": {"reason": np.array([b"force"])}})()
    monkeypatch.setattr(spec, "check_packing", lambda *a, **k: Failed())
    with pytest.raises(JammingFailed) as err:
        spec.checked(result, dataclasses.replace(spec.MinimizerSettings()), v_tol)
    others = {"--gravity", "--pressure", "--vtol"} - {option}
    assert option in str(err.value) and not any(o in str(err.value) for o in others)
    assert ("--minimizer" in str(err.value)) != balanced


@pytest.mark.parametrize("dim, vtol, remedy", [(2, "0.05", "--pressure for denser states"),
                                               (3, "0.01", "more particles")])
def test_jam_refuses_a_vtol_no_state_reaches_before_work(tmp_path, capsys, monkeypatch, dim, vtol, remedy):
    """The compression stops at phi = 1 (or where 16 spheres' box loses its unique minimum image):
    a window above the energy there was a whole compression and a misleading 'use a larger vtol'."""
    import jamflow.protocols.compression as compression

    monkeypatch.setattr(compression, "bisect", lambda *a, **k: pytest.fail("the compression started"))
    out = tmp_path / "j.h5"
    assert main(["jam", "--n", "16", "--dim", str(dim), "--vtol", vtol, "--out", str(out), "--quiet"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert f"--vtol {vtol} is above the energy" in line and "use --vtol below" in line and remedy in line
    assert not out.exists()


def test_a_vtol_below_the_densest_energy_still_jams(tmp_path):
    assert main(["jam", "--n", "16", "--dim", "3", "--vtol", "1e-7", "--out", str(tmp_path / "j.h5"), "--quiet"]) == 0


@pytest.mark.parametrize("command", [["shear", "PACKING", "--dgamma", "1e-3", "--to", "2e-3", "--out", "OUT"],
                                     ["anneal", "PACKING", "--to", "1.5", "--dalpha", "0.05", "--out", "OUT.h5"]])
def test_commands_without_pressure_refuse_an_unreachable_vtol_naming_only_their_options(packing_file, tmp_path, capsys,
                                                                                       command):
    argv = [str(packing_file) if w == "PACKING" else str(tmp_path / w) if w.startswith("OUT") else w for w in command]
    assert main(argv + ["--vtol", "0.05", "--quiet"]) == EXIT_USER
    line = one_line(capsys.readouterr().err)
    assert "--vtol 0.05 is above the energy" in line and "--pressure" not in line
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("vtol", ["1e-3", "0.05"])
def test_repulsive_lj_jams_into_a_large_window(tmp_path, vtol):
    """The start's overlaps are removed to V < 1e-16 whatever the window: with the window's V_min
    the relaxation stopped at once, and the deep overlaps left ended in a ZeroDivisionError or a
    refusal advising a function a command-line user cannot call."""
    from jamflow.io.packing_file import load_packing

    out = tmp_path / "j.h5"
    assert main(["jam", "--n", "16", "--potential", "rlj", "--phi0", "0.7", "--vtol", vtol, "--out", str(out),
                 "--quiet"]) == 0
    assert load_packing(out).potential.name == "rlj"


def test_a_pressure_whose_box_runs_away_fails_in_one_line_with_what_helps():
    """Repulsive LJ at P = 100: FIRE's box steps overshoot and the cell inverts or grows without
    bound within a window (it ended in "negative dimensions not allowed" or "Box side lengths must
    be positive"); the compiled engine reports it as blown-up and the protocol says what helps."""
    from jamflow import JamSpec, run_jam
    from jamflow.protocols.outcome import JammingFailed

    with pytest.raises(JammingFailed, match=r"P = 100 diverged.*--engine lammps --minimizer cg"):
        run_jam(JamSpec(n=64, potential="rlj", pressure=100.0))
