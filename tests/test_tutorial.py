"""The tutorial notebook (docs/tutorial.ipynb) runs from top to bottom under nbmake, so its
code works with this jamflow; a cell that raises fails this test. It is stored
without outputs, so the repository stays small and diffs stay readable."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"


def run_notebook(notebook: Path, where: Path) -> subprocess.CompletedProcess:
    """``pytest --nbmake`` on a copy of ``notebook`` in ``where`` (its files land there)."""
    copy = where / notebook.name
    if copy != notebook:
        shutil.copy(notebook, copy)
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--nbmake",
                           "--nbmake-timeout=600", copy.name], cwd=where, capture_output=True, text=True, timeout=900)


def test_tutorial_notebook_runs(tmp_path):
    done = run_notebook(NOTEBOOK, tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "1 passed" in done.stdout
    for figure in ("compression", "packing", "modes", "mode", "gr", "sk", "q6", "shear", "moduli"):
        assert (tmp_path / "tutorial-output" / f"{figure}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_failing_cell_fails_the_run(tmp_path):
    notebook = json.loads(NOTEBOOK.read_text())
    notebook["cells"] = [{"cell_type": "code", "execution_count": None, "id": "broken", "metadata": {}, "outputs": [],
                          "source": ["import jamflow\n", "jamflow.jam(n=-1)\n"]}]
    broken = tmp_path / "broken" / "tutorial.ipynb"
    broken.parent.mkdir()
    broken.write_text(json.dumps(notebook))
    done = run_notebook(broken, broken.parent)
    assert done.returncode != 0
    assert "ValueError" in done.stdout


def test_tutorial_is_stored_without_outputs():
    notebook = json.loads(NOTEBOOK.read_text())
    code = [c for c in notebook["cells"] if c["cell_type"] == "code"]
    assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code)
