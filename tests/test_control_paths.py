"""python-control's functions on a PolytopicStateSpace.

Time responses with ``params`` give the frozen response at ``params``;
linear tools that read the nominal matrices warn once per call with
`NominalPointWarning`; scheduled values outside the domain warn with
`ParameterClipWarning`. Expected values come from hand-written matrices,
closed-form responses and scipy's ODE solver, not from the class.
"""

import warnings

import control as ct
import matplotlib
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import NominalPointWarning, ParameterClipWarning

matplotlib.use("Agg")

T = np.linspace(0.0, 10.0, 401)


def msd(k):
    """The README plant at stiffness k, written by hand (x'' + 0.5 x' + k x)."""
    A = np.array([[0.0, 1.0], [-k, -0.5]])
    B = np.array([[0.0, 0.0], [1.0, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 0.0]])
    D = np.array([[0.0, 0.0], [0.0, 0.1]])
    return A, B, C, D


def step_x(k, t):
    """Closed-form position for a unit force step from rest."""
    zw = 0.25  # zeta * omega_n = 0.5 / 2
    wd = np.sqrt(k - zw**2)
    return (1.0 - np.exp(-zw * t) * (np.cos(wd * t) + zw / wd * np.sin(wd * t))) / k


def free_x(k, t, x0=1.0):
    """Closed-form position released from x0 at rest."""
    zw = 0.25
    wd = np.sqrt(k - zw**2)
    return x0 * np.exp(-zw * t) * (np.cos(wd * t) + zw / wd * np.sin(wd * t))


def count(record, category=NominalPointWarning):
    return sum(issubclass(w.category, category) for w in record)


