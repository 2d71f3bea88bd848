"""`certify` on gridded plants, against independent facts.

The plant is built from `control.linearize` of a nonlinear python-control
pendulum at trim points; the frozen closed loops are formed here from
``G.at(p)`` and the gains interpolated by scipy (what python-control's
``gainsched_method="linear"`` does), and their H-infinity norms come from
`control.linfnorm`. The certified L2 bound must be at least the worst of
them on a grid ten times denser than the design grid.
"""

import control as ct
import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator

import ctrl_lpv as lpv
from ctrl_lpv.schedules import FrozenCounterexample

GRAVITY, LENGTH, DAMPING = 9.81, 1.0, 0.5


def pendulum_dynamics(t, x, u, params):
    m = params.get("m", 1.0)
    torque = -m * GRAVITY * LENGTH * np.sin(x[0]) - DAMPING * x[1] + u[0] + u[1]
    return [x[1], torque / (m * LENGTH**2)]


PENDULUM = ct.nlsys(pendulum_dynamics, None, inputs=["u", "w"],
                    states=["theta", "omega"], outputs=["theta", "omega"],
                    params={"m": 1.0}, name="pendulum")  # fmt: skip


def trim_linearization(theta0, m):
    """The pendulum linearized where it holds the angle theta0."""
    u0 = m * GRAVITY * LENGTH * np.sin(theta0)
    return ct.linearize(PENDULUM, [theta0, 0.0], [u0, 0.0], params={"m": m},
                        copy_names=True)  # fmt: skip


DESIGN = {"theta0": np.linspace(0.0, 1.2, 3), "m": np.linspace(0.8, 1.25, 3)}


@pytest.fixture(scope="module")
def design():
    G = lpv.gss(trim_linearization, DESIGN)
    points = G.grid.points
    gains = [ct.lqr(G.at(p)[:, "u"], np.diag([10.0, 1.0]), 1.0)[0] for p in points]
    return G, gains, points


def frozen_loop(G, gain_of, p):
    S = G.at(p)
    K = gain_of(p)
    return ct.ss(S.A - S.B[:, [0]] @ K, S.B[:, [1]], S.C[[0]], 0)


def test_certified_l2_bound_covers_the_frozen_norms_on_a_10x_denser_grid(design):
    G, gains, points = design
    c = lpv.certify((gains, points), G, objective=lpv.Hinf(w="w", z="theta"))
    assert c.certified and c.certificate.verified
    assert c.rate_bound == {"theta0": np.inf, "m": np.inf}
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))

    def gain_of(p):
        return interp(p).reshape(1, 2)

    # Design spacing / 10 on both axes: 21 x 21 points.
    dense = [np.linspace(0.0, 1.2, 21), np.linspace(0.8, 1.25, 21)]
    norms = [float(ct.linfnorm(frozen_loop(G, gain_of, [a, m]))[0])
             for a in dense[0] for m in dense[1]]  # fmt: skip
    worst = max(norms)
    assert c.bound >= worst
    # Arbitrary rates cost something, but the bound is not vacuous.
    assert c.bound < 10 * worst


def test_the_spanning_terms_reproduce_every_frozen_loop(design):
    """The frozen loop is the convex combination the docstring claims:
    ``sum_i w_i^2 M_ii + sum_{i<j} 2 w_i w_j (M_ij + M_ji) / 2``."""
    from ctrl_lpv.schedules.polytopic import gridded_loops as _gridded_loops
    from ctrl_lpv.schedules.schedule import schedule_of

    G, gains, points = design
    schedule = schedule_of((gains, points), names=G.param_names)
    loops = _gridded_loops(schedule, G, (gains, points), None)
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))
    rng = np.random.default_rng(3)
    for piece in loops.pieces:
        K = loops.corner_gains(piece)
        terms = loops.products(piece)
        for _ in range(5):
            # A point of the piece: a random convex combination of the
            # simplex's points, kept if it lies in the cell.
            lam = rng.dirichlet(np.ones(3))
            p = lam @ loops.points[piece.points]
            lo, hi = G.grid.points[piece.corners[[0, -1]]]
            if np.any(p < lo) or np.any(p > hi):
                continue
            w = G.grid.weights(p)
            combined = np.zeros((2, 2))
            for term in terms:
                if isinstance(term[0], tuple):
                    (i, b), (j, a) = term
                    coef = 2 * w[i] * w[j]
                    Mij = loops.A[i] - loops.B[i] @ K[b]
                    Mji = loops.A[j] - loops.B[j] @ K[a]
                    combined += coef * 0.5 * (Mij + Mji)
                else:
                    i, a = term
                    combined += w[i] ** 2 * (loops.A[i] - loops.B[i] @ K[a])
            true = frozen_loop(G, lambda q: interp(q).reshape(1, 2), p).A
            np.testing.assert_allclose(combined, true, atol=1e-12)


