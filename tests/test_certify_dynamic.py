"""`certify` on dynamic (output-feedback) controllers, against independent facts.

The closed loops are formed by python-control (`control.interconnect`, by
signal names) from the plant's frozen systems and the controller; their
norms come from `control.linfnorm` / `control.norm`, their eigenvalues
from numpy; LTI controllers from `control.hinfsyn` / `control.h2syn`; a
destabilising trajectory is simulated with scipy.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv.schedules import FrozenCounterexample, ParameterTrajectory

W, Z = ["w0", "w1"], ["z0", "z1"]


def plant(seed, vertices=1, n=3, dt=0):
    """A stable normalised plant (``D12 = [0; 1]``, ``D21 = [0, 1]``: the
    assumptions of `control.hinfsyn`), ``B2`` and ``C2`` common to the
    vertices; over ``p`` in [0, 1] with two vertices, over ``(p, q)`` in
    [0, 1]^2 with four."""
    rng = np.random.default_rng(seed)
    B2 = rng.standard_normal((n, 1))
    C2 = rng.standard_normal((1, n))
    B2, C2 = B2 / np.linalg.norm(B2), C2 / np.linalg.norm(C2)
    D = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    out = []
    for _ in range(vertices):
        A = rng.standard_normal((n, n)) / np.sqrt(n)
        if dt:
            A = A / (1.2 * np.abs(np.linalg.eigvals(A)).max())
        else:
            A = A - 1.5 * np.eye(n)
        B1 = np.hstack([rng.standard_normal((n, 1)) / np.sqrt(n), np.zeros((n, 1))])
        C1 = np.vstack([rng.standard_normal((1, n)) / np.sqrt(n), np.zeros((1, n))])
        out.append(ct.ss(A, np.hstack([B1, B2]), np.vstack([C1, C2]), D, dt,
                         inputs=W + ["u"], outputs=Z + ["y"]))  # fmt: skip
    domain = {1: None, 2: {"p": (0.0, 1.0)},
              4: {"p": (0.0, 1.0), "q": (0.0, 1.0)}}[vertices]  # fmt: skip
    return lpv.PolytopicStateSpace(out, domain=domain)


def loop(G, K, w=W, z=Z):
    """The frozen closed loop w -> z, connected by name by python-control."""
    return ct.interconnect([G, K], inplist=w, outlist=z)


def lti_controller(K):
    """A controller of `control.hinfsyn`/`h2syn` (u = K y), named."""
    return ct.ss(*ct.ssdata(K), inputs="y", outputs="u",
                 states=[f"k[{i}]" for i in range(K.nstates)])  # fmt: skip


# ------------------------------------------------------- output-feedback designs


@pytest.fixture(scope="module")
def of_design():
    G = plant(7, vertices=2)
    return G, lpv.hinf_output_feedback(G, W, "u", Z, "y")


def test_output_feedback_design_bound_holds_at_dense_frozen_points(of_design):
    G, d = of_design
    c = lpv.certify(d, G, objective=lpv.Hinf(w=W, z=Z))
    assert c.certified and c.rate_bound == {"p": np.inf}
    K = d.controller()
    worst = max(float(ct.linfnorm(loop(G.at({"p": p}), K.at({"p": p})))[0])
                for p in np.linspace(0.0, 1.0, 101))  # fmt: skip
    assert c.bound >= worst
    # The design's own certificate is one Lyapunov matrix too (a
    # different relaxation): the two bounds are of the same size.
    assert c.bound <= 1.5 * d.gamma
    assert c.certificate.verified and len(c.certificate) > 0


def test_the_design_and_its_controller_system_agree(of_design):
    G, d = of_design
    objective = lpv.Hinf(w=W, z=Z)
    a = lpv.certify(d, G, objective=objective)
    b = lpv.certify(d.controller(), G, objective=objective)
    assert a.certified == b.certified
    assert a.bound == pytest.approx(b.bound, rel=1e-6)


def test_two_parameter_design_bound_holds_at_dense_frozen_points():
    """Multilinear weights on a box: the products of plant and controller
    coordinates (``w_i w_j``) span the loop."""
    G = plant(11, vertices=4)
    d = lpv.hinf_output_feedback(G, W, "u", Z, "y")
    c = lpv.certify(d, G, objective=lpv.Hinf(w=W, z=Z))
    K = d.controller()
    grid = np.linspace(0.0, 1.0, 21)
    worst = max(float(ct.linfnorm(loop(G.at({"p": p, "q": q}),
                                       K.at({"p": p, "q": q})))[0])
                for p in grid for q in grid)  # fmt: skip
    assert c.certified and worst <= c.bound <= 1.5 * d.gamma


def test_discrete_time_design_bound_holds_at_dense_frozen_points():
    G = plant(4, vertices=2, dt=0.1)
    d = lpv.hinf_output_feedback(G, W, "u", Z, "y")
    c = lpv.certify(d, G, objective=lpv.Hinf(w=W, z=Z))
    K = d.controller()
    worst = max(float(ct.linfnorm(loop(G.at({"p": p}), K.at({"p": p})))[0])
                for p in np.linspace(0.0, 1.0, 101))  # fmt: skip
    assert c.certified and worst <= c.bound <= 1.5 * d.gamma


def test_observer_based_controller_bound_holds_at_dense_frozen_points():
    vertices = [ct.ss([[0.0, 1.0], [-a, 0.1]], [[0.0, 0.0], [1.0, 1.0]],
                      [[1.0, 0.0], [1.0, 0.0]], 0, inputs=["u", "w"],
                      outputs=["y", "z"]) for a in (1.0, 3.0)]  # fmt: skip
    G = lpv.PolytopicStateSpace(vertices, domain={"a": (1.0, 3.0)})
    combined = lpv.observer_based(lpv.synthesize(G, "u"),
                                  lpv.observer(G, "y", u="u"))  # fmt: skip
    c = lpv.certify(combined, G, objective=lpv.Hinf(w="w", z="z"))
    K = combined.controller()
    worst = max(float(ct.linfnorm(loop(G.at({"a": a}), K.at({"a": a}), "w", "z"))[0])
                for a in np.linspace(1.0, 3.0, 101))  # fmt: skip
    assert c.certified and c.bound >= worst


# ------------------------------------------------------------ LTI controllers


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_hinfsyn_controller_bound_is_the_closed_loop_norm(seed):
    """LTI: one Lyapunov matrix is exact, the bound is the H-infinity norm."""
    G = plant(seed)
    K = lti_controller(ct.hinfsyn(ct.ss(*ct.ssdata(G.vertices[0])), 1, 1)[0])
    c = lpv.certify(K, G, objective=lpv.Hinf(w=W, z=Z))
    true = float(ct.linfnorm(loop(G.vertices[0], K))[0])
    assert c.certified
    assert true * (1 - 1e-7) <= c.bound <= true * (1 + 1e-3)


def test_h2syn_controller_bound_is_the_closed_loop_h2_norm():
    G = plant(1)
    K = lti_controller(ct.h2syn(ct.ss(*ct.ssdata(G.vertices[0])), 1, 1))
    c = lpv.certify(K, G, objective=lpv.H2(w=W, z=Z))
    true = float(ct.norm(loop(G.vertices[0], K), 2))
    assert c.certified
    assert true * (1 - 1e-7) <= c.bound <= true * (1 + 1e-3)


def test_h2_of_a_loop_with_feedthrough_is_refused_naming_the_signals():
    """u = -y passes w1 (through y) to z1 (through u): H2 is infinite."""
    K = ct.ss([], [], [], [[-1.0]], inputs="y", outputs="u")
    with pytest.raises(ValueError, match="from 'w1' to 'z1'"):
        lpv.certify(K, plant(1), objective=lpv.H2(w=W, z=Z))


def test_lti_controller_on_a_polytopic_plant_bounds_every_frozen_loop():
    G = plant(7, vertices=2)
    K = lti_controller(ct.hinfsyn(ct.ss(*ct.ssdata(G.at({"p": 0.5}))), 1, 1)[0])
    c = lpv.certify(K, G, objective=lpv.Hinf(w=W, z=Z))
    worst = max(float(ct.linfnorm(loop(G.at({"p": p}), K))[0])
                for p in np.linspace(0.0, 1.0, 101))  # fmt: skip
    assert c.certified and c.bound >= worst


def test_destabilising_controller_gives_the_frozen_eigenvalue():
    G = plant(7, vertices=2)
    K = ct.ss([], [], [], [[50.0]], inputs="y", outputs="u")  # positive feedback
    c = lpv.certify(K, G)
    assert not c.certified and c.rate_bound == {"p": 0.0}
    ce = c.counterexample
    assert isinstance(ce, FrozenCounterexample)
    eig = np.linalg.eigvals(loop(G.at(ce.point), K).A)
    worst = eig[np.argmax(eig.real)]
    assert worst.real > 0
    assert ce.eigenvalue == pytest.approx(worst, rel=1e-9)
    # The same gain with negative feedback is certified.
    assert lpv.certify(ct.ss([], [], [], [[-50.0]], inputs="y", outputs="u"),
                       G).certified  # fmt: skip


# ------------------------------------------------------------------- rates

A1 = np.array([[-0.1, 1.0], [-2.0, -0.1]])
A2 = np.array([[-0.1, 2.0], [-1.0, -0.1]])


def switched():
    """x' = u, y = x, and a scheduled controller u = D(p) y with D(0) = A1,
    D(1) = A2 (and a decoupled state): the loop is (1 - p) A1 + p A2, every
    frozen one stable, with no common quadratic Lyapunov function."""
    base = ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0,
                 inputs=["u0", "u1"], outputs=["y0", "y1"])  # fmt: skip
    G = lpv.PolytopicStateSpace.from_affine(
        base, {"p": (np.zeros((2, 2)), 0, 0, 0)}, {"p": (0.0, 1.0)}
    )
    vertices = [ct.ss([[-1.0]], np.zeros((1, 2)), np.zeros((2, 1)), D,
                      inputs=["y0", "y1"], outputs=["u0", "u1"])
                for D in (A1, A2)]  # fmt: skip
    K = lpv.PolytopicStateSpace(vertices, domain={"p": (0.0, 1.0)},
                                scheduling="inputs")  # fmt: skip
    return G, K


@pytest.fixture(scope="module")
def switched_certificate():
    G, K = switched()
    return lpv.certify(K, G)


def test_switched_dynamic_loop_has_the_state_feedback_rate(switched_certificate):
    """The same loop as the state-feedback table (-A1, -A2): the same
    bisection finds the same rate."""
    c = switched_certificate
    assert not c.certified and 0.0 < c.rate_bound["p"] < np.inf
    G, _ = switched()
    table = lpv.certify(([-A1, -A2], [0.0, 1.0]), G)
    assert c.rate_bound["p"] == pytest.approx(table.rate_bound["p"], rel=0.1)


def test_switched_dynamic_counterexample_diverges(switched_certificate):
    traj = switched_certificate.counterexample
    assert isinstance(traj, ParameterTrajectory)
    assert traj.rate > switched_certificate.rate_bound["p"]
    G, K = switched()
    # The plant is constant and the controller affine in p: so is the loop
    # python-control forms, known from its two ends.
    ends = [loop(G.at({"p": p}), K.at({"p": p}), w=[], z=[]).A for p in (0.0, 1.0)]

    def rhs(t, x):
        p = float(np.clip(traj(np.array([t]))[0, 0], 0.0, 1.0))
        return ((1 - p) * ends[0] + p * ends[1]) @ x

    T = 6 * traj.period
    x0 = np.array([1.0, 0.0, 0.0])
    sol = solve_ivp(rhs, (0.0, T), x0, rtol=1e-9, atol=1e-12, max_step=0.01)
    growth = np.linalg.norm(sol.y[:, -1]) / np.linalg.norm(x0)
    assert growth > 1.5


def test_gridded_rate_agrees_with_the_state_feedback_path():
    """The switched loop on a 5-point grid, by both analyses (P(p)
    piecewise linear on the grid): the same rate. (This comparison found
    the state-feedback path's dP/dt reading another cell's P.)"""
    _, K = switched()
    G = lpv.gss(lambda p: ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0,
                                inputs=["u0", "u1"], outputs=["y0", "y1"]),
                {"p": np.linspace(0.0, 1.0, 5)})  # fmt: skip
    dynamic = lpv.certify(K, G, counterexample=False)
    table = lpv.certify(([-A1, -A2], [0.0, 1.0]), G, counterexample=False)
    assert 0.0 < dynamic.rate_bound["p"] < np.inf
    assert dynamic.rate_bound["p"] == pytest.approx(table.rate_bound["p"], rel=1e-9)


def test_rate_bounded_lyapunov_function_recomputed_with_numpy():
    """The rate-bounded LMIs' solution on a two-parameter box, with the loop
    quadratic in the weights (plant and controller vary): ``dV/dt < 0`` at
    dense frozen points and every corner of the rate box, with the loop
    formed by python-control and ``P(p)``, ``dP/dp`` from the weights."""
    from ctrl_lpv.schedules.dynamic import DynamicLoops

    G = plant(11, vertices=4)
    design = lpv.hinf_output_feedback(G, W, "u", Z, "y")
    K = design.controller()
    nu = 3.0
    lmi = DynamicLoops(design, G)._rate_problem(1e-6)
    lmi.set_parameter("nu", [nu, nu])
    P = np.array([lmi.solve().values[f"P{i}"] for i in range(4)])

    def weights(p, q):
        return G.weights({"p": p, "q": q})

    worst = -np.inf
    for p in np.linspace(0.0, 1.0, 11):
        for q in np.linspace(0.0, 1.0, 11):
            A = loop(G.at({"p": p, "q": q}), K.at({"p": p, "q": q})).A
            V = np.tensordot(weights(p, q), P, axes=1)
            # The weights are affine in each parameter: exact differences.
            dp = np.tensordot(weights(1.0, q) - weights(0.0, q), P, axes=1)
            dq = np.tensordot(weights(p, 1.0) - weights(p, 0.0), P, axes=1)
            for sp in (-nu, nu):
                for sq in (-nu, nu):
                    F = A.T @ V + V @ A + sp * dp + sq * dq
                    worst = max(worst, float(np.linalg.eigvalsh(F).max()))
    assert worst < 0


# ------------------------------------------------------------ gridded plants


def grid_point(a, b):
    A = np.array([[0.0, 1.0], [-a, -0.4 - 0.2 * b]])
    return ct.ss(A, [[0.0, 0.0], [1.0, 1.0]], [[1.0, 0.0], [1.0, 0.0]],
                 np.zeros((2, 2)), inputs=["u", "w"], outputs=["y", "z"])  # fmt: skip


def observer_based(G):
    """An LQR gain with an LQE observer of `G` (``u = -K xhat``)."""
    K, _, _ = ct.lqr(G.A, G.B[:, :1], np.eye(2), 1.0)
    L, _, _ = ct.lqe(G.A, np.eye(2), G.C[:1], np.eye(2), 1.0)
    return ct.ss(G.A - G.B[:, :1] @ K - L @ G.C[:1], L, -K, 0,
                 inputs="y", outputs="u", states=["k0", "k1"])  # fmt: skip


def test_gridded_plant_with_an_lti_controller():
    G = lpv.gss(grid_point, {"a": [1.5, 2.0, 2.5], "b": [0.0, 1.0]})
    K = observer_based(grid_point(2.0, 0.5))
    c = lpv.certify(K, G, objective=lpv.Hinf(w="w", z="z"))
    worst = max(float(ct.linfnorm(loop(grid_point(a, b), K, "w", "z"))[0])
                for a in np.linspace(1.5, 2.5, 21)
                for b in np.linspace(0.0, 1.0, 11))  # fmt: skip
    assert c.certified and c.bound >= worst


def test_gridded_plant_with_a_scheduled_controller_on_a_box_holding_it():
    G = lpv.gss(grid_point, {"a": [1.0, 2.0, 4.0], "b": [0.0, 1.0]})
    vertices = [observer_based(grid_point(a, b)) for a in (0.5, 4.5) for b in (0, 1)]
    K = lpv.PolytopicStateSpace(vertices, domain={"a": (0.5, 4.5), "b": (0.0, 1.0)},
                                scheduling="inputs")  # fmt: skip
    c = lpv.certify(K, G, objective=lpv.Hinf(w="w", z="z"))
    worst = max(
        float(ct.linfnorm(loop(grid_point(a, b), K.at({"a": a, "b": b}), "w", "z"))[0])
        for a in np.linspace(1.0, 4.0, 31)
        for b in np.linspace(0.0, 1.0, 11)
    )
    assert c.certified and c.bound >= worst


def test_gridded_controller_on_the_plant_grid():
    """Controllers designed at the grid points, interpolated as the plant."""
    axes = {"a": [1.0, 2.0, 4.0], "b": [0.0, 1.0]}
    G = lpv.gss(grid_point, axes)
    K = lpv.gss(lambda a, b: observer_based(grid_point(a, b)), axes)
    c = lpv.certify(K, G, objective=lpv.Hinf(w="w", z="z"))
    worst = max(
        float(ct.linfnorm(loop(grid_point(a, b), K.at({"a": a, "b": b}), "w", "z"))[0])
        for a in np.linspace(1.0, 4.0, 31)
        for b in np.linspace(0.0, 1.0, 11)
    )
    assert c.certified and c.bound >= worst


def test_destabilising_controller_on_a_grid_gives_the_cell_and_eigenvalue():
    G = lpv.gss(grid_point, {"a": [1.0, 2.0, 4.0], "b": [0.0, 1.0]})
    K = ct.ss([], [], [], [[3.0]], inputs="y", outputs="u")  # u = 3 y
    c = lpv.certify(K, G)
    ce = c.counterexample
    assert not c.certified and isinstance(ce, FrozenCounterexample)
    assert ce.cell in {(0, 0), (1, 0)}
    eig = np.linalg.eigvals(loop(grid_point(ce.point["a"], ce.point["b"]), K,
                                 "w", "z").A)  # fmt: skip
    assert ce.eigenvalue == pytest.approx(eig[np.argmax(eig.real)], rel=1e-9)
    assert ce.eigenvalue.real >= 0


# ---------------------------------------------------------------- bad input


def test_controller_output_that_is_not_a_plant_input_is_named():
    K = ct.ss([], [], [], [[1.0]], inputs="y", outputs="v")
    with pytest.raises(ValueError, match=r"outputs \['v'\] are not inputs"):
        lpv.certify(K, plant(0))


def test_controller_input_that_is_not_a_plant_output_is_named():
    K = ct.ss([], [], [], [[1.0]], inputs="q", outputs="u")
    with pytest.raises(ValueError, match=r"inputs \['q'\] are not outputs"):
        lpv.certify(K, plant(0))


def test_other_parameters_and_driven_objective_inputs_are_refused():
    G = plant(7, vertices=2)
    vertices = [ct.ss([[-1.0]], [[0.0]], [[0.0]], [[g]], inputs="y", outputs="u")
                for g in (-1.0, -2.0)]  # fmt: skip
    K = lpv.PolytopicStateSpace(vertices, domain={"q": (0.0, 1.0)})
    with pytest.raises(ValueError, match="scheduled on"):
        lpv.certify(K, G)
    assert lpv.certify(K, G, parameters={"q": "p"}).certified
    with pytest.raises(ValueError, match="objective.w"):
        lpv.certify(K, G, parameters={"q": "p"},
                    objective=lpv.Hinf(w=["u"], z=Z))  # fmt: skip


def test_algebraic_loop_and_time_base_are_refused():
    G = plant(0)
    A, B, C, D = ct.ssdata(G.vertices[0])
    D = D.copy()
    D[2, 2] = 1.0
    looped = lpv.PolytopicStateSpace([ct.ss(A, B, C, D, inputs=W + ["u"],
                                            outputs=Z + ["y"])])  # fmt: skip
    K = ct.ss([], [], [], [[-1.0]], inputs="y", outputs="u")
    with pytest.raises(ValueError, match="algebraic loop"):
        lpv.certify(K, looped)
    with pytest.raises(ValueError, match="time base"):
        lpv.certify(ct.ss([], [], [], [[-1.0]], 0.1, inputs="y", outputs="u"), G)


def test_controller_domain_not_holding_the_plant_is_refused():
    G = plant(7, vertices=2)
    vertices = [ct.ss([[-1.0]], [[0.0]], [[0.0]], [[g]], inputs="y", outputs="u")
                for g in (-1.0, -2.0)]  # fmt: skip
    K = lpv.PolytopicStateSpace(vertices, domain={"p": (0.2, 1.0)})
    with pytest.raises(ValueError, match="does not hold the plant"):
        lpv.certify(K, G)
    # The same segment as a polytope: its (least-squares) weights are not
    # the box's by construction, so it is refused rather than assumed.
    hull = lpv.PolytopicStateSpace(vertices, domain=lpv.Polytope([[0.0], [1.0]], ["p"]))
    with pytest.raises(ValueError, match="expected the plant's domain"):
        lpv.certify(hull, G)
