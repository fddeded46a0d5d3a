"""Python that feels native: dir() shows the public API and the layers' modules,
reprs are one short informative line, ``result.save(path)`` writes the file ``jamflow jam`` writes
and refuses a packing that fails its checks, and ``jam()`` has the command's defaults."""

import inspect
from dataclasses import fields, replace
from pathlib import Path

import h5py
import numpy as np
import pytest

import jamflow
from jamflow.analysis.modes import DensityOfStates, Spectrum, Stability
from jamflow.cli.app import main
from jamflow.mechanics.checks import check_packing
from jamflow.mechanics.contacts import Contacts
from jamflow.mechanics.dynamical_matrix import DynamicalMatrix
from jamflow.protocols.compression import initial_packing
from jamflow.protocols.outcome import JammingFailed
from jamflow.protocols.spec import JamSpec, run_jam

ELLIPSES = Path(__file__).parent / "data" / "ellipse1.5_n16_s0.h5"


@pytest.fixture(scope="module")
def result():
    return jamflow.jam(n=32, seed=1)


def test_dir_lists_the_public_api_and_the_layers():
    names = dir(jamflow)
    assert set(jamflow.__all__) <= set(names) and "save_result" in names and "__version__" in names
    assert {"model", "mechanics", "protocols", "analysis", "io", "plots", "cli"} <= set(names)
    assert not {"import_module", "_moved", "_EXPORTS", "hooks", "_save_result"} & set(names)
    assert {"modes", "structure", "order"} <= set(dir(jamflow.analysis))
    assert {"checks", "contacts", "dynamical_matrix"} <= set(dir(jamflow.mechanics))
    assert {"packing_file", "save_packing", "load_packing"} <= set(dir(jamflow.io))
    assert "_lazy_submodules" not in dir(jamflow.model) and "packing" in dir(jamflow.model)
    assert jamflow.analysis.modes.Spectrum is Spectrum  # a listed module imports on first use
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        _ = jamflow.analysis.nothing


def _one_short_line(obj, *expected):
    text = repr(obj)
    assert "\n" not in text and len(text) < 200, text
    for part in expected:
        assert part in text, (part, text)
    return text


def test_reprs_are_one_short_informative_line(result):
    p = result.packing
    checks = check_packing(p, result.energy_per_particle, None, 1e-16)
    contacts = Contacts().compute(p)
    spectrum = Spectrum().compute(p)
    stability = Stability().compute(p, spectrum)
    _one_short_line(result, "JamResult(N=32", "dim=2", f"phi_j={result.phi_j:.10f}",
                    f"V={result.energy_per_particle:.3e}", f"P={result.pressure:.3e}",
                    f"minimizations={result.minimizations}", f"engine={result.engine!r}")
    _one_short_line(p, "Packing(N=32", "dim=2", "shape='disk'", f"phi={p.phi:.6f}", "potential='spring'")
    _one_short_line(p.box, "Box(h=[[", "periodic=(True, True)")
    assert eval(repr(p.box), {"Box": jamflow.Box}).is_same_lattice(p.box, 0.0)
    _one_short_line(checks, "PackingChecks(passed=True", f"N_c={checks.n_contacts}",
                    f"isostatic={checks.isostatic_count}", f"floaters={checks.n_floaters}")
    _one_short_line(contacts, "ContactsResult(N=32", f"kept={contacts.n_kept}", f"N_c={contacts.n_contacts}",
                    f"excess={contacts.excess_contacts:+d}")
    n_dof = 2 * contacts.n_kept
    _one_short_line(DynamicalMatrix().compute(p), f"shape=({n_dof}, {n_dof})", f"kept={contacts.n_kept}", "N=32")
    _one_short_line(spectrum, f"modes={n_dof}", "n_zero=2", "n_negative=0", f"eigenvectors=({n_dof}, {n_dof})")
    _one_short_line(spectrum.without_vectors(), "eigenvectors=None")
    _one_short_line(stability, "label='mechanically stable'", "n_zero=2", "behaviour='quadratic'")
    _one_short_line(stability.profiles[0], "behaviour='quadratic'")
    _one_short_line(DensityOfStates(bins=30).compute([spectrum]), "bins=30", "n_packings=1", f"n_modes={n_dof - 2}")


def test_jam_spec_repr_shows_the_options_that_differ_from_the_defaults():
    assert repr(JamSpec()) == "JamSpec()"
    spec = JamSpec(n=128, shape="ellipse:1.6", sizes="mono", seed=2, pressure=1e-3)
    assert repr(spec) == "JamSpec(n=128, sizes='mono', shape='ellipse:1.6', seed=2, pressure=0.001)"
    assert eval(repr(spec), {"JamSpec": JamSpec}) == spec