@pytest.mark.filterwarnings("ignore:cannot verify system output:UserWarning")
def test_python_control_controller_on_a_gridded_plant_agrees_with_the_table():
    def upright(theta0):
        return trim_linearization(theta0, 1.0)[:, "u"]

    points = np.linspace(0.0, 1.2, 4)
    gains = [ct.lqr(upright(t), np.diag([10.0, 1.0]), 1.0)[0] for t in points]
    ctrl, _ = ct.create_statefbk_iosystem(upright(0.6), (gains, points),
                                          gainsched_indices=["xd[0]"])  # fmt: skip
    # The plant's grid is finer than the schedule's points.
    G = lpv.gss(upright, {"theta0": np.linspace(0.0, 1.2, 7)})
    from_object = lpv.certify(ctrl, G)
    from_table = lpv.certify((gains, points), G)
    assert from_object.certified and from_table.certified
    assert from_object.rate_bound == from_table.rate_bound == {"theta0": np.inf}
    assert from_object.certificate.verified


def test_frozen_unstable_schedule_is_refused_with_the_cell_and_eigenvalue(design):
    G, gains, points = design
    bad = [K.copy() for K in gains]
    # Positive feedback at the last grid point: unstable there.
    bad[-1] = -gains[-1]
    c = lpv.certify((bad, points), G)
    assert not c.certified
    example = c.counterexample
    assert isinstance(example, FrozenCounterexample)
    p = np.array([example.point["theta0"], example.point["m"]])
    interp = LinearNDInterpolator(points, np.array(bad).reshape(len(points), -1))
    S = G.at(p)
    eig = np.linalg.eigvals(S.A - S.B[:, [0]] @ interp(p).reshape(1, 2))
    assert eig.real.max() >= 0
    assert example.eigenvalue.real == pytest.approx(eig.real.max(), abs=1e-9)
    lo = G.grid.points[G.grid.corners(example.cell)[0]]
    hi = G.grid.points[G.grid.corners(example.cell)[-1]]
    assert np.all(lo <= p) and np.all(p <= hi)


def first_order(a):
    return ct.ss([[-a]], [[1.0, 1.0]], [[1.0]], 0, inputs=["u", "w"], outputs="z")


def test_objective_is_checked():
    G = lpv.gss(first_order, {"a": [1, 2]})
    table = ([np.array([[1.0]]), np.array([[1.0]])], [1.0, 2.0])
    with pytest.raises(TypeError, match="objective"):
        lpv.certify(table, G, objective="hinf")
    with pytest.raises(ValueError, match="objective: name the channel"):
        lpv.certify(table, G, objective=lpv.Hinf())
    with pytest.raises(ValueError, match="objective.w"):
        lpv.certify(table, G, objective=lpv.Hinf(w="nope", z="z"))