@pytest.fixture
def single_input():
    """x'' + 0.5 x' + k x = u, k in [1, 4], output x (SISO)."""
    base = ([[0.0, 1.0], [0.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    term = ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)
    return lpv.PolytopicStateSpace.from_affine(
        base, {"k": term}, {"k": (1.0, 4.0)}, name="msd1"
    )


# ----------------------------------------------------------------------
# Time responses with params
# ----------------------------------------------------------------------
def test_step_response_with_params_is_the_frozen_response(mass_spring):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        got = ct.step_response(mass_spring, T, params={"k": 4.0})
    x_from_u = got.outputs[0, 1]
    np.testing.assert_allclose(x_from_u, step_x(4.0, T), atol=1e-9)
    # The nominal point (k = 2.5) is far from it: the check can fail.
    assert np.abs(step_x(2.5, T) - step_x(4.0, T)).max() > 0.1
    # Same as python-control on an independently built frozen system.
    frozen = ct.ss(*msd(4.0), inputs=["w", "u"], outputs=["x", "uw"])
    np.testing.assert_allclose(
        got.outputs, ct.step_response(frozen, T).outputs, atol=1e-12
    )


def test_forced_and_initial_response_with_params(mass_spring):
    U = np.vstack([np.sin(T), np.cos(2 * T)])
    got = ct.forced_response(mass_spring, T, U, [0.2, 0.0], params={"k": 4.0})
    A, B, C, D = msd(4.0)

    def rhs(t, x):
        # forced_response holds U linear between samples: the same here.
        return A @ x + B @ np.array([np.interp(t, T, row) for row in U])

    ref = solve_ivp(
        rhs, (0, T[-1]), [0.2, 0.0], t_eval=T, rtol=1e-10, atol=1e-12, max_step=0.025
    )
    np.testing.assert_allclose(got.states, ref.y, atol=1e-7)
    nominal = ct.forced_response(mass_spring.at({"k": 2.5}), T, U, [0.2, 0.0])
    assert np.abs(nominal.states - ref.y).max() > 0.1

    free = ct.initial_response(mass_spring, T, [1.0, 0.0], params={"k": 4.0})
    np.testing.assert_allclose(free.outputs[0], free_x(4.0, T), atol=1e-9)


def test_step_info_and_default_time_vector_use_params(single_input):
    info = ct.step_info(single_input, T, params={"k": 4.0})
    # Final value 1/k and overshoot exp(-pi zeta / sqrt(1 - zeta^2)).
    zeta = 0.25 / 2.0
    overshoot = 100 * np.exp(-np.pi * zeta / np.sqrt(1 - zeta**2))
    assert info["Overshoot"] == pytest.approx(overshoot, rel=2e-3)
    assert info["SteadyStateValue"] == pytest.approx(1 / 4.0, rel=1e-2)
    # No T: python-control picks the time vector from the poles, which are
    # those at params too (no nominal read, so no warning).
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        resp = ct.step_response(single_input, params={"k": 4.0})
    np.testing.assert_allclose(resp.outputs, step_x(4.0, resp.time), atol=1e-9)


def test_input_output_response_with_params(single_input):
    got = ct.input_output_response(
        single_input, T, np.ones_like(T), [0.0, 0.0], params={"k": 4.0},
        solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12},
    )  # fmt: skip
    np.testing.assert_allclose(got.outputs, step_x(4.0, T), atol=1e-7)


def test_params_errors_name_params(single_input):
    with pytest.raises(ValueError, match="params.*outside"):
        ct.step_response(single_input, T, params={"k": 5.0})
    with pytest.raises(ValueError, match="params: none of"):
        ct.step_response(single_input, T, params={"kk": 4.0})
    with pytest.raises(TypeError, match=r"params\['k'\]"):
        ct.forced_response(single_input, T, 1.0, params={"k": "4"})
    with pytest.raises(ValueError, match="params.*outside"):
        ct.input_output_response(single_input, T, 1.0, params={"k": 0.0})
    with pytest.raises(ValueError, match="params: none of"):
        ct.input_output_response(single_input, T, 1.0, params={"K": 4.0})
    with pytest.raises(ValueError, match="params.*outside"):
        ct.linearize(single_input, [0, 0], 0, params={"k": 9.0})
    # impulse_response (python-control 0.10) takes no params: refused.
    with pytest.raises(TypeError, match="params"):
        ct.impulse_response(single_input, T, params={"k": 4.0})


def test_params_on_a_scheduled_system_is_refused(single_input):
    by_inputs = single_input.scheduled("inputs")
    with pytest.raises(ValueError, match="params.*scheduled by its inputs"):
        ct.step_response(by_inputs, T, params={"k": 4.0})
    by_callable = single_input.scheduled(lambda t, x, u: [4.0])
    with pytest.raises(ValueError, match="params.*scheduled by a callable"):
        ct.forced_response(by_callable, T, 1.0, params={"k": 4.0})


def test_partial_params_warn_for_the_missing_ones():
    base = ([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]], [[1.0, 1.0]], 0)
    terms = {
        "a": ([[-1.0, 0.0], [0.0, 0.0]], 0, 0, 0),
        "b": ([[0.0, 0.0], [0.0, -1.0]], 0, 0, 0),
    }
    sys = lpv.PolytopicStateSpace.from_affine(
        base, terms, {"a": (0.0, 2.0), "b": (0.0, 4.0)}
    )
    with pytest.warns(NominalPointWarning, match=r"\['b'\] not given"):
        got = ct.step_response(sys, T, params={"a": 2.0})
    # a = 2 and the nominal b = 2 (box center): poles -3 and -4.
    expected = (1 - np.exp(-3 * T)) / 3 + (1 - np.exp(-4 * T)) / 4
    np.testing.assert_allclose(got.outputs, expected, atol=1e-9)


def test_time_responses_without_params_warn_once(mass_spring):
    for call in (
        lambda: ct.step_response(mass_spring, T),  # two inputs, two runs
        lambda: ct.initial_response(mass_spring, T, [1.0, 0.0]),
        lambda: ct.impulse_response(mass_spring, T),
        lambda: ct.forced_response(mass_spring, T, 0.0, [1.0, 0.0]),
    ):
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            resp = call()
        assert count(record) == 1
        assert "'k': 2.5" in str(record[0].message)
    # ... and the nominal response is the one at the domain's center.
    np.testing.assert_allclose(resp.outputs[0], free_x(2.5, T), atol=1e-9)


