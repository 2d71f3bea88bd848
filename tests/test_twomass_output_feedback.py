"""The two-mass drive on angle encoders: certified output feedback of the
paper's LPV model (tracking formulation), checked on frozen closed loops
built by python-control from the returned controller."""

import control as ct
import numpy as np
import pytest

from ctrl_lpv import twomass


@pytest.mark.parametrize("sensors", ["both", "motor"])
def test_encoder_designs_certify_and_bound_the_frozen_loops(sensors):
    d = twomass.output_feedback_design(sensors=sensors)
    assert d.certificate.verified
    controller = d.controller()
    measured = ["y_e_m", "y_e_l", "y_int_e_l"] if sensors == "both" else ["y_e_m"]
    assert controller.input_labels == [*measured, "p"]
    assert controller.output_labels == ["Tm"]
    sys = d.plant.system
    w = d.plant.names("w")
    z = d.plant.names("z")
    for p in np.linspace(-0.95, 0.0, 7):
        loop = ct.interconnect([sys.at({"p": p}), controller.at({"p": p})],
                               inplist=w, outlist=z)  # fmt: skip
        assert np.linalg.eigvals(loop.A).real.max() < 0
        assert float(ct.linfnorm(loop)[0]) <= d.gamma


def test_bad_sensor_set_is_named():
    with pytest.raises(ValueError, match="sensors"):
        twomass.output_feedback_design(sensors="load")


@pytest.fixture(scope="module")
def both_encoders():
    return twomass.output_feedback_design(sensors="both")


@pytest.mark.parametrize(
    ("theta_m", "theta_l", "p"),
    [(0.31, 0.30, -0.95),  # inside the gap: p = -1, projected onto [-0.95, 0]
     (0.40, 0.30, -0.3)],  # twist 0.1 rad outside the gap: p = -0.03 / 0.1
)  # fmt: skip
def test_encoder_controller_forms_the_measurements_and_schedules(
    both_encoders, theta_m, theta_l, p
):
    """The position-controller form of the design, against the frozen
    controller: y = [theta_m - theta_r, theta_l - theta_r, its integral]
    and p from the measured twist, then Tm = Ck(p) xk + Dk(p) y."""
    from ctrl_lpv.twomass.encoders import encoder_controller

    ctrl = encoder_controller(both_encoders, alpha_estimate=0.03)
    assert ctrl.input_labels == ["theta_m", "omega_m", "theta_l", "omega_l",
                                 "theta_r"]  # fmt: skip
    assert ctrl.output_labels == ["Tm"]
    rng = np.random.default_rng(0)
    x = rng.standard_normal(ctrl.nstates)
    theta_r = 0.5
    u = np.array([theta_m, 7.0, theta_l, -3.0, theta_r])  # speeds unused
    frozen = both_encoders.controller().at({"p": p})
    x_int, xk = x[0], x[1:]  # interconnect orders the states by subsystem
    y = np.array([theta_m - theta_r, theta_l - theta_r, x_int])
    expected = frozen.C @ xk + frozen.D @ y
    np.testing.assert_allclose(ctrl.output(0.0, x, u), expected, rtol=1e-12)
    dx = ctrl.dynamics(0.0, x, u)
    assert dx[0] == pytest.approx(theta_l - theta_r)
    np.testing.assert_allclose(dx[1:], frozen.A @ xk + frozen.B @ y, rtol=1e-12)


def test_encoder_controller_refuses_the_motor_design_and_a_bad_estimate(
    both_encoders,
):
    from ctrl_lpv.twomass.encoders import encoder_controller

    with pytest.raises(ValueError, match="design: .*load encoder"):
        encoder_controller(twomass.output_feedback_design(sensors="motor"))
    with pytest.raises(ValueError, match="alpha_estimate"):
        encoder_controller(both_encoders, alpha_estimate=-0.1)
