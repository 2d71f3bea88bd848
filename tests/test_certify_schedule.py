"""`certify` on gain schedules, against independent facts.

Frozen closed-loop eigenvalues from numpy; trajectories simulated with
scipy (a destabilising one grows, rate-bounded random ones decay); the
python-control controller object and the same gains as a table agree.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv.schedules import FrozenCounterexample, ParameterTrajectory, schedule_of
from ctrl_lpv.schedules.polytopic import PolytopicLoops

# A switched pair of stable matrices without a common Lyapunov function:
# every convex combination is stable (eigenvalues -0.1 +- j w), switching
# between them is not.
A1 = np.array([[-0.1, 1.0], [-2.0, -0.1]])
A2 = np.array([[-0.1, 2.0], [-1.0, -0.1]])


def switched_plant():
    """x' = u (B = I): with K(0) = -A1, K(1) = -A2 the closed loop is
    (1 - p) A1 + p A2."""
    base = ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0, inputs=["u0", "u1"])
    return lpv.PolytopicStateSpace.from_affine(
        base, {"p": (np.zeros((2, 2)), 0, 0, 0)}, {"p": (0.0, 1.0)}
    )


def closed_loop(p):
    return (1 - p) * A1 + p * A2


def simulate(p_of_t, T, x0=(1.0, 0.0)):
    sol = solve_ivp(lambda t, x: closed_loop(float(p_of_t(t))) @ x, (0.0, T), x0,
                    rtol=1e-9, atol=1e-12, max_step=0.01)  # fmt: skip
    return sol.y


@pytest.fixture(scope="module")
def switched():
    return lpv.certify(([-A1, -A2], [0.0, 1.0]), switched_plant())


def test_frozen_stable_everywhere():
    for p in np.linspace(0, 1, 101):
        assert np.linalg.eigvals(closed_loop(p)).real.max() < 0


def test_switched_pair_has_a_finite_certified_rate(switched):
    assert not switched.certified
    assert 0.0 < switched.rate_bound["p"] < np.inf
    assert "quadratic" in " ".join(switched.tried)


def test_counterexample_diverges_in_simulation(switched):
    traj = switched.counterexample
    assert isinstance(traj, ParameterTrajectory)
    assert traj.rate > switched.rate_bound["p"]
    periods = 12
    x = simulate(lambda t: traj([t])[0, 0], periods * traj.period)
    growth = np.linalg.norm(x[:, -1]) / np.linalg.norm(x[:, 0])
    assert traj.growth > 1
    assert growth > 0.5 * traj.growth**periods > 1


def test_rate_bounded_trajectories_below_the_bound_decay(switched):
    nu = 0.9 * switched.rate_bound["p"]
    rng = np.random.default_rng(1)
    for _ in range(5):
        # p(t) = 0.5 + sum a_i sin(w_i t + phi_i), sum a_i = 0.5 (in [0, 1]),
        # |dp/dt| <= sum a_i w_i = nu.
        r, w, phase = rng.uniform(0.2, 1.0, (3, 3))
        a = 0.5 * r / r.sum()
        w = w * nu / np.sum(a * w)

        def p(t, a=a, w=w, phase=2 * np.pi * phase):
            return 0.5 + np.sum(a * np.sin(w * t + phase))

        x = simulate(p, 150.0)
        assert np.linalg.norm(x[:, -1]) < 1e-2 * np.linalg.norm(x[:, 0])


def test_the_certificate_below_the_rate_is_verified():
    c = lpv.certify(([-A1, -A2], [0.0, 1.0]), switched_plant(),
                    rate_bounds={"p": 0.1})  # fmt: skip
    assert c.certified and c.certificate.verified and c.rate_bound == {"p": 0.1}


# ------------------------------------------------------- python-control


def spring(a):
    return ct.ss([[0.0, 1.0], [-a, -0.5]], [[0.0], [1.0]], np.eye(2), 0,
                 inputs="u", states=["x0", "x1"], outputs=["x0", "x1"])  # fmt: skip


def spring_plant():
    return lpv.PolytopicStateSpace.from_affine(
        spring(0.0), {"a": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)}, {"a": (1.0, 3.0)}
    )


def test_python_control_schedule_is_read_from_the_controller():
    points = [1.0, 2.0, 3.0]
    gains = [ct.lqr(spring(a), np.eye(2), 1.0)[0] for a in points]
    ctrl, _ = ct.create_statefbk_iosystem(spring(2.0), (gains, points),
                                          gainsched_indices=["xd[0]"])  # fmt: skip
    from_object = lpv.certify(ctrl, spring_plant())
    from_table = lpv.certify((gains, points), spring_plant())
    assert from_object.certified and from_table.certified
    assert from_object.rate_bound == from_table.rate_bound == {"a": np.inf}
    assert from_object.certificate.verified


def test_two_variable_schedule_uses_the_delaunay_cells():
    def plant2(a, b):
        return ct.ss([[0.0, 1.0], [-a, -b]], [[0.0], [1.0]], np.eye(2), 0,
                     inputs="u", states=["x0", "x1"])  # fmt: skip

    G = lpv.PolytopicStateSpace.from_affine(
        plant2(0.0, 0.0),
        {"a": ([[0, 0], [-1.0, 0]], 0, 0, 0), "b": ([[0, 0], [0, -1.0]], 0, 0, 0)},
        {"a": (1.0, 3.0), "b": (0.1, 1.0)},
    )
    grid = [(a, b) for a in (1.0, 2.0, 3.0) for b in (0.1, 0.55, 1.0)]
    gains = [ct.lqr(plant2(a, b), np.eye(2), 1.0)[0] for a, b in grid]
    ctrl, _ = ct.create_statefbk_iosystem(
        plant2(2.0, 0.5), (gains, grid), gainsched_indices=["xd[0]", "xd[1]"]
    )
    schedule = schedule_of(ctrl)
    assert len(schedule.cells) == 8  # two triangles per grid square
    c = lpv.certify(ctrl, G)
    assert c.certified and c.certificate.verified
    assert c.rate_bound == lpv.certify((gains, np.array(grid)), G).rate_bound


def test_frozen_unstable_schedule_is_refused_with_cell_and_eigenvalue():
    points = [1.0, 2.0, 3.0]
    gains = [ct.lqr(spring(a), np.eye(2), 1.0)[0] for a in points]
    gains[1] = np.array([[-5.0, 0.0]])  # destabilising at a = 2
    c = lpv.certify((gains, points), spring_plant())
    assert not c.certified
    ce = c.counterexample
    assert isinstance(ce, FrozenCounterexample)
    a = ce.point["a"]
    K = np.array([[np.interp(a, points, [g[0, i] for g in gains]) for i in (0, 1)]])
    A = spring(a).A - spring(a).B @ K
    assert ce.eigenvalue.real >= 0
    assert np.isclose(np.linalg.eigvals(A).real.max(), ce.eigenvalue.real)
    assert ce.cell in (0, 1)


def test_cubic_schedule_is_refused():
    points = [1.0, 2.0, 3.0, 2.5]
    gains = [ct.lqr(spring(a), np.eye(2), 1.0)[0] for a in points]
    ctrl, _ = ct.create_statefbk_iosystem(
        spring(2.0), (gains, [[p, 0.0] for p in points[:3]] + [[2.5, 1.0]]),
        gainsched_indices=["xd[0]", "xd[1]"], gainsched_method="nearest",
    )  # fmt: skip
    with pytest.raises(ValueError, match="gainsched_method must be 'linear'"):
        schedule_of(ctrl)


def test_points_outside_the_domain_are_refused():
    gains = [ct.lqr(spring(a), np.eye(2), 1.0)[0] for a in (1.0, 4.0)]
    with pytest.raises(ValueError, match="outside the plant's domain"):
        lpv.certify((gains, [1.0, 4.0]), spring_plant())


def test_input_matrix_varying_with_scheduled_gains():
    """B_u(p) K(p) is quadratic on a cell: the pairwise terms span it. The
    closed loops at dense frozen points are all stable and, for arbitrary
    rates, the verdict holds in a fast switching simulation."""

    def vehicle(v):  # lateral error and heading of a car at speed v
        return ct.ss([[0.0, v], [0.0, 0.0]], [[0.0], [v / 3.0]], np.eye(2), 0,
                     inputs="delta", states=["y", "theta"])  # fmt: skip

    G = lpv.PolytopicStateSpace.from_affine(
        vehicle(0.0), {"v": ([[0, 1.0], [0, 0]], [[0.0], [1 / 3.0]], 0, 0)},
        {"v": (2.0, 10.0)},
    )  # fmt: skip
    points = [2.0, 5.0, 10.0]
    gains = [ct.lqr(vehicle(v), np.diag([1.0, 1.0]), 1.0)[0] for v in points]
    c = lpv.certify((gains, points), G)
    for v in np.linspace(2.0, 10.0, 81):
        K = np.array([[np.interp(v, points, [g[0, i] for g in gains]) for i in (0, 1)]])
        assert np.linalg.eigvals(vehicle(v).A - vehicle(v).B @ K).real.max() < 0
    assert c.certified and c.rate_bound == {"v": np.inf}, str(c)

    def rhs(t, x):
        v = 2.0 if np.sin(20.0 * t) > 0 else 10.0
        K = np.array([[np.interp(v, points, [g[0, i] for g in gains]) for i in (0, 1)]])
        return (vehicle(v).A - vehicle(v).B @ K) @ x

    x = solve_ivp(rhs, (0.0, 30.0), [1.0, 0.0], max_step=0.01).y
    assert np.linalg.norm(x[:, -1]) < 1e-3


def test_a_design_is_certified_on_another_plant():
    """A scheduled design of the nominal model, certified on a plant whose
    damping is lower than the model's: the frozen loops are stable, and the
    design's own gains are read."""
    design = lpv.synthesize(spring_plant(), "u", gains="scheduled")
    lighter = ct.ss([[0.0, 1.0], [0.0, -0.2]], [[0.0], [1.0]], np.eye(2), 0,
                    inputs="u", states=["x0", "x1"], outputs=["x0", "x1"])  # fmt: skip
    true = lpv.PolytopicStateSpace.from_affine(
        lighter, {"a": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)}, {"a": (1.0, 3.0)}
    )
    for a in np.linspace(1.0, 3.0, 21):
        K = np.tensordot(true.weights({"a": a}), np.array(design.gains), axes=1)
        frozen = true.at({"a": a})
        assert np.linalg.eigvals(frozen.A - frozen.B @ K).real.max() < 0
    c = lpv.certify(design, true)
    np.testing.assert_array_equal(schedule_of(design).gains, np.array(design.gains))
    assert c.certified and c.rate_bound == {"a": np.inf}


