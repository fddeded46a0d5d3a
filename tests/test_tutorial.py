"""The tutorial notebook (docs/tutorial.ipynb) is stored with the outputs of every code cell, and
the documentation site shows them as stored (docs/conf.py: nb_execution_mode "off"). These
tests run the notebook again from top to bottom under nbmake and require what it prints now to
be what is stored: cell by cell the same outputs, the same text, each number equal to a relative
1e-5 (absolute 1e-12, for values at round-off size such as V = 1.5e-16), the round-off
residuals max_force, max|F| and force_ratio masked; every figure a PNG. So a cell that raises,
or a change to jamflow or to the notebook that changes what it prints, fails the suite until the
outputs are stored again with

    python tests/test_tutorial.py

which runs the notebook in a scratch directory and writes its outputs into docs/tutorial.ipynb:
stderr dropped (notices of first compiles), stdout in one piece per cell, each PNG at most 800 pixels wide in 256 colours, the
notebook's own metadata kept. No cell prints a time, an absolute path or the kernels that ran,
which differ from machine to machine."""

from __future__ import annotations

import base64
import copy
import io
import json
import math
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"
FIGURES = ("compression", "packing", "modes", "mode", "gr", "sk", "q6", "shear", "moduli")
PNG = b"\x89PNG\r\n\x1a\n"
MAX_WIDTH = 800  # pixels of a stored figure
MAX_BYTES = 600_000  # the stored notebook
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
ROUND_OFF = re.compile(r"(max_force=|max\|F\| = |force_ratio=)" + NUMBER.pattern)
REL, ABS = 1e-5, 1e-12


def run_notebook(notebook: Path, where: Path, overwrite: bool = False) -> subprocess.CompletedProcess:
    """``pytest --nbmake`` on a copy of ``notebook`` in ``where`` (its files land there); with
    ``overwrite`` the copy keeps the outputs of the run."""
    copy_ = where / notebook.name
    if copy_ != notebook:
        shutil.copy(notebook, copy_)
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--nbmake",
                           "--nbmake-timeout=600", *(["--overwrite"] if overwrite else []), copy_.name],
                          cwd=where, capture_output=True, text=True, timeout=900)


def executed(where: Path) -> dict:
    """The stored notebook run in ``where``, with the outputs of the run (AssertionError if a cell raised)."""
    done = run_notebook(NOTEBOOK, where, overwrite=True)
    assert done.returncode == 0 and "1 passed" in done.stdout, done.stdout[-3000:] + done.stderr[-2000:]
    return json.loads((where / NOTEBOOK.name).read_text())


def code_cells(notebook: dict) -> list[dict]:
    return [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]


def text(value) -> str:
    return value if isinstance(value, str) else "".join(value)


def small_png(data: str) -> str:
    """A base64 PNG at most MAX_WIDTH pixels wide, in 256 colours on white (a few times smaller)."""
    from PIL import Image

    image = Image.open(io.BytesIO(base64.b64decode(data))).convert("RGBA")
    if image.width > MAX_WIDTH:
        image = image.resize((MAX_WIDTH, round(image.height * MAX_WIDTH / image.width)), Image.LANCZOS)
    flat = Image.new("RGB", image.size, "white")
    flat.paste(image, mask=image.getchannel("A"))
    out = io.BytesIO()
    flat.quantize(256).save(out, "PNG", optimize=True)
    return base64.b64encode(out.getvalue()).decode()


def merged(outputs: list[dict]) -> list[dict]:
    """``outputs`` without stderr, and stdout in one piece where the kernel sent it in several
    (where it splits depends on timing)."""
    kept = []
    for output in outputs:
        if output["output_type"] == "stream" and output["name"] == "stderr":
            continue
        output = copy.deepcopy(output)
        if output["output_type"] == "stream" and kept and kept[-1]["output_type"] == "stream":
            kept[-1]["text"] = text(kept[-1]["text"]) + text(output["text"])
            continue
        kept.append(output)
    return kept


def stored_outputs(outputs: list[dict]) -> list[dict]:
    """``outputs`` as the notebook stores them: merged, small PNGs."""
    kept = merged(outputs)
    for output in kept:
        if "image/png" in output.get("data", {}):
            output["data"]["image/png"] = small_png(text(output["data"]["image/png"]))
    return kept


def store(where: Path) -> dict:
    """Run the notebook in ``where`` and write its outputs into docs/tutorial.ipynb; the notebook written."""
    run = code_cells(executed(where))
    notebook = json.loads(NOTEBOOK.read_text())
    cells = code_cells(notebook)
    assert len(run) == len(cells)
    for cell, done in zip(cells, run):
        assert cell["source"] == done["source"]
        cell["outputs"], cell["execution_count"] = stored_outputs(done["outputs"]), done["execution_count"]
    import nbformat

    nbformat.write(nbformat.from_dict(notebook), NOTEBOOK)
    return notebook


