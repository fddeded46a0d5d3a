"""The compression step rules on a closed-form energy landscape V = A (phi - phi_J)^alpha.

P follows from the virial relation P = phi^2 dV/dphi / v (v the mean particle volume),
which is what the Newton jumps invert.
"""


import pytest

from jamflow.protocols.settings import CompressionSettings, chapter_protocol, fast_protocol
from jamflow.protocols.compression import PhiStepper

PHI_J, A, VBAR = 0.8412345678, 0.3, 1.16


def landscape(phi, alpha):
    delta = max(0.0, phi - PHI_J)
    v = A * delta**alpha
    pressure = phi**2 * alpha * A * delta ** (alpha - 1) / VBAR if delta > 0 else 0.0
    return v, pressure


def drive(settings, alpha, phi0=0.80, max_steps=2000):
    stepper, phi = PhiStepper(settings, alpha, VBAR), phi0
    for step in range(max_steps):
        v, p = landscape(phi, alpha)
        if settings.v_tol < v < 2 * settings.v_tol:
            return phi, step + 1
        phi = stepper.next_phi(phi, v, p, unjammed=v <= settings.v_tol)
    raise AssertionError("did not reach the window")


@pytest.mark.parametrize("alpha", [2.0, 2.5])
def test_seed_rule_and_fast_rule_reach_the_same_window(alpha):
    phi_seed, steps_seed = drive(chapter_protocol(), alpha)
    phi_fast, steps_fast = drive(fast_protocol(), alpha)
    for phi in (phi_seed, phi_fast):
        assert 1e-16 < landscape(phi, alpha)[0] < 2e-16
    assert steps_fast < steps_seed / 5  # the point of the shortcut: far fewer minimisations
    # the window pins phi to phi_J + (V/A)^(1/alpha) within its width
    assert abs(phi_fast - phi_seed) < (2e-16 / A) ** (1 / alpha)


def test_seed_rule_halves_on_every_crossing():
    stepper = PhiStepper(chapter_protocol(dphi0=1e-3), 2.0, VBAR)
    assert stepper.next_phi(0.84, 0.0, 0.0, unjammed=True) == pytest.approx(0.841)
    assert stepper.next_phi(0.841, 1e-9, 1e-5) == pytest.approx(0.841 - 5e-4)
    assert stepper.next_phi(0.8405, 1e-9, 1e-5) == pytest.approx(0.8405 - 5e-4)  # same side: no halving
    assert stepper.next_phi(0.840, 0.0, 0.0, unjammed=True) == pytest.approx(0.840 + 2.5e-4)


def test_newton_jump_stays_above_jamming_until_close():
    stepper = PhiStepper(fast_protocol(), 2.0, VBAR)
    phi = PHI_J + 1e-3
    v, p = landscape(phi, 2.0)
    stepper.side, stepper.crossed = "below", True  # pretend we came from below
    target = stepper.next_phi(phi, v, p)
    assert target - PHI_J == pytest.approx(1e-3 / 10, rel=1e-9)  # shrinks phi - phi_J tenfold, exactly here
    assert not stepper.final_approach


def test_resolution_failure_is_reported():
    from jamflow.protocols.outcome import JammingFailed

    stepper = PhiStepper(chapter_protocol(dphi0=1e-17), 2.0, VBAR)
    with pytest.raises(JammingFailed, match="float64 resolution"):
        stepper.next_phi(0.8, 0.0, 0.0, unjammed=True)


@pytest.mark.parametrize("kwargs", [dict(dphi_growth=0.5), dict(newton_ratio=1.0), dict(coarse_v_min=1e-16),
                                    dict(dphi_max=-1.0), dict(large_n_newton_ratio=0.5), dict(large_n=1),
                                    dict(large_n=2048.5)])
def test_bad_shortcut_settings_rejected(kwargs):
    with pytest.raises(ValueError):
        CompressionSettings(**kwargs)


def test_loose_tolerance_never_comes_from_a_zero_pressure():
    """approach_force_rtol x P is 0 for a state below jamming (P = 0): the loose tolerance
    falls back to coarse_force_tol instead of an invalid 0."""
    stepper = PhiStepper(fast_protocol(), 2.0, VBAR)
    stepper.crossed, stepper.pressure, stepper.final_approach = True, 0.0, False
    assert stepper.minimizer().force_tol == stepper.s.coarse_force_tol
    stepper.pressure = 1e-6
    assert stepper.minimizer().force_tol == pytest.approx(1e-11)


def test_newton_jumps_are_shorter_from_large_n_on():
    """A jump from the same jammed state (V = 1e-10, so the predicted phi - phi_J is far above the
    window) shrinks phi - phi_J by newton_ratio = 10 below large_n particles, by 3 from large_n on."""
    settings = fast_protocol()
    assert (settings.jump_ratio(1024), settings.jump_ratio(2048), settings.jump_ratio(16384)) == (10.0, 3.0, 3.0)
    targets = {}
    for n in (1024, 4096):
        stepper = PhiStepper(settings, 2.0, VBAR, n)
        stepper.side, stepper.crossed = "above", True
        phi, v = 0.85, 1e-10
        pressure = 2.0 * v * phi**2 / (1e-4 * VBAR)  # the virial pressure of phi - phi_J = 1e-4
        targets[n] = stepper.next_phi(phi, v, pressure)
    assert 0.85 - targets[1024] == pytest.approx(1e-4 * (1 - 1 / 10))
    assert 0.85 - targets[4096] == pytest.approx(1e-4 * (1 - 1 / 3))
