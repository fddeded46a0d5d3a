"""Every script in examples/ runs at small N and writes its figure (so CI runs them)."""

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
SMALL = {"jam_and_draw.py": ["--n", "32"], "ensemble_phi_j.py": ["--n", "12", "16", "--seeds", "3"],
         "modes_dos.py": ["--n", "32", "--seeds", "2"], "structure_polydisperse.py": ["--n", "64", "--seeds", "1"],
         "shear_path.py": ["--n", "10", "--to", "0.02"], "ellipse_modes.py": ["--n", "32", "--seeds", "1"],
         "shapes.py": ["--n", "16"]}


def test_every_example_is_run():
    assert sorted(p.name for p in EXAMPLES.glob("*.py")) == sorted(SMALL)


@pytest.mark.parametrize("script", sorted(SMALL))
def test_example_runs_and_draws(script, tmp_path):
    figure = tmp_path / "figure.png"
    done = subprocess.run([sys.executable, str(EXAMPLES / script), *SMALL[script], "--out", str(figure)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "figure ->" in done.stdout
