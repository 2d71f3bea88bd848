"""`ctrl_lpv.simulate`: the fused fast path against independent references."""

import math
import re

import control as ct
import numpy as np
import pytest
import scipy.linalg
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.interconnection import interconnect
from ctrl_lpv.simulation import (
    DivergenceError,
    SimulationError,
    SimulationTimeout,
    simulate,
)

P = twomass.Parameters()
K = twomass.paper_gain()[0]


# --------------------------------------------- two-mass loop vs a reference


def reference_rhs(alpha, theta_r=0.5, Td=8.0):
    """The exact plant under the published gain, written independently.

    The smoothed backlash of `twomass.plant` (1e-6 rad contact layer, 1e-5
    rad rest band, see its Notes), for a constant alpha.
    """
    rate, layer, band = P.ks / P.cs, 1e-6, 1e-5

    def rhs(t, x):
        tm, wm, tl, wl, tb = x
        Tm = -(K[0] * (tm - theta_r) + K[1] * wm + K[2] * (tl - theta_r) + K[3] * wl)
        wd = wm - wl
        if tb >= alpha or tb <= -alpha:
            bound = alpha if tb >= alpha else -alpha
            s = wd + rate * (tm - tl - bound)
            pushing = s > 0 if bound > 0 else s < 0
            v = 0.0 if pushing else s
            Ts = P.cs * (s - v)
            excess = abs(tb) - alpha - band
            dtb = v - np.sign(bound) * rate * excess if excess > 0 else v
        else:
            s = wd + rate * (tm - tl - tb)
            depth = alpha - tb if s > 0 else alpha + tb
            dtb = s * min(depth, layer) / layer
            Ts = P.cs * (s - dtb)
        return [wm, (Tm - P.cm * wm - Ts) / P.Jm, wl, (Ts - P.cl * wl - Td) / P.Jl, dtb]

    return rhs


@pytest.fixture(scope="module")
def two_mass_reference():
    T = np.linspace(0.0, 5.0, 5001)
    ref = solve_ivp(reference_rhs(0.03), (0, 5), np.zeros(5), method="DOP853",
                    rtol=1e-11, atol=1e-13, t_eval=T)  # fmt: skip
    assert ref.success
    return T, ref.y


@pytest.mark.parametrize("method", ["LSODA", "RK45"])
def test_fast_path_matches_tight_reference_on_two_mass_loop(two_mass_reference, method):
    T, y = two_mass_reference
    loop = twomass.closed_loop(twomass.lpv_controller(), alpha=0.03)
    U = [0.5 * np.ones_like(T), 8.0 * np.ones_like(T)]
    resp = simulate(loop, T, U, 0.0, method=method, return_states=True)
    assert resp.success
    theta_l = resp.outputs[resp.output_labels.index("theta_l")]
    assert np.abs(theta_l - y[2]).max() <= 1e-6
    # Angles to 1e-5 rad, speeds (up to ~10 rad/s) to 1e-3 rad/s.
    error = np.abs(resp.states[:4] - y[:4]).max(axis=1)
    assert np.all(error <= [1e-5, 1e-3, 1e-5, 1e-3]), error
    Tm = resp.outputs[resp.output_labels.index("Tm")]
    Tm_ref = -(K @ (y[:4] - np.array([[0.5], [0.0], [0.5], [0.0]])))
    assert np.abs(Tm - Tm_ref).max() <= 2.0  # of a 21 kNm peak


def test_twomass_simulate_engines_agree():
    for ctrl in (twomass.lpv_controller(torque_limit=2000.0),
                 twomass.backstepping_controller(Td_hat=8.0)):  # fmt: skip
        kw = dict(alpha=twomass.alpha_step(0.03, 0.045, at=0.3), T=0.6, npoints=601)
        slow = twomass.simulate(ctrl, **kw)
        fast = twomass.simulate(ctrl, engine="fast", **kw)
        tight = twomass.simulate(ctrl, rtol=1e-10, atol=1e-12, **kw)
        assert fast.output_labels == slow.output_labels
        # The same LSODA (odeint's driver against solve_ivp's): errors of
        # the same size against a tight-tolerance run, angles within 1e-6.
        fast_error = np.abs(fast.outputs - tight.outputs).max(axis=1)
        slow_error = np.abs(slow.outputs - tight.outputs).max(axis=1)
        assert np.all(fast_error <= 2 * slow_error + 1e-9), (fast_error, slow_error)
        assert fast_error[0] <= 1e-6  # theta_l, rad
    with pytest.raises(ValueError, match="engine"):
        twomass.simulate(ctrl, engine="numba")


