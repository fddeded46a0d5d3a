"""A first run says when numba compiles kernels: one line on stderr before the compile, none when
the machine code is in memory or in the disk cache."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import jamflow
import jamflow.engines.compiled as compiled
from jamflow.engines.compiled.engine import CompiledEngine

ROOT = Path(__file__).resolve().parents[1]
ELLIPSES = Path(__file__).parent / "data" / "ellipse1.5_n16_s0.h5"

SCRIPT = """
from jamflow.engines.compiled import announce_compile, jit

@jit
def twice(x):
    return 2.0 * x

announce_compile("test", 3, twice, (1.0,))
print(twice(1.0))
announce_compile("test", 3, twice, (1.0,))
"""


def test_a_kernel_about_to_compile_is_announced_once_and_a_cached_one_is_not(tmp_path):
    (tmp_path / "kernel_script.py").write_text(SCRIPT)
    env = {**os.environ, "JAMFLOW_CACHE_DIR": str(tmp_path / "cache"),
           "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    runs = [subprocess.run([sys.executable, "kernel_script.py"], cwd=tmp_path, env=env, capture_output=True, text=True)
            for _ in range(2)]
    assert all(r.returncode == 0 and r.stdout.strip() == "2.0" for r in runs), [r.stderr for r in runs]
    cold = [line for line in runs[0].stderr.splitlines() if "compiling" in line]
    assert len(cold) == 1, runs[0].stderr  # once, though asked twice
    assert cold[0].startswith(f"jamflow: compiling the test kernels once (~3 s) into {tmp_path / 'cache' / 'numba'}")
    assert "compiling" not in runs[1].stderr, runs[1].stderr  # loaded from the disk cache: nothing said


def test_the_compiled_engine_names_its_shape_before_numba_compiles(monkeypatch, capsys):
    monkeypatch.setattr(compiled, "will_compile", lambda dispatcher, args: True)
    monkeypatch.setattr(compiled, "_announced", set())
    monkeypatch.setattr(compiled, "_checked", set())
    engine = CompiledEngine(jamflow.load_packing(ELLIPSES))
    assert engine.kernels == "numba"
    engine.evaluate()
    engine.evaluate()
    lines = [line for line in capsys.readouterr().err.splitlines() if "compiling" in line]
    assert len(lines) == 1 and lines[0].startswith("jamflow: compiling the ellipse kernels once (~10 s) into ")


def test_no_notice_when_the_machine_code_is_there(monkeypatch, capsys):
    monkeypatch.setattr(compiled, "_announced", set())
    monkeypatch.setattr(compiled, "_checked", set())
    engine = CompiledEngine(jamflow.load_packing(ELLIPSES))
    engine.evaluate()  # compiled now if it was not (announced or not)
    capsys.readouterr()
    monkeypatch.setattr(compiled, "_checked", set())
    CompiledEngine(jamflow.load_packing(ELLIPSES)).evaluate()
    assert "compiling" not in capsys.readouterr().err