# ----------------------------------------------------------------------
# Linear tools: nominal point, one warning per call
# ----------------------------------------------------------------------
A_NOM = msd(2.5)[0]


def _linear_calls(sys):
    K = np.array([[1.0, 2.0]])
    return {
        "tf": lambda: ct.tf(sys),
        "ss": lambda: ct.ss(sys),
        "frequency_response": lambda: ct.frequency_response(sys, [0.1, 1.0]),
        "bode_plot": lambda: ct.bode_plot(sys, [0.1, 1.0]),
        "nichols_plot": lambda: ct.nichols_plot(sys, [0.1, 1.0]),
        "pole_zero_plot": lambda: ct.pole_zero_plot(sys),
        "nyquist_response": lambda: ct.nyquist_response(sys),
        "sys(s)": lambda: sys(1j),
        "evalfr": lambda: ct.evalfr(sys, 1j),
        "poles": lambda: ct.poles(sys),
        "sys.poles": lambda: sys.poles(),
        "zeros": lambda: ct.zeros(sys),
        "dcgain": lambda: ct.dcgain(sys),
        "damp": lambda: ct.damp(sys, doprint=False),
        "stability_margins": lambda: ct.stability_margins(sys),
        "bandwidth": lambda: ct.bandwidth(sys),
        "linfnorm": lambda: ct.linfnorm(sys),
        "system_norm": lambda: ct.system_norm(sys, p=2),
        "lqr": lambda: ct.lqr(sys, np.eye(2), np.eye(1)),
        "place": lambda: ct.place(sys.A, sys.B, [-1.0, -2.0]),
        "ctrb": lambda: ct.ctrb(sys.A, sys.B),
        "linearize": lambda: ct.linearize(sys, [0.0, 0.0], 0.0),
        "feedback(G, sys)": lambda: ct.ss(-1, 1, 1, 0).feedback(sys * 1.0),
        "gram": lambda: ct.gram(sys, "c"),
        "similarity_transform": lambda: ct.similarity_transform(sys, np.eye(2)),
        "state feedback A-BK": lambda: sys.A - sys.B @ K,
        "nyquist_plot": lambda: ct.nyquist_plot(sys),
        "singular_values_response": lambda: ct.singular_values_response(sys),
        "margin": lambda: ct.margin(sys),
        "pole_zero_map": lambda: ct.pole_zero_map(sys),
        "root_locus_map": lambda: ct.root_locus_map(sys, [0.0, 1.0]),
        "ss2tf": lambda: ct.ss2tf(sys),
        "StateSpace(sys)": lambda: ct.StateSpace(sys),
        "nlsys": lambda: ct.nlsys(sys).dynamics(0.0, [1.0, 0.0], [0.0]),
        "canonical_form": lambda: ct.canonical_form(sys),
        "modal_form": lambda: ct.modal_form(sys),
        "balred": lambda: ct.balred(sys, 2),
        "hsvd": lambda: ct.hsvd(sys),
        "modred": lambda: ct.modred(sys, [1]),
        "obsv": lambda: ct.obsv(sys.A, sys.C),
        "acker": lambda: ct.acker(sys.A, sys.B, [-1.0, -2.0]),
        "lqe": lambda: ct.lqe(sys, np.eye(1), np.eye(1)),
        "lqr integral_action": lambda: ct.lqr(
            sys, np.eye(3), np.eye(1), integral_action=np.array([[1.0, 0.0]])
        ),
        "augw": lambda: ct.augw(sys, ct.tf(1, [1, 1])),
        "create_estimator_iosystem": lambda: ct.create_estimator_iosystem(
            sys, np.eye(1), np.eye(1)
        ),
    }


@pytest.mark.parametrize("name", sorted(_linear_calls(None)))
def test_linear_tools_warn_once_naming_the_nominal_point(single_input, name):
    call = _linear_calls(single_input)[name]
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        call()
    matplotlib.pyplot.close("all")
    assert count(record) == 1, [str(w.message) for w in record]
    message = str(next(w for w in record if w.category is NominalPointWarning).message)
    assert "'k': 2.5" in message and "center" in message
    # The warning points at this file (the user's line), not python-control.
    warned = next(w for w in record if w.category is NominalPointWarning)
    assert warned.filename == __file__


