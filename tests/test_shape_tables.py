"""Every shape kind is registered once per layer: each per-kind table of every layer has an entry
for every kind of ``model.shapes.SHAPES`` (and none for a kind that is not there), every shape
class declares every capability, and no module tests the kind string."""

import re
from pathlib import Path

import pytest

from jamflow.decks.shapes import JAM_DECKS
from jamflow.engines.compiled import kernels
from jamflow.engines.compiled.engine import COMPILE_SECONDS, CompiledEngine
from jamflow.engines.lammps.data_file import ATOM_STYLES
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.io import export, gsd_file
from jamflow.mechanics import deformation, hessian, reference
from jamflow.minimize.soft_modes import AFTER_BY_SHAPE
from jamflow.model.shapes.parse import SPECS, parse_shape
from jamflow.model.shapes.shape import CAPABILITIES, SHAPES, shape_from_attrs
from jamflow.plots.drawing import DRAWERS

# tables every shape kind needs an entry in: to jam it, check it, measure it, file, draw and export it
COMPLETE = {
    "mechanics.reference._SHAPES": reference._SHAPES,
    "mechanics.hessian._REDUCED": hessian._REDUCED,
    "mechanics.deformation._CHANGES": deformation._CHANGES,
    "engines.compiled.kernels.BUILDERS": kernels.BUILDERS,
    "CompiledEngine.CAPABILITIES.shapes": CompiledEngine.CAPABILITIES.shapes,
    "engines.lammps.data_file.ATOM_STYLES": ATOM_STYLES,
    "io.export._ROWS": export._ROWS,
    "io.gsd_file._ROWS": gsd_file._ROWS,
    "plots.drawing.DRAWERS": DRAWERS,
}
# tables a kind may leave out (no LAMMPS run, no deck, the default trigger, the default notice time)
PARTIAL = {
    "LammpsEngine.CAPABILITIES.shapes": LammpsEngine.CAPABILITIES.shapes,
    "decks.shapes.JAM_DECKS": JAM_DECKS,
    "minimize.soft_modes.AFTER_BY_SHAPE": AFTER_BY_SHAPE,
    "engines.compiled.engine.COMPILE_SECONDS": COMPILE_SECONDS,
}
EXAMPLES = {"sphere": ("disk", 2), "ellipsoid": ("ellipse:1.5", 2), "rigid": ("dimer:1.5:1", 2)}


@pytest.mark.parametrize("table", sorted(COMPLETE))
@pytest.mark.parametrize("kind", sorted(SHAPES))
def test_every_shape_kind_has_an_entry_in_every_table(kind, table):
    assert kind in COMPLETE[table], f"shape kind {kind!r} has no entry in {table}"


@pytest.mark.parametrize("table", sorted({**COMPLETE, **PARTIAL}))
def test_no_table_names_a_kind_that_is_not_a_shape(table):
    assert set({**COMPLETE, **PARTIAL}[table]) <= set(SHAPES)


@pytest.mark.parametrize("kind", sorted(SHAPES))
def test_every_shape_class_declares_every_capability_once(kind):
    cls = SHAPES[kind]
    assert cls.kind == kind
    for name in CAPABILITIES:
        assert isinstance(getattr(cls, name), bool), f"{cls.__name__}.{name}"
    shape = parse_shape(*EXAMPLES[kind])
    assert shape.kind == kind and shape_from_attrs(shape.attrs()) == shape
    assert shape.aspect_ratio is None or shape.aspect_ratio > 0


def test_capabilities_of_the_shapes():
    sphere, ellipse, dimer = (parse_shape(*EXAMPLES[k]) for k in ("sphere", "ellipsoid", "rigid"))
    assert [s.round for s in (sphere, ellipse, dimer)] == [True, False, False]
    assert [s.elliptic for s in (sphere, ellipse, dimer)] == [False, True, False]
    assert [s.made_of_sites for s in (sphere, ellipse, dimer)] == [False, False, True]
    assert [s.sphere_contacts for s in (sphere, ellipse, dimer)] == [True, False, True]
    assert [s.aspect_ratio for s in (sphere, ellipse, dimer)] == [1.0, 1.5, None]
    assert set(ellipse.datasets(None, None, [1.0, 1.4])) == {"axes"} and sphere.datasets(None, None, [1.0]) == {}


@pytest.mark.parametrize("word", sorted(SPECS))
def test_every_spec_word_makes_a_registered_shape(word):
    spec = {"disk": "disk", "sphere": "sphere", "ellipse": "ellipse:1.5", "spheroid": "spheroid:1.5",
            "nmer": "nmer:3:1.5", "dimer": "dimer:1.5:1", "trimer": "trimer:1.5:0.5"}[word]
    dim = 3 if word == "spheroid" else 2
    assert parse_shape(spec, dim).kind in SHAPES


def test_no_module_tests_the_shape_kind_string():
    """Shapes are told apart by their capabilities and per-kind tables, not by comparing
    ``shape.kind`` with a name."""
    root = Path(__file__).resolve().parents[1] / "jamflow"
    test = re.compile(r"""(shape|particle)\.kind\s*(==|!=|in|not in)\s*[("']""")
    found = [f"{path.relative_to(root)}:{k + 1}" for path in sorted(root.rglob("*.py"))
             for k, line in enumerate(path.read_text().splitlines()) if test.search(line)]
    assert not found, found