# ------------------------------------------------------------- objective


def steered(v):
    """The vehicle of the test above with a heading disturbance w."""
    return ct.ss([[0.0, v], [0.0, 0.0]], [[0.0, 0.0], [v / 3.0, 1.0]],
                 [[1.0, 0.0]], 0, inputs=["delta", "w"], outputs="y",
                 states=["y", "theta"])  # fmt: skip


def test_l2_bound_covers_the_frozen_norms_on_polytopic_and_gridded_plants():
    """B_u and K both vary: the pairwise terms span the channel. The bound
    is at least control's H-infinity norm of every frozen loop on a dense
    grid, and the polytopic and gridded models of the same (affine) plant
    give the same bound (the same terms)."""
    polytopic = lpv.PolytopicStateSpace.from_affine(
        steered(0.0), {"v": ([[0, 1.0], [0, 0]], [[0.0, 0.0], [1 / 3.0, 0.0]], 0, 0)},
        {"v": (2.0, 10.0)},
    )  # fmt: skip
    points = [2.0, 5.0, 10.0]
    gridded = lpv.gss(steered, {"v": points})
    gains = [ct.lqr(steered(v)[:, "delta"], np.eye(2), 1.0)[0] for v in points]
    hinf = lpv.Hinf(w="w", z="y")
    on_polytope = lpv.certify((gains, points), polytopic, objective=hinf)
    on_grid = lpv.certify((gains, points), gridded, objective=hinf)
    worst = 0.0
    for v in np.linspace(2.0, 10.0, 81):
        K = np.array([[np.interp(v, points, [g[0, i] for g in gains]) for i in (0, 1)]])
        S = steered(v)
        loop = ct.ss(S.A - S.B[:, [0]] @ K, S.B[:, [1]], S.C, 0)
        worst = max(worst, float(ct.linfnorm(loop)[0]))
    for c in (on_polytope, on_grid):
        assert c.certified and c.certificate.verified, str(c)
        assert c.bound >= worst
    assert on_grid.bound == pytest.approx(on_polytope.bound, rel=1e-3)


