"""The layer rule (docs/architecture.md): each layer of jamflow imports only from the layers below
it (the import-linter contract in pyproject.toml, imports inside functions included), no import
cycle among jamflow's modules, few loose modules at the top of the package."""

import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


def lint(cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(LINT), "--no-cache"], cwd=cwd, env={"PYTHONPATH": str(pythonpath), "PATH": "/usr/bin:/bin"},
                          capture_output=True, text=True, timeout=300)


def test_the_layer_contract_holds():
    done = lint(ROOT, ROOT)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "Contracts: 2 kept, 0 broken." in done.stdout


def test_an_upward_import_breaks_the_contract(tmp_path):
    """The contract is not vacuous: the model layer importing the CLI, inside a function, fails it."""
    shutil.copytree(ROOT / "jamflow", tmp_path / "jamflow", ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    box = tmp_path / "jamflow" / "model" / "box.py"
    box.write_text(box.read_text() + "\n\ndef _upward():\n    from jamflow.cli import app\n\n    return app\n")
    done = lint(tmp_path, tmp_path)
    assert done.returncode != 0
    assert "jamflow.model is not allowed to import jamflow.cli" in done.stdout
    assert "jamflow.model.box -> jamflow.cli.app" in done.stdout


def _cycles(graph) -> list[set]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = counter[0]; counter[0] += 1; stack.append(root); on.add(root)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = counter[0]; counter[0] += 1; stack.append(w); on.add(w)
                    work.append((w, iter(sorted(graph.find_modules_directly_imported_by(w)))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = set()
                    while True:
                        w = stack.pop(); on.discard(w); component.add(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        out.append(component)
    return out


def test_no_import_cycles_among_modules():
    graph = grimp.build_graph("jamflow", cache_dir=None)
    assert len(graph.modules) > 100
    assert _cycles(graph) == []


def test_the_cycle_finder_finds_a_cycle():
    graph = grimp.ImportGraph()
    for m in ("p", "p.a", "p.b", "p.c"):
        graph.add_module(m)
    graph.add_import(importer="p.a", imported="p.b")
    graph.add_import(importer="p.b", imported="p.a")
    graph.add_import(importer="p.c", imported="p.a")
    assert _cycles(graph) == [{"p.a", "p.b"}]


@pytest.mark.parametrize("limit", [8])
def test_few_loose_modules_at_the_top(limit):
    loose = sorted(p.name for p in (ROOT / "jamflow").glob("*.py"))
    assert len(loose) <= limit, loose
