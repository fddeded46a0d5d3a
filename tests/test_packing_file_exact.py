"""Packing files hold the packing bit for bit, and refuse damaged ones.

Saving then loading returns the same positions, orientations and box (so the same energy) for
every shape, sheared boxes and double-double packings. Damaged extended-precision low parts and
boxes are refused on load with one line naming the dataset, by ``load_packing`` and by the
commands that read packing files (exit code 2, no traceback)."""

import subprocess
import sys

import h5py
import numpy as np
import pytest

import jamflow
from jamflow.cli.app import EXIT_USER, main
from jamflow.io.packing_file import load_packing, save_packing
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.model.box import Box
from jamflow.model.packing import random_packing
from jamflow.model.shapes.parse import parse_shape
from jamflow.model.sizes import parse_sizes

SHAPES = [("disk", 2), ("sphere", 3), ("ellipse:1.3", 2), ("spheroid:1.5", 3), ("spheroid:0.6", 3),
          ("dimer:1.5:0.5", 2), ("dimer:1.5:0.5", 3), ("trimer:1.5:0.5", 2), ("trimer:1.5:0.5", 3)]


def as_an_engine_hands_it(spec: str, dim: int, seed: int, tilt: float = 0.0):
    """A random packing of ``spec`` at phi = 0.5 (overlapping, so with an energy), its positions
    wrapped into the cell once as every engine returns them; ``tilt``: xy = tilt * ly."""
    p = random_packing(96, dim, parse_sizes("bi:1.4:0.5"), 0.5, seed, shape=parse_shape(spec, dim))
    if tilt:
        h = p.box.h.copy()
        h[0, 1] = tilt * h[1, 1]
        p = p.with_positions(Box(h).to_cartesian(p.box.to_fractional(p.positions)), box=Box(h))
    return p.with_positions(p.box.wrap(p.positions))


def assert_same_bits(back, p):
    assert np.array_equal(back.positions, p.positions)
    assert (back.orientations is None) == (p.orientations is None)
    if p.orientations is not None:
        assert np.array_equal(back.orientations, p.orientations)
    assert np.array_equal(back.box.h, p.box.h) and np.array_equal(back.diameters, p.diameters)
    assert energy_forces_pressure(back).energy == energy_forces_pressure(p).energy


@pytest.mark.parametrize("spec, dim", SHAPES)
def test_save_then_load_returns_the_same_bits_for_every_shape(spec, dim, tmp_path):
    for seed, tilt in ((1, 0.0), (2, 0.37)):
        p = as_an_engine_hands_it(spec, dim, seed, tilt)
        back = load_packing(save_packing(tmp_path / f"p{seed}.h5", p))
        assert_same_bits(back, p)


def test_a_jammed_packing_reads_back_bit_for_bit(tmp_path):
    res = jamflow.jam(n=128, seed=3)
    back = load_packing(res.save(tmp_path / "x.h5"))
    assert_same_bits(back, res.packing)


def test_positions_outside_the_cell_are_stored_wrapped_once(config, tmp_path):
    p = config(40, 2, 0.4, seed=4)
    outside = p.with_positions(p.positions + p.box.lengths * np.array([2.0, -1.0]))
    first = load_packing(save_packing(tmp_path / "a.h5", outside))
    assert np.array_equal(first.positions, outside.box.wrap(outside.positions))
    assert_same_bits(load_packing(save_packing(tmp_path / "b.h5", first)), first)


def test_a_double_double_packing_reads_back_bit_for_bit(tmp_path):
    from jamflow.protocols.refine import refine

    refined = refine(jamflow.jam(n=32, seed=1, engine="numba").packing, 1e-12)
    back = load_packing(refined.save(tmp_path / "dd.h5"))
    p = refined.packing
    assert back.precision == "double-double"
    assert_same_bits(back, p)
    assert np.array_equal(back.positions_lo, p.positions_lo) and np.array_equal(back.lengths_lo, p.lengths_lo)


# --- damaged files ----------------------------------------------------------------------------


@pytest.fixture(scope="module")
def valid_dd(tmp_path_factory):
    """A small valid double-double packing file (jammed disks, low parts of a fraction of an ulp)."""
    p = jamflow.jam(n=32, seed=1, engine="numba").packing
    lo = 0.25 * np.spacing(p.positions) * np.where(np.arange(p.positions.size).reshape(p.positions.shape) % 2, 1, -1)
    path = tmp_path_factory.mktemp("valid") / "dd.h5"
    save_packing(path, p.with_low_parts(lo, 0.25 * np.spacing(p.box.lengths)))
    assert load_packing(path).precision == "double-double"
    return path


def _set(name, value):
    def damage(f):
        data = f[name][...]
        data[(0,) * data.ndim] = value
        del f[name]
        f[name] = data
    return damage


def _scale_box(factor):
    def damage(f):
        h = f["box"][...]
        h[0, 0] *= factor
        del f["box"]
        f["box"] = h
    return damage


DAMAGES = {
    "huge positions_lo": (_set("positions_lo", 1e300), "positions_lo"),
    "positions_lo of ten ulps": (lambda f: _set("positions_lo", 10 * np.spacing(f["positions"][0, 0]))(f),
                                 "positions_lo"),
    "negative box_lo": (_set("box_lo", -1e-3), "box_lo"),
    "NaN box_lo": (_set("box_lo", np.nan), "box_lo"),
    "infinite box_lo": (_set("box_lo", np.inf), "box_lo"),
    "negative box side": (_scale_box(-1.0), "dataset box"),
    "zero box side": (_scale_box(0.0), "dataset box"),
    "infinite box side": (_scale_box(np.inf), "dataset box"),
}


@pytest.fixture(params=sorted(DAMAGES))
def damaged(request, valid_dd, tmp_path):
    damage, dataset = DAMAGES[request.param]
    path = tmp_path / "damaged.h5"
    path.write_bytes(valid_dd.read_bytes())
    with h5py.File(path, "a") as f:
        damage(f)
    return path, dataset


def test_load_packing_refuses_damaged_low_parts_and_boxes_naming_the_dataset(damaged):
    path, dataset = damaged
    with pytest.raises(ValueError, match=f"{path}.*{dataset}") as err:
        load_packing(path)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize("command", ["modes", "refine", "export"])
def test_commands_refuse_damaged_files_with_one_line(command, damaged, tmp_path, capsys):
    path, dataset = damaged
    argv = {"modes": ["modes", str(path)],
            "refine": ["refine", str(path), "--pressure", "1e-13", "--out", str(tmp_path / "r.h5")],
            "export": ["export", str(path), "--format", "xyz", "-o", str(tmp_path / "e.xyz")]}[command]
    assert main(argv) == EXIT_USER
    err = capsys.readouterr().err
    assert dataset in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.h5").exists() and not (tmp_path / "e.xyz").exists()


def test_refine_of_a_file_with_huge_low_parts_exits_cleanly(valid_dd, tmp_path):
    path = tmp_path / "damaged.h5"
    path.write_bytes(valid_dd.read_bytes())
    with h5py.File(path, "a") as f:
        _set("positions_lo", 1e300)(f)
    run = subprocess.run([sys.executable, "-m", "jamflow.cli", "refine", str(path), "--pressure", "1e-13", "--out",
                          str(tmp_path / "r.h5")], capture_output=True, text=True)
    assert run.returncode == EXIT_USER and "Traceback" not in run.stderr
    assert "positions_lo" in run.stderr