def test_linear_tools_see_the_nominal_matrices(single_input):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NominalPointWarning)
        poles = ct.poles(single_input)
        dc = ct.dcgain(single_input)
        K, _, _ = ct.lqr(single_input, np.eye(2), np.eye(1))
    np.testing.assert_allclose(np.sort(poles), np.sort(np.linalg.eigvals(A_NOM)))
    assert dc == pytest.approx(1 / 2.5)
    ref_K, _, _ = ct.lqr(A_NOM, [[0.0], [1.0]], np.eye(2), np.eye(1))
    np.testing.assert_allclose(K, ref_K)


def test_nominal_given_by_the_user_is_named(single_input):
    sys = lpv.PolytopicStateSpace(
        single_input.vertices, single_input.domain, nominal={"k": 1.5}
    )
    with pytest.warns(NominalPointWarning, match=r"'k': 1\.5.*nominal="):
        poles = ct.poles(sys)
    np.testing.assert_allclose(np.sort(poles), np.sort(np.linalg.eigvals(msd(1.5)[0])))


def test_warning_is_filterable_and_frozen_systems_do_not_warn(single_input):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", category=NominalPointWarning)
        ct.frequency_response(single_input, [0.1, 1.0])
    assert count(record) == 0
    frozen = single_input.at({"k": 3.0})
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        ct.frequency_response(frozen, [0.1, 1.0])
        ct.lqr(frozen, np.eye(2), np.eye(1))
        str(single_input)  # prints the nominal matrices and says so
        single_input._repr_html_()
    assert issubclass(NominalPointWarning, UserWarning)
    assert issubclass(ParameterClipWarning, UserWarning)


def test_two_calls_warn_twice(single_input):
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        for _ in range(3):
            ct.poles(single_input)
    assert count(record) == 3


def test_linearize_with_params_is_the_frozen_system(single_input):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        lin = ct.linearize(single_input, [0.3, -0.1], 0.5, params={"k": 4.0})
    np.testing.assert_allclose(lin.A, msd(4.0)[0], atol=1e-5)
    # Scheduled by a callable of the state: the Jacobian of A(p(x)) x.
    quasi = single_input.scheduled(lambda t, x, u: {"k": 1.0 + x[0]})
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        lin = ct.linearize(quasi, [1.0, 0.0], 0.0)
    # xdot2 = -(1 + x1) x1 - 0.5 x2 + u: d/dx1 = -(1 + 2 x1) = -3 at x1 = 1.
    np.testing.assert_allclose(lin.A, [[0.0, 1.0], [-3.0, -0.5]], atol=1e-5)


def test_library_code_does_not_warn(mass_spring):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        design = lpv.quadratic_stabilization(mass_spring, u="u")
        design.controller()
        lpv.frozen_sweep(mass_spring, design.gains, "u")
        lpv.simulate(mass_spring, T, [np.ones_like(T), 0 * T], params={"k": 3.0})
        lpv.simulate(mass_spring, T, 0.0, [1.0, 0.0], engine="fast")
        mass_spring.scheduled("inputs") * 2.0


# ----------------------------------------------------------------------
# Scheduling callables, clipping, vertex order
# ----------------------------------------------------------------------
def test_scheduling_callable_may_return_a_dict(mass_spring):
    sys = mass_spring.scheduled(lambda t, x, u: {"k": 1.0 + t})
    x, u = np.array([0.3, -1.2]), np.array([0.5, 2.0])
    A, B, _, _ = msd(3.0)
    np.testing.assert_allclose(sys.dynamics(2.0, x, u), A @ x + B @ u)
    with pytest.raises(ValueError, match="scheduling: the callable returned keys"):
        mass_spring.scheduled(lambda t, x, u: {"kk": 2.0}).dynamics(0.0, x, u)
    with pytest.raises(ValueError, match="scheduling: the callable returned 2"):
        mass_spring.scheduled(lambda t, x, u: [2.0, 3.0]).dynamics(0.0, x, u)