def test_first_order_gridded_bound_against_the_exact_worst_case():
    """x' = -(a + k(a)) x + w, z = x: one state, so the L2 gain under
    arbitrary variation is the frozen worst 1 / min(a + k(a)) (a constant P
    is exact for scalar systems)."""
    G = lpv.gss(first_order, {"a": [1.0, 2.0, 3.0]})
    gains = [np.array([[0.5]]), np.array([[0.2]]), np.array([[0.1]])]
    c = lpv.certify((gains, [1.0, 2.0, 3.0]), G, objective=lpv.Hinf(w="w", z="z"))
    a = np.linspace(1.0, 3.0, 201)
    k = np.interp(a, [1.0, 2.0, 3.0], [0.5, 0.2, 0.1])
    exact = 1.0 / np.min(a + k)
    assert c.certified
    assert exact <= c.bound <= exact * (1 + 1e-3)


# ------------------------------------------------------------ rate bounds

# The switched pair of test_certify_schedule: every convex combination is
# stable, switching between them is not.
A1 = np.array([[-0.1, 1.0], [-2.0, -0.1]])
A2 = np.array([[-0.1, 2.0], [-1.0, -0.1]])
E = np.array([[0.0, 0.3], [-0.3, 0.0]])


def integrator(p=None, q=0.0):
    """x' = q E x + u: with K(p) = -((1 - p) A1 + p A2) the closed loop is
    (1 - p) A1 + p A2 + q E."""
    return ct.ss(q * E, np.eye(2), np.eye(2), 0, inputs=["u0", "u1"])


def simulate(loop_of_t, T, x0=(1.0, 0.0)):
    from scipy.integrate import solve_ivp

    sol = solve_ivp(lambda t, x: loop_of_t(t) @ x, (0.0, T), x0, rtol=1e-9,
                    atol=1e-12, max_step=0.05)  # fmt: skip
    return sol.y


def bounded_rate_signal(rng, nu, center, amplitude):
    """A random smooth signal in center +- amplitude with |d/dt| <= nu."""
    r, w, phase = rng.uniform(0.2, 1.0, (3, 3))
    a = amplitude * r / r.sum()
    w = w * nu / np.sum(a * w)
    return lambda t: center + np.sum(a * np.sin(w * t + 2 * np.pi * phase))


def test_gridded_rate_bound_matches_the_polytopic_one_on_the_same_cell():
    table = ([-A1, -A2], [0.0, 1.0])
    polytopic = lpv.PolytopicStateSpace.from_affine(
        integrator(), {"p": (np.zeros((2, 2)), 0, 0, 0)}, {"p": (0.0, 1.0)}
    )
    gridded = lpv.gss(integrator, {"p": [0.0, 1.0]})
    a = lpv.certify(table, polytopic, counterexample=False)
    b = lpv.certify(table, gridded, counterexample=False)
    assert not a.certified and not b.certified
    assert b.rate_bound["p"] == pytest.approx(a.rate_bound["p"], rel=1e-9)


def test_finer_grid_certifies_a_rate_that_simulations_confirm():
    """P(p) on a finer grid is more flexible: a larger certified rate.
    Below it random trajectories decay; the counterexample diverges."""
    coarse = lpv.certify(([-A1, -A2], [0.0, 1.0]),
                         lpv.gss(integrator, {"p": [0.0, 1.0]}),
                         counterexample=False)  # fmt: skip
    c = lpv.certify(([-A1, -A2], [0.0, 1.0]),
                    lpv.gss(integrator, {"p": np.linspace(0.0, 1.0, 5)}))  # fmt: skip
    nu = c.rate_bound["p"]
    assert coarse.rate_bound["p"] < nu < np.inf
    assert c.certificate.verified and "multilinear" in c.certificate.statement

    def loop(p):
        return (1 - p) * A1 + p * A2

    rng = np.random.default_rng(1)
    for _ in range(4):
        p = bounded_rate_signal(rng, 0.9 * nu, 0.5, 0.5)
        x = simulate(lambda t, p=p: loop(p(t)), 120.0)
        assert np.linalg.norm(x[:, -1]) < 1e-2 * np.linalg.norm(x[:, 0])
    traj = c.counterexample
    assert traj.rate > nu
    periods = 12
    x = simulate(lambda t: loop(traj([t])[0, 0]), periods * traj.period)
    assert np.linalg.norm(x[:, -1]) > 0.5 * traj.growth**periods > 1


