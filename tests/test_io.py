import h5py
import numpy as np
import pytest

from jamflow.engines.lammps.data_file import write_lammps_data
from jamflow.engines.lammps.engine import LammpsEngine
from jamflow.mechanics.reference import energy_forces_pressure
from jamflow.io.packing_file import load_packing, read_attrs, save_packing, to_universe
from jamflow.model.potentials import Spring


def test_hdf5_round_trip_is_exact(config, tmp_path):
    p = config(30, 3, 0.4, seed=1, tilt=0.2, potential=Spring(2.5))
    path = save_packing(tmp_path / "p.h5", p, energy_per_particle=1.5e-16, pressure_tensor=np.eye(3) * 2,
                        history={"phi": [0.1, 0.2]}, protocol={"phi0": 0.8})
    q = load_packing(path)
    assert np.array_equal(q.positions, p.positions)  # in the cell: stored as the packing holds them
    assert np.array_equal(q.diameters, p.diameters) and np.array_equal(q.box.h, p.box.h)
    assert q.potential == p.potential
    attrs = read_attrs(path)
    assert attrs["schema"] == "jamflow.packing" and attrs["pressure"] == 2.0 and attrs["dim"] == 3
    with h5py.File(path) as f:
        assert f["protocol"].attrs["phi0"] == 0.8 and list(f["history/phi"][...]) == [0.1, 0.2]


def test_interrupted_write_leaves_no_file(config, tmp_path, monkeypatch):
    p = config(10, 2, 0.3, seed=1)
    target = tmp_path / "p.h5"

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr("jamflow.io.packing_file._attr", boom)
    with pytest.raises(KeyboardInterrupt):
        save_packing(target, p, protocol={"x": 1})
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_is_reported(config, tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        save_packing(tmp_path / "missing" / "p.h5", config(10, 2, 0.3, seed=1))


def test_lammps_data_file_reproduces_the_energy(config, tmp_path):
    d = np.where(np.arange(60) % 2 == 0, 1.0, 1.4)
    p = config(60, 2, 0.85, seed=2, diameters=d, tilt=0.1)
    path = write_lammps_data(tmp_path / "p.data", p)
    with LammpsEngine(p) as eng:
        eng.run_commands(["delete_atoms group all", f"read_data {path} add merge"])
        e = eng.evaluate().energy
    assert e == pytest.approx(energy_forces_pressure(p).energy, rel=1e-12)


def test_mdanalysis_universe(config):
    p = config(20, 2, 0.3, seed=3, tilt=0.2)
    u = to_universe(p)
    assert len(u.atoms) == 20
    assert np.allclose(u.atoms.radii, p.diameters / 2)
    assert u.dimensions[0] == pytest.approx(np.linalg.norm(p.box.h[:, 0]), rel=1e-6)


def test_written_files_get_the_usual_permissions(config, tmp_path):
    import os

    path = save_packing(tmp_path / "p.h5", config(10, 2, 0.3, seed=1))
    mask = os.umask(0)
    os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask
