"""The cascade P/PI reference, held to independent facts.

Its gains against the documented rule computed by hand; its law against a
linear recurrence written here from the formulas of the docs; its linear
loop (the contact model sampled by `control.c2d`, the delay, the
differencing filter) stable with the rule's gains and unstable with a
position loop at a quarter of the motor-side speed crossover (why the
rule uses the whole drive's); and the paper scenario on the exact plant.
"""

import control as ct
import numpy as np
import pytest

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.cascade import cascade_design
from ctrl_lpv.twomass.servo_compare import run_sampled_servo_scenario, servo_metrics

DT = 1e-3


@pytest.fixture(scope="module")
def servo():
    return twomass.servo_design(dt=DT, delay=1, sensors="encoders", certify=False)


@pytest.fixture(scope="module")
def cascade(servo):
    return cascade_design(servo)


def test_gains_follow_the_documented_rule(cascade):
    # T_sigma = 1.5 ms (delay and hold) + 0.5 ms (differencing) + 1 ms
    # (filter); Kv = Jm / (2 T_sigma) = 0.4 / 6e-3; the whole drive (6 kg m^2)
    # crosses over at Kv / 6 = 11.1 rad/s; Ti = 4 / 11.1; Kp = 11.1 / 4.
    assert cascade.small_time == pytest.approx(3e-3)
    assert cascade.speed_gain == pytest.approx(200.0 / 3.0)
    assert cascade.integral_time == pytest.approx(4.0 / (200.0 / 18.0))
    assert cascade.position_gain == pytest.approx(200.0 / 18.0 / 4.0)
    assert cascade.dt == DT and cascade.delay == 1


def _linear_loop(kp, kv, ti, tf, params):
    """Contact model (ZOH), one sample of delay, the differencing filter and
    the P/PI law, as one discrete-time matrix (state: plant, held command,
    previous motor angle, filtered speed, speed-error integral)."""
    Jm, Jl, cm, cl, ks, cs = (params.Jm, params.Jl, params.cm, params.cl,
                              params.ks, params.cs)  # fmt: skip
    A = np.array([
        [0, 1, 0, 0],
        [-ks / Jm, -(cm + cs) / Jm, ks / Jm, cs / Jm],
        [0, 0, 0, 1],
        [ks / Jl, cs / Jl, -ks / Jl, -(cl + cs) / Jl],
    ])  # fmt: skip
    B = np.array([[0.0], [1.0 / Jm], [0.0], [0.0]])
    plant = ct.c2d(ct.ss(A, B, np.eye(4), 0), DT)
    n, g = 8, DT / (tf + DT)
    speed = np.zeros(n)
    speed[[0, 5, 6]] = [g / DT, -g / DT, 1.0 - g]
    error = -speed
    error[2] -= kp
    integral = np.zeros(n)
    integral[7] = 1.0
    integral += DT * error
    M = np.zeros((n, n))
    M[:4, :4], M[:4, 4] = plant.A, plant.B[:, 0]
    held = np.zeros(n)
    held[7] = 1.0
    M[4] = kv * (error + held / ti)  # the integral up to the last sample
    M[5, 0] = 1.0
    M[6], M[7] = speed, integral
    return M


def test_law_is_the_documented_p_pi(cascade):
    """At a target of 0 (no move, no feedforward) the controller's torque is
    the linear recurrence of the docs, for arbitrary encoder readings."""
    rng = np.random.default_rng(3)
    ctrl = cascade.controller()
    M = _linear_loop(cascade.position_gain, cascade.speed_gain,
                     cascade.integral_time, cascade.filter_time,
                     cascade.params)  # fmt: skip
    x = np.zeros(ctrl.nstates)
    z = np.zeros(8)  # the recurrence's controller part: rows 5-7
    for _ in range(50):
        y = rng.normal(scale=1e-3, size=2)
        z[[0, 2]] = y
        u = ctrl._out(0.0, x, [y[0], y[1], 0.0])[0]
        assert u == pytest.approx(M[4] @ z, rel=1e-9, abs=1e-12)
        x = ctrl._rhs(0.0, x, [y[0], y[1], 0.0])
        z[5:8] = M[5:8] @ z
        np.testing.assert_allclose(x[6:9], z[5:8], rtol=1e-9, atol=1e-12)


def test_linear_loop_is_stable_and_the_motor_side_position_gain_is_not(cascade):
    p = cascade.params
    args = (cascade.speed_gain, cascade.integral_time, cascade.filter_time, p)
    tuned = np.abs(np.linalg.eigvals(_linear_loop(cascade.position_gain, *args)))
    assert tuned.max() < 1.0
    # The usual quarter of the speed loop's crossover, 1 / (a T_sigma) / 4:
    # the load's antiresonance (24 rad/s, shaft damping only) goes unstable.
    motor_side = 1.0 / (2.0 * cascade.small_time) / 4.0
    assert motor_side > 10 * cascade.position_gain
    fast = np.abs(np.linalg.eigvals(_linear_loop(motor_side, *args)))
    assert fast.max() > 1.0


def test_paper_scenario_sampled_on_encoders(servo, cascade):
    """The reproduce row: the cascade settles the paper scenario (slowly)
    within the limit; the servo, same trajectory and feedforward, is more
    than ten times faster. The error is computed here from the plant."""
    r = run_sampled_servo_scenario(cascade, alpha=twomass.alpha_step(), Td=8.0)
    theta_l = r.outputs[r.output_labels.index("theta_l")]
    assert abs(theta_l[-1] - 0.5) < 2e-4
    assert np.abs(r.outputs[r.output_labels.index("Tm")]).max() <= 500.0 + 1e-9
    m = servo_metrics(r)
    fast = servo_metrics(run_sampled_servo_scenario(servo, alpha=twomass.alpha_step()))
    assert np.isfinite(m.settling) and m.settling > 10 * fast.settling


def test_same_simulation_as_sampled_response(cascade):
    """The scenario runner is `sampled_response` with the design's delay and
    encoders (no second simulation)."""
    r = run_sampled_servo_scenario(cascade, alpha=0.03, Td=8.0, T=0.3, seed=4)
    sensors = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}
    direct = sampled_response(
        twomass.plant(alpha=0.03), cascade.controller(), 0.3,
        inputs={"Td": 8.0, "theta_r": 0.5}, delay=1, sensors=sensors, seed=4,
    )  # fmt: skip
    np.testing.assert_array_equal(
        r.outputs[r.output_labels.index("theta_l")], direct.plant.outputs[2]
    )


@pytest.mark.parametrize(
    "kwargs, error, name",
    [
        ({"position_ratio": -1.0}, ValueError, "position_ratio"),
        ({"filter_time": -1e-3}, ValueError, "filter_time"),
        ({"symmetry": 1.0}, ValueError, "symmetry"),
    ],
)
def test_settings_are_checked(servo, kwargs, error, name):
    with pytest.raises(error, match=name):
        cascade_design(servo, **kwargs)


def test_servo_argument_is_checked():
    with pytest.raises(TypeError, match="servo"):
        cascade_design("servo")
    continuous = twomass.servo_design(certify=False)
    with pytest.raises(ValueError, match="servo"):
        cascade_design(continuous)