# ------------------------------------- rate bounds with B_u and K varying


def bilinear_pair():
    """x' = (1 + p) u with K(0) = -A1, K(1) = -A2 / 2: the loop
    -(1 + p) K(p) is A1 at p = 0, A2 at p = 1 and quadratic in p between
    (B_u and the gains both vary); no quadratic Lyapunov function exists
    (the switched pair's vertices are among the loops)."""
    base = ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0, inputs=["u0", "u1"])
    plant = lpv.PolytopicStateSpace.from_affine(
        base, {"p": (np.zeros((2, 2)), np.eye(2), 0, 0)}, {"p": (0.0, 1.0)}
    )
    gains = [-A1, -A2 / 2.0]

    def loop(p):
        return -(1.0 + p) * ((1.0 - p) * gains[0] + p * gains[1])

    return plant, gains, loop


@pytest.fixture(scope="module")
def bilinear():
    plant, gains, loop = bilinear_pair()
    return lpv.certify((gains, [0.0, 1.0]), plant), loop


def test_bilinear_schedule_gets_a_finite_certified_rate(bilinear):
    verdict, loop = bilinear
    for p in np.linspace(0.0, 1.0, 101):  # frozen-stable everywhere
        assert np.linalg.eigvals(loop(p)).real.max() < 0
    assert not verdict.certified
    assert 0.0 < verdict.rate_bound["p"] < np.inf, str(verdict)
    assert verdict.certificate.verified