def test_rate_bounded_lyapunov_function_recomputed_with_numpy():
    """The rate-bounded LMIs' solution on a 5-point grid: with ``P(p)``
    piecewise linear between the grid points' matrices, ``dV/dt < 0`` for
    the loop ``(1 - p) A1 + p A2`` at dense points of every cell, both rate
    signs (this failed while a cell's dP/dt read another cell's P)."""
    from ctrl_lpv.schedules import schedule_of
    from ctrl_lpv.schedules.gridded import GriddedLoops

    axis = np.linspace(0.0, 1.0, 5)
    G = lpv.gss(integrator, {"p": axis})
    schedule = schedule_of(([-A1, -A2], [0.0, 1.0]), names=["p"])
    lmi = GriddedLoops(schedule, schedule.points, G, [0, 1])._rate_problem(1e-6)
    nu = 0.28
    lmi.set_parameter("nu", [nu])
    values = lmi.solve().values
    P = [values[f"P{i}"] for i in range(axis.size)]
    worst = -np.inf
    for c in range(axis.size - 1):
        slope = (P[c + 1] - P[c]) / (axis[c + 1] - axis[c])
        for s in np.linspace(0.0, 1.0, 21):
            p = axis[c] + s * (axis[c + 1] - axis[c])
            A = (1 - p) * A1 + p * A2
            V = (1 - s) * P[c] + s * P[c + 1]
            for rate in (-nu, nu):
                F = A.T @ V + V @ A + rate * slope
                worst = max(worst, float(np.linalg.eigvalsh(F).max()))
    assert worst < 0


def test_two_parameter_rate_bound_is_confirmed_by_simulation():
    G = lpv.gss(integrator, {"p": [0.0, 0.5, 1.0], "q": [0.0, 0.5, 1.0]})
    points = G.grid.points
    gains = [-((1 - p) * A1 + p * A2) for p, _ in points]
    c = lpv.certify((gains, points), G, counterexample=False)
    nu = c.rate_bound
    assert not c.certified and 0 < nu["p"] < np.inf and nu["p"] == nu["q"]
    assert c.certificate.verified
    rng = np.random.default_rng(2)
    for _ in range(3):
        p = bounded_rate_signal(rng, 0.9 * nu["p"], 0.5, 0.5)
        q = bounded_rate_signal(rng, 0.9 * nu["q"], 0.5, 0.5)
        x = simulate(lambda t, p=p, q=q: (1 - p(t)) * A1 + p(t) * A2 + q(t) * E,
                     150.0)  # fmt: skip
        assert np.linalg.norm(x[:, -1]) < 1e-2 * np.linalg.norm(x[:, 0])


def test_h2_bound_of_a_scalar_gridded_loop_is_the_exact_worst_case():
    """x' = -(a + k(a)) x + w, z = x: the frozen H2 norm is
    1 / sqrt(2 (a + k)); with one P the bound is exact for a scalar loop."""
    G = lpv.gss(first_order, {"a": [1.0, 2.0, 3.0]})
    gains = [np.array([[0.5]]), np.array([[0.2]]), np.array([[0.1]])]
    c = lpv.certify((gains, [1.0, 2.0, 3.0]), G, objective=lpv.H2(w="w", z="z"))
    frozen = [
        float(ct.norm(ct.ss(-(a + np.interp(a, [1, 2, 3], [0.5, 0.2, 0.1])),
                            1.0, 1.0, 0), 2))
        for a in np.linspace(1.0, 3.0, 201)
    ]  # fmt: skip
    assert c.certified
    assert max(frozen) <= c.bound <= max(frozen) * (1 + 1e-3)


