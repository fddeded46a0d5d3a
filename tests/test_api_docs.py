"""The API reference's descriptions and the site's links to other projects' docs (docs/conf.py)."""

from __future__ import annotations

import ast
import dataclasses
import importlib.util
import inspect
import io
import os
import sys
import textwrap
import time
import tokenize
from pathlib import Path

import jamflow

ROOT = Path(__file__).resolve().parents[1]


def _documented_fields(cls) -> set[str]:
    """Class-body names with a ``#:`` comment on their line or on the line just above it (what
    Sphinx's autodoc shows as the attribute's description)."""
    source = textwrap.dedent(inspect.getsource(cls))
    doc_lines = {tok.start[0] for tok in tokenize.generate_tokens(io.StringIO(source).readline)
                 if tok.type == tokenize.COMMENT and tok.string.startswith("#:")}
    documented = set()
    for node in ast.parse(source).body[0].body:
        targets = [node.target] if isinstance(node, ast.AnnAssign) else getattr(node, "targets", [])
        if {node.lineno, node.lineno - 1} & doc_lines:
            documented |= {t.id for t in targets if isinstance(t, ast.Name)}
    return documented


def test_every_field_of_the_top_level_dataclasses_has_a_description():
    missing = {}
    for name in jamflow.__all__:
        obj = getattr(jamflow, name)
        if inspect.isclass(obj) and dataclasses.is_dataclass(obj):
            undocumented = [f.name for f in dataclasses.fields(obj) if f.name not in _documented_fields(obj)]
            if undocumented:
                missing[name] = undocumented
    assert not missing, f"dataclass fields without a #: description: {missing}"


def test_every_public_method_of_the_top_level_names_has_a_docstring():
    missing = []
    for name in jamflow.__all__:
        obj = getattr(jamflow, name)
        if not inspect.isclass(obj):
            assert inspect.getdoc(obj), name
            continue
        for attr, value in vars(obj).items():
            if attr.startswith("_"):
                continue
            func = value.fget if isinstance(value, property) else getattr(value, "__func__", value)
            if inspect.isfunction(func) and not func.__doc__:
                missing.append(f"{name}.{attr}")
    assert not missing, f"public methods without a docstring: {missing}"


def _conf(monkeypatch):
    monkeypatch.setenv("JAMFLOW_DOCS_OFFLINE", "1")
    monkeypatch.setenv("COLUMNS", os.environ.get("COLUMNS", "100"))  # conf.py sets it: restored after the test
    monkeypatch.setattr(sys, "path", list(sys.path))  # and extends the path
    spec = importlib.util.spec_from_file_location("jamflow_docs_conf", ROOT / "docs" / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    return conf


def test_the_site_maps_no_inventory_it_cannot_reach(monkeypatch):
    # Sphinx -W fails on an intersphinx inventory it cannot fetch: conf.py maps only those that answer
    conf = _conf(monkeypatch)
    assert conf.intersphinx_mapping == {}
    assert {"numpy", "scipy", "h5py", "freud", "gsd", "MDAnalysis"} <= set(conf.INTERSPHINX)
    monkeypatch.delenv("JAMFLOW_DOCS_OFFLINE")
    start = time.perf_counter()
    assert conf._reachable_inventories({"nowhere": "http://127.0.0.1:9/"}, timeout=1.0) == {}
    assert time.perf_counter() - start < 5


def test_the_api_reference_lists_every_top_level_name():
    page = (ROOT / "docs" / "reference" / "api" / "top-level.rst").read_text()
    missing = [name for name in jamflow.__all__ if f":: jamflow.{name}\n" not in page]
    assert not missing, f"jamflow.__all__ names missing from docs/reference/api/top-level.rst: {missing}"
