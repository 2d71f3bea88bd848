"""`ctrl_lpv.interconnect` against `control.interconnect`."""

import copy

import control as ct
import numpy as np
import pytest
from control.nlsys import InterconnectedSystem
from control.statesp import LinearICSystem

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.interconnection import BlockKernel, interconnect, kernel_nlsys, plan

RNG = np.random.default_rng(7)


def both(syslist, **kwargs):
    """The same diagram built by python-control and by ctrl_lpv."""
    kwargs.setdefault("name", "diagram")
    return ct.interconnect(syslist, **kwargs), interconnect(syslist, **kwargs)


def assert_same_system(ref, fast, points=20, scale=1.0):
    """Labels and evaluations at random states and inputs agree."""
    assert isinstance(fast, type(ref))
    assert type(fast) is not type(ref)
    for attr in ("name", "input_labels", "output_labels", "state_labels"):
        assert getattr(fast, attr) == getattr(ref, attr), attr
    ref._update_params(None)
    fast._update_params(None)
    for _ in range(points):
        x = scale * RNG.normal(size=ref.nstates)
        u = scale * RNG.normal(size=ref.ninputs)
        t = float(RNG.uniform(0, 3))
        np.testing.assert_allclose(
            fast._rhs(t, x, u), ref._rhs(t, x, u), rtol=1e-12, atol=1e-12
        )
        np.testing.assert_allclose(
            fast._out(t, x, u), ref._out(t, x, u), rtol=1e-12, atol=1e-12
        )


def assert_same_response(ref, fast, T, U, X0, tol):
    kw = dict(solve_ivp_kwargs={"rtol": 1e-9, "atol": 1e-12}, return_states=True)
    r_ref = ct.input_output_response(ref, T, U, X0, **kw)
    r_fast = ct.input_output_response(fast, T, U, X0, **kw)
    assert r_fast.output_labels == r_ref.output_labels
    assert r_fast.state_labels == r_ref.state_labels
    np.testing.assert_allclose(r_fast.outputs, r_ref.outputs, rtol=0, atol=tol)
    np.testing.assert_allclose(r_fast.states, r_ref.states, rtol=0, atol=tol)


# ------------------------------------------------------------ the two-mass loop


def two_mass_kwargs():
    return dict(
        inplist=["theta_r", "Td"], inputs=["theta_r", "Td"],
        outlist=["plant.theta_l", "plant.Tm", "plant.Ts", "lpv.theta_r"],
        outputs=["theta_l", "Tm", "Ts", "r"], name="loop",
    )  # fmt: skip


@pytest.mark.parametrize("alpha", [0.03, twomass.alpha_step()])
def test_two_mass_loop_matches_python_control(alpha):
    gain = np.hstack([twomass.paper_gain(), [[-2e4]]])  # with integral state
    blocks = [
        twomass.plant(alpha=alpha),
        twomass.lpv_controller(gain, torque_limit=5000.0),
    ]
    ref, fast = both(blocks, **two_mass_kwargs())
    assert not fast.algebraic_loop
    # States near the contact, the torque limit and the gap.
    assert_same_system(ref, fast, points=30, scale=0.02)
    T = np.linspace(0.0, 0.3, 301)
    U = [0.5 * np.ones_like(T), 8.0 * np.ones_like(T)]
    assert_same_response(ref, fast, T, U, 0.0, tol=1e-7)


def test_one_pass_in_dependency_order():
    # The plant declares no feedthrough and its first outputs are states:
    # the right-hand side calls the controller once and the plant's
    # output function not at all; python-control calls each up to 3 times.
    plant_, ctrl = twomass.plant(alpha=0.03), twomass.lpv_controller()
    fast = interconnect([plant_, ctrl], **two_mass_kwargs())
    source = fast._plan().rhs.source
    assert source.count("_o1(") == 1 and "_o0(" not in source


# ------------------------------------------- polytopic plant, state feedback


def measured(mass_spring):
    vertices = [(v.A, v.B, np.eye(2), np.zeros((2, 2))) for v in mass_spring.vertices]
    return lpv.pss(
        vertices, mass_spring.domain, inputs=["w", "u"], outputs=["x", "v"],
        states=["x", "v"], name="plant",
    )  # fmt: skip


def stiffness(t):
    return 2.5 + 1.5 * np.sin(2.0 * t)


