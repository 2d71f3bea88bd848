"""Closed loops of the exact two-mass plant: the paper's figures and ours."""

import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.twomass.feedback import lpv_controller
from ctrl_lpv.twomass.scenarios import alpha_step, metrics, simulate

P = twomass.Parameters()


def final_load_angle(response):
    return response.outputs[response.output_labels.index("theta_l")][-1]


def hand_equilibrium(K, alpha, Td=8.0, theta_r=0.5):
    """Steady state under u = -K e without integral action.

    At rest the load needs Ts = Td, so the motor torque is Td and the shaft
    is in contact with theta_d = alpha + Td / ks; the controller then gives
    Td = -(K1 (e_l + theta_d) + K3 e_l).
    """
    K1, K3 = K[0, 0], K[0, 2]
    theta_d = alpha + Td / P.ks
    e_l = -(Td + K1 * theta_d) / (K1 + K3)
    return theta_r + e_l


@pytest.fixture(scope="module")
def tracking_design():
    sys = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    return lpv.hinf_state_feedback(sys, w="Td", u="Tm", z=sys.output_labels)


@pytest.mark.parametrize("method", ["LSODA", "RK45"])
def test_published_gain_reproduces_paper_figures(method):
    response = simulate(lpv_controller(), alpha=0.03, method=method)
    theta_l = final_load_angle(response)
    assert theta_l == pytest.approx(0.4899, abs=1e-3)
    assert theta_l == pytest.approx(
        hand_equilibrium(twomass.paper_gain(), 0.03), abs=1e-5
    )
    m = metrics(response)
    assert m.peak_input == pytest.approx(21.2e3, rel=0.01)
    assert m.rise_time == pytest.approx(0.053, abs=0.003)


def test_published_gain_alpha_step_equilibrium():
    response = simulate(lpv_controller(), alpha=alpha_step())
    assert final_load_angle(response) == pytest.approx(
        hand_equilibrium(twomass.paper_gain(), 0.045), abs=1e-5
    )


def test_tracking_design_with_integral_action(tracking_design):
    response = simulate(lpv_controller(tracking_design), alpha=alpha_step())
    error = final_load_angle(response) - 0.5
    assert abs(error) < 1e-3
    assert metrics(response).peak_input < 21.2e3


def test_scheduled_design_with_alpha_estimate(tracking_design):
    sys = tracking_design.system
    design = lpv.gain_scheduled_hinf(sys, w="Td", u="Tm", z=sys.output_labels)
    response = simulate(lpv_controller(design, alpha_estimate=0.03), alpha=alpha_step())
    assert abs(final_load_angle(response) - 0.5) < 1e-3


def test_controller_argument_errors(tracking_design):
    with pytest.raises(ValueError, match="design"):
        lpv_controller(np.ones((1, 3)))
    with pytest.raises(ValueError, match="alpha_estimate"):
        lpv_controller(tracking_design, alpha_estimate=0.03)
    with pytest.raises(ValueError, match="torque_limit"):
        lpv_controller(torque_limit=-1.0)
