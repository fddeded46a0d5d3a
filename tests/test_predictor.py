"""The secant predictor between jammed states (issue 17 item 2, jamflow/protocols/predictor.py)."""

import numpy as np
import pytest

from jamflow.packing import random_packing
from jamflow.protocols.compression import CompressionSettings, fast_protocol, jam
from jamflow.protocols.predictor import SecantPredictor, contact_ids, network_change
from jamflow.sizes import parse_sizes


def _path(phi, base, shift):
    """A packing whose base-box positions move linearly with phi (closed form)."""
    scale = (base.phi / phi) ** 0.5
    return base.with_positions(base.box.scaled(scale).wrap((base.positions + shift * (phi - base.phi)) * scale),
                               box=base.box.scaled(scale))


def test_secant_is_exact_on_a_linear_path():
    base = random_packing(20, 2, parse_sizes("mono"), 0.05, seed=1)  # dilute: no contacts anywhere
    shift = np.random.default_rng(2).normal(size=base.positions.shape)
    pred = SecantPredictor(base.box, base.phi, 2)
    for phi in (0.0501, 0.0502):
        pred.record(phi, _path(phi, base, shift), jammed=True)
    kind, x = pred.predict(0.05025, base)
    expected = _path(0.05025, base, shift).positions
    assert kind == "secant"
    assert np.abs(base.box.minimum_image(x - expected)).max() < 1e-12


def test_falls_back_to_affine_without_two_jammed_states_or_when_contacts_change():
    packing = random_packing(32, 2, parse_sizes("bi:1.4:0.5"), 0.9, seed=0)  # overlapping: many contacts
    pred = SecantPredictor(packing.box, packing.phi, 2)
    pred.record(0.9, packing, jammed=True)
    assert pred.predict(0.91, packing)[1] is None  # one state only
    dilated = packing.with_positions(packing.positions * 1.0, box=packing.box.scaled(1.2))
    pred.record(0.9 / 1.44, dilated, jammed=True)
    kind, x = pred.predict(0.89, packing)
    assert x is None and "contact network changed" in kind
    pred.record(0.85, packing, jammed=False)  # an unjammed state forgets the path
    assert pred.states == []


def test_network_change_counts_the_symmetric_difference():
    assert network_change(np.array([1, 2, 3, 4]), np.array([1, 2, 3, 5])) == 0.5
    assert network_change(np.array([], int), np.array([], int)) == 0.0
    packing = random_packing(16, 2, parse_sizes("mono"), 0.9, seed=3)
    ids = contact_ids(packing)
    assert len(ids) > 0 and np.all(np.diff(ids) > 0)


def test_secant_jams_to_the_same_phi_j_with_fewer_iterations():
    """N = 32, seed 1: the secant starts 4 minimisations and reaches the affine run's phi_J
    (measured: 7349 -> 6197 iterations; docs/speed-2.md has the ensembles)."""
    affine = jam(n=32, seed=1, settings=fast_protocol())
    secant = jam(n=32, seed=1, settings=fast_protocol(predictor="secant"))
    assert secant.history["predicted"].sum() >= 2
    assert secant.phi_j == pytest.approx(affine.phi_j, abs=1e-9)
    assert secant.iterations < affine.iterations
    assert "predicted" not in affine.history  # the default writes the same history as before


def test_bad_predictor_is_refused_before_work():
    with pytest.raises(ValueError, match="predictor must be one of affine, secant"):
        CompressionSettings(predictor="newton")
    with pytest.raises(ValueError, match="use predictor affine"):
        jam(n=16, seed=0, settings=fast_protocol(predictor="secant"), walls="y")