@pytest.fixture(scope="module")
def msd_designs():
    """The conftest mass-spring plant with a common and a vertex-gain design."""
    base = ct.ss(
        [[0.0, 1.0], [0.0, -0.5]], [[0.0, 0.0], [1.0, 1.0]],
        [[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.1]],
        inputs=["w", "u"], outputs=["x", "uw"], states=["x", "v"], name="msd",
    )  # fmt: skip
    term = ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)
    sys = lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": (1.0, 4.0)})
    kw = dict(w="w", u="u", z=["x", "uw"])
    return sys, lpv.hinf_state_feedback(sys, **kw), lpv.gain_scheduled_hinf(sys, **kw)


@pytest.mark.parametrize("scheduling", ["params", "inputs", "callable"])
def test_polytopic_plant_with_state_feedback(msd_designs, scheduling):
    mass_spring, common, scheduled = msd_designs
    plant_ = measured(mass_spring)
    inplist, inputs = ["plant.w"], ["w"]
    if scheduling == "params":
        # Frozen parameter value from params, common gain.
        ctrl = common.controller()
    elif scheduling == "inputs":
        plant_ = plant_.scheduled("inputs")
        ctrl = scheduled.controller()
        inplist, inputs = ["plant.w", ["plant.k", "ctrl.k"]], ["w", "k"]
    else:
        plant_ = plant_.scheduled(lambda t, x, u: stiffness(t))
        ctrl = scheduled.controller(lambda t, x: stiffness(t))
    ctrl.name = "ctrl"
    kwargs = dict(inplist=inplist, inputs=inputs,
                  outlist=["plant.x", "plant.v", "ctrl.u"])  # fmt: skip
    ref, fast = both([plant_, ctrl], **kwargs)
    assert not fast.algebraic_loop
    assert_same_system(ref, fast)
    T = np.linspace(0.0, 1.0, 51)
    U = [np.sin(T)] + ([stiffness(T)] if scheduling == "inputs" else [])
    # Inputs are interpolated linearly: kinks at the samples limit the
    # agreement of two solver runs to ~1e-7.
    assert_same_response(ref, fast, T, U, [0.2, -0.1], tol=1e-6)


# --------------------------------------------------------- linear diagrams


def test_linear_diagram_with_gains_sums_and_input_outputs():
    # Feedthrough in G2, K and the sum; G1 (no feedthrough) breaks the loop.
    G1 = ct.ss([[-1.0, 2.0], [0.0, -3.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]],
               inputs="u", outputs="y", name="G1")  # fmt: skip
    G2 = ct.ss([[-2.0]], [[1.0]], [[3.0]], [[0.5]], inputs="u", outputs="y", name="G2")
    K = ct.ss([], [], [], [[-4.0]], inputs="e", outputs="u", name="K")
    sum_ = ct.summing_junction(["r", "-y1", "-y2"], "e", name="sum")
    kwargs = dict(
        connections=[["G1.u", "K.u"], ["G2.u", ("G1", "y", 0.5)],
                     ["sum.y1", "G1.y"], ["sum.y2", ("G2", "y", 2.0)],
                     ["K.e", "sum.e"]],
        inplist=["sum.r"], outlist=["G1.y", "-G2.y", "K.u", "G1.u"],
        inputs="r", outputs=["y1", "y2", "u", "u_copy"],
    )  # fmt: skip
    ref, fast = both([G1, G2, K, sum_], **kwargs)
    assert isinstance(fast, LinearICSystem)
    for name in "ABCD":
        np.testing.assert_array_equal(getattr(fast, name), getattr(ref, name))
    assert_same_system(ref, fast)
    T = np.linspace(0.0, 3.0, 61)
    assert_same_response(ref, fast, T, np.cos(T), 0.0, tol=1e-9)


def test_discrete_time_diagram():
    P = ct.ss([[0.9]], [[0.1]], [[1.0]], 0, dt=0.1, name="P")
    C = ct.ss([], [], [], [[2.0]], dt=0.1, name="C")
    ref, fast = both(
        [P, C], connections=[["P.u[0]", "C.y[0]"], ["C.u[0]", "-P.y[0]"]],
        inplist=["P.u[0]"], outlist=["P.y[0]"],
    )  # fmt: skip
    T = np.arange(0.0, 2.0, 0.1)
    r_ref = ct.input_output_response(ref, T, 1.0)
    r_fast = ct.input_output_response(fast, T, 1.0)
    np.testing.assert_allclose(r_fast.outputs, r_ref.outputs, rtol=1e-14)


# ------------------------------------------------------- algebraic loops


