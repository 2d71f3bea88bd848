import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv


def msd_matrices(k):
    """Hand-written matrices of the mass_spring fixture at stiffness k."""
    A = np.array([[0.0, 1.0], [-k, -0.5]])
    B = np.array([[0.0, 0.0], [1.0, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 0.0]])
    D = np.array([[0.0, 0.0], [0.0, 0.1]])
    return A, B, C, D


def test_is_a_statespace_with_names(mass_spring):
    assert isinstance(mass_spring, ct.StateSpace)
    assert isinstance(mass_spring, ct.NonlinearIOSystem)
    assert mass_spring.input_labels == ["w", "u"]
    assert mass_spring.output_labels == ["x", "uw"]
    assert mass_spring.state_labels == ["x", "v"]
    assert mass_spring.nvertices == 2
    assert all(isinstance(v, ct.StateSpace) for v in mass_spring.vertices)
    assert mass_spring.vertices[0].input_labels == ["w", "u"]


def test_from_affine_vertices_match_hand_derivation(mass_spring):
    for vertex, k in zip(mass_spring.vertices, (1.0, 4.0)):
        for got, expected in zip(
            (vertex.A, vertex.B, vertex.C, vertex.D), msd_matrices(k)
        ):
            np.testing.assert_array_equal(got, expected)


def test_at_and_nominal(mass_spring):
    for k in (1.0, 1.7, 4.0):
        np.testing.assert_allclose(mass_spring.at(k).A, msd_matrices(k)[0])
    # python-control's linear view is the nominal point, the domain center,
    # and says so.
    with pytest.warns(lpv.NominalPointWarning):
        np.testing.assert_allclose(mass_spring.A, msd_matrices(2.5)[0])
    with pytest.warns(lpv.NominalPointWarning):
        poles = mass_spring.poles()
    np.testing.assert_allclose(
        np.sort(poles), np.sort(np.linalg.eigvals(msd_matrices(2.5)[0]))
    )
    with pytest.warns(lpv.NominalPointWarning):
        assert np.allclose(ct.ss(mass_spring).A, mass_spring.at(2.5).A)


def test_weights(mass_spring):
    np.testing.assert_allclose(mass_spring.weights(1.75), [0.75, 0.25])
    with pytest.raises(ValueError, match="outside"):
        mass_spring.weights(5.0)


def test_dynamics_follow_params_inputs_and_callable(mass_spring):
    x = np.array([0.3, -1.2])
    u = np.array([0.5, 2.0])
    A, B, C, D = msd_matrices(3.0)
    np.testing.assert_allclose(
        mass_spring.dynamics(0.0, x, u, params={"k": 3.0}), A @ x + B @ u
    )
    np.testing.assert_allclose(
        mass_spring.output(0.0, x, u, params={"k": 3.0}), C @ x + D @ u
    )
    by_input = mass_spring.scheduled("inputs")
    assert by_input.input_labels == ["w", "u", "k"]
    np.testing.assert_allclose(by_input.dynamics(0.0, x, [*u, 3.0]), A @ x + B @ u)
    np.testing.assert_allclose(by_input._rhs(0.0, x, [*u, 3.0]), A @ x + B @ u)
    by_callable = mass_spring.scheduled(lambda t, x, u: 1.0 + t)
    A2, B2, C2, D2 = msd_matrices(3.0)
    np.testing.assert_allclose(by_callable.dynamics(2.0, x, u), A2 @ x + B2 @ u)
    np.testing.assert_allclose(by_callable.output(2.0, x, u), C2 @ x + D2 @ u)
    # A scheduling value outside the domain saturates at the boundary.
    with pytest.warns(lpv.ParameterClipWarning):
        np.testing.assert_allclose(
            by_callable.dynamics(10.0, x, u), msd_matrices(4.0)[0] @ x + B @ u
        )


def test_tuple_vertices_and_default_simplex():
    sys = lpv.pss([([[-1.0]], [[1.0]], [[1.0]], 0), ([[-2.0]], [[1.0]], [[1.0]], 0)])
    assert sys.param_names == ("delta[0]", "delta[1]")
    np.testing.assert_allclose(sys.at([0.25, 0.75]).A, [[-1.75]])


@pytest.mark.parametrize(
    "vertices, error, match",
    [
        ([], ValueError, "at least one"),
        ("abc", TypeError, "sequence"),
        ([([[1.0, 0.0]], [[1.0]], [[1.0]], 0)], ValueError, "square"),
        ([([[np.nan]], [[1.0]], [[1.0]], 0)], ValueError, "finite"),
        (
            [([[1.0]], [[1.0]], [[1.0]], 0), ([[1.0]], [[1.0, 2.0]], [[1.0]], 0)],
            ValueError,
            r"vertices\[1\]",
        ),
        (
            [ct.ss([[0.5]], [[1.0]], [[1.0]], 0, dt=0.1), ct.ss([[1.0]], [[1.0]], [[1.0]], 0)],
            ValueError,
            "dt",
        ),
        ([object()], TypeError, r"vertices\[0\]"),
    ],
)
def test_bad_vertices(vertices, error, match):
    with pytest.raises(error, match=match):
        lpv.pss(vertices)