def random_case(seed):
    """A random plant on a 3 x 3 grid (A, B_u, B_w varying, nonlinear in
    q) and gains near LQR at the grid points."""
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(2, 2)) - 1.5 * np.eye(2)
    dA, dB = rng.normal(scale=0.5, size=(2, 2, 2)), rng.normal(scale=0.3, size=2)

    def plant(p, q):
        A = base + p * dA[0] + np.sin(2 * q) * dA[1] + p * q * dA[0] @ dA[1]
        B = np.array([[0.0, 1.0], [1.0 + dB[0] * p * q, 0.3 + dB[1] * q]])
        return ct.ss(A, B, np.eye(2), 0, inputs=["u", "w"], outputs=["z0", "z1"])

    G = lpv.gss(plant, {"p": [0.0, 0.5, 1.0], "q": [0.0, 0.5, 1.0]})
    points = G.grid.points
    gains = [ct.lqr(G.at(x)[:, "u"], np.eye(2), 1.0)[0]
             + rng.normal(scale=0.2, size=(1, 2)) for x in points]  # fmt: skip
    return G, gains, points


def test_random_gridded_schedules_certified_are_stable_with_their_bound():
    """Whenever certify certifies a random case, every frozen loop on a grid
    ten times denser is stable and its H-infinity norm is below the bound
    (and most cases certify)."""
    certified = 0
    for seed in range(8):
        G, gains, points = random_case(seed)
        hinf = lpv.Hinf(w="w", z=["z0", "z1"])
        c = lpv.certify((gains, points), G, objective=hinf)
        if not c.certified:
            continue
        certified += 1
        table = np.array(gains).reshape(len(points), -1)
        interp = LinearNDInterpolator(points, table)
        for p in np.linspace(0.0, 1.0, 21):
            for q in np.linspace(0.0, 1.0, 21):
                S = G.at([p, q])
                loop = S.A - S.B[:, [0]] @ interp([p, q]).reshape(1, 2)
                assert np.linalg.eigvals(loop).real.max() < 0
                norm = float(ct.linfnorm(ct.ss(loop, S.B[:, [1]], S.C, 0))[0])
                assert norm <= c.bound, (seed, p, q)
    assert certified >= 4


def test_scattered_schedule_points_across_grid_cells():
    """python-control also schedules on scattered points: Delaunay triangles
    that cross the plant's grid cells (pieces found by a linear program).
    The terms reproduce the frozen loops on every piece, and the certified
    bound covers the frozen norms on a dense grid."""
    from ctrl_lpv.schedules.polytopic import gridded_loops as _gridded_loops
    from ctrl_lpv.schedules.schedule import schedule_of

    G, _, _ = random_case(5)
    rng = np.random.default_rng(11)
    corners = [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]]
    points = np.vstack([corners, rng.uniform(0.1, 0.9, size=(5, 2))])
    gains = [ct.lqr(G.at(x)[:, "u"], np.eye(2), 1.0)[0] for x in points]
    table = (gains, points)
    loops = _gridded_loops(schedule_of(table, names=G.param_names), G, table, None)
    assert len(loops.pieces) > len(loops.schedule.cells)  # triangles are split
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))
    for piece in loops.pieces:
        K = loops.corner_gains(piece)
        p = piece.inside
        w = G.grid.weights(p)
        combined = np.zeros((2, 2))
        for term in loops.products(piece):
            if isinstance(term[0], tuple):
                (i, b), (j, a) = term
                ij = loops.A[i] - loops.B[i] @ K[b]
                ji = loops.A[j] - loops.B[j] @ K[a]
                combined += w[i] * w[j] * (ij + ji)
            else:
                i, a = term
                combined += w[i] ** 2 * (loops.A[i] - loops.B[i] @ K[a])
        S = G.at(p)
        true = S.A - S.B[:, [0]] @ interp(p).reshape(1, 2)
        np.testing.assert_allclose(combined, true, atol=1e-10)
    c = lpv.certify(table, G, objective=lpv.Hinf(w="w", z=["z0", "z1"]))
    assert c.certified
    for p in np.linspace(0.0, 1.0, 21):
        for q in np.linspace(0.0, 1.0, 21):
            S = G.at([p, q])
            loop = S.A - S.B[:, [0]] @ interp([p, q]).reshape(1, 2)
            norm = float(ct.linfnorm(ct.ss(loop, S.B[:, [1]], S.C, 0))[0])
            assert norm <= c.bound
