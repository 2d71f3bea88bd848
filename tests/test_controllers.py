import math
import warnings

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv import twomass


def stiffness(t):
    return 2.5 + 1.5 * np.sin(2.0 * t)


@pytest.fixture
def measured_plant(mass_spring):
    """The mass_spring vertices with all states measured (C = I)."""
    vertices = [(v.A, v.B, np.eye(2), np.zeros((2, 2))) for v in mass_spring.vertices]
    return lpv.pss(
        vertices, mass_spring.domain, inputs=["w", "u"], outputs=["x", "v"],
        states=["x", "v"], name="plant",
    )  # fmt: skip


def hand_rhs(design, T):
    """Closed loop written by hand: x' = A(k) x + B(k) [w, -K(k) x].

    w is sin(t) interpolated linearly between the samples T, as
    input_output_response interpolates its input.
    """

    def rhs(t, x):
        k = stiffness(t)
        A = np.array([[0.0, 1.0], [-k, -0.5]])
        B = np.array([[0.0, 0.0], [1.0, 1.0]])
        lam = (k - 1.0) / 3.0
        K = (1 - lam) * design.gains[0] + lam * design.gains[-1]
        w = np.interp(t, T, np.sin(T))
        return A @ x + B @ np.array([w, -(K @ x)[0]])

    return rhs