def test_bad_domain_and_scheduling():
    v = ([[-1.0]], [[1.0]], [[1.0]], 0)
    with pytest.raises(ValueError, match="domain"):
        lpv.pss([v, v, v], {"p": (0.0, 1.0)})
    with pytest.raises(ValueError, match="scheduling"):
        lpv.pss([v, v], {"p": (0.0, 1.0)}, scheduling="sometimes")
    with pytest.raises(ValueError, match="nominal"):
        lpv.pss([v, v], {"p": (0.0, 1.0)}, nominal=2.0)


STATIC_GAIN = ct.ss(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), [[0.0, 2.0]])


def assert_same_system(got, expected):
    for a, b in zip(
        (got.A, got.B, got.C, got.D), (expected.A, expected.B, expected.C, expected.D)
    ):
        np.testing.assert_allclose(a, b, atol=1e-12)


@pytest.mark.parametrize(
    "operation",
    [
        lambda s: -s,
        lambda s: 2.0 * s,
        lambda s: s * np.diag([1.0, 3.0]),
        lambda s: s + ct.ss([[-3.0]], [[1.0, 0.0]], [[1.0], [2.0]], 0),
        lambda s: s - 1.0,
        lambda s: ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0]], 0) * s,
        lambda s: s[0, 1],
        lambda s: s.append(ct.ss([[-5.0]], [[1.0]], [[1.0]], 0)),
        lambda s: s[:, 1].feedback(STATIC_GAIN),
    ],
)
def test_operations_stay_polytopic(mass_spring, operation):
    result = operation(mass_spring)
    assert isinstance(result, lpv.PolytopicStateSpace)
    for k in (1.0, 2.2, 3.9):
        assert_same_system(result.at(k), operation(mass_spring.at(k)))


def test_nonaffine_product_is_refused():
    # B and C both vary with p: the series product has a p^2 term.
    v1 = ([[-1.0]], [[1.0]], [[1.0]], 0)
    v2 = ([[-1.0]], [[2.0]], [[3.0]], 0)
    sys = lpv.pss([v1, v2], {"p": (0.0, 1.0)})
    with pytest.raises(TypeError, match="not affine"):
        sys * sys
    other = lpv.pss([v1, v2], {"q": (0.0, 1.0)})
    with pytest.raises(TypeError, match="different parameter domains"):
        sys + other


@pytest.mark.parametrize("method", ["minreal", "returnScipySignalLTI"])
def test_frozen_conversions_raise(mass_spring, method):
    with pytest.raises(TypeError, match="sys.at"):
        getattr(mass_spring, method)()


def k_of_t(t):
    return 2.5 + 1.5 * np.sin(3.0 * t)


def test_interconnect_keeps_scheduled_dynamics(mass_spring):
    """control.interconnect of StateSpace blocks gives a LinearICSystem, but
    input_output_response still integrates the blocks' own scheduled RHS."""
    plant = mass_spring.scheduled(lambda t, x, u: k_of_t(t))
    gain = ct.ss([], [], [], [[-2.0]], inputs="x", outputs="u", name="K")
    loop = ct.interconnect(
        [plant, gain], inplist=["w"], outlist=["x"], inputs="w", outputs="x",
        check_unused=False,
    )  # fmt: skip
    assert isinstance(loop, ct.LinearICSystem)
    T = np.linspace(0.0, 6.0, 301)
    resp = ct.input_output_response(
        loop, T, np.ones_like(T), [0.1, 0.0],
        solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-12},
    )  # fmt: skip

    def rhs(t, x):
        A, B, _, _ = msd_matrices(k_of_t(t))
        return A @ x + B @ [1.0, -2.0 * x[0]]

    ref = solve_ivp(rhs, (0, 6), [0.1, 0.0], t_eval=T, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(resp.outputs, ref.y[0], atol=1e-7)


def test_params_schedule_simulation(mass_spring):
    T = np.linspace(0.0, 3.0, 61)
    resp = ct.input_output_response(
        mass_spring, T, [np.zeros_like(T), np.zeros_like(T)], [1.0, 0.0],
        params={"k": 4.0}, solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12},
    )  # fmt: skip
    frozen = ct.initial_response(mass_spring.at(4.0), T, [1.0, 0.0])
    np.testing.assert_allclose(resp.outputs[0], frozen.outputs[0], atol=1e-7)


def test_str_and_repr(mass_spring):
    text = str(mass_spring)
    assert "2 vertices" in text and "Nominal p" in text
    assert "PolytopicStateSpace" in repr(mass_spring)
