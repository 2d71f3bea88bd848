import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv


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
