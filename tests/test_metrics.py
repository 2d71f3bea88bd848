"""Metrics against closed-form responses."""

import numpy as np
import pytest

from ctrl_lpv.metrics import rest_metrics, step_metrics

T = np.linspace(0.0, 20.0, 200001)


def test_first_order_response():
    tau = 0.5
    y = 2.0 * (1 - np.exp(-T / tau))
    u = np.exp(-T / tau)
    m = step_metrics(T, y, 2.0, u)
    assert m.rise_time == pytest.approx(tau * np.log(9), rel=1e-6)
    assert m.settling_time == pytest.approx(tau * np.log(50), rel=1e-6)
    assert m.overshoot == 0.0
    assert m.iae == pytest.approx(2.0 * tau, rel=1e-6)
    assert m.ise == pytest.approx(4.0 * tau / 2, rel=1e-6)
    assert m.peak_input == pytest.approx(1.0)
    assert m.energy == pytest.approx(tau / 2, rel=1e-6)
    assert abs(m.steady_state_error) < 1e-12


def test_second_order_overshoot():
    zeta, wn = 0.3, 2.0
    wd = wn * np.sqrt(1 - zeta**2)
    phi = np.arccos(zeta)
    y = 1 - np.exp(-zeta * wn * T) * np.sin(wd * T + phi) / np.sqrt(1 - zeta**2)
    m = step_metrics(T, y, 1.0)
    expected = 100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    assert m.overshoot == pytest.approx(expected, rel=1e-5)
    assert np.isnan(m.peak_input)


def test_downward_step_and_offset():
    y = 1.0 - 0.9 * (1 - np.exp(-T))  # settles at 0.1 instead of 0
    m = step_metrics(T, y, 0.0)
    assert m.steady_state_error == pytest.approx(-0.1, abs=1e-8)
    assert m.settling_time == np.inf  # 10 % off, outside the 2 % band
    assert m.rise_time == np.inf  # 90 % of the way down (0.1) is never reached
    m_half = step_metrics(T, y, 0.5)
    # 10 % at y = 0.95: 0.9 (1 - exp(-t)) = 0.05; 90 % at y = 0.55.
    expected = np.log(1 / (1 - 0.45 / 0.9)) - np.log(1 / (1 - 0.05 / 0.9))
    assert m_half.rise_time == pytest.approx(expected, rel=1e-6)


def test_bad_input():
    with pytest.raises(ValueError, match="no step"):
        step_metrics(T, np.zeros_like(T), 0.0)
    with pytest.raises(ValueError, match="increasing"):
        step_metrics(T[::-1], T, 1.0)
    with pytest.raises(ValueError, match="u:"):
        step_metrics(T, T, 1.0, u=T[:5])


def test_rest_metrics_of_an_analytic_limit_cycle():
    """A sine of amplitude a about the reference over whole periods: error
    peak-to-peak 2a, largest error a; a torque sine of amplitude b: standard
    deviation b / sqrt(2), ripple b. Only the last `window` s count."""
    t = np.linspace(0.0, 3.0, 30001)
    a, b = 2e-4, 30.0
    y = 0.5 + np.where(t >= 2.0, a * np.sin(2 * np.pi * 10 * t), 0.1)
    u = 5.0 + np.where(t >= 2.0, b * np.sin(2 * np.pi * 10 * t), 400.0)
    m = rest_metrics(t, y, 0.5, u)
    assert m.window == 1.0
    assert m.error_peak_to_peak == pytest.approx(2 * a, rel=1e-6)
    assert m.max_error == pytest.approx(a, rel=1e-6)
    assert m.input_std == pytest.approx(b / np.sqrt(2), rel=1e-3)
    assert m.input_ripple == pytest.approx(b, rel=1e-6)
    assert np.isnan(rest_metrics(t, y, 0.5).input_std)


@pytest.mark.parametrize(
    "kwargs, named",
    [({"window": 0.0}, "window"), ({"window": 5.0}, "window"), ({"u": [1.0]}, "u")],
)
def test_rest_metrics_refuses_bad_input(kwargs, named):
    t = np.linspace(0.0, 3.0, 31)
    with pytest.raises(ValueError, match=named):
        rest_metrics(t, np.ones_like(t), 1.0, **kwargs)