def test_reprs_of_shapes_and_walls():
    ellipses = jamflow.load_packing(ELLIPSES)
    _one_short_line(ellipses, "Packing(N=16", "shape='ellipse:1.5'")
    _one_short_line(Spectrum().compute(ellipses), "modes=48", "n_zero=6")
    walled = initial_packing(20, 2, "bi:1.4:0.5", "spring", 1, 0.5, "disk", "y")  # walls show when there are any
    _one_short_line(walled, "walls='y'")


def test_repr_leaves_fields_and_equality_alone(result):
    names = [f.name for f in fields(type(result))]
    assert names[:3] == ["packing", "phi_j", "energy_per_particle"] and "history" in names
    spectrum = Spectrum().compute(result.packing)
    assert [f.name for f in fields(spectrum)][:6] == ["eigenvalues", "eigenvectors", "dynamical", "e_min", "mass",
                                                     "complete"]
    kept = spectrum.without_vectors()
    assert kept.eigenvectors is None and np.array_equal(kept.translational_fraction, spectrum.translational_fraction)
    assert not {f.name for f in fields(kept) if f.compare} - {"eigenvalues", "eigenvectors", "dynamical", "e_min",
                                                             "mass", "complete"}


def _contents(path):
    out = {}
    with h5py.File(path) as f:
        out["/"] = {k: v for k, v in f.attrs.items() if k != "created"}

        def visit(name, obj):
            out[name] = dict(obj.attrs)
            if isinstance(obj, h5py.Dataset):
                out[name + "[]"] = obj[()]
        f.visititems(visit)
    return out


def _same(a, b):
    assert sorted(a) == sorted(b)
    for key in a:
        if isinstance(a[key], dict):
            assert sorted(a[key]) == sorted(b[key]), key
            for name in a[key]:
                x, y = a[key][name], b[key][name]
                assert np.array_equal(x, y) or (np.all(np.isnan(x)) and np.all(np.isnan(y))), (key, name, x, y)
        else:
            assert np.array_equal(a[key], b[key]), key


def test_result_save_writes_the_file_the_command_writes(tmp_path):
    res = jamflow.jam(n=16, seed=3)
    assert res.save(tmp_path / "api.h5") == tmp_path / "api.h5"
    assert main(["jam", "--n", "16", "--seed", "3", "--quiet", "--out", str(tmp_path / "cli.h5")]) == 0
    _same(_contents(tmp_path / "api.h5"), _contents(tmp_path / "cli.h5"))
    with h5py.File(tmp_path / "api.h5") as f:
        assert f["checks"].attrs["passed"] and f["protocol"].attrs["engine"] == res.engine
    spec_result, checks = run_jam(JamSpec(n=16, seed=3))
    jamflow.save_result(spec_result, tmp_path / "spec.h5", checks)  # the checks run_jam made
    _same(_contents(tmp_path / "spec.h5"), _contents(tmp_path / "cli.h5"))
    (tmp_path / "link.h5").symlink_to(tmp_path / "api.h5")
    with pytest.raises(ValueError, match="symbolic link"):
        res.save(tmp_path / "link.h5")
    res.save(tmp_path / "link.h5", force=True)
    assert not (tmp_path / "link.h5").is_symlink()


def test_result_save_at_constant_pressure_writes_the_file_the_command_writes(tmp_path):
    res, _ = run_jam(JamSpec(n=16, seed=2, pressure=1e-4))
    assert "PressureResult(N=16" in repr(res) and len(repr(res)) < 200
    res.save(tmp_path / "api.h5")
    assert main(["jam", "--n", "16", "--seed", "2", "--pressure", "1e-4", "--quiet",
                 "--out", str(tmp_path / "cli.h5")]) == 0
    _same(_contents(tmp_path / "api.h5"), _contents(tmp_path / "cli.h5"))


def test_result_save_refuses_a_packing_that_fails_its_checks(result, tmp_path):
    unjammed = replace(result, packing=initial_packing(32, 2, "bi:1.4:0.5", "spring", 1, 0.8))
    with pytest.raises(JammingFailed, match="failed its checks.*Nothing was written"):
        unjammed.save(tmp_path / "bad.h5")
    failed = check_packing(unjammed.packing, None, None, 1e-16)
    assert not failed.passed
    with pytest.raises(JammingFailed, match="failed its checks"):
        result.save(tmp_path / "bad.h5", checks=failed)
    assert list(tmp_path.iterdir()) == []


def test_jam_has_the_command_defaults():
    defaults = {k: v.default for k, v in inspect.signature(jamflow.jam).parameters.items()}
    spec = JamSpec()
    for name in ("n", "dim", "sizes", "potential", "seed", "shape", "contact", "engine", "wall_type", "gravity"):
        assert defaults[name] == getattr(spec, name), name
    assert defaults["n"] == 64