# ---------------------------------------------------- analytic linear cases


def test_linear_system_matches_matrix_exponential():
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    sys = ct.ss(A, B, np.eye(2), 0, name="osc")
    T = np.linspace(0.0, 6.0, 121)
    x0 = np.array([0.3, -0.2])
    resp = simulate(sys, T, 2.0, x0)
    # x(t) = e^{At} x0 + A^{-1} (e^{At} - I) B u for a constant input u.
    expected = np.array([
        scipy.linalg.expm(A * t) @ x0
        + np.linalg.solve(A, (scipy.linalg.expm(A * t) - np.eye(2)) @ B[:, 0] * 2.0)
        for t in T
    ]).T  # fmt: skip
    np.testing.assert_allclose(resp.outputs, expected, rtol=0, atol=1e-6)


def test_polytopic_plant_with_state_feedback_at_frozen_parameter(mass_spring):
    design = lpv.hinf_state_feedback(mass_spring, w="w", u="u", z=["x", "uw"])
    vertices = [(v.A, v.B, np.eye(2), np.zeros((2, 2))) for v in mass_spring.vertices]
    plant = lpv.pss(vertices, mass_spring.domain, inputs=["w", "u"],
                    outputs=["x", "v"], states=["x", "v"], name="plant")  # fmt: skip
    ctrl = design.controller()
    loop = interconnect([plant, ctrl], inplist=["plant.w"], outlist=["plant.x"],
                        params={"k": 3.0})  # fmt: skip
    T = np.linspace(0.0, 4.0, 81)
    x0 = np.array([0.5, 0.0])
    resp = simulate(loop, T, 0.0, x0, method="LSODA", return_states=True)
    # With p fixed the loop is LTI: x' = (A(3) - B_u K) x.
    Acl = plant.at({"k": 3.0}).A - plant.at({"k": 3.0}).B[:, [1]] @ design.gains[0]
    expected = np.array([scipy.linalg.expm(Acl * t) @ x0 for t in T]).T
    np.testing.assert_allclose(resp.states, expected, rtol=0, atol=1e-6)
    np.testing.assert_allclose(resp.outputs, expected[0], rtol=0, atol=1e-6)


def test_time_varying_input_interpolated_as_python_control():
    sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0, name="lag")
    T = np.linspace(0.0, 3.0, 31)  # coarse: the interpolation matters
    U = np.sin(2 * T)
    kw = dict(rtol=1e-10, atol=1e-12)
    fast = simulate(sys, T, U, 0.0, **kw)
    # Exact solution of x' = -x + u with u piecewise linear between samples.
    x, exact = 0.0, [0.0]
    for k in range(30):
        h, u0, du = T[k + 1] - T[k], U[k], (U[k + 1] - U[k]) / (T[k + 1] - T[k])
        # particular solution u0 + du (t - tk) - du, plus decay
        x = (x - (u0 - du)) * math.exp(-h) + u0 + du * h - du
        exact.append(x)
    # The input's kinks at the samples limit the solver's accuracy to a few
    # 1e-8 whatever rtol (scipy 1.17's RK45: 2.7e-8); another interpolation
    # would be off by 1e-2.
    np.testing.assert_allclose(fast.outputs, exact, rtol=0, atol=1e-7)


# -------------------------------------------------------- response object


def test_response_matches_input_output_response_shape():
    P_ = ct.nlsys(lambda t, x, u, p: [x[1], -np.sin(x[0]) + u[0]],
                  lambda t, x, u, p: x[0], inputs="u", outputs="y",
                  states=["q", "dq"], name="pend")  # fmt: skip
    T = np.linspace(0.0, 2.0, 21)
    kw = dict(solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-12})
    ref = ct.input_output_response(P_, T, 0.1, [0.5, 0.0], return_states=True, **kw)
    got = simulate(P_, T, 0.1, [0.5, 0.0], rtol=1e-9, atol=1e-12, return_states=True)
    for attr in ("output_labels", "input_labels", "state_labels", "sysname",
                 "title", "issiso", "success"):  # fmt: skip
        assert getattr(got, attr) == getattr(ref, attr), attr
    for attr in ("time", "outputs", "states", "inputs"):
        a, b = getattr(got, attr), getattr(ref, attr)
        assert np.shape(a) == np.shape(b), attr
        np.testing.assert_allclose(a, b, atol=1e-7)
    t, y, x = got  # return_states: (time, outputs, states)
    assert y.shape == (21,) and x.shape == (2, 21)
    engine = simulate(P_, T, 0.1, [0.5, 0.0], engine="control", rtol=1e-9,
                      atol=1e-12)  # fmt: skip
    np.testing.assert_array_equal(engine.outputs, ref.outputs)


