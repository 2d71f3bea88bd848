"""Synthesis and analysis under input saturation, against independent facts.

Facts used: the exact region of attraction of a scalar unstable plant under
saturation (``|x| < b u0 / a``), which no certified region may exceed and
which the generalized sector condition approaches; the homogeneity of the
problem (doubling the saturation level doubles the region); and
simulations of the saturated closed loop (a saturation written here, scipy
rtol 1e-8) from the boundary of the certified ellipsoid, at vertices and
with a time-varying parameter.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import InfeasibleError
from ctrl_lpv.saturation import saturated_state_feedback, saturation_region


def sat(u, u0):
    return np.minimum(np.maximum(u, -u0), u0)


def scalar_plant(a, b):
    return lpv.PolytopicStateSpace([ct.ss([[a]], [[b]], [[1.0]], 0)], inputs="u")


@pytest.fixture(scope="module")
def plant():
    """Unstable 2-state plant with uncertain input gain and stiffness."""
    verts = [
        ct.ss(
            [[0.0, 1.0], [a, 0.0]],
            [[0.0, 0.0], [b, 1.0]],
            np.eye(2),
            0,
            inputs=["u", "w"],
            states=["x1", "x2"],
        )  # fmt: skip
        for b in (0.5, 1.5)
        for a in (-0.1, 0.3)
    ]
    return lpv.PolytopicStateSpace(verts, domain=lpv.box(b=(0.5, 1.5), a=(-0.1, 0.3)))


def boundary_points(P, count=8):
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    out = []
    for t in angles:
        x = np.array([np.cos(t), np.sin(t)])
        out.append(x / np.sqrt(x @ P @ x))
    return out


def closed_loop_rhs(sys, gain, u0, delta, w=None):
    data = sys.vertex_data()
    A_stack = np.stack([v[0] for v in data])
    B_stack = np.stack([v[1] for v in data])

    def rhs(t, x):
        d = delta(t)
        A = np.tensordot(d, A_stack, axes=1)
        B = np.tensordot(d, B_stack, axes=1)
        u = sat(-gain(d) @ x, u0)
        dx = A @ x + B[:, 0] * u[0]
        if w is not None:
            dx = dx + B[:, 1] * w(t, x)
        return dx

    return rhs


def V_along(rhs, x0, P, t_end=20.0):
    sol = solve_ivp(rhs, (0, t_end), x0, rtol=1e-8, atol=1e-11, max_step=0.1)
    assert sol.success
    return sol.t, np.einsum("it,ij,jt->t", sol.y, P, sol.y), sol.y


# ----------------------------------------------------------------------
# Scalar plant: the exact region of attraction
# ----------------------------------------------------------------------
@pytest.mark.parametrize("a, b, u0", [(1.0, 1.0, 1.0), (0.5, 2.0, 3.0)])
def test_scalar_design_approaches_the_true_region(a, b, u0):
    # dx = a x + b sat(u), a > 0: x* = b u0 / a is an equilibrium under full
    # braking, so the region of attraction is at most |x| < b u0 / a.
    d = saturated_state_feedback(scalar_plant(a, b), "u", u0, backoff=None)
    exact = b * u0 / a
    assert d.certificate.verified
    assert d.beta < exact
    assert d.beta > 0.99 * exact


def test_scalar_analysis_of_a_given_gain():
    a, b, u0 = 1.0, 1.0, 1.0
    for k in (1.5, 3.0, 10.0):
        r = saturation_region(scalar_plant(a, b), [[k]], "u", u0)
        assert not r.designed
        assert r.beta < b * u0 / a
        assert r.beta > 0.99 * b * u0 / a
    # A gain that does not stabilise the linear loop has no region.
    with pytest.raises(InfeasibleError):
        saturation_region(scalar_plant(a, b), [[0.5]], "u", u0)


def test_backoff_keeps_the_stated_fraction_of_the_region():
    d0 = saturated_state_feedback(scalar_plant(1.0, 1.0), "u", 1.0, backoff=None)
    d1 = saturated_state_feedback(scalar_plant(1.0, 1.0), "u", 1.0, backoff=0.25)
    assert d1.beta >= d0.beta / 1.25 * (1 - 1e-6)
    assert d1.beta_opt == pytest.approx(d0.beta, rel=1e-4)
    # The slack goes to decay first: with a region of at least 1/1.25 of
    # b u0 / a, the largest rate is 0.25 (region < b u0 / (a + sigma)); the
    # back-off uses half of it, and the linear loop is at least that fast.
    assert 0.1 < d1.decay < 0.25
    (Acl,) = d1.closed_loop_vertices()
    assert np.linalg.eigvals(Acl).real.max() <= -d1.decay * (1 - 1e-6)


# ----------------------------------------------------------------------
# Polytopic plant: homogeneity and simulations
# ----------------------------------------------------------------------
def test_region_scales_with_the_saturation_level(plant):
    # x -> c x, u0 -> c u0 maps trajectories to trajectories: the optimal
    # beta is linear in u0 (up to solver accuracy).
    b1 = saturated_state_feedback(plant, "u", 1.0, backoff=None).beta
    b2 = saturated_state_feedback(plant, "u", 2.0, backoff=None).beta
    assert b2 == pytest.approx(2 * b1, rel=2e-3)
    assert b2 > b1


def test_faster_decay_costs_region(plant):
    slow = saturated_state_feedback(plant, "u", 1.0)
    fast = saturated_state_feedback(plant, "u", 1.0, decay=0.3)
    assert fast.beta < slow.beta
    assert fast.decay >= 0.3  # the back-off may raise the certified rate


@pytest.fixture(scope="module")
def common_design(plant):
    # No back-off: the region of largest size is one where the input does
    # saturate (back-off trades region for gain: here it gives a design that
    # never saturates inside its ellipsoid).
    return saturated_state_feedback(plant, "u", 1.0, decay=0.1, backoff=None)


def test_trajectories_from_the_boundary_stay_inside_and_converge(plant, common_design):
    d = common_design
    K = d.gains[0]
    assert d.certificate.verified
    deltas = [lambda t, j=j: np.eye(4)[j] for j in (0, 3)]
    deltas.append(
        lambda t: np.array([np.sin(2 * t) ** 2, 0.0, 0.0, np.cos(2 * t) ** 2])
    )
    saturated = False
    for delta in deltas:
        rhs = closed_loop_rhs(plant, lambda _: K, 1.0, delta)
        for x0 in boundary_points(d.P, 4):
            t, V, x = V_along(rhs, x0, d.P)
            assert V[0] == pytest.approx(1.0)
            # V(t) <= exp(-2 sigma t) V(0): invariance and the certified decay.
            assert np.all(V <= np.exp(-2 * d.decay * t) * (1 + 1e-6))
            assert V[-1] < 1e-2
            saturated |= bool(np.any(np.abs(K @ x) > 1.0))
    assert saturated  # the test does exercise the saturation


def test_certified_region_is_not_the_linear_one(plant, common_design):
    # Outside {x'Px <= 1} the input saturates at some point of the ellipsoid
    # boundary, so the region is limited by the saturation, not by a cap.
    d = common_design
    assert not d.capped
    assert np.max(d.support(d.gains[0])) > 1.0


def test_disturbance_design_is_invariant_under_bang_bang_inputs(plant):
    d = saturated_state_feedback(plant, "u", 1.0, w="w", w_max=0.05)
    assert d.w == ("w",) and 0 < d.rho < 1 and d.lam > 0
    K = d.gains[0]
    Pw = d.P @ np.array([0.0, 1.0])
    inputs = [
        lambda t, x: 0.05 * np.sign(np.sin(1.5 * t)),
        lambda t, x: 0.05 * np.sign(x @ Pw),  # pushes V up as hard as possible
    ]
    for w in inputs:
        for j in (0, 3):
            vertex = np.eye(4)[j]
            rhs = closed_loop_rhs(plant, lambda _: K, 1.0, lambda t, v=vertex: v, w)
            for x0 in boundary_points(d.P, 3):
                _, V, _ = V_along(rhs, x0, d.P, 8.0)
                assert np.all(V <= 1.0 + 1e-6)


def test_scheduled_gains_with_time_varying_parameter(plant):
    d = saturated_state_feedback(plant, "u", 1.0, gains="scheduled")
    assert d.scheduled and len(d.gains) == 4
    gains = np.stack(d.gains)

    def delta(t):
        p = np.array([np.sin(1.3 * t) ** 2, 0.3, 0.2, 0.0])
        p[3] = 1.0 - p[:3].sum() if p[:3].sum() < 1 else 0.0
        return p / p.sum()

    rhs = closed_loop_rhs(plant, lambda dl: np.tensordot(dl, gains, axes=1), 1.0, delta)
    for x0 in boundary_points(d.P, 3):
        _, V, _ = V_along(rhs, x0, d.P, 25.0)
        assert np.all(V <= 1.0 + 1e-6) and V[-1] < 1e-2


def test_points_target_and_controller(plant):
    pts = np.array([[1.0, 0.0], [0.0, 1.0]])
    d = saturated_state_feedback(plant, "u", 1.0, points=pts)
    values = np.einsum("ki,ij,kj->k", pts * d.beta, d.P, pts * d.beta)
    assert np.all(values <= 1.0 + 1e-9)
    ctrl = d.controller()
    assert ctrl.output_labels == ["u"]
    x = np.array([0.3, -0.2])
    y = ctrl.output(0.0, [], x)
    np.testing.assert_allclose(y, -d.gains[0] @ x)


@pytest.mark.parametrize(
    "kwargs, exc, match",
    [
        (dict(u="w", u_max=0.0), ValueError, "u_max"),
        (dict(u="nope", u_max=1.0), ValueError, "u"),
        (dict(u="u", u_max=1.0, w="u", w_max=1.0), ValueError, "w"),
        (dict(u="u", u_max=1.0, w="w"), ValueError, "w_max"),
        (dict(u="u", u_max=1.0, decay=-1.0), ValueError, "decay"),
        (dict(u="u", u_max=1.0, shape=-np.eye(2)), ValueError, "shape"),
        (dict(u="u", u_max=1.0, gains="both"), ValueError, "gains"),
    ],
)
def test_bad_arguments(plant, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        saturated_state_feedback(plant, **kwargs)


def test_not_a_polytopic_system():
    with pytest.raises(TypeError, match="sys"):
        saturated_state_feedback(ct.ss([[1.0]], [[1.0]], [[1.0]], 0), "u", 1.0)


def test_output_objective_gives_a_small_invariant_set(plant):
    # Smallest invariant ellipsoid along x1 for |w| <= 0.05, still holding
    # 0.4 times the unit ball: checked with the worst-case-ish input.
    C = np.array([[1.0, 0.0]])
    d = saturated_state_feedback(
        plant, "u", 1.0, w="w", w_max=0.05, output=C, beta_min=0.4
    )
    assert d.beta >= 0.4 * (1 - 1e-6) and d.beta_opt is None
    region = saturated_state_feedback(plant, "u", 1.0, w="w", w_max=0.05)
    assert d.support(C)[0] < region.support(C)[0]
    K = d.gains[0]
    Pw = d.P @ np.array([0.0, 1.0])
    rhs = closed_loop_rhs(
        plant, lambda _: K, 1.0, lambda t: np.eye(4)[1],
        lambda t, x: 0.05 * np.sign(x @ Pw),
    )  # fmt: skip
    for x0 in boundary_points(d.P, 2) + [np.zeros(2)]:
        _, V, x = V_along(rhs, x0, d.P, 8.0)
        assert np.all(V <= 1.0 + 1e-6)
        assert np.max(np.abs(x[0])) <= d.support(C)[0] * (1 + 1e-6)
    with pytest.raises(ValueError, match="output"):
        saturated_state_feedback(plant, "u", 1.0, output=C)


def test_two_mass_tracking_model_under_a_torque_limit():
    # A stiff, badly scaled plant (shaft resonance ~94 rad/s, integral state,
    # near-uncontrollable vertex): the design must still certify, and the
    # saturated LPV model must stay in the ellipsoid from its boundary.
    from ctrl_lpv import twomass

    m = twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking", integral=True)
    shape = np.diag(1 / np.array([0.5, 20.0, 0.5, 20.0, 0.2]) ** 2)
    d = saturated_state_feedback(m, "Tm", 500.0, shape=shape, decay=0.2, backoff=None)
    assert d.certificate.verified and d.beta > 0
    K, P = d.gains[0], d.P
    rng = np.random.default_rng(0)
    saturated = False
    for A, B, _, _ in m.vertex_data():
        b = B[:, m.physical_inputs.index("Tm")]
        for _ in range(2):
            x0 = rng.standard_normal(5)
            x0 /= np.sqrt(x0 @ P @ x0)
            sol = solve_ivp(
                lambda t, x, A=A, b=b: A @ x + b * sat(-K @ x, 500.0)[0],
                (0.0, 3.0), x0, rtol=1e-8, atol=1e-10, method="LSODA",
            )  # fmt: skip
            V = np.einsum("it,ij,jt->t", sol.y, P, sol.y)
            assert np.all(V <= 1.0 + 1e-6)
            assert np.all(V[sol.t > 2.0] <= np.exp(-2 * 0.2 * 2.0))
            saturated |= bool(np.any(np.abs(K @ sol.y) > 500.0))
    assert saturated


@pytest.mark.parametrize("scale", [1e-3, 1e4])
def test_region_is_invariant_under_a_change_of_units(plant, scale):
    # x1 in other units (x1' = scale x1) with the shape transformed alike:
    # the same physical problem, so the same beta (the prescaling must not
    # change the answer).
    S = np.diag([scale, 1.0])
    Si = np.linalg.inv(S)
    verts = [
        (S @ A @ Si, S @ B, C @ Si, D) for A, B, C, D in plant.vertex_data()
    ]  # fmt: skip
    other = lpv.PolytopicStateSpace(verts, domain=plant.domain, inputs=["u", "w"])
    ref = saturated_state_feedback(plant, "u", 1.0, backoff=None)
    new = saturated_state_feedback(other, "u", 1.0, shape=Si.T @ Si, backoff=None)
    assert new.beta == pytest.approx(ref.beta, rel=1e-4)


def test_two_inputs_with_different_levels():
    A1 = np.array([[0.5, 1.0, 0.0], [0.0, 0.2, 1.0], [0.0, 0.0, -1.0]])
    A2 = A1 + np.diag([0.3, 0.0, 0.0])
    B = np.array([[1.0, 0.0], [0.0, 0.5], [0.3, 1.0]])
    sys = lpv.pss(
        [ct.ss(A, B, np.eye(3), 0) for A in (A1, A2)], {"p": (0, 1)},
        inputs=["u1", "u2"],
    )  # fmt: skip
    u0 = np.array([1.0, 2.0])
    d = saturated_state_feedback(sys, ["u1", "u2"], u0)
    assert d.u == ("u1", "u2") and d.gains[0].shape == (2, 3)
    K, P = d.gains[0], d.P
    rng = np.random.default_rng(1)
    for A in (A1, A2):
        for _ in range(3):
            x0 = rng.standard_normal(3)
            x0 /= np.sqrt(x0 @ P @ x0)
            sol = solve_ivp(
                lambda t, x, A=A: A @ x + B @ sat(-K @ x, u0), (0.0, 15.0), x0,
                rtol=1e-8, atol=1e-11,
            )  # fmt: skip
            V = np.einsum("it,ij,jt->t", sol.y, P, sol.y)
            assert np.all(V <= 1.0 + 1e-6)
            assert np.all(V <= np.exp(-2 * d.decay * sol.t) * (1 + 1e-6))


# ----------------------------------------------------------------------
# Discrete time: the sampled loop, simulated and recomputed with numpy
# ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def sampled():
    """Unstable sampled plant (two vertices), dt = 0.1."""
    A1 = np.array([[1.05, 0.1], [0.0, 1.02]])
    A2 = A1 + np.diag([0.03, 0.0])
    B = np.array([[0.0], [0.1]])
    return lpv.PolytopicStateSpace(
        [ct.ss(A, B, np.eye(2), 0, dt=0.1) for A in (A1, A2)], inputs="u"
    )


def discrete_sector(A, B, K, G, T, P, contraction):
    """``[A-BK, -B]' P [A-BK, -B] + [[-r P, -G'T], [*, -2T]]`` (numpy)."""
    F = np.hstack([A - B @ K, -B])
    return F.T @ P @ F + np.block([[-contraction * P, -G.T @ T], [-T @ G, -2 * T]])


def run_sampled(sys, gain, P, steps, rng, count=16):
    """Saturated loop x+ = A(delta_k) x + B sat(-K x) from the boundary of
    {x'Px <= 1}, delta_k random in the simplex: the ratios V(x+)/V(x) and
    the final V of each start."""
    data = sys.vertex_data()
    ratios, finals = [], []
    for angle in np.linspace(0, 2 * np.pi, count, endpoint=False):
        x = np.array([np.cos(angle), np.sin(angle)])
        x /= np.sqrt(x @ P @ x)
        for _ in range(steps):
            d = rng.dirichlet(np.ones(len(data)))
            A = sum(dj * v[0] for dj, v in zip(d, data))
            B = sum(dj * v[1] for dj, v in zip(d, data))
            nxt = A @ x + B @ sat(-gain(d) @ x, 1.0)
            ratios.append((nxt @ P @ nxt) / (x @ P @ x))
            x = nxt
        finals.append(x @ P @ x)
    return np.array(ratios), np.array(finals)


@pytest.mark.parametrize("decay", [0.0, 2.0])
def test_discrete_time_design_is_invariant_and_contracting(sampled, decay):
    # The certificate is the discrete-time sector condition: recomputed at
    # each vertex with numpy, and the saturated sampled loop started on the
    # ellipsoid's boundary stays inside it, V shrinking by exp(-2 sigma dt)
    # per sample, and reaches the origin.
    d = saturated_state_feedback(sampled, "u", 1.0, decay=decay, backoff=None)
    assert d.certificate.verified and d.decay == decay
    assert "V(x+)" in d.certificate.statement
    r = np.exp(-2 * decay * 0.1)
    K, G, P, W = d.gains[0], d.G[0], d.P, np.linalg.inv(d.P)
    for A, B, _, _ in sampled.vertex_data():
        M = discrete_sector(A, B, K, G, d.T, P, r)
        assert np.linalg.eigvalsh(M).max() < 0
    assert ((K - G) @ W @ (K - G).T).item() <= 1.0 + 1e-9
    ratios, finals = run_sampled(sampled, lambda _: K, P, 300, np.random.default_rng(2))
    assert ratios.max() <= r * (1 + 1e-9)
    assert finals.max() < 1e-3
    saturated = np.max(d.support(K)) > 1.0
    assert saturated  # the region reaches where the input saturates


def test_discrete_time_certificate_is_not_the_continuous_one(sampled):
    # The same matrices read as a continuous-time plant have an entirely
    # different region (here the sampled plant's A is near I: x' = A x is
    # violently unstable): the sampled design must not be that one.
    d = saturated_state_feedback(sampled, "u", 1.0, backoff=None)
    P, K = d.P, d.gains[0]
    for A, B, _, _ in sampled.vertex_data():
        Acl = A - B @ K
        # Continuous-time reading: A - B K is not Hurwitz, the discrete one
        # is Schur (the design is for x+ = A x + B u).
        assert np.abs(np.linalg.eigvals(Acl)).max() < 1
        assert np.linalg.eigvals(Acl).real.max() > 0
        assert np.linalg.eigvalsh(Acl.T @ P @ Acl - P).max() < 0


def test_discrete_time_analysis_of_a_given_gain(sampled):
    # The region of a given gain (the LQR gain of one vertex, rounded):
    # invariance by simulation; a gain that does not stabilise the linear
    # sampled loop is refused.
    K = np.array([[3.0, 3.0]])
    r = saturation_region(sampled, K, "u", 1.0)
    assert not r.designed and r.certificate.verified
    np.testing.assert_array_equal(r.gains[0], K)
    for A, B, _, _ in sampled.vertex_data():
        M = discrete_sector(A, B, K, r.G[0], r.T, r.P, 1.0)
        assert np.linalg.eigvalsh(M).max() < 0
    rng = np.random.default_rng(3)
    ratios, finals = run_sampled(sampled, lambda _: K, r.P, 400, rng)
    assert ratios.max() <= 1.0 + 1e-9
    assert finals.max() < 1e-3
    with pytest.raises(InfeasibleError, match="gain"):
        saturation_region(sampled, [[0.1, 0.0]], "u", 1.0)


def test_discrete_time_scheduled_gains(sampled):
    # Vertex gains: the sector inequality at frozen parameter values inside
    # the polytope (the relaxation's pairs are the engine's; here a grid),
    # and the loop simulated with a random parameter sequence.
    d = saturated_state_feedback(sampled, "u", 1.0, gains="scheduled", backoff=None)
    assert d.scheduled and d.certificate.verified
    data = sampled.vertex_data()
    for s in np.linspace(0.0, 1.0, 11):
        A = s * data[0][0] + (1 - s) * data[1][0]
        B = s * data[0][1] + (1 - s) * data[1][1]
        K = s * d.gains[0] + (1 - s) * d.gains[1]
        G = s * d.G[0] + (1 - s) * d.G[1]
        assert np.linalg.eigvalsh(discrete_sector(A, B, K, G, d.T, d.P, 1.0)).max() < 0
    ratios, _ = run_sampled(sampled, d.gain, d.P, 100, np.random.default_rng(4))
    assert ratios.max() <= 1.0 + 1e-9
