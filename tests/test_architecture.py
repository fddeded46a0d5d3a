"""The layer rule (docs/architecture.md): each layer of jamflow imports only from the layers below
it (the import-linter contract in pyproject.toml, imports inside functions included), no import
cycle among jamflow's modules, few loose modules at the top of the package. The import graph
(grimp, which import-linter reads) must hold every ``.py`` file under ``jamflow/``: a folder
without ``__init__.py`` is invisible to it and to the contract."""

import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = Path(sys.executable).with_name("lint-imports")


@pytest.fixture(scope="module")
def graph():
    """jamflow's import graph, as import-linter builds it (imports inside functions included)."""
    spec = importlib.util.find_spec("jamflow")
    assert Path(spec.origin).resolve().parent == ROOT / "jamflow", spec.origin  # the tree under test
    return grimp.build_graph("jamflow", include_external_packages=False, cache_dir=None)


def module_files(root: Path) -> set[str]:
    """The module name of every ``.py`` file under ``root/jamflow`` (a package's ``__init__.py`` is
    the package itself), ``__pycache__`` left out."""
    names = set()
    for path in (root / "jamflow").rglob("*.py"):
        if "__pycache__" in path.parts:
            continue
        parts = path.relative_to(root).with_suffix("").parts
        names.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return names


def layer_levels(layers: list[str]) -> dict[str, tuple[int, int]]:
    """Package -> (level, sibling) from an import-linter ``layers`` list (top first; ``a | b``
    are independent siblings on one level)."""
    return {name.strip(): (-level, sibling) for level, entry in enumerate(layers)
            for sibling, name in enumerate(entry.split("|"))}


def upward_imports(graph, layers: list[str]) -> list[tuple[str, str]]:
    """(importer, imported) pairs where a module imports from a layer above its own or from an
    independent sibling; the package's own ``__init__`` (outside the layers) is not counted."""
    levels = layer_levels(layers)

    def level(module):
        for package, where in levels.items():
            if module == package or module.startswith(package + "."):
                return where
        return None

    out = []
    for importer in sorted(graph.modules):
        mine = level(importer)
        for imported in sorted(graph.find_modules_directly_imported_by(importer)):
            theirs = level(imported)
            if None not in (mine, theirs) and (theirs[0] > mine[0] or (theirs[0] == mine[0] and theirs != mine)):
                out.append((importer, imported))
    return out


def contract_layers() -> list[str]:
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    contracts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]["contracts"]
    return next(c["layers"] for c in contracts if c["type"] == "layers")


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


def test_the_import_graph_holds_every_module(graph):
    """No folder hides from the contract: grimp's modules are exactly the ``.py`` files."""
    files = module_files(ROOT)
    assert len(files) > 100
    assert {"missing from the graph": sorted(files - graph.modules),
            "not a file": sorted(graph.modules - files)} == {"missing from the graph": [], "not a file": []}


def test_no_import_cycles_among_modules(graph):
    assert _cycles(graph) == []


def test_no_upward_imports_among_modules(graph):
    assert upward_imports(graph, contract_layers()) == []


def test_the_upward_finder_finds_upward_and_sibling_imports():
    graph = grimp.ImportGraph()
    for m in ("p", "p.low", "p.low.a", "p.mid", "p.mid.b", "p.left", "p.right", "p.top", "p._loose"):
        graph.add_module(m)
    graph.add_import(importer="p.low.a", imported="p.mid.b")  # upward
    graph.add_import(importer="p.mid.b", imported="p.low.a")  # downward
    graph.add_import(importer="p.left", imported="p.right")  # between independent siblings
    graph.add_import(importer="p.top", imported="p.left")  # downward
    graph.add_import(importer="p._loose", imported="p.top")  # outside the layers
    layers = ["p.top", "p.left | p.right", "p.mid", "p.low"]
    assert upward_imports(graph, layers) == [("p.left", "p.right"), ("p.low.a", "p.mid.b")]


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