def test_algebraic_loop_and_static_systems():
    # An undeclared nonlinear plant: looks like an algebraic loop, so the
    # fast engine falls back on the system's own evaluation.
    P_ = ct.nlsys(lambda t, x, u, p: -x + u, lambda t, x, u, p: 2 * x,
                  inputs="u", outputs="y", states=1, name="P")  # fmt: skip
    C = ct.nlsys(None, lambda t, x, u, p: 3.0 * (u[0] - u[1]),
                 inputs=["r", "y"], outputs="u", name="C")  # fmt: skip
    loop = ct.interconnect([P_, C], inplist="C.r", outlist=["P.y", "C.u"])
    T = np.linspace(0.0, 1.0, 11)
    got = simulate(loop, T, 1.0, 0.0)
    # y' = 2 x' = 2 (-x + 3 (1 - 2 x)): x(t) = 3/7 (1 - e^{-7 t}).
    np.testing.assert_allclose(got.outputs[0], 6 / 7 * (1 - np.exp(-7 * T)), atol=1e-6)
    static = ct.nlsys(None, lambda t, x, u, p: u**2, inputs=1, outputs=1)
    resp = simulate(static, T, T)
    np.testing.assert_allclose(resp.outputs, T**2)


@pytest.mark.parametrize(
    "method, reason",
    [
        ("RK45", "solve_ivp failed"),
        # LSODA steps onto an infinite derivative: reported as such.
        ("LSODA", r"derivative of state 'x\[0\]' is inf"),
    ],
)
def test_solver_failure(method, reason):
    # x' = x^2, x(0) = 1: x = 1 / (1 - t) escapes at t = 1.
    blowup = ct.nlsys(lambda t, x, u, p: x**2, None, inputs=0, outputs=1, states=1)
    T = np.linspace(0.0, 2.0, 21)
    kw = dict(X0=1.0, method=method, state_bound=None)
    with np.errstate(over="ignore"), pytest.raises(RuntimeError, match=reason):
        simulate(blowup, T, **kw)
    with np.errstate(over="ignore"):
        resp = simulate(blowup, T, ignore_errors=True, **kw)
    assert not resp.success and re.search(reason, resp.message)
    assert resp.time.size < T.size and resp.outputs.shape == (1, resp.time.size)
    # What is returned before the escape time is the solution.
    before = resp.time < 0.95
    assert before.sum() == 10
    np.testing.assert_allclose(resp.outputs[0, before], 1 / (1 - resp.time[before]),
                               rtol=1e-4)  # fmt: skip


@pytest.mark.parametrize("engine", ["fast", "control"])
@pytest.mark.parametrize("method", ["RK45", "LSODA"])
def test_escape_is_a_divergence(engine, method):
    # x' = x^2, x(0) = 1: x = 1 / (1 - t) reaches 1e6 at t = 1 - 1e-6.
    blowup = ct.nlsys(lambda t, x, u, p: x**2, None, inputs=0, outputs=1, states=1)
    T = np.linspace(0.0, 2.0, 21)
    kw = dict(X0=1.0, method=method, engine=engine, state_bound=1e6)
    with pytest.raises(DivergenceError, match=r"state 'x\[0\]'.*state_bound") as info:
        simulate(blowup, T, **kw)
    assert info.value.signal == "x[0]" and abs(info.value.value) > 1e6
    assert 1 - 1e-3 < info.value.time < 1.0
    # ignore_errors: the solution before the escape, and the reason.
    resp = simulate(blowup, T, ignore_errors=True, **kw)
    assert not resp.success and "state_bound" in resp.message
    assert resp.time.size == 10  # t = 0, ..., 0.9
    np.testing.assert_allclose(np.ravel(resp.outputs), 1 / (1 - resp.time), rtol=1e-4)