def same_text(now: str, stored: str) -> str | None:
    """None when ``now`` reads as ``stored`` (numbers within REL/ABS, round-off residuals masked); else why not."""
    now, stored = ROUND_OFF.sub(r"\1<round-off>", now), ROUND_OFF.sub(r"\1<round-off>", stored)
    if NUMBER.split(now) != NUMBER.split(stored):
        return f"the text differs:\n  now:    {now!r}\n  stored: {stored!r}"
    for a, b in zip(NUMBER.findall(now), NUMBER.findall(stored)):
        if not math.isclose(float(a), float(b), rel_tol=REL, abs_tol=ABS):
            return f"{a} now, {b} stored, in\n  {stored!r}"
    return None


def differences(run: dict, stored: dict) -> list[str]:
    """How the outputs of the notebook ``run`` differ from the ``stored`` ones, cell by cell."""
    found = []
    for k, (cell, old) in enumerate(zip(code_cells(run), code_cells(stored), strict=True)):
        new = merged(cell["outputs"])
        where = f"code cell {k + 1} ({text(old['source']).splitlines()[-1][:60]!r})"
        kinds = [(o["output_type"], o.get("name"), sorted(o.get("data", {}))) for o in new]
        if kinds != [(o["output_type"], o.get("name"), sorted(o.get("data", {}))) for o in old["outputs"]]:
            found.append(f"{where}: outputs {kinds} now")
            continue
        for o_new, o_old in zip(new, old["outputs"]):
            pairs = [(o_new["text"], o_old["text"])] if "text" in o_new else [
                (o_new["data"][mime], o_old["data"][mime]) for mime in o_new.get("data", {}) if mime.startswith("text/")]
            for a, b in pairs:
                why = same_text(text(a), text(b))
                if why:
                    found.append(f"{where}: {why}")
            if o_new.get("metadata") != o_old.get("metadata"):
                found.append(f"{where}: metadata {o_new.get('metadata')} now, {o_old.get('metadata')} stored")
            if "image/png" in o_new.get("data", {}):
                for data in (o_new["data"]["image/png"], o_old["data"]["image/png"]):
                    if not base64.b64decode(text(data)).startswith(PNG):
                        found.append(f"{where}: a figure that is not a PNG")
    return found


def test_stored_outputs_are_what_the_notebook_prints_now(tmp_path):
    run = executed(tmp_path)
    for figure in FIGURES:
        assert (tmp_path / "tutorial-output" / f"{figure}.png").read_bytes()[:8] == PNG
    found = differences(run, json.loads(NOTEBOOK.read_text()))
    assert not found, ("docs/tutorial.ipynb stores outputs other than those of this jamflow; check the "
                       "differences and store the new ones with `python tests/test_tutorial.py`:\n" + "\n".join(found))


def test_every_cell_stores_its_output_and_nothing_of_the_machine():
    assert NOTEBOOK.stat().st_size < MAX_BYTES
    cells = code_cells(json.loads(NOTEBOOK.read_text()))
    assert cells and all(cell["outputs"] for cell in cells)
    assert [cell["execution_count"] for cell in cells] == list(range(1, len(cells) + 1))
    figures = 0
    for cell in cells:
        for output in cell["outputs"]:
            assert not (output["output_type"] == "stream" and output["name"] == "stderr")
            words = text(output.get("text", "")) + "".join(text(v) for m, v in output.get("data", {}).items()
                                                          if m.startswith("text/"))
            assert not re.search(r"\d s\b|ahead-of-time|compiled, numba|/home/|/tmp/|/root/|[A-Z]:\\", words), words
            if "image/png" in output.get("data", {}):
                from PIL import Image

                png = base64.b64decode(text(output["data"]["image/png"]))
                assert png.startswith(PNG) and Image.open(io.BytesIO(png)).width <= MAX_WIDTH
                figures += 1
    assert figures == len(FIGURES)


def test_a_changed_number_is_found():
    stored = json.loads(NOTEBOOK.read_text())
    run = copy.deepcopy(stored)
    cell = next(c for c in code_cells(run) if "jamflow.jam(n=32" in text(c["source"]))
    result = cell["outputs"][0]["data"]
    result["text/plain"] = text(result["text/plain"]).replace("phi_j=0.83", "phi_j=0.84")
    assert differences(stored, stored) == []
    assert len(differences(run, stored)) == 1


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


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as scratch:
        written = store(Path(scratch))
    cells = code_cells(written)
    print(f"{NOTEBOOK}: {sum(bool(c['outputs']) for c in cells)} of {len(cells)} code cells with outputs, "
          f"{NOTEBOOK.stat().st_size / 1000:.0f} kB")
