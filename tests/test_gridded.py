"""`GriddedStateSpace` and `gss`, against independent facts.

A system bilinear in two parameters is reproduced exactly by multilinear
interpolation (a fact of the interpolation, checked against the formula);
simulations with the parameters as inputs agree with scipy's integration
of the formula; linearizations of a nonlinear python-control system agree
with its analytic Jacobian; bad grids and systems are refused naming the
argument.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv

M0 = np.array([[-1.0, 0.5], [0.0, -2.0]])
MA = np.array([[-0.5, 0.0], [0.3, 0.1]])
MB = np.array([[0.0, 0.2], [-0.4, -0.3]])
MAB = np.array([[0.1, 0.0], [0.0, -0.2]])


def bilinear(a, b):
    """A system whose A and B are bilinear in (a, b)."""
    A = M0 + a * MA + b * MB + a * b * MAB
    B = np.array([[0.0], [1.0 + 0.2 * a * b]])
    return ct.ss(A, B, np.eye(2), 0, inputs="u", outputs=["y0", "y1"],
                 states=["x0", "x1"])  # fmt: skip


AXES = {"a": [0.0, 0.5, 2.0], "b": [-1.0, 0.0, 1.0, 3.0]}


@pytest.fixture(scope="module")
def G():
    return lpv.gss(bilinear, AXES)


def test_grid_points_and_interpolation_reproduce_a_bilinear_system(G):
    rng = np.random.default_rng(0)
    for p in G.grid.points:
        np.testing.assert_array_equal(G.at(p).A, bilinear(*p).A)
    for a, b in rng.uniform([0.0, -1.0], [2.0, 3.0], size=(20, 2)):
        frozen, true = G.at({"a": a, "b": b}), bilinear(a, b)
        np.testing.assert_allclose(frozen.A, true.A, atol=1e-13)
        np.testing.assert_allclose(frozen.B, true.B, atol=1e-13)


def test_interpolation_is_multilinear_not_exact_for_a_nonlinear_dependence():
    G = lpv.gss(lambda v: ct.ss([[-(v**2)]], [[1.0]], [[1.0]], 0), {"v": [1.0, 3.0]})
    # Between the points the model is the chord, not v**2.
    assert G.at(2.0).A[0, 0] == pytest.approx(-0.5 * (1.0 + 9.0))


def test_a_cell_is_the_polytopic_system_of_its_corners(G):
    cell = G.cell((1, 2))
    assert isinstance(cell, lpv.PolytopicStateSpace)
    assert cell.domain.lower.tolist() == [0.5, 1.0]
    assert cell.domain.upper.tolist() == [2.0, 3.0]
    rng = np.random.default_rng(1)
    for p in rng.uniform([0.5, 1.0], [2.0, 3.0], size=(10, 2)):
        np.testing.assert_allclose(cell.at(p).A, G.at(p).A, atol=1e-13)
    with pytest.raises(ValueError, match="index"):
        G.cell((2, 0))


def test_signal_names_and_frozen_matrices_follow_the_polytopic_conventions(G):
    assert G.input_labels == ["u"] and G.output_labels == ["y0", "y1"]
    assert G.param_names == ("a", "b")
    with pytest.warns(lpv.NominalPointWarning):
        A = G.A
    np.testing.assert_allclose(A, bilinear(1.0, 1.0).A, atol=1e-13)
    scheduled = G.scheduled("inputs")
    assert scheduled.input_labels == ["u", "a", "b"]


def test_simulation_with_the_parameters_as_inputs_matches_the_formula(G):
    sys = G.scheduled("inputs")
    T = np.linspace(0.0, 6.0, 601)

    def a(t):
        return 1.0 + np.sin(t)

    def b(t):
        return 1.0 + 1.5 * np.cos(0.7 * t)

    def u(t):
        return np.sin(2 * t)

    tight = {"rtol": 1e-10, "atol": 1e-12}
    U = [u(T), a(T), b(T)]
    resp = ct.input_output_response(sys, T, U, X0=[1.0, -0.5], solve_ivp_kwargs=tight)

    def rhs(t, x):
        # python-control interpolates the inputs linearly between samples.
        ut, at, bt = (np.interp(t, T, s) for s in U)
        true = bilinear(at, bt)
        return true.A @ x + true.B[:, 0] * ut

    ref = solve_ivp(rhs, (0.0, 6.0), [1.0, -0.5], t_eval=T, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(resp.outputs, ref.y, atol=1e-6)


def test_frozen_simulation_with_params_is_the_frozen_system(G):
    T = np.linspace(0.0, 3.0, 301)
    U = np.ones_like(T)
    p = {"a": 0.7, "b": 2.2}
    tight = {"rtol": 1e-10, "atol": 1e-12}
    resp = ct.input_output_response(
        G, T, U, X0=[0.0, 0.0], params=p, solve_ivp_kwargs=tight
    )
    ref = ct.forced_response(bilinear(0.7, 2.2), T, U)
    np.testing.assert_allclose(resp.outputs, ref.outputs, atol=1e-6)


def test_linearizations_of_a_nonlinear_system_at_trim_points():
    g, b = 9.81, 0.5

    def f(t, x, u, params):
        return [x[1], -g * np.sin(x[0]) - b * x[1] + u[0]]

    pendulum = ct.nlsys(f, None, inputs="u", states=["theta", "omega"],
                        outputs=["theta", "omega"])  # fmt: skip

    def linearization(theta0):
        return ct.linearize(pendulum, [theta0, 0.0], [g * np.sin(theta0)],
                            copy_names=True)  # fmt: skip

    G = lpv.gss(linearization, {"theta0": [0.0, 0.4, 0.8, 1.2]})
    for theta0 in G.grid.axes[0]:
        A = G.at(theta0).A
        np.testing.assert_allclose(A, [[0.0, 1.0], [-g * np.cos(theta0), -b]],
                                   atol=1e-5)  # fmt: skip
    assert G.state_labels == ["theta", "omega"] and G.input_labels == ["u"]


def test_systems_as_a_nested_sequence_flat_sequence_or_mapping_agree(G):
    nested = [[bilinear(a, b) for b in AXES["b"]] for a in AXES["a"]]
    flat = [bilinear(a, b) for a in AXES["a"] for b in AXES["b"]]
    mapping = {(a, b): bilinear(a, b) for a in AXES["a"] for b in AXES["b"]}
    for systems in (nested, flat, mapping):
        other = lpv.GriddedStateSpace(systems, AXES)
        np.testing.assert_array_equal(other.at([1.3, 0.4]).A, G.at([1.3, 0.4]).A)


@pytest.mark.parametrize(
    "axes, match",
    [
        ({"a": [0.0, 1.0, 1.0]}, r"grid\['a'\]: values must be strictly increasing"),
        ({"a": [0.0, 2.0, 1.0]}, r"grid\['a'\]: values must be strictly increasing"),
        ({"a": [1.0]}, r"grid\['a'\]: expected at least two"),
        ({"a": [[0.0, 1.0]]}, r"grid\['a'\]: expected a 1-D"),
        ({}, "grid: expected a non-empty mapping"),
    ],
)
def test_bad_grids_are_refused_naming_the_axis(axes, match):
    with pytest.raises(ValueError, match=match):
        lpv.gss(lambda a: ct.ss(-1.0, 1.0, 1.0, 0), axes)


def test_mismatched_shapes_and_signal_names_are_refused():
    sys = ct.ss(-1.0, 1.0, 1.0, 0)
    with pytest.raises(ValueError, match=r"systems: expected 3 entries"):
        lpv.GriddedStateSpace([sys, sys], {"a": [0.0, 1.0, 2.0]})
    with pytest.raises(ValueError, match=r"systems\[1\]: expected"):
        lpv.GriddedStateSpace([[sys, sys], [sys]], {"a": [0.0, 1.0], "b": [0, 1]})
    with pytest.raises(ValueError, match=r"systems at \{'a': 1\}: dimensions"):
        two = ct.ss(-np.eye(2), np.ones((2, 1)), np.ones((1, 2)), 0)
        lpv.GriddedStateSpace([sys, two], {"a": [0, 1]})
    renamed = ct.ss(-1.0, 1.0, 1.0, 0, inputs="v")
    with pytest.raises(ValueError, match=r"system at \{'a': 1\} has inputs \['v'\]"):
        lpv.GriddedStateSpace([sys, renamed], {"a": [0, 1]})
    with pytest.raises(ValueError, match=r"systems: no system at the grid points"):
        lpv.GriddedStateSpace({0.0: sys}, {"a": [0, 1]})
    with pytest.raises(TypeError, match="grid"):
        lpv.GriddedStateSpace([sys, sys], [0, 1])


def test_a_function_failing_at_a_grid_point_is_reported_with_the_point():
    def f(a):
        if a > 0.5:
            raise ValueError("no trim")
        return ct.ss(-1.0, 1.0, 1.0, 0)

    with pytest.raises(ValueError, match=r"systems: the function failed at \{'a': 1"):
        lpv.gss(f, {"a": [0.0, 1.0]})


def test_block_diagram_operations_are_refused(G):
    with pytest.raises(TypeError, match="gridded"):
        G * 2.0
    with pytest.raises(TypeError, match="gridded"):
        G.feedback(1)