def unstable_loop(k):
    """x' = x + u + w under u = -k x: x(t) = exp((1 - k) t) x(0) for w = 0."""
    plant = ct.ss([[1.0]], [[1.0, 1.0]], [[1.0]], 0, inputs=["u", "w"], outputs="x",
                  states="x", name="plant")  # fmt: skip
    ctrl = ct.ss(
        np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[-k]],
        inputs="x", outputs="u", name="ctrl",
    )  # fmt: skip
    return interconnect(
        [plant, ctrl], inplist=["plant.w"], inputs=["w"], outlist=["x"], outputs=["x"]
    )


@pytest.mark.parametrize("engine", ["fast", "control"])
@pytest.mark.parametrize("method", ["RK45", "LSODA"])
def test_destabilizing_gain_stops_at_the_bound(engine, method):
    loop = unstable_loop(-4.0)  # a destabilizing gain: x' = 5 x
    T = np.linspace(0.0, 100.0, 1001)
    with pytest.raises(DivergenceError, match="plant_x") as info:
        simulate(loop, T, 0.0, 1.0, engine=engine, method=method, state_bound=1e6)
    # Stopped where exp(5 t) crosses 1e6, within a few solver steps (the
    # fast engine checks the bound every few calls; a stage point may run
    # slightly ahead); the value reported is the state then, exp(5 t).
    err = info.value
    assert math.log(1e6) / 5.0 - 0.05 < err.time < math.log(1e6) / 5.0 + 0.5
    assert abs(err.value) > 1e6
    assert math.log(abs(err.value)) / 5.0 == pytest.approx(err.time, abs=0.02)
    # The default bound 1e12 stops it too, long before t = 100.
    with pytest.raises(DivergenceError) as info:
        simulate(loop, T, 0.0, 1.0, engine=engine, method=method)
    assert math.log(1e12) / 5.0 - 0.05 < info.value.time < math.log(1e12) / 5.0 + 0.5


@pytest.mark.parametrize("engine", ["fast", "control"])
def test_nan_signal_is_named_not_an_algebraic_loop(engine, mass_spring):
    """A controller output turning NaN at t = 1 (as from a NaN parameter)."""
    ctrl = ct.nlsys(
        None, lambda t, x, u, p: [-u[0] - u[1] if t < 1 else math.nan],
        inputs=["x", "v"], outputs=["u"], name="ctrl",
    )  # fmt: skip
    full = lpv.pss(
        [(v.A, v.B, np.eye(2), np.zeros((2, 2))) for v in mass_spring.vertices],
        mass_spring.domain, scheduling=lambda t, x, u: 2.0, inputs=["w", "u"],
        outputs=["x", "v"], states=["x", "v"], name="plant",
    )  # fmt: skip
    loop = ct.interconnect([full, ctrl], inputs=["w"], outputs=["x", "v"])
    T = np.linspace(0.0, 3.0, 31)
    with pytest.raises(DivergenceError, match="derivative of state 'plant_.*nan"):
        simulate(loop, T, 0.0, [1.0, 0.0], engine=engine)
    # python-control alone reports the NaN as an algebraic loop.
    with pytest.raises(RuntimeError, match="algebraic loop"):
        ct.input_output_response(loop, T, 0.0, [1.0, 0.0])


@pytest.mark.parametrize("engine", ["fast", "control"])
def test_timeout(engine):
    loop = twomass.closed_loop(twomass.lpv_controller())
    T = np.linspace(0.0, 5.0, 501)
    with pytest.raises(SimulationTimeout, match="timeout = 1e-09 s") as info:
        simulate(loop, T, [0.5, 8.0], 0.0, engine=engine, timeout=1e-9)
    assert isinstance(info.value, TimeoutError) and isinstance(
        info.value, SimulationError
    )
    assert info.value.timeout == 1e-9 and 0.0 <= info.value.time <= 5.0


@pytest.mark.parametrize("key", ["timeout", "state_bound"])
@pytest.mark.parametrize("value", [0, -1.0, True, "1", math.nan])
def test_bad_guard_arguments(key, value):
    loop = unstable_loop(2.0)
    with pytest.raises(ValueError, match=key):
        simulate(loop, np.linspace(0, 1, 11), 0.0, 1.0, **{key: value})