def test_bilinear_counterexample_diverges_in_simulation(bilinear):
    """The trajectory, simulated with the exact (quadratic) loop."""
    verdict, loop = bilinear
    traj = verdict.counterexample
    assert isinstance(traj, ParameterTrajectory)
    assert traj.rate > verdict.rate_bound["p"]
    periods = 10
    sol = solve_ivp(lambda t, x: loop(traj([t])[0, 0]) @ x,
                    (0.0, periods * traj.period), [1.0, 0.0], rtol=1e-9,
                    atol=1e-12, max_step=0.01)  # fmt: skip
    growth = np.linalg.norm(sol.y[:, -1])
    assert growth > 0.5 * traj.growth**periods > 1


def test_bilinear_rate_bounded_trajectories_decay(bilinear):
    verdict, loop = bilinear
    nu = 0.9 * verdict.rate_bound["p"]
    rng = np.random.default_rng(3)
    for _ in range(4):
        r, w, phase = rng.uniform(0.2, 1.0, (3, 3))
        a = 0.5 * r / r.sum()
        w = w * nu / np.sum(a * w)

        def p(t, a=a, w=w, phase=2 * np.pi * phase):
            return 0.5 + np.sum(a * np.sin(w * t + phase))

        sol = solve_ivp(lambda t, x: loop(p(t)) @ x, (0.0, 200.0), [1.0, 0.0],
                        rtol=1e-8, atol=1e-12, max_step=0.05)  # fmt: skip
        assert np.linalg.norm(sol.y[:, -1]) < 1e-3


def test_bilinear_given_rate_is_checked_not_bisected(bilinear):
    """rate_bounds: below the certified rate certified, far above refused."""
    verdict, _ = bilinear
    plant, gains, _ = bilinear_pair()
    nu = verdict.rate_bound["p"]
    below = lpv.certify((gains, [0.0, 1.0]), plant, rate_bounds={"p": 0.5 * nu})
    above = lpv.certify((gains, [0.0, 1.0]), plant, rate_bounds={"p": 100 * nu})
    assert below.certified and below.certificate.verified
    assert not above.certified and above.rate_bound == {"p": 0.0}


