"""A double-double packing file read back (docs/guide/precision.md): its contacts, floaters, dynamical
matrix, pressure and moduli come from hi + lo. At p = 1e-14 the overlaps (~1e-14 diameters) are
below one ulp of a coordinate: N = 256 seed 1 refined to 1e-14 has 479 contacts in double-double,
but 470 (19 floaters, 4 zero modes, G = -3.5e-13) from its float64 positions (main 8c2345b)."""

import warnings
from dataclasses import replace

import numpy as np
import pytest

import jamflow
from jamflow.analysis.modes import Spectrum
from jamflow.engines.compiled.ddkernel import spring_dd
from jamflow.io.packing_file import load_packing
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.elastic import HessianModuli
from jamflow.model.pairs import candidate_pairs
from jamflow.protocols.refine import refine


@pytest.fixture(scope="module")
def refined256():
    return refine(jamflow.jam(n=256, seed=1, engine="numba").packing, 1e-14)


@pytest.fixture(scope="module")
def saved(refined256, tmp_path_factory):
    path = tmp_path_factory.mktemp("dd") / "p256.h5"
    refined256.save(path)
    return path


@pytest.fixture(scope="module")
def read_back(saved):
    return load_packing(saved)


def test_pair_overlaps_equal_the_compiled_double_double_kernel(read_back):
    """The numpy double-double pair geometry and the compiled kernel give the same overlaps, bit for bit."""
    from jamflow.model.pairs import pair_geometry

    p = read_back
    i, j = candidate_pairs(p, 1.1 * p.diameters.max())
    ext = p.extended
    out = spring_dd(p.positions, ext.positions_lo, p.box.lengths, ext.lengths_lo, p.diameters, i, j, 1.0)
    touch = (out.overlap[0] > 0) | ((out.overlap[0] == 0) & (out.overlap[1] > 0))
    geo = pair_geometry(p)
    order = np.lexsort((geo.j, geo.i))
    ref = np.lexsort((j[touch], i[touch]))
    assert np.array_equal(geo.i[order], i[touch][ref]) and np.array_equal(geo.j[order], j[touch][ref])
    assert np.array_equal(geo.overlap[order], (out.overlap[0] + out.overlap[1])[touch][ref])
    assert pair_geometry(replace(p, extended=None)).overlap is None  # float64: the old path


def test_contacts_and_floaters_of_the_file_are_those_of_the_refinement(refined256, read_back):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing here reads float64 only
        c = Contacts().compute(read_back)
    assert c.n_contacts == refined256.n_contacts == refined256.isostatic_contacts == 479  # baseline: 470
    assert np.array_equal(c.floater, refined256.network.floater)  # 16 floaters; baseline 19
    hi = Contacts().compute(replace(read_back, extended=None))
    assert hi.n_contacts < c.n_contacts  # the float64 positions miss contacts: this case tests something


def test_spectrum_of_the_file_has_d_zero_modes(read_back):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = Spectrum().compute(read_back)
    assert s.n_zero == read_back.dim and s.n_negative == 0  # baseline: 4 zero modes


def test_the_modes_command_counts_the_double_double_network(saved, capsys):
    from jamflow.cli.app import main

    assert main(["modes", str(saved), "--no-figure"]) == 0
    text = capsys.readouterr().out
    assert "N' = 240 (16 floaters)  N_c = 479 (iso 479, excess +0)" in text and "zero modes 2 " in text


def test_moduli_and_pressure_of_the_file_match_the_refinement(refined256, read_back):
    """HessianModuli of the file (eigen-decomposition) against the refinement's sparse-solve route
    on its own network (``contact_moduli``); the pressure from the same pair terms."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h = HessianModuli().compute(read_back)
    m = refined256.moduli()
    assert h.n_contacts == m.n_contacts == 479
    assert abs(h.G / m.G - 1) < 1e-6 and abs(h.B / m.B - 1) < 1e-6  # measured 7e-11; baseline G = -3.5e-13
    pressure = np.trace(h.pressure_tensor) / read_back.dim
    assert abs(pressure / refined256.pressure - 1) < 1e-10  # measured 0; baseline -1.2e-2


def test_a_subset_keeps_the_low_parts(read_back):
    keep = np.arange(0, read_back.n, 2)
    sub = read_back.subset(keep)
    assert sub.precision == "double-double"
    assert np.array_equal(sub.positions_lo, read_back.positions_lo[keep])


def test_moduli_warns_that_its_sweeps_relax_in_float64():
    """The strain sweeps of ``jamflow moduli`` relax float64 positions: the one part left warning."""
    from jamflow.protocols.moduli import Moduli

    r = refine(jamflow.jam(n=32, seed=1, engine="numba").packing, 1e-6)
    with pytest.warns(UserWarning, match="strain sweeps"):
        Moduli().check(r.packing)