def test_lsoda_max_step_reaches_the_solver():
    # LSODA's steps grow past a pulse narrower than the output grid;
    # max_step makes it see the pulse, whose integral is 0.01.
    pulse = ct.nlsys(
        lambda t, x, u, p: [1.0 if 0.3 < t < 0.31 else 0.0],
        None, inputs=0, outputs=1, states=1,
    )  # fmt: skip
    T = np.array([0.0, 1.0])
    free = simulate(pulse, T, method="LSODA")
    assert free.outputs.reshape(-1)[-1] == 0.0
    limited = simulate(pulse, T, method="LSODA", solve_ivp_kwargs={"max_step": 1e-3})
    assert limited.outputs.reshape(-1)[-1] == pytest.approx(0.01, abs=1e-4)


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(sys="plant"), TypeError, "sys"),
        (dict(engine="numba"), ValueError, "engine"),
        (dict(T=[0.0, 1.0, 0.5]), ValueError, "T"),
        (dict(T=[0.0]), ValueError, "T"),
        (dict(U=np.zeros((3, 11))), ValueError, "U"),
        (dict(U=[0.0, np.nan]), ValueError, "U"),
        (dict(X0=np.zeros(7)), ValueError, "X0"),
        (dict(X0=np.full(5, np.inf)), ValueError, "X0"),
        (dict(rtol=0.0), ValueError, "rtol"),
        (dict(atol=-1.0), ValueError, "atol"),
        (dict(solve_ivp_kwargs={"method": "RK23"}), ValueError, "solve_ivp_kwargs"),
    ],
)
def test_bad_arguments(kwargs, error, match):
    args = dict(sys=twomass.closed_loop(twomass.lpv_controller()),
                T=np.linspace(0, 1, 11), U=0.0, X0=0.0)  # fmt: skip
    for key in ("sys", "T", "U", "X0"):
        if key in kwargs:
            args[key] = kwargs.pop(key)
    with pytest.raises(error, match=match):
        simulate(args["sys"], args["T"], args["U"], args["X0"], **kwargs)


def test_discrete_time_needs_the_control_engine():
    sys = ct.ss([[0.5]], [[1.0]], [[1.0]], 0, dt=0.1)
    T = np.arange(0.0, 1.0, 0.1)
    with pytest.raises(ValueError, match="continuous-time"):
        simulate(sys, T, 1.0)
    resp = simulate(sys, T, 1.0, engine="control")
    assert resp.outputs[-1] == pytest.approx(2.0 * (1 - 0.5**9))


# ------------------------------------------- block kernels: one source of truth


def random_points(n, scale, seed=0):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(n, 400)) * np.reshape(scale, (-1, 1))


@pytest.mark.parametrize("model", ["exact", "deadzone"])
@pytest.mark.parametrize("alpha", [0.0, 0.03, twomass.alpha_step(0.03, 0.01, 0.5)])
def test_vectorized_outputs_equal_scalar_outputs(model, alpha):
    blocks = [
        twomass.plant(model=model, alpha=alpha),
        twomass.lpv_controller(torque_limit=3000.0),
        twomass.lpv_controller(np.vstack([K, 1.5 * K]), p_bounds=(-0.95, 0.0),
                               alpha_estimate=lambda t: 0.03 + 0.01 * t),
        twomass.backstepping_controller(Td_hat=8.0),
    ]  # fmt: skip
    t = np.linspace(0.0, 1.0, 400)
    for sys in blocks:
        kernel = sys._kernel
        # States around the contact: theta_b near +-alpha, shaft angles of
        # the order of the gap.
        X = random_points(sys.nstates, [0.03, 3.0, 0.03, 3.0, 0.03][: sys.nstates])
        U = random_points(sys.ninputs, [0.03, 3.0, 0.03, 3.0, 0.5][: sys.ninputs])
        if sys.ninputs == 2:
            U = random_points(2, [1e3, 10.0])
        many = np.array(kernel.out_many(t, list(X), list(U)), dtype=float)
        one = np.array([kernel.out(ti, X[:, i].tolist(), U[:, i].tolist())
                        for i, ti in enumerate(t)]).T  # fmt: skip
        np.testing.assert_allclose(many, one, rtol=1e-12, atol=1e-9)