def test_dict_callable_in_a_simulation(single_input):
    sys = single_input.scheduled(lambda t, x, u: {"k": 4.0})
    got = ct.input_output_response(
        sys, T, np.ones_like(T), [0.0, 0.0],
        solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12},
    )  # fmt: skip
    np.testing.assert_allclose(got.outputs, step_x(4.0, T), atol=1e-7)


def test_clipping_warns_once_per_simulation_naming_the_value(single_input):
    sys = single_input.scheduled(lambda t, x, u: {"k": 2.0 + t})  # leaves at t=2
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        got = ct.input_output_response(
            sys, T, np.ones_like(T), [0.0, 0.0],
            solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-11},
        )  # fmt: skip
    clips = [w for w in record if w.category is ParameterClipWarning]
    assert len(clips) == 1
    assert "k = " in str(clips[0].message) and "[1, 4]" in str(clips[0].message)
    assert clips[0].filename == __file__
    # After t = 2 the parameter is held at 4: the state at the end is the
    # k = 4 solution from the state at t = 2 (scipy, hand-written matrices).

    def rhs(t, x):
        k = min(2.0 + t, 4.0)
        return msd(k)[0] @ x + np.array([0.0, 1.0])

    ref = solve_ivp(rhs, (0, T[-1]), [0, 0], t_eval=T, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got.outputs, ref.y[0], atol=1e-6)

    # Inside the domain: no warning.
    inside = single_input.scheduled(lambda t, x, u: {"k": 2.0 + 0.1 * t})
    with warnings.catch_warnings():
        warnings.simplefilter("error", ParameterClipWarning)
        ct.input_output_response(inside, T, 1.0, [0.0, 0.0])


def test_clipping_of_scheduling_inputs_warns(single_input):
    sys = single_input.scheduled("inputs")
    U = np.vstack([np.ones_like(T), np.full_like(T, 6.0)])
    with pytest.warns(ParameterClipWarning, match=r"k = 6 \(outside \[1, 4\]\)"):
        got = ct.input_output_response(
            sys, T, U, [0.0, 0.0], solve_ivp_kwargs={"rtol": 1e-10, "atol": 1e-12}
        )
    np.testing.assert_allclose(got.outputs[0], step_x(4.0, T), atol=1e-7)


def test_non_finite_scheduled_value_is_an_error_naming_scheduling(single_input):
    sys = single_input.scheduled(lambda t, x, u: {"k": np.nan})
    with pytest.raises(ValueError, match="scheduling: non-finite"):
        sys.dynamics(0.0, [0.0, 0.0], [1.0])


def test_vertices_as_a_mapping_follow_the_domain(mass_spring):
    v1, v4 = (ct.ss(*msd(k)) for k in (1.0, 4.0))
    sys = lpv.PolytopicStateSpace({4.0: v4, 1.0: v1}, {"k": (1.0, 4.0)})
    np.testing.assert_allclose(sys.at(1.0).A, msd(1.0)[0])
    np.testing.assert_allclose(sys.at(3.0).A, msd(3.0)[0])
    with pytest.raises(ValueError, match="vertices: key 2.0 is not a vertex"):
        lpv.PolytopicStateSpace({2.0: v4, 1.0: v1}, {"k": (1.0, 4.0)})
    with pytest.raises(TypeError, match="vertices: a mapping"):
        lpv.PolytopicStateSpace({0: v4, 1: v1})


def test_two_parameter_mapping_and_box_order():
    base = np.array([[-1.0]])

    def vertex(a, b):
        return (base - a - 10 * b, [[1.0]], [[1.0]], 0)

    corners = {(a, b): vertex(a, b) for a in (0.0, 1.0) for b in (0.0, 2.0)}
    shuffled = dict(reversed(list(corners.items())))
    sys = lpv.pss(shuffled, {"a": (0.0, 1.0), "b": (0.0, 2.0)})
    # The documented box order: a slowest, lower bound first.
    assert [tuple(p) for p in sys.domain.points] == [
        (0.0, 0.0), (0.0, 2.0), (1.0, 0.0), (1.0, 2.0),
    ]  # fmt: skip
    np.testing.assert_allclose(sys.at({"a": 0.5, "b": 1.0}).A, [[-11.5]])


