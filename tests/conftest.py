"""Shared fixtures: small random packings in orthogonal and tilted boxes; eigen-solvers that
return the other sign of every eigenvector (``flipped_eigen_solvers``, and the whole run with
JAMFLOW_FLIP_EIGENVECTORS=1); a jammed packing file (``packing_file``, one per test module) and
the helpers of tests that run the command line as a user does (``run_jam``, ``no_traceback``,
``JAMFLOW``)."""

import os
import sys

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse.linalg

from jamflow.cli.app import main
from jamflow.model.box import Box
from jamflow.model.packing import Packing
from jamflow.model.potentials import Spring


def random_config(n, dim, phi, seed, diameters=None, tilt=0.0, potential=None):
    """N particles at random positions in a (possibly tilted) box at packing fraction phi."""
    rng = np.random.default_rng(seed)
    d = np.asarray(diameters if diameters is not None else 1.0 + 0.4 * rng.random(n), float)
    vol = (np.pi * d**2 / 4).sum() if dim == 2 else (np.pi * d**3 / 6).sum()
    length = (vol / phi) ** (1 / dim)
    h = np.eye(dim) * length
    h[0, 1] = tilt * length
    box = Box(h)
    pos = box.to_cartesian(rng.random((n, dim)))
    return Packing(pos, d, box, potential or Spring())


@pytest.fixture
def config():
    return random_config


def tilted(packing, tilt: float):
    """The packing in the box with xy tilt = tilt * ly, positions moved affinely."""
    h = packing.box.h.copy()
    h[0, 1] = tilt * h[1, 1]
    return packing.with_positions(Box(h).to_cartesian(packing.box.to_fractional(packing.positions)), box=Box(h))


def rel(a, b) -> float:
    """Largest absolute difference over the largest |b|."""
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


# --- the command line, run as a user runs it ------------------------------------------------
JAMFLOW = [sys.executable, "-m", "jamflow.cli"]


def no_traceback(err: str) -> bool:
    return "Traceback" not in err and len(err.strip().splitlines()) >= 1


@pytest.fixture(scope="module")
def packing_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("packing") / "p.h5"
    assert main(["jam", "--n", "32", "--seed", "3", "--out", str(out), "--quiet"]) == 0
    return out


def run_jam(tmp_path, capsys, *args):
    code = main(["jam", "--quiet", *args])
    return code, capsys.readouterr().err


# --- eigen-solvers of another machine ----------------------------------------------------------
TIED = 1e-8  # eigenvalues this close (relative to the largest |eigenvalue|) count as tied


def _other_machine(values, vectors, permute: bool):
    """Every eigenvector negated; with ``permute`` the pairs of each run of tied eigenvalues reversed."""
    vectors = -vectors
    if permute and len(values) > 1:
        order, start = np.arange(len(values)), 0
        scale = max(float(np.abs(values).max()), np.finfo(float).tiny)
        for k in range(1, len(values) + 1):
            if k == len(values) or abs(values[k] - values[k - 1]) > TIED * scale:
                order[start:k] = order[start:k][::-1]
                start = k
        values, vectors = values[order], vectors[:, order]
    return values, vectors


def flipped_eigen_solvers(patch, permute: bool = True) -> None:
    """Make numpy's and scipy's ``eigh`` and scipy's ``eigsh`` return every eigenvector with the
    other sign (and, with ``permute``, tied eigenpairs in reverse order), as a LAPACK or ARPACK
    of another machine may. ``patch(module, name, value)`` sets an attribute (monkeypatch.setattr)."""
    np_eigh, sp_eigh, eigsh = np.linalg.eigh, scipy.linalg.eigh, scipy.sparse.linalg.eigsh

    def numpy_eigh(a, *args, **kwargs):
        out = np_eigh(a, *args, **kwargs)
        return type(out)(*_other_machine(*out, permute))

    def scipy_eigh(a, *args, **kwargs):
        out = sp_eigh(a, *args, **kwargs)
        return _other_machine(*out, permute) if isinstance(out, tuple) else out

    def sparse_eigsh(a, *args, **kwargs):
        out = eigsh(a, *args, **kwargs)
        return _other_machine(*out, permute) if isinstance(out, tuple) else out

    patch(np.linalg, "eigh", numpy_eigh)
    patch(scipy.linalg, "eigh", scipy_eigh)
    patch(scipy.sparse.linalg, "eigsh", sparse_eigsh)


@pytest.fixture
def flipped_eigenvectors(monkeypatch):
    """For the test: eigen-solvers that return the other sign and the other order of tied pairs."""
    flipped_eigen_solvers(monkeypatch.setattr)


def pytest_configure(config):
    """JAMFLOW_FLIP_EIGENVECTORS=1: the whole run (this process; not the subprocesses it starts)
    with every eigenvector of the other sign, results must not change."""
    if os.environ.get("JAMFLOW_FLIP_EIGENVECTORS") == "1":
        flipped_eigen_solvers(setattr, permute=False)