@pytest.mark.parametrize("scheduled", [False, True])
def test_closed_loop_matches_hand_written_solve_ivp(
    mass_spring, measured_plant, scheduled
):
    function = lpv.gain_scheduled_hinf if scheduled else lpv.hinf_state_feedback
    design = function(mass_spring, w="w", u="u", z=["x", "uw"])
    plant = measured_plant.scheduled(lambda t, x, u: stiffness(t))
    ctrl = (
        design.controller(lambda t, x: stiffness(t))
        if scheduled
        else design.controller()
    )
    loop = ct.interconnect(
        [plant, ctrl], inplist=["plant.w"], outlist=["plant.x", "plant.v"],
        inputs=["w"], outputs=["x", "v"],
    )  # fmt: skip
    T = np.linspace(0.0, 2.0, 101)
    x0 = [0.2, -0.1]
    resp = ct.input_output_response(
        loop, T, np.sin(T), x0, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
    )
    ref = solve_ivp(hand_rhs(design, T), (0, 2), x0, t_eval=T, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(resp.outputs, ref.y, atol=1e-7)


def test_scheduling_input_controller(mass_spring):
    design = lpv.gain_scheduled_stabilization(mass_spring, u="u")
    ctrl = design.controller()
    assert ctrl.input_labels == ["x", "v", "k"]
    assert ctrl.output_labels == ["u"]
    x = np.array([0.3, -0.7])
    for k in (1.0, 2.0, 4.0):
        np.testing.assert_allclose(ctrl.output(0, [], [*x, k]), -design.gain(k) @ x)
    # A scheduling value outside [1, 4] saturates.
    np.testing.assert_allclose(ctrl.output(0, [], [*x, 9.0]), -design.gain(4.0) @ x)


def test_reference_inputs(mass_spring):
    design = lpv.quadratic_stabilization(mass_spring, u="u")
    ctrl = design.controller(reference=True)
    assert ctrl.input_labels == ["x", "v", "x_d", "v_d", "u_d"]
    x, xd, ud = np.array([1.0, 2.0]), np.array([0.5, 0.0]), np.array([3.0])
    np.testing.assert_allclose(
        ctrl.output(0, [], np.concatenate([x, xd, ud])), ud - design.gains[0] @ (x - xd)
    )


def test_controller_argument_errors(mass_spring):
    common = lpv.quadratic_stabilization(mass_spring, u="u")
    with pytest.raises(ValueError, match="scheduling"):
        common.controller("inputs")
    scheduled = lpv.gain_scheduled_stabilization(mass_spring, u="u")
    with pytest.raises(ValueError, match="scheduling"):
        scheduled.controller("sometimes")
    with pytest.raises(ValueError, match="states"):
        common.controller(states=["x"])


def test_integral_augmentation(mass_spring):
    aug = lpv.integral_augmentation(mass_spring, "x")
    assert aug.state_labels == ["x", "v", "int_x"]
    for vertex, original in zip(aug.vertices, mass_spring.vertices):
        np.testing.assert_array_equal(vertex.A[:2, :2], original.A)
        np.testing.assert_array_equal(vertex.A[2], [1.0, 0.0, 0.0])
        np.testing.assert_array_equal(vertex.B[2], [0.0, 0.0])
    # Integral of an output with feedthrough picks up D.
    aug_out = lpv.integral_augmentation(mass_spring, "uw", names=["int_u"])
    np.testing.assert_array_equal(aug_out.vertices[0].B[2], [0.0, 0.1])
    with pytest.raises(ValueError, match="signals: unknown signal"):
        lpv.integral_augmentation(mass_spring, "nope")


def test_integral_action_removes_steady_error(mass_spring):
    """With an integrator on x, a constant disturbance leaves no offset."""
    aug = lpv.integral_augmentation(mass_spring, "x")
    design = lpv.quadratic_stabilization(aug, u="u")
    K = design.gains[0]
    for k in (1.0, 4.0):
        A, B, _, _ = aug.at(k).A, aug.at(k).B, None, None
        Acl = A - B[:, [1]] @ K
        # Equilibrium for w = 1: Acl x + B_w = 0.
        x_eq = np.linalg.solve(Acl, -B[:, 0])
        assert abs(x_eq[0]) < 1e-12


# ------------------------------------------ integral action, connected by name


def frozen_plant(measured_plant, k):
    """The plant (not augmented) with the stiffness frozen at k."""
    return measured_plant.scheduled(lambda t, x, u: k)


@pytest.mark.parametrize("scheduled", [False, True])
def test_integral_controller_connects_by_name(measured_plant, scheduled):
    aug = lpv.integral_augmentation(measured_plant, "x")
    assert aug.integral_signals == {"int_x": "x"}
    function = (
        lpv.gain_scheduled_stabilization if scheduled else lpv.quadratic_stabilization
    )
    design = function(aug, u="u")
    ctrl = design.controller()
    assert ctrl.input_labels == ["x", "v"] + (["k"] if scheduled else [])
    assert ctrl.state_labels == ["int_x"] and ctrl.output_labels == ["u"]
    # d int_x/dt = x and u = -K [x, v, int_x], read off the system itself.
    K = design.gain(2.0)
    z = np.array([0.3, -0.2, 0.7])
    u_in = [*z[:2]] + ([2.0] if scheduled else [])
    np.testing.assert_allclose(ctrl.dynamics(0, [z[2]], u_in), [z[0]])
    np.testing.assert_allclose(ctrl.output(0, [z[2]], u_in), -K @ z)


def test_integral_action_zero_steady_error_in_simulation(measured_plant):
    """Constant disturbance w: x -> 0, u -> -w, int_x -> w / K_int."""
    aug = lpv.integral_augmentation(measured_plant, "x")
    design = lpv.gain_scheduled_stabilization(aug, u="u")
    k, w = 2.5, 1.0
    plant = measured_plant.scheduled("inputs")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no unconnected signal
        loop = ct.interconnect(
            [plant, design.controller()], inputs=["w", "k"], outputs=["x", "v", "u"]
        )
    # The frozen closed loop [x, v, int_x] and its slowest mode.
    A = np.array([[0.0, 1.0, 0.0], [-k, -0.5, 0.0], [1.0, 0.0, 0.0]])
    Bu = np.array([[0.0], [1.0], [0.0]])
    K = (1 - (k - 1) / 3) * design.gains[0] + (k - 1) / 3 * design.gains[1]
    rate = -np.linalg.eigvals(A - Bu @ K).real.max()
    assert rate > 0
    T = np.linspace(0.0, 30.0 / rate, 3001)
    resp = lpv.simulate(loop, T, [w, k], 0.0, return_states=True)
    x_end, v_end, u_end = resp.outputs[:, -1]
    assert abs(x_end) < 1e-6 and abs(v_end) < 1e-6
    assert u_end == pytest.approx(-w, abs=1e-6)
    assert resp.states[-1, -1] == pytest.approx(w / K[0, 2], rel=1e-5)
    # Without integral action the same disturbance leaves x = w / (k + K_x).
    common = lpv.gain_scheduled_stabilization(measured_plant, u="u")
    K0 = (1 - (k - 1) / 3) * common.gains[0] + (k - 1) / 3 * common.gains[1]
    loop0 = ct.interconnect(
        [plant, common.controller()], inputs=["w", "k"], outputs=["x", "v", "u"]
    )
    rate0 = -np.linalg.eigvals(A[:2, :2] - Bu[:2] @ K0).real.max()
    T0 = np.linspace(0.0, 30.0 / rate0, 3001)
    resp0 = lpv.simulate(loop0, T0, [w, k], 0.0)
    assert resp0.outputs[0, -1] == pytest.approx(w / (k + K0[0, 0]), rel=1e-5)


def test_integral_with_reference_tracks(measured_plant):
    """u = ud - K (x - xd): the integrator drives x to x_d despite w."""
    aug = lpv.integral_augmentation(measured_plant, "x")
    design = lpv.quadratic_stabilization(aug, u="u")
    ctrl = design.controller(reference=True)
    assert ctrl.input_labels == ["x", "v", "x_d", "v_d", "u_d"]
    loop = ct.interconnect(
        [frozen_plant(measured_plant, 1.5), ctrl],
        inputs=["w", "x_d", "v_d", "u_d"], outputs=["x", "v"],
    )  # fmt: skip
    T = np.linspace(0.0, 200.0, 2001)
    resp = lpv.simulate(loop, T, [2.0, 0.4, 0.0, 0.0], 0.0)
    np.testing.assert_allclose(resp.outputs[:, -1], [0.4, 0.0], atol=1e-6)


def test_integral_of_an_output(measured_plant):
    """An integrated output becomes an input without feedthrough to u."""
    vertices = [
        (A, B, np.vstack([C, [[1.0, 0.0]]]), np.vstack([D, [[0.0, 0.0]]]))
        for A, B, C, D in measured_plant.vertex_data()
    ]
    plant = lpv.pss(
        vertices, measured_plant.domain, inputs=["w", "u"],
        outputs=["x", "v", "pos"], states=["x", "v"], name="plant",
    )  # fmt: skip
    aug = lpv.integral_augmentation(plant, "pos")
    design = lpv.quadratic_stabilization(aug, u="u")
    ctrl = design.controller()
    assert ctrl.input_labels == ["x", "v", "pos"]
    np.testing.assert_array_equal(ctrl._feedthrough, [[True, True, False]])
    np.testing.assert_allclose(ctrl.dynamics(0, [0.0], [0.0, 0.0, 0.25]), [0.25])
    loop = ct.interconnect(
        [plant.scheduled(lambda t, x, u: 3.0), ctrl], inputs=["w"], outputs=["pos"]
    )
    resp = lpv.simulate(loop, np.linspace(0.0, 200.0, 2001), 1.0, 0.0)
    assert abs(resp.outputs[-1]) < 1e-6


def test_states_mapping_and_integrals_argument(measured_plant):
    design = lpv.quadratic_stabilization(measured_plant, u="u")
    ctrl = design.controller(states={"v": "speed"})
    assert ctrl.input_labels == ["x", "speed"]
    with pytest.raises(ValueError, match="states"):
        design.controller(states={"nope": "a"})
    aug = lpv.integral_augmentation(measured_plant, "x")
    design = lpv.quadratic_stabilization(aug, u="u")
    # integrals={}: the integral state is read as an input (the old layout).
    assert design.controller(integrals={}).input_labels == ["x", "v", "int_x"]
    assert design.controller(states=["p", "q"]).input_labels == ["p", "q"]
    with pytest.raises(ValueError, match="states: expected 2 names"):
        design.controller(states=["p", "q", "r"])
    with pytest.raises(ValueError, match="integrals"):
        design.controller(integrals={"int_x": "nope"})
    with pytest.raises(ValueError, match="integrals"):
        design.controller(integrals={"nope": "x"})
    with pytest.raises(TypeError, match="integrals"):
        design.controller(integrals=["int_x"])
    with pytest.raises(ValueError, match="names"):
        lpv.integral_augmentation(measured_plant, "x", names=["v"])


def test_scheduling_callable_may_return_a_mapping(mass_spring):
    design = lpv.gain_scheduled_stabilization(mass_spring, u="u")
    ctrl = design.controller(lambda t, x: {"k": 3.0})
    x = np.array([0.3, -0.7])
    np.testing.assert_allclose(ctrl.output(0, [], x), -design.gain(3.0) @ x)


# ------------------------------------------------ two-mass backlash estimate


VERTEX_GAINS = np.array([[1e4, 150.0, 3e4, 1800.0], [1.2e4, 180.0, 2.9e4, 1800.0]])


@pytest.mark.parametrize("bad", [-1.0, -1e-9, math.nan, math.inf])
def test_negative_or_nonfinite_alpha_estimate_is_refused(bad):
    with pytest.raises(ValueError, match="alpha_estimate"):
        twomass.lpv_controller(VERTEX_GAINS, p_bounds=(-1.0, 0.0), alpha_estimate=bad)


@pytest.mark.parametrize("bad", ["0.03", True, [0.03]])
def test_alpha_estimate_of_the_wrong_type(bad):
    with pytest.raises(TypeError, match="alpha_estimate"):
        twomass.lpv_controller(VERTEX_GAINS, p_bounds=(-1.0, 0.0), alpha_estimate=bad)


def test_alpha_estimate_with_a_common_gain_is_refused():
    with pytest.raises(ValueError, match="alpha_estimate: a common gain"):
        twomass.lpv_controller(twomass.paper_gain(), alpha_estimate=0.03)
    with pytest.raises(ValueError, match="alpha_estimate: a common gain"):
        twomass.lpv_controller(alpha_estimate=0.0)  # the paper's gain


def test_alpha_estimate_values_and_callables():
    # alpha = 0: p = 0 outside a zero gap, the gain at p = 0.
    ctrl = twomass.lpv_controller(VERTEX_GAINS, p_bounds=(-1.0, 0.0), alpha_estimate=0)
    e = np.array([0.1, 0.0, 0.05, 0.0])  # theta_r = 0: errors are the angles
    np.testing.assert_allclose(ctrl.output(0, [], [*e, 0.0]), [-VERTEX_GAINS[1] @ e])
    # A callable returning a negative estimate stops the evaluation.
    bad = twomass.lpv_controller(
        VERTEX_GAINS, p_bounds=(-1.0, 0.0), alpha_estimate=lambda t: 0.03 - t
    )
    bad.output(0.0, [], [*e, 0.0])
    with pytest.raises(
        ValueError, match=r"alpha_estimate: the callable returned -0\.97"
    ):
        bad.output(1.0, [], [*e, 0.0])
    with pytest.raises(ValueError, match="alpha_estimate"):
        twomass.simulate(bad, T=0.2, npoints=21, engine="fast")