def test_vertex_systems_with_params_are_checked_against_the_order():
    v1 = ct.ss(*msd(1.0), params={"k": 1.0})
    v4 = ct.ss(*msd(4.0), params={"k": 4.0})
    lpv.pss([v1, v4], {"k": (1.0, 4.0)})  # right order: accepted
    with pytest.raises(ValueError, match=r"vertices\[0\].*vertex 1 of the domain"):
        lpv.pss([v4, v1], {"k": (1.0, 4.0)})


def test_warning_from_an_interactive_session(single_input):
    # A REPL or ``python -c`` runs in a __main__ whose loader has no source.
    import importlib.machinery

    namespace = {
        "__name__": "__main__",
        "__loader__": importlib.machinery.BuiltinImporter,
        "ct": ct,
        "sys": single_input,
    }
    with pytest.warns(NominalPointWarning, match="control.lti.poles"):
        exec(compile("ct.poles(sys)", "<stdin>", "exec"), namespace)


def test_hinfsyn_and_h2syn_warn_once():
    # w = (force, sensor noise), u; z = (x, u), y = x + noise.
    base = ct.ss(
        [[0.0, 1.0], [0.0, -0.5]],
        [[0.0, 0.0, 0.0], [1.0, 0.0, 1.0]],
        [[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]],
        [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]],
    )
    term = ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)
    P = lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": (1.0, 4.0)})
    for synthesis in (ct.hinfsyn, ct.h2syn):
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            synthesis(P, 1, 1)
        assert count(record) == 1


@pytest.mark.parametrize(
    "call",
    [
        lambda s: ct.minreal(s),
        lambda s: s.returnScipySignalLTI(),
    ],
    ids=["minreal", "returnScipySignalLTI"],
)
def test_refused_paths(single_input, call):
    with pytest.raises(TypeError, match=r"sys\.at\(p\)"):
        call(single_input)


@pytest.mark.parametrize(
    "call",
    [
        lambda s: ct.sample_system(s, 0.1),
        lambda s: ct.c2d(s, 0.1),
        lambda s: s.sample(0.1),
    ],
    ids=["sample_system", "c2d", "sys.sample"],
)
def test_sampling_paths_stay_polytopic(single_input, call):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        sysd = call(single_input)
    assert isinstance(sysd, lpv.PolytopicStateSpace)
    assert sysd.dt == 0.1 and sysd.isdtime(strict=True)
    assert sysd.discretization_error.Ts == 0.1


G = ct.ss([[-3.0]], [[1.0]], [[2.0]], [[0.5]])
POLYTOPIC = {
    "neg": lambda s: -s,
    "add": lambda s: s + G,
    "mul": lambda s: s * G,
    "rmul": lambda s: G * s,
    "getitem": lambda s: s[0, 0],
    "feedback(sys, K)": lambda s: ct.feedback(s, 2.0),
    "series": lambda s: ct.series(G, s),
    "parallel": lambda s: ct.parallel(s, G),
    "append": lambda s: ct.append(s, G),
    "negate": lambda s: ct.negate(s),
    "lft": lambda s: s.append(G).lft(ct.ss([], [], [], [[-1.0]]), 1, 1),
}


@pytest.mark.parametrize("name", sorted(POLYTOPIC))
def test_operations_that_stay_polytopic(single_input, name):
    operation = POLYTOPIC[name]
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        result = operation(single_input)
    assert isinstance(result, lpv.PolytopicStateSpace)
    # At k = 3: the same operation on python-control's own frozen system.
    frozen = ct.ss(*msd(3.0)[0:1], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    expected = operation(frozen)
    got = result.at({"k": 3.0})
    for s in (1j, 0.3 + 2j):
        np.testing.assert_allclose(got(s), expected(s), rtol=1e-10)
