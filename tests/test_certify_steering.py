"""The gallery's steering schedule (examples/plot_7_steering_schedule.py),
against independent facts.

python-control's own closed loop (`create_statefbk_iosystem`, linearized
by `control.linearize` at a dense set of speeds) is stable at every frozen
speed with H-infinity norms under the certified bound; the nonlinear vehicle
with the scheduled controller, simulated by python-control while the speed
swings fast between the ends of the range, returns to the lane.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv

L = 3.0  # wheelbase, m
SPEEDS = [2.0, 5.0, 10.0, 20.0]


def update(t, x, u, params):
    v, phi, w = u
    phi = np.clip(phi, -0.5, 0.5)
    return [np.cos(x[2]) * v, np.sin(x[2]) * v, v / L * np.tan(phi) + w]


VEHICLE = ct.nlsys(update, None, states=["x", "y", "theta"], inputs=["v", "phi", "w"],
                   outputs=["x", "y", "theta"], name="vehicle")  # fmt: skip


def structural(M):
    """Structural zeros of a finite-difference Jacobian (its noise there is
    about 1e-6 * v, e.g. from cos(theta) - 1) set to zero."""
    return np.where(np.abs(M) < 1e-4, 0.0, M)


def linearized(v):
    S = ct.linearize(VEHICLE, [0.0, 0.0, 0.0], [v, 0.0, 0.0])
    return ct.ss(structural(S.A), structural(S.B), S.C, S.D,
                 inputs=VEHICLE.input_labels, outputs=VEHICLE.output_labels,
                 states=VEHICLE.state_labels)  # fmt: skip


def analytic(v):
    """The linearization by hand: y' = v theta, theta' = v phi / l + w."""
    A = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, v], [0.0, 0.0, 0.0]])
    B = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, v / L, 1.0]])
    return A, B


@pytest.fixture(scope="module")
def steering():
    lo, hi = SPEEDS[0], SPEEDS[-1]
    slow, fast = linearized(lo), linearized(hi)
    dA, dB = (fast.A - slow.A) / (hi - lo), (fast.B - slow.B) / (hi - lo)
    base = ct.ss(slow.A - lo * dA, slow.B - lo * dB, slow.C, slow.D,
                 inputs=slow.input_labels, outputs=slow.output_labels,
                 states=slow.state_labels)  # fmt: skip
    plant = lpv.PolytopicStateSpace.from_affine(
        base, {"v": (dA, dB, 0, 0)}, {"v": (lo, hi)}
    )
    gains = [ct.lqr(linearized(v)[:, ["v", "phi"]], np.eye(3),
                    np.diag([1.0, (v / L) ** 2]))[0] for v in SPEEDS]  # fmt: skip
    ctrl, clsys = ct.create_statefbk_iosystem(
        VEHICLE, (gains, SPEEDS), ud_labels=["vd", "phid"],
        control_indices=["v", "phi"], gainsched_indices=["vd"],
        gainsched_method="linear")  # fmt: skip
    verdict = lpv.certify(ctrl, plant, objective=lpv.Hinf(w="w", z="y"))
    return plant, gains, ctrl, clsys, verdict


def test_the_polytopic_plant_is_the_linearization(steering):
    plant = steering[0]
    for v in np.linspace(2.0, 20.0, 19):
        A, B = analytic(v)
        np.testing.assert_allclose(plant.at({"v": v}).A, A, atol=1e-9)
        np.testing.assert_allclose(plant.at({"v": v}).B, B, atol=1e-9)


def test_the_gains_are_scheduled(steering):
    """The yaw-rate weight makes the gains depend on the speed (with a
    constant weight on phi they would not: a nontrivial schedule)."""
    gains = steering[1]
    assert abs(gains[0][1, 1]) > 5 * abs(gains[-1][1, 1])


def test_certified_for_any_acceleration_from_the_controller_object(steering):
    plant, gains, ctrl, _, verdict = steering
    assert verdict.certified and verdict.certificate.verified, str(verdict)
    assert verdict.rate_bound == {"v": np.inf}
    table = lpv.certify((gains, SPEEDS), plant)
    assert table.certified and table.rate_bound == {"v": np.inf}


def test_frozen_loops_of_python_control_are_stable_under_the_bound(steering):
    clsys, verdict = steering[3], steering[4]
    worst = 0.0
    for v in np.linspace(2.01, 19.99, 91):
        loop = clsys.linearize([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, v, 0.0, 0.0],
                               copy_names=True)  # fmt: skip
        assert loop.poles().real.max() < -1e-3, v
        worst = max(worst, float(ct.linfnorm(loop[["y"], ["w"]])[0]))
    assert worst > 0.5  # the channel is not trivial
    assert verdict.bound >= worst


def test_scheduled_nonlinear_loop_converges_under_fast_speed_changes(steering):
    """Speed swinging between 2.1 and 19.9 m/s at up to 8.9 * 3 m/s^2 (the
    certificate allows any rate), starting 0.3 m off the lane."""
    clsys = steering[3]
    T = np.linspace(0.0, 20.0, 2001)
    vd = 11.0 - 8.9 * np.cos(3.0 * T)
    xd = np.vstack([11.0 * T - 8.9 / 3.0 * np.sin(3.0 * T), 0 * T, 0 * T])
    resp = ct.input_output_response(clsys, T, np.vstack([xd, vd, 0 * T, 0 * T]),
                                    [0.0, 0.3, 0.0])  # fmt: skip
    y, theta = resp.outputs[1], resp.outputs[2]
    assert np.abs(resp.outputs[4]).max() < 0.5  # no steering saturation
    assert np.abs(y[-100:]).max() < 1e-3 * 0.3
    assert np.abs(theta[-100:]).max() < 1e-3


@pytest.fixture(scope="module")
def comfort(steering):
    """LQR weighting the lateral acceleration v**2 phi / l: gains ~ 1 / v**2."""
    plant = steering[0]
    gains = [ct.lqr(linearized(v)[:, ["v", "phi"]], np.eye(3),
                    np.diag([1.0, (v**2 / L) ** 2]))[0] for v in SPEEDS]  # fmt: skip
    ctrl, clsys = ct.create_statefbk_iosystem(
        VEHICLE, (gains, SPEEDS), ud_labels=["vd", "phid"],
        control_indices=["v", "phi"], gainsched_indices=["vd"],
        gainsched_method="linear")  # fmt: skip
    verdict = lpv.certify(ctrl, plant, counterexample=False)
    return plant, ctrl, clsys, verdict


def test_comfort_schedule_has_a_finite_certified_acceleration(comfort):
    plant, ctrl, clsys, verdict = comfort
    for v in np.linspace(2.01, 19.99, 91):
        loop = clsys.linearize([0.0, 0.0, 0.0], [0.0, 0.0, 0.0, v, 0.0, 0.0])
        assert loop.poles().real.max() < -1e-3, v
    assert not verdict.certified
    nu = verdict.rate_bound["v"]
    assert 0.0 < nu < np.inf and verdict.certificate.verified, str(verdict)
    given = lpv.certify(ctrl, plant, rate_bounds={"v": 0.9 * nu})
    assert given.certified and given.certificate.verified


def test_comfort_schedule_converges_within_the_certified_acceleration(comfort):
    """The nonlinear loop, speed swinging over the range at 0.9 times the
    certified acceleration."""
    clsys, nu = comfort[2], comfort[3].rate_bound["v"]
    w = 0.9 * nu / 8.9
    T = np.linspace(0.0, 40.0, 4001)
    vd = 11.0 - 8.9 * np.cos(w * T)
    xd = np.vstack([11.0 * T - 8.9 / w * np.sin(w * T), 0 * T, 0 * T])
    resp = ct.input_output_response(clsys, T, np.vstack([xd, vd, 0 * T, 0 * T]),
                                    [0.0, 0.3, 0.0])  # fmt: skip
    assert np.abs(resp.outputs[4]).max() < 0.5
    assert np.abs(resp.outputs[1][-100:]).max() < 1e-3 * 0.3
    assert np.abs(resp.outputs[2][-100:]).max() < 1e-3
