"""Rate-bounded synthesis on a `GriddedStateSpace` (``lyapunov="affine"``).

Checked against independent facts: a plant for which no constant Lyapunov
matrix exists (an argument on the data, below) gets a design for a bounded
rate; the frozen closed loops on a grid ten times denser (``G.at(p)``
under the gains interpolated by numpy/scipy, as python-control interpolates
them) are stable and their `control.linfnorm` is below the certified bound;
simulated random parameter trajectories within the rate bound converge;
`certify`, called here on the design's table, confirms the rate and the
bound; a rate bound helps (the bound is below the one for arbitrary rates).
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.interpolate import LinearNDInterpolator

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import SynthesisError

# ------------------------------------------------- a rotating input matrix

# x' = A x + b(p) u with A unstable (eigenvalues 0.2 +- i) and b(p) turning
# half a circle as p goes from 0 to pi.
A_ROT = np.array([[0.2, 1.0], [-1.0, 0.2]])


def rotating(p):
    b = np.array([[np.cos(p)], [np.sin(p)]])
    return ct.ss(A_ROT, b, np.eye(2), 0, inputs="u", outputs=["x0", "x1"])


@pytest.fixture(scope="module")
def rotating_plant():
    return lpv.gss(rotating, {"p": np.linspace(0.0, np.pi, 7)})


def bounded_rate_signal(rng, nu, center, amplitude):
    """A random smooth signal in center +- amplitude with |d/dt| <= nu."""
    r, w, phase = rng.uniform(0.2, 1.0, (3, 3))
    a = amplitude * r / r.sum()
    w = w * nu / np.sum(a * w)
    return lambda t: center + np.sum(a * np.sin(w * t + 2 * np.pi * phase))


def test_rotating_input_no_constant_lyapunov_matrix_but_a_rate_bounded_design(
    rotating_plant,
):
    """With one W, ``A W + W A' + b Z + Z' b' < 0`` at every p needs
    ``v' (A W + W A') v < 0`` for every v orthogonal to some b(p): the
    interpolated b turns from (1, 0) to (-1, 0), so every direction is
    orthogonal to one of them, and A would be Hurwitz. It is not."""
    G = rotating_plant
    assert np.linalg.eigvals(A_ROT).real.max() > 0
    with pytest.raises(SynthesisError):
        lpv.synthesize(G, "u", solvers="CLARABEL")
    nu = 0.1
    design = lpv.synthesize(G, "u", lyapunov="affine", rate_bounds={"p": nu})
    assert design.certificate.certified and design.gamma is None
    assert design.certificate.rate_bound == {"p": nu}
    # The independent analysis on the table, as a user would call it.
    verdict = lpv.certify(design.table, G, rate_bounds={"p": nu})
    assert verdict.certified and verdict.certificate.verified
    assert not lpv.certify(design.table, G, counterexample=False).certified

    points = G.grid.points[:, 0]
    gains = np.array(design.gains)[:, 0, :]

    b = np.array([rotating(p).B[:, 0] for p in points])

    def interpolated(p, values):
        return np.array([np.interp(p, points, values[:, j]) for j in range(2)])

    def loop(p):
        """The model between grid points: b and K interpolated linearly."""
        return A_ROT - np.outer(interpolated(p, b), interpolated(p, gains))

    for p in np.linspace(0.0, np.pi, 61):  # 10x the design grid
        np.testing.assert_allclose(G.at([p]).B[:, 0], interpolated(p, b), atol=1e-12)
        assert np.linalg.eigvals(loop(p)).real.max() < 0
    rng = np.random.default_rng(4)
    for _ in range(3):
        traj = bounded_rate_signal(rng, 0.95 * nu, 0.5 * np.pi, 0.5 * np.pi)
        sol = solve_ivp(lambda t, x, traj=traj: loop(traj(t)) @ x, (0.0, 80.0),
                        [1.0, 0.5], rtol=1e-9, atol=1e-12, max_step=0.1)  # fmt: skip
        assert np.linalg.norm(sol.y[:, -1]) < 1e-3 * np.linalg.norm(sol.y[:, 0])


# ----------------------------------------------------- the pendulum, H-inf

GRAVITY, DAMPING = 9.81, 0.5


def pendulum_dynamics(t, x, u, params):
    m = params.get("m", 1.0)
    # w disturbs the angle's rate; the control acts through the torque.
    torque = -m * GRAVITY * np.sin(x[0]) - DAMPING * x[1] + u[0]
    return [x[1] + u[1], torque / m]


PENDULUM = ct.nlsys(pendulum_dynamics, None, inputs=["u", "w"],
                    states=["theta", "omega"], outputs=["theta", "omega"],
                    params={"m": 1.0})  # fmt: skip
HINF = lpv.Hinf(w="w", z=["theta", "effort"])


def with_effort(theta0, m=1.0):
    """The pendulum linearized at the trim angle theta0, with the control
    effort as a third output."""
    lin = ct.linearize(PENDULUM, [theta0, 0.0], [m * GRAVITY * np.sin(theta0), 0.0],
                       params={"m": m}, copy_names=True)  # fmt: skip
    C = np.vstack([lin.C, [0.0, 0.0]])
    D = np.vstack([lin.D, [1.0, 0.0]])
    outputs = ["theta", "omega", "effort"]
    return ct.ss(lin.A, lin.B, C, D, inputs=lin.input_labels,
                 states=lin.state_labels, outputs=outputs)  # fmt: skip


def channel(S, K):
    """The frozen loop from w to (theta, effort) under u = -K x."""
    return ct.ss(S.A - S.B[:, [0]] @ K, S.B[:, [1]],
                 S.C[[0, 2]] - S.D[[0, 2]][:, [0]] @ K, 0)  # fmt: skip


@pytest.mark.filterwarnings("ignore:cannot verify system output:UserWarning")
def test_rate_bounded_hinf_design_on_one_parameter():
    G = lpv.gss(with_effort, {"theta0": np.linspace(0.0, 1.2, 4)})
    arbitrary = lpv.synthesize(G, "u", objective=HINF)
    nu = 0.1
    design = lpv.synthesize(G, "u", objective=HINF, lyapunov="affine",
                            rate_bounds={"theta0": nu})  # fmt: skip
    # A rate bound helps: a clearly smaller certified bound.
    assert design.gamma < 0.8 * arbitrary.gamma
    verdict = lpv.certify(design.table, G, objective=HINF,
                          rate_bounds={"theta0": nu})  # fmt: skip
    assert verdict.certified and verdict.certificate.verified
    assert verdict.bound == pytest.approx(design.gamma, rel=1e-6)
    assert verdict.rate_bound == {"theta0": nu}
    points = G.grid.points[:, 0]
    gains = np.array(design.gains)[:, 0, :]
    worst = 0.0
    for theta0 in np.linspace(0.0, 1.2, 31):  # 10x the design grid
        K = np.array([[np.interp(theta0, points, gains[:, j]) for j in range(2)]])
        loop = channel(G.at([theta0]), K)
        assert np.linalg.eigvals(loop.A).real.max() < 0
        worst = max(worst, float(ct.linfnorm(loop)[0]))
    assert worst <= design.gamma
    # The frozen norms are a lower bound of any rate's bound: not vacuous.
    assert design.gamma < 3 * worst
    # The table drives python-control's scheduled controller, certified as is.
    sys = with_effort(0.6)[["theta", "omega"], "u"]
    ctrl, _ = ct.create_statefbk_iosystem(sys, design.table,
                                          gainsched_indices=["xd[0]"])  # fmt: skip
    from_object = lpv.certify(ctrl, G, objective=HINF, rate_bounds={"theta0": nu})
    assert from_object.certified
    assert from_object.bound == pytest.approx(design.gamma, rel=1e-3)


def test_rate_bounded_l2_bound_holds_along_simulated_parameter_trajectories():
    """From rest, ``||z||_2 <= gamma ||w||_2`` for a random disturbance
    while theta0 moves at up to the rate bound (the model between grid
    points interpolated linearly, as `GriddedStateSpace` does)."""
    grid = np.linspace(0.0, 1.2, 4)
    G = lpv.gss(with_effort, {"theta0": grid})
    nu = 0.1
    design = lpv.synthesize(G, "u", objective=HINF, lyapunov="affine",
                            rate_bounds={"theta0": nu})  # fmt: skip
    data = [with_effort(t) for t in grid]
    A, B, C, D = (np.array([getattr(S, name) for S in data]) for name in "ABCD")
    K = np.array(design.gains)

    def at(M, theta0):
        """M (given at the grid points) interpolated linearly at theta0."""
        i = min(max(int(np.searchsorted(grid, theta0)) - 1, 0), len(grid) - 2)
        f = (theta0 - grid[i]) / (grid[i + 1] - grid[i])
        return (1 - f) * M[i] + f * M[i + 1]

    rng = np.random.default_rng(11)
    T = 30.0
    for _ in range(2):
        theta0 = bounded_rate_signal(rng, 0.95 * nu, 0.6, 0.6)
        a, f, phase = rng.uniform(0.2, 1.0, (3, 4))
        f = 3 * f

        def w(t, a=a, f=f, phase=phase):
            return float(np.sum(a * np.sin(f * t + 2 * np.pi * phase))) * (t < 0.6 * T)

        def rhs(t, xe, theta0=theta0, w=w):
            p = theta0(t)
            Kp = at(K, p)
            x = xe[:2]
            dx = (at(A, p) - at(B, p)[:, [0]] @ Kp) @ x + at(B, p)[:, 1] * w(t)
            Cp, Dp = at(C, p), at(D, p)
            z = (Cp[[0, 2]] - Dp[[0, 2]][:, [0]] @ Kp) @ x + Dp[[0, 2], 1] * w(t)
            return np.concatenate([dx, [z @ z, w(t) ** 2]])

        sol = solve_ivp(rhs, (0.0, T), np.zeros(4), rtol=1e-8, atol=1e-10,
                        max_step=0.1)  # fmt: skip
        energy_z, energy_w = sol.y[2, -1], sol.y[3, -1]
        assert energy_w > 0.1
        gain = np.sqrt(energy_z / energy_w)
        assert gain <= design.gamma


def test_a_design_certify_refuses_is_not_returned(monkeypatch):
    """The design is returned only with `certify`'s verdict: stand in a
    refusing `certify` and the synthesis raises."""
    import ctrl_lpv.schedules as schedules
    from ctrl_lpv.certificate import Certificate
    from ctrl_lpv.exceptions import CertificationError
    from ctrl_lpv.schedules import ScheduleCertificate

    def refusing(*args, **kwargs):
        return ScheduleCertificate(False, {"theta0": 0.0}, None, Certificate(()))

    G = lpv.gss(with_effort, {"theta0": np.linspace(0.0, 1.2, 3)})
    monkeypatch.setattr(schedules, "certify", refusing)
    with pytest.raises(CertificationError, match="not certified by certify"):
        lpv.synthesize(G, "u", objective=HINF, lyapunov="affine",
                       rate_bounds={"theta0": 0.1})  # fmt: skip


def test_bad_rate_bounds_are_refused_naming_the_argument():
    G = lpv.gss(with_effort, {"theta0": [0.0, 0.6]})
    with pytest.raises(
        ValueError, match=r"rate_bounds: unknown parameter\(s\) \['m'\]"
    ):
        lpv.synthesize(G, "u", lyapunov="affine", rate_bounds={"m": 1.0})
    with pytest.raises(ValueError, match=r"rate_bounds\['theta0'\]"):
        lpv.synthesize(G, "u", lyapunov="affine", rate_bounds={"theta0": -1.0})
    with pytest.raises(TypeError, match="rate_bounds: expected a mapping"):
        lpv.synthesize(G, "u", lyapunov="affine", rate_bounds=[1.0])
    with pytest.raises(ValueError, match=r"rate_bounds: unknown parameter"):
        lpv.certify(([np.zeros((1, 2))] * 2, [0.0, 0.6]), G, rate_bounds={"m": 1})
    discrete = lpv.gss(lambda theta0: ct.c2d(with_effort(theta0), 0.01),
                       {"theta0": [0.0, 0.6]})  # fmt: skip
    with pytest.raises(ValueError, match="continuous-time"):
        lpv.synthesize(discrete, "u", lyapunov="affine", rate_bounds={"theta0": 1.0})


@pytest.mark.slow
def test_two_parameter_hinf_design_with_b_and_gains_varying():
    """``B_u`` depends on m: the loop is quadratic in the cell's weights
    (pairs in the synthesis, triples in `certify`). One rate bound given,
    the other parameter arbitrarily fast."""
    axes = {"theta0": np.linspace(0.0, 1.2, 3), "m": np.linspace(0.8, 1.25, 3)}
    G = lpv.gss(with_effort, axes)
    arbitrary = lpv.synthesize(G, "u", objective=HINF)
    both = lpv.synthesize(G, "u", objective=HINF, lyapunov="affine",
                          rate_bounds={"theta0": 0.1, "m": 0.1})  # fmt: skip
    one = lpv.synthesize(G, "u", objective=HINF, lyapunov="affine",
                         rate_bounds={"theta0": 0.1})  # fmt: skip
    assert one.certificate.rate_bound == {"theta0": 0.1, "m": np.inf}
    assert both.gamma < 0.8 * arbitrary.gamma
    assert one.gamma < arbitrary.gamma
    points = G.grid.points
    for design in (both, one):
        interp = LinearNDInterpolator(points, np.array(design.gains).reshape(9, 2))
        worst = 0.0
        for theta0 in np.linspace(0.0, 1.2, 21):
            for m in np.linspace(0.8, 1.25, 21):
                loop = channel(G.at([theta0, m]), interp([theta0, m]).reshape(1, 2))
                assert np.linalg.eigvals(loop.A).real.max() < 0
                worst = max(worst, float(ct.linfnorm(loop)[0]))
        assert worst <= design.gamma


# --------------------------------------- certify: what the synthesis relies on


def test_certify_rate_bound_when_input_matrix_and_gains_both_vary(rotating_plant):
    """An LQR schedule on the rotating plant: frozen stable, no common
    Lyapunov function (the argument above holds for any gains), so the
    rate-bounded analysis (triples of terms: b and K both vary on a cell)
    gives a finite rate; below it random trajectories of the model decay."""
    G = rotating_plant
    points = G.grid.points[:, 0]
    gains = [ct.lqr(rotating(p), np.eye(2), 1.0)[0] for p in points]
    c = lpv.certify((gains, points), G, counterexample=False)
    nu = c.rate_bound["p"]
    assert not c.certified and 0 < nu < np.inf and c.certificate.verified
    assert lpv.certify((gains, points), G, rate_bounds={"p": 0.5 * nu}).certified
    b = np.array([rotating(p).B[:, 0] for p in points])
    K = np.array(gains)[:, 0, :]

    def loop(p):
        bp = np.array([np.interp(p, points, b[:, j]) for j in range(2)])
        Kp = np.array([np.interp(p, points, K[:, j]) for j in range(2)])
        return A_ROT - np.outer(bp, Kp)

    rng = np.random.default_rng(5)
    for _ in range(3):
        traj = bounded_rate_signal(rng, 0.9 * nu, 0.5 * np.pi, 0.5 * np.pi)
        sol = solve_ivp(lambda t, x, traj=traj: loop(traj(t)) @ x, (0.0, 60.0),
                        [1.0, 0.5], rtol=1e-9, atol=1e-12, max_step=0.1)  # fmt: skip
        assert np.linalg.norm(sol.y[:, -1]) < 1e-3 * np.linalg.norm(sol.y[:, 0])


def test_certify_rate_bounded_hinf_bound_between_frozen_norms_and_arbitrary_rates():
    """A rate-bounded L2 bound (``B_u`` varies with m: triples of terms)
    is at least every frozen norm (frozen parameters have rate 0) and at
    most the bound for arbitrary rates."""
    axes = {"theta0": np.linspace(0.0, 1.2, 3), "m": np.linspace(0.8, 1.25, 3)}
    G = lpv.gss(with_effort, axes)
    points = G.grid.points
    gains = [ct.lqr(G.at(p)[:, "u"], np.diag([10.0, 1.0]), 1.0)[0] for p in points]
    arbitrary = lpv.certify((gains, points), G, objective=HINF)
    slow = lpv.certify((gains, points), G, objective=HINF,
                       rate_bounds={"theta0": 0.1, "m": 0.1})  # fmt: skip
    assert arbitrary.certified and slow.certified and slow.certificate.verified
    assert slow.rate_bound == {"theta0": 0.1, "m": 0.1}
    assert slow.bound <= arbitrary.bound
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))
    worst = max(
        float(ct.linfnorm(channel(G.at([a, m]), interp([a, m]).reshape(1, 2)))[0])
        for a in np.linspace(0.0, 1.2, 11)
        for m in np.linspace(0.8, 1.25, 11)
    )
    assert worst <= slow.bound


# The switched pair of tests/test_certify_gridded.py: with K(p) = -((1 - p)
# A1 + p A2) on x' = u, the closed loop is (1 - p) A1 + p A2.
A1 = np.array([[-0.1, 1.0], [-2.0, -0.1]])
A2 = np.array([[-0.1, 2.0], [-1.0, -0.1]])


def integrator(p):
    return ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0, inputs=["u0", "u1"])


@pytest.mark.parametrize("case", ["switched pair", "rotating input"])
def test_certified_lyapunov_function_decreases_between_the_grid_points(case):
    """The ``P_i`` of the rate-bounded analysis, read as documented (``P``
    linear between grid points), make ``A_cl' P + P A_cl + (dp/dt) dP/dp``
    negative definite at dense points of every cell for both signs of the
    rate. (Regression: the derivative once took the last cell's ``P`` on
    every cell, and certified 0.308 and 0.440 on three and five points for
    the switched pair, where this check fails.)"""
    from ctrl_lpv.schedules.polytopic import gridded_loops as _gridded_loops
    from ctrl_lpv.schedules.schedule import schedule_of

    if case == "switched pair":
        G = lpv.gss(integrator, {"p": np.linspace(0.0, 1.0, 5)})
        table = ([-A1, -A2], [0.0, 1.0])

        def loop(p):
            return (1 - p) * A1 + p * A2

    else:
        points = np.linspace(0.0, np.pi, 7)
        G = lpv.gss(rotating, {"p": points})
        gains = [ct.lqr(rotating(p), np.eye(2), 1.0)[0] for p in points]
        table = (gains, points)
        b = np.array([rotating(p).B[:, 0] for p in points])
        K = np.array(gains)[:, 0, :]

        def loop(p):
            bp = [np.interp(p, points, b[:, j]) for j in range(2)]
            Kp = [np.interp(p, points, K[:, j]) for j in range(2)]
            return A_ROT - np.outer(bp, Kp)

    nu = lpv.certify(table, G, counterexample=False).rate_bound["p"]
    assert 0 < nu < np.inf
    loops = _gridded_loops(schedule_of(table, names=G.param_names), G, table, None)
    lmi = loops._rate_problem(1e-6)
    lmi.set_parameter("nu", [nu])
    solution = lmi.solve()
    grid = G.grid.points[:, 0]
    P = [getattr(solution, f"P{i}") for i in range(len(grid))]
    for i in range(len(grid) - 1):
        h = grid[i + 1] - grid[i]
        slope = (P[i + 1] - P[i]) / h
        for f in np.linspace(0.0, 1.0, 11):
            p = grid[i] + f * h
            Pp = (1 - f) * P[i] + f * P[i + 1]
            M = loop(p)
            for sign in (-1.0, 1.0):
                Q = M.T @ Pp + Pp @ M + sign * nu * slope
                assert np.linalg.eigvalsh(Q).max() < 0, (case, p, sign)


def test_certified_bounded_real_inequality_holds_between_the_grid_points():
    """The rate-bounded L2 bound's ``P_i`` and ``g`` (``B_u`` varies with
    m, the gains with both parameters: the cubic relaxation), read as
    documented (``P`` multilinear on each cell), satisfy the bounded-real
    inequality with ``dP/dt`` at the corners of the rate box, at points
    inside the cells (``G.at`` and scipy's interpolation of the gains)."""
    from ctrl_lpv.schedules.polytopic import gridded_loops as _gridded_loops
    from ctrl_lpv.schedules.schedule import schedule_of

    axes = {"theta0": np.linspace(0.0, 1.2, 3), "m": np.linspace(0.8, 1.25, 3)}
    G = lpv.gss(with_effort, axes)
    points = G.grid.points
    gains = [ct.lqr(G.at(p)[:, "u"], np.diag([10.0, 1.0]), 1.0)[0] for p in points]
    table = (gains, points)
    nu = np.array([0.1, 0.1])
    loops = _gridded_loops(schedule_of(table, names=G.param_names), G, table, None)
    lmi = loops._rate_problem(1e-6, (), HINF)
    lmi.set_parameter("nu", nu)
    solution = lmi.solve(lambda v: v.g[0, 0])
    P = np.array([getattr(solution, f"P{i}") for i in range(len(points))])
    g = float(solution.g[0, 0])
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))

    def P_at(p):
        return np.tensordot(G.grid.weights(p), P, axes=1)

    rng = np.random.default_rng(7)
    for cell in G.grid.cells():
        lo = np.array([a[i] for a, i in zip(G.grid.axes, cell)])
        hi = np.array([a[i + 1] for a, i in zip(G.grid.axes, cell)])
        for p in rng.uniform(lo, hi, size=(6, 2)):
            S = G.at(p)
            K = interp(p).reshape(1, 2)
            loop = channel(S, K)
            Pp = P_at(p)
            # P is affine along each axis within the cell: the difference
            # quotient over the cell's width is its partial derivative.
            slopes = []
            for d in range(2):
                a, b = p.copy(), p.copy()
                a[d], b[d] = lo[d], hi[d]
                slopes.append((P_at(b) - P_at(a)) / (hi[d] - lo[d]))
            for signs in ((-1, -1), (-1, 1), (1, -1), (1, 1)):
                Pdot = sum(s * r * D for s, r, D in zip(signs, nu, slopes))
                A, B, C, D = loop.A, loop.B, loop.C, loop.D
                F = np.block([
                    [A.T @ Pp + Pp @ A + Pdot, Pp @ B, C.T],
                    [B.T @ Pp, -np.eye(1), D.T],
                    [C, D, -g * np.eye(2)],
                ])  # fmt: skip
                assert np.linalg.eigvalsh(F).max() < 0, (p, signs)