def undeclared_loop():
    """A nonlinear plant without feedthrough declaration: looks algebraic."""
    P = ct.nlsys(lambda t, x, u, p: -x + np.tanh(u), lambda t, x, u, p: 2 * x,
                 inputs="u", outputs="y", states=1, name="P")  # fmt: skip
    C = ct.nlsys(None, lambda t, x, u, p: 3.0 * (u[0] - u[1]),
                 inputs=["r", "y"], outputs="u", name="C")  # fmt: skip
    return [P, C], dict(inplist="C.r", outlist=["P.y", "C.u"], name="loop")


def test_undeclared_feedthrough_falls_back_on_python_control():
    blocks, kwargs = undeclared_loop()
    ref, fast = both(blocks, **kwargs)
    assert fast.algebraic_loop
    assert_same_system(ref, fast)
    T = np.linspace(0.0, 2.0, 41)
    assert_same_response(ref, fast, T, 1.0, 0.3, tol=1e-12)


def test_declared_feedthrough_removes_the_loop():
    blocks, kwargs = undeclared_loop()
    ref = ct.interconnect(blocks, **kwargs)
    blocks[0]._feedthrough = False  # y = 2 x does not read u
    fast = interconnect(blocks, **kwargs)
    assert not fast.algebraic_loop
    assert_same_system(ref, fast)


def test_genuine_algebraic_loop_raises_like_python_control():
    A = ct.nlsys(None, lambda t, x, u, p: 0.5 * u + 1.0, inputs=1, outputs=1,
                 name="A")  # fmt: skip
    B = ct.nlsys(None, lambda t, x, u, p: np.sin(u), inputs=1, outputs=1, name="B")
    kwargs = dict(connections=[["A.u[0]", "B.y[0]"], ["B.u[0]", "A.y[0]"]],
                  outlist=["A.y[0]"], inplist=[])  # fmt: skip
    ref, fast = both([A, B], **kwargs)
    assert fast.algebraic_loop
    for sys in (ref, fast):
        with pytest.raises(RuntimeError, match="algebraic loop"):
            sys.output(0.0, [], [])


# ------------------------------------------------ copies, maps, errors


def test_copy_and_map_changes_rebuild_the_plan():
    blocks, kwargs = undeclared_loop()
    blocks[0]._feedthrough = False
    ref, fast = both(blocks, **kwargs)
    x, u = np.array([0.4]), np.array([1.0])
    clone = copy.deepcopy(fast)
    np.testing.assert_allclose(clone._rhs(0.0, x, u), ref._rhs(0.0, x, u))
    assert clone._fast_plan is not fast._fast_plan
    cmap = ref.connect_map.copy()
    cmap[cmap != 0] *= 2.0
    for sys in (ref, fast):
        sys.set_connect_map(cmap.copy())
    np.testing.assert_allclose(fast._rhs(0.0, x, u), ref._rhs(0.0, x, u))
    np.testing.assert_allclose(fast._out(0.0, x, u), ref._out(0.0, x, u))


def test_errors_are_python_controls():
    blocks, kwargs = undeclared_loop()
    for build in (ct.interconnect, interconnect):
        with pytest.raises(ValueError, match="nope"):
            build(blocks, inplist="C.nope", outlist="P.y")


def test_bad_feedthrough_declaration():
    blocks, kwargs = undeclared_loop()
    blocks[0]._feedthrough = np.zeros((2, 2), bool)
    with pytest.raises(ValueError, match="P._feedthrough"):
        plan(interconnect(blocks, **kwargs))


def test_kernel_nlsys_checks_its_arguments():
    kernel = BlockKernel(out=lambda t, x, u: (u[0],))
    sys = kernel_nlsys(kernel, inputs=["a"], outputs=["b"], name="k")
    assert isinstance(sys, ct.NonlinearIOSystem)
    assert not isinstance(sys, InterconnectedSystem)
    assert sys.output(0.0, [], [3.0]) == pytest.approx([3.0])
    with pytest.raises(TypeError, match="kernel"):
        kernel_nlsys(lambda t, x, u: u, inputs=["a"], outputs=["b"])
    with pytest.raises(ValueError, match="states"):
        kernel_nlsys(kernel, inputs=["a"], outputs=["b"], states=["x"])
    with pytest.raises(ValueError, match="feedthrough"):
        kernel_nlsys(kernel, inputs=["a"], outputs=["b"], feedthrough=[[1, 0]])