def test_one_state_polytopic_plant():
    """x' = -(a + k(a)) x: with k >= 0 every loop decays (V = x^2 serves for
    any variation), and the schedule of a one-state plant is certified."""
    plant = lpv.pss(
        [ct.ss([[-a]], [[1.0]], [[1.0]], 0, inputs="u") for a in (1.0, 2.0)],
        {"a": (1.0, 2.0)},
    )
    cert = lpv.certify(([np.array([[1.0]]), np.array([[2.0]])], [1.0, 2.0]), plant)
    assert cert.certified and cert.certificate.verified


# ------------------------------------------- an L2 gain under a rate bound

BW = np.array([1.0, 0.5])


def switched_channel_plant(points=None):
    """The switched pair with a disturbance ``w`` (``B_w`` = `BW`) and the
    state as output; polytopic, or gridded on `points`."""
    base = ct.ss(np.zeros((2, 2)), np.column_stack([np.eye(2), BW]), np.eye(2), 0,
                 inputs=["u0", "u1", "w"], outputs=["y0", "y1"])  # fmt: skip
    if points is None:
        return lpv.PolytopicStateSpace.from_affine(
            base, {"p": (np.zeros((2, 2)), 0, 0, 0)}, {"p": (0.0, 1.0)}
        )
    return lpv.gss(lambda p: base, {"p": points})


def l2_ratio(p_of_t, w_of_t, T):
    """sqrt(int z'z / int w'w) from rest, z = y0, w on [0, T/2], then free."""

    def rhs(t, s):
        x, w = s[:2], w_of_t(t)
        dx = closed_loop(float(p_of_t(t))) @ x + BW * w
        return np.concatenate([dx, [x[0] ** 2, w**2]])

    sol = solve_ivp(rhs, (0.0, T), np.zeros(4), rtol=1e-9, atol=1e-12, max_step=0.01)
    return np.sqrt(sol.y[2, -1] / sol.y[3, -1])


@pytest.fixture(scope="module")
def bounded_under_rate(switched):
    nu = 0.5 * switched.rate_bound["p"]
    hinf = lpv.Hinf(w="w", z="y0")
    table = ([-A1, -A2], [0.0, 1.0])
    polytopic = lpv.certify(table, switched_channel_plant(), objective=hinf,
                            rate_bounds={"p": nu})  # fmt: skip
    gridded = lpv.certify(table, switched_channel_plant([0.0, 1.0]), objective=hinf,
                          rate_bounds={"p": nu})  # fmt: skip
    return nu, polytopic, gridded


def test_l2_gain_under_a_rate_bound_covers_frozen_norms(bounded_under_rate):
    """The schedule has no common Lyapunov function, so no bound holds for
    arbitrary rates; under half its certified rate the L2 gain is bounded,
    above every frozen loop's H-infinity norm (control's), and the polytopic
    and gridded models of the same plant (one cell) give the same bound."""
    nu, polytopic, gridded = bounded_under_rate
    worst = max(
        float(ct.linfnorm(ct.ss(closed_loop(p), BW[:, None], [[1.0, 0.0]], 0))[0])
        for p in np.linspace(0.0, 1.0, 41)
    )
    for c in (polytopic, gridded):
        assert c.certified and c.certificate.verified, str(c)
        assert c.rate_bound == {"p": nu}
        assert worst <= c.bound < np.inf
    assert gridded.bound == pytest.approx(polytopic.bound, rel=1e-3)


def test_l2_gain_under_a_rate_bound_holds_in_simulation(bounded_under_rate):
    """From rest, random parameter trajectories within the rate bound and
    random disturbances: the output's energy ratio stays below the bound."""
    nu, polytopic, _ = bounded_under_rate
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(4):
        r, w, phase = rng.uniform(0.2, 1.0, (3, 3))
        a = 0.5 * r / r.sum()
        w = w * nu / np.sum(a * w)
        freq, amp = rng.uniform(0.2, 3.0, 4), rng.standard_normal(4)

        def p(t, a=a, w=w, phase=2 * np.pi * phase):
            return 0.5 + np.sum(a * np.sin(w * t + phase))

        def dist(t, freq=freq, amp=amp):
            return float(amp @ np.sin(freq * t)) if t < 40.0 else 0.0

        worst = max(worst, l2_ratio(p, dist, 80.0))
    assert 0.0 < worst <= polytopic.bound


