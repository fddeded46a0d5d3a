"""The benchmark suite (benchmarks/README.md): every script is registered, support or archived, and
``python -m benchmarks --quick`` runs every quick mode without error (numbers are not checked)."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "benchmarks"


def benchmarks(*args, timeout=60):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-m", "benchmarks", *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env=env)


def registry():
    sys.path.insert(0, str(ROOT))
    try:
        from benchmarks import BENCHMARKS, KINDS, SUPPORT
    finally:
        sys.path.remove(str(ROOT))
    return BENCHMARKS, KINDS, SUPPORT


def test_list_names_every_registered_benchmark():
    registered, kinds, _ = registry()
    out = benchmarks("list")
    assert out.returncode == 0, out.stderr
    listed = {line.split()[0]: line.split()[1] for line in out.stdout.splitlines()}
    assert listed == {name: b.kind for name, b in registered.items()}
    assert {b.kind for b in registered.values()} <= set(kinds)


def test_every_script_is_registered_support_or_archived():
    registered, _, support = registry()
    archive = (BENCH / "ARCHIVE.md").read_text()
    scripts = {p.stem for p in BENCH.glob("*.py")}
    unlisted = sorted(s for s in scripts if s not in registered and s not in support and f"`{s}.py`" not in archive)
    assert not unlisted, f"benchmarks neither registered nor in ARCHIVE.md: {unlisted}"
    assert not sorted(set(registered) - scripts), "registered benchmarks without a script"
    retired_still_here = sorted(s for s in scripts - set(support) if f"| `{s}.py` |" in archive)
    assert not retired_still_here, f"archived but still present: {retired_still_here}"


def test_scripts_import_no_sibling_but_common():
    registered, _, _ = registry()
    for name in registered:
        text = (BENCH / f"{name}.py").read_text()
        for other in registered:
            assert f"from {other} import" not in text and f"import {other}\n" not in text, (name, other)


def test_run_refuses_an_unknown_name_and_arguments_for_several():
    out = benchmarks("run", "no_such_benchmark")
    assert out.returncode == 2 and "unknown benchmark" in out.stderr
    out = benchmarks("run", "kernel", "engines", "--", "--help")
    assert out.returncode == 2 and "exactly one benchmark" in out.stderr


@pytest.mark.slow
def test_quick_mode_of_every_benchmark_runs():
    out = benchmarks("--quick", timeout=600)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-4000:]
    assert "FAILED" not in out.stdout


def test_pressure_ladder_quick_mode_records_every_state(tmp_path):
    """The ladder's quick mode (N = 16, p = 1e-3 .. 1e-4): one row per state, balanced in
    double-double, at its pressure, with N_c >= d (N' - 1) + 1 and Delta z = 2 (N_c / N' - d + d / N')."""
    import csv

    out = tmp_path / "ladder.csv"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run([sys.executable, str(BENCH / "pressure_ladder.py"), "--quick", "--out", str(out)], cwd=ROOT,
                         check=False, capture_output=True, text=True, timeout=300, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    rows = list(csv.DictReader(out.open()))
    assert [r["target"] for r in rows] == ["1.000e-03", "3.162e-04", "1.000e-04"]
    for r in rows:
        assert r["status"] == "ok", r["error"]
        assert abs(float(r["p"]) / float(r["target"]) - 1) < 1e-3 and float(r["force_balance"]) < 1e-10
        nc, nprime = int(r["n_contacts"]), int(r["n_prime"])
        assert int(r["excess"]) == nc - (2 * (nprime - 1) + 1) >= 0
        assert abs(float(r["delta_z"]) - (2 * nc / nprime - 4 * (nprime - 1) / nprime)) < 1e-9
        assert float(r["G"]) > 0
    assert (tmp_path / "ladder.png").stat().st_size > 0
