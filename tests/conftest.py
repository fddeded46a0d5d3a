"""Shared fixtures: small random packings in orthogonal and tilted boxes."""

import numpy as np
import pytest

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