def test_l2_gain_at_rate_zero_is_the_worst_frozen_norm(switched):
    """Frozen parameters (rate 0): the bound is at least, and on this one-
    parameter schedule within 1 % of, the largest frozen H-infinity norm."""
    hinf = lpv.Hinf(w="w", z="y0")
    table = ([-A1, -A2], [0.0, 1.0])
    c = lpv.certify(table, switched_channel_plant(), objective=hinf,
                    rate_bounds={"p": 0.0})  # fmt: skip
    worst = max(
        float(ct.linfnorm(ct.ss(closed_loop(p), BW[:, None], [[1.0, 0.0]], 0))[0])
        for p in np.linspace(0.0, 1.0, 201)
    )
    assert c.certified and worst <= c.bound <= 1.01 * worst


def test_h2_under_a_rate_bound_says_it_is_not_bounded(switched):
    c = lpv.certify(([-A1, -A2], [0.0, 1.0]), switched_channel_plant(),
                    objective=lpv.H2(w="w", z="y0"),
                    rate_bounds={"p": 0.5 * switched.rate_bound["p"]})  # fmt: skip
    assert not c.certified and c.bound is None
    assert "only the L2 gain" in " ".join(c.tried)


def test_objective_without_rate_bounds_asks_for_them(switched):
    hinf = lpv.Hinf(w="w", z="y0")
    c = lpv.certify(([-A1, -A2], [0.0, 1.0]), switched_channel_plant(),
                    objective=hinf, counterexample=False)  # fmt: skip
    assert not c.certified and c.bound is None
    assert c.rate_bound["p"] == pytest.approx(switched.rate_bound["p"], rel=0.1)
    assert "pass rate_bounds=" in " ".join(c.tried)


def test_l2_gain_under_a_rate_bound_when_input_matrix_and_gains_vary():
    """The steering schedule (B_u and K both vary with the speed): the L2
    gain under a rate bound (a cubic form in the cell's coordinates) is
    certified, at least every frozen loop's H-infinity norm (control's), and
    reported only where it is below the bound for arbitrary rates."""
    polytopic = lpv.PolytopicStateSpace.from_affine(
        steered(0.0), {"v": ([[0, 1.0], [0, 0]], [[0.0, 0.0], [1 / 3.0, 0.0]], 0, 0)},
        {"v": (2.0, 10.0)},
    )  # fmt: skip
    points = [2.0, 5.0, 10.0]
    gains = [ct.lqr(steered(v)[:, "delta"], np.eye(2), 1.0)[0] for v in points]
    hinf = lpv.Hinf(w="w", z="y")
    anyrate = lpv.certify((gains, points), polytopic, objective=hinf)
    slow = lpv.certify((gains, points), polytopic, objective=hinf,
                       rate_bounds={"v": 0.01})  # fmt: skip
    assert slow.certified and slow.certificate.verified, str(slow)
    assert any("with P(p), rates [0.01]" in t and "not" not in t for t in slow.tried)
    # The rate-bounded bound itself (certify reports the smaller of the two).
    loops = PolytopicLoops.of(schedule_of((gains, points), names=["v"]), polytopic,
                              (gains, points), None)  # fmt: skip
    under, certificate = loops.rate_bound(hinf, np.array([0.01]), 1e-6)
    assert certificate.verified
    worst = 0.0
    for v in np.linspace(2.0, 10.0, 81):
        K = np.array([[np.interp(v, points, [g[0, i] for g in gains]) for i in (0, 1)]])
        S = steered(v)
        loop = ct.ss(S.A - S.B[:, [0]] @ K, S.B[:, [1]], S.C, 0)
        worst = max(worst, float(ct.linfnorm(loop)[0]))
    assert worst <= slow.bound <= anyrate.bound
    assert worst <= under < np.inf
