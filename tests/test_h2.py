"""H2 state feedback (issue 13) against independent facts.

References (``tests/_h2dt_reference.py``, which cites the textbooks):

* LTI, ``z = [C x; F u]``, ``D_zw = 0``: the optimum is
  ``sqrt(trace(B1' X B1))`` with ``X`` the stabilizing solution of the LQR
  Riccati equation (``Q = C'C``, ``R = F'F``): the CARE in continuous time
  (Zhou, Doyle and Glover, Robust and Optimal Control, ch. 14), the DARE in
  discrete time (impulse-response energy = LQR cost from ``x_1 = B1 e_i``),
  from ``scipy.linalg.solve_continuous_are`` / ``solve_discrete_are``.
* The true H2 norm of a closed loop is ``control.norm(sys, 2)`` (with the
  closed loop's ``dt`` in discrete time), of loops this file builds from the
  plant matrices and the returned gain; a certified bound is never below it.
* H-infinity levels: ``control.linfnorm`` and, for the LTI optimum, the
  Riccati bisection of ``tests/_independent.py`` (continuous) and
  ``tests/_h2dt_reference.py`` (discrete).
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _h2dt_reference import (
    affine_at,
    affine_system,
    box_corners,
    channels,
    closed_loop,
    dt_hinf_riccati,
    h2_riccati,
    is_stable,
    lti_system,
    quadratically_stabilizable,
    random_box_polytope,
    random_lti,
    spectral_abscissa,
    vertex_system,
)
from _independent import hinf_riccati

SEED = 1313
DT = 0.1
RTOL_OPT = 1e-3  # raw optimum vs Riccati value (issue 13, "Must show")
RTOL_NORM = 1e-9  # a certified bound vs a computed norm (rounding only)

# (index, n, m, scaled): n = 1..6, m = 1..3, badly scaled ones included.
FAST = [(0, 1, 1, False), (1, 2, 3, False), (2, 3, 2, True), (3, 4, 1, False),
        (4, 5, 2, True), (5, 6, 3, False)]  # fmt: skip
SLOW = [(10 + i, 1 + i % 6, 1 + i % 3, i % 3 == 2) for i in range(18)]


def _problem(index, n, m, scaled, dt):
    rng = np.random.default_rng([SEED, index, 1 if dt else 0])
    return random_lti(rng, n=n, m=m, dt=dt, scaled=scaled)


def _h2_design(problem, dt, **kwargs):
    A, B1, B2, C, F, _ = problem
    sys = lti_system(lpv, A, B1, B2, C, F, dt=dt)
    w, u, z = channels(B1.shape[1], B2.shape[1], C.shape[0])
    return lpv.h2_state_feedback(sys, w, u, z, **kwargs)


def _check_lti(problem, dt):
    """Raw optimum vs Riccati; default design's bound vs the true norm."""
    A, B1, B2, C, F, _ = problem
    h2, _, _ = h2_riccati(A, B1, B2, C, F, dt=dt)

    raw = _h2_design(problem, dt, backoff=None)
    assert raw.gamma_opt == pytest.approx(h2, rel=RTOL_OPT), (h2, raw.gamma_opt)
    K = raw.gain()
    assert is_stable(A - B2 @ K, dt)
    true = ct.norm(closed_loop(A, B1, B2, C, K, F, dt), 2)
    assert raw.gamma >= true * (1 - RTOL_NORM), (raw.gamma, true)

    design = _h2_design(problem, dt)  # default options (back-off 0.2)
    assert design.certificate.verified
    assert design.gamma_opt == pytest.approx(h2, rel=RTOL_OPT)  # raw optimum
    K = design.gain()
    assert is_stable(A - B2 @ K, dt), spectral_abscissa(A - B2 @ K, dt)
    true = ct.norm(closed_loop(A, B1, B2, C, K, F, dt), 2)
    assert design.gamma >= true * (1 - RTOL_NORM), (design.gamma, true)
    # No certified bound below the optimum; back-off stays within its budget.
    assert true >= h2 * (1 - 1e-6)
    assert design.gamma <= (1 + 0.2) * h2 * (1 + RTOL_OPT), (design.gamma, h2)


# ----------------------------------------------------------------------
# The reference itself
# ----------------------------------------------------------------------
@pytest.mark.parametrize("a, b1, b2, c", [(-1.0, 1.0, 1.0, 1.0), (2.0, 0.5, 3.0, 2.0)])
def test_reference_scalar_continuous_closed_form(a, b1, b2, c):
    # 2 a X - b2^2 X^2 + c^2 = 0, X > 0.
    X = (a + np.sqrt(a**2 + b2**2 * c**2)) / b2**2
    h2, _, _ = h2_riccati(*(np.array([[v]]) for v in (a, b1, b2, c)))
    assert h2 == pytest.approx(abs(b1) * np.sqrt(X), rel=1e-12)


@pytest.mark.parametrize("a, b1, b2, c", [(0.5, 1.0, 1.0, 1.0), (1.8, 0.5, 2.0, 3.0)])
def test_reference_scalar_discrete_closed_form(a, b1, b2, c):
    # X = a^2 X / (1 + b2^2 X) + c^2  <=>  b2^2 X^2 + (1 - a^2 - b2^2 c^2) X - c^2 = 0
    q = 1 - a**2 - b2**2 * c**2
    X = (-q + np.sqrt(q**2 + 4 * b2**2 * c**2)) / (2 * b2**2)
    h2, _, K = h2_riccati(*(np.array([[v]]) for v in (a, b1, b2, c)), dt=DT)
    assert h2 == pytest.approx(abs(b1) * np.sqrt(X), rel=1e-12)
    # Brute force over scalar gains: the closed-loop norm is smallest at K.
    gains = K[0, 0] + np.linspace(-0.2, 0.2, 41) * abs(a / b2)
    # x+ = f x + b1 w, z = [c x; -k x]: ||T||_2^2 = b1^2 (c^2 + k^2) / (1 - f^2).
    poles = a - b2 * gains
    assert np.all(np.abs(poles) < 1)
    norms = abs(b1) * np.sqrt((c**2 + gains**2) / (1 - poles**2))
    assert min(norms) >= h2 * (1 - 1e-12)
    assert norms[20] == pytest.approx(h2, rel=1e-9)  # attained at K itself


@pytest.mark.parametrize("dt", [0, DT])
def test_reference_matches_closed_loop_norm_and_is_minimal(dt):
    for i in range(6):
        A, B1, B2, C, F, _ = _problem(100 + i, None, None, i % 2 == 1, dt)
        h2, _, K = h2_riccati(A, B1, B2, C, F, dt=dt)
        assert ct.norm(closed_loop(A, B1, B2, C, K, F, dt), 2) == pytest.approx(
            h2, rel=1e-6
        )
        rng = np.random.default_rng(i)
        for _ in range(3):
            dK = 1e-2 * np.abs(K).max() * rng.standard_normal(K.shape)
            if is_stable(A - B2 @ (K + dK), dt):
                cl = closed_loop(A, B1, B2, C, K + dK, F, dt)
                assert ct.norm(cl, 2) >= h2 * (1 - 1e-9)


# ----------------------------------------------------------------------
# LTI H2 state feedback vs Riccati
# ----------------------------------------------------------------------
def test_double_integrator_textbook():
    # A = [[0, 1], [0, 0]], B2 = [0; 1], Q = diag(1, 0), R = 1: the LQR
    # solution is X = [[sqrt 2, 1], [1, sqrt 2]], K = [1, sqrt 2]; with
    # B1 = B2 the H2 optimum is sqrt(X_22) = 2^(1/4).
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    problem = (A, B, B, C, np.eye(1), np.eye(2))
    raw = _h2_design(problem, 0, backoff=None)
    assert raw.gamma_opt == pytest.approx(2**0.25, rel=RTOL_OPT)
    # The minimiser is unique (LQR gain); near-optimal gamma, nearby gain.
    assert raw.gain() == pytest.approx(np.array([[1.0, np.sqrt(2)]]), rel=5e-2)
    _check_lti(problem, 0)


@pytest.mark.parametrize("dt", [0, DT], ids=["ct", "dt"])
@pytest.mark.parametrize(
    "case", FAST, ids=[f"n{c[1]}m{c[2]}{'s' * c[3]}" for c in FAST]
)
def test_lti_h2_matches_riccati(case, dt):
    _check_lti(_problem(*case, dt), dt)


@pytest.mark.slow
@pytest.mark.parametrize("dt", [0, DT], ids=["ct", "dt"])
@pytest.mark.parametrize("case", SLOW, ids=[f"{c[0]}n{c[1]}m{c[2]}" for c in SLOW])
def test_lti_h2_matches_riccati_many(case, dt):
    _check_lti(_problem(*case, dt), dt)


@pytest.mark.parametrize("dt", [0, DT], ids=["ct", "dt"])
def test_synthesize_h2_objective_matches_riccati(dt):
    A, B1, B2, C, F, _ = problem = _problem(3, 4, 2, False, dt)
    h2, _, _ = h2_riccati(A, B1, B2, C, F, dt=dt)
    sys = lti_system(lpv, A, B1, B2, C, F, dt=dt)
    w, u, z = channels(B1.shape[1], B2.shape[1], C.shape[0])
    spec = lpv.H2(w, z)
    raw = lpv.synthesize(sys, u, objective=spec, backoff=None)
    assert raw.gamma_opt == pytest.approx(h2, rel=RTOL_OPT)
    design = lpv.synthesize(sys, u, objective=spec)
    assert design.system.dt == sys.dt
    K = design.gain()
    true = ct.norm(closed_loop(A, B1, B2, C, K, F, dt), 2)
    assert design.gamma >= true * (1 - RTOL_NORM)
    assert design.bounds[spec] == pytest.approx(design.gamma, rel=1e-12)
    # The default channels (w: inputs not in u, z: all outputs) are these.
    default = lpv.synthesize(sys, u, objective=lpv.H2(), backoff=None)
    assert default.gamma_opt == pytest.approx(h2, rel=RTOL_OPT)
    del problem


@pytest.mark.parametrize("dt", [0, DT], ids=["ct", "dt"])
def test_h2_bound_analysis_of_lqr_gain(dt):
    # For a fixed gain (LTI) the H2 bound is the closed-loop norm itself.
    A, B1, B2, C, F, _ = _problem(4, 3, 2, False, dt)
    h2, _, K = h2_riccati(A, B1, B2, C, F, dt=dt)
    sys = lti_system(lpv, A, B1, B2, C, F, dt=dt)
    w, u, z = channels(B1.shape[1], B2.shape[1], C.shape[0])
    result = lpv.h2_bound(sys, [K], w, u, z)
    assert result.gamma >= h2 * (1 - RTOL_NORM)
    assert result.gamma == pytest.approx(h2, rel=RTOL_OPT)


def test_h2_state_feedback_required_gamma_region_and_gain_bound():
    A, B1, B2, C, F, _ = problem = _problem(3, 4, 2, False, 0)
    h2, _, K_lqr = h2_riccati(A, B1, B2, C, F)
    # A required bound: met, no optimum reported.
    design = _h2_design(problem, 0, gamma=1.3 * h2)
    assert design.gamma <= 1.3 * h2 and design.gamma_opt is None
    cl = closed_loop(A, B1, B2, C, design.gain(), F)
    assert ct.norm(cl, 2) <= design.gamma * (1 + RTOL_NORM)
    # A decay rate beyond the LQR loop's and a gain bound below its gain.
    decay = 1.0 - spectral_abscissa(A - B2 @ K_lqr)
    limit = 0.9 * np.linalg.norm(K_lqr, 2)  # 0.9 K_lqr stabilizes (LQR margin)
    for kwargs in ({"regions": [lpv.halfplane(decay)]}, {"gain_bound": limit}):
        design = _h2_design(problem, 0, **kwargs)
        K = design.gain()
        if "regions" in kwargs:
            assert spectral_abscissa(A - B2 @ K) < -decay
        else:
            assert np.linalg.norm(K, 2) <= limit * (1 + 1e-9)
        cl = closed_loop(A, B1, B2, C, K, F)
        assert design.gamma >= ct.norm(cl, 2) * (1 - RTOL_NORM)
        assert ct.norm(cl, 2) > h2 * (1 + 1e-6)  # the LQR gain is excluded


# ----------------------------------------------------------------------
# Polytopic H2
# ----------------------------------------------------------------------
def _polytope_case(kind, dt, seed):
    """``(sys, frozen(p) -> (A, B1, B2, C), points, vertices)``."""
    rng = np.random.default_rng([SEED, 77, seed, 1 if dt else 0])
    n, m, nw = 3, 2 if kind == "box2" else 1, 2
    if kind == "simplex3":
        M0, terms = random_box_polytope(rng, 2, n, m, nw, dt=dt)
        verts = [affine_at(M0, terms, c) for c in ([0, 0], [1, 0], [0, 1])]
        sys = vertex_system(lpv, verts, dt=dt)
        points = [np.eye(3)[j] for j in range(3)] + list(
            rng.dirichlet(np.ones(3), size=8)
        )

        def frozen(p):
            return tuple(sum(pj * v[k] for pj, v in zip(p, verts)) for k in range(4))

        return sys, frozen, points, verts
    k = 1 if kind == "box1" else 2
    M0, terms = random_box_polytope(rng, k, n, m, nw, dt=dt)
    sys = affine_system(lpv, M0, terms, dt=dt)
    corners = box_corners(k)
    points = corners + list(rng.uniform(-1, 1, (8, k)))

    def frozen(p):
        return affine_at(M0, terms, p)

    return sys, frozen, points, [frozen(c) for c in corners]


POLY = [
    ("box1", "common", 0),
    ("box2", "scheduled", 0),
    ("simplex3", "scheduled", DT),
    ("box2", "common", DT),
]


def _check_polytope_bound(design, frozen, points, dt, bound=None, which="h2"):
    """Frozen closed loops stable, norms <= the certified bound."""
    assert design.certificate.verified
    bound = design.gamma if bound is None else bound
    worst = 0.0
    for p in points:
        A, B1, B2, C = frozen(p)
        K = design.gain(p)
        assert is_stable(A - B2 @ K, dt), (p, spectral_abscissa(A - B2 @ K, dt))
        cl = closed_loop(A, B1, B2, C, K, dt=dt)
        value = ct.norm(cl, 2) if which == "h2" else ct.linfnorm(cl)[0]
        worst = max(worst, value)
        assert value <= bound * (1 + RTOL_NORM), (p, value, bound)
    return worst


@pytest.mark.parametrize(
    "kind, gains, dt", POLY, ids=[f"{a}-{b}-{c}" for a, b, c in POLY]
)
def test_polytopic_h2_bounds_frozen_norms(kind, gains, dt):
    sys, frozen, points, verts = _polytope_case(kind, dt, seed=0)
    assert quadratically_stabilizable(verts, dt) is not None  # ground truth
    p = verts[0]
    w, u, z = channels(p[1].shape[1], p[2].shape[1], p[3].shape[0])
    spec = lpv.H2(w, z)
    design = lpv.synthesize(sys, u, objective=spec, gains=gains)
    assert design.scheduled == (gains == "scheduled")
    worst = _check_polytope_bound(design, frozen, points, dt)
    # Each vertex needs at least its own LTI optimum.
    lower = max(h2_riccati(*v, dt=dt)[0] for v in verts)
    assert worst >= lower * (1 - 1e-6)
    assert design.bounds[spec] == pytest.approx(design.gamma, rel=1e-12)
    # The objective channel of closed_loop(p) is the loop built here.
    A, B1, B2, C = frozen(points[-1])
    K = design.gain(points[-1])
    Acl, Bw, Cz, Dzw = ct.ssdata(design.closed_loop(points[-1]))
    np.testing.assert_allclose(Acl, A - B2 @ K, atol=1e-12 * max(1, np.abs(A).max()))
    np.testing.assert_allclose(Bw, B1)
    np.testing.assert_allclose(Cz, np.vstack([C, -K]), atol=1e-12)
    np.testing.assert_allclose(Dzw, 0)


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_dt_h2_bound_time_varying_white_noise_variance(gains):
    # What a constant-W Gramian-form bound does cover for time-varying
    # parameters: with unit white noise w and x_0 = 0 the state covariance
    # X_{k+1} = A_k X_k A_k' + Bw Bw' stays below W, so the output variance
    # trace(Cz_k X_k Cz_k') stays below the bound at every k, for every
    # parameter sequence (same sequences as above, covariance propagated here).
    sys, frozen, _, verts = _polytope_case("box1", DT, seed=3)
    w, u, z = channels(2, 1, verts[0][3].shape[0])
    design = lpv.synthesize(sys, u, objective=lpv.H2(w, z), gains=gains)
    loops = {}
    for j, p in enumerate(box_corners(1)):
        A, _, B2, C = frozen(p)
        K = design.gain(p)
        loops[j] = (A - B2 @ K, np.vstack([C, -K]))
    Bw = verts[0][1]
    rng = np.random.default_rng(5)
    steps = 150
    sequences = [[0] * steps, [1] * steps]
    sequences += [[(k // h) % 2 for k in range(steps)] for h in (1, 2, 3, 5)]
    sequences += [list(rng.integers(0, 2, steps)) for _ in range(30)]
    worst = 0.0
    for seq in sequences:
        X = np.zeros((Bw.shape[0],) * 2)
        for j in seq:
            Acl, Cz = loops[j]
            worst = max(worst, float(np.trace(Cz @ X @ Cz.T)))
            X = Acl @ X @ Acl.T + Bw @ Bw.T
    assert np.sqrt(worst) <= design.gamma * (1 + RTOL_NORM), (
        np.sqrt(worst),
        design.gamma,
    )


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_h2_state_feedback_polytopic_wrapper(gains):
    sys, frozen, points, verts = _polytope_case("box1", 0, seed=1)
    p = verts[0]
    w, u, z = channels(p[1].shape[1], p[2].shape[1], p[3].shape[0])
    design = lpv.h2_state_feedback(sys, w, u, z, gains=gains)
    assert design.gamma_opt is not None and design.gamma_opt <= design.gamma
    _check_polytope_bound(design, frozen, points, 0)


# ----------------------------------------------------------------------
# Mixed H2 / H-infinity
# ----------------------------------------------------------------------
def _hinf_opt(A, B1, B2, C, dt):
    if dt:
        return dt_hinf_riccati(A, B1, B2, C, rtol=1e-6)[0]
    m = B2.shape[1]
    C1 = np.vstack([C, np.zeros((m, A.shape[0]))])
    D12 = np.vstack([np.zeros((C.shape[0], m)), np.eye(m)])
    return hinf_riccati(A, B1, B2, C1, D12, rtol=1e-6)[0]


def _mixed_problem(dt):
    """An LTI problem whose LQR loop has an H-infinity norm well above the optimum."""
    for i in range(50):
        A, B1, B2, C, _, _ = _problem(200 + i, 3, 1, False, dt)
        h2, _, K = h2_riccati(A, B1, B2, C, dt=dt)
        g_lqr = ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=dt))[0]
        g_opt = _hinf_opt(A, B1, B2, C, dt)
        if g_lqr > 1.3 * g_opt:
            return (A, B1, B2, C), h2, g_opt, g_lqr
    raise RuntimeError("no mixed test problem found")


@pytest.mark.parametrize("dt", [0, DT], ids=["ct", "dt"])
def test_mixed_h2_with_hinf_constraint(dt):
    (A, B1, B2, C), h2, g_opt, g_lqr = _mixed_problem(dt)
    g = g_opt + 0.5 * (g_lqr - g_opt)  # the H2-optimal gain violates it
    sys = lti_system(lpv, A, B1, B2, C, dt=dt)
    w, u, z = channels(B1.shape[1], B2.shape[1], C.shape[0])
    h2spec, hinfspec = lpv.H2(w, z), lpv.Hinf(w, z, bound=g)
    design = lpv.synthesize(sys, u, objective=h2spec, constraints=[hinfspec])
    assert design.certificate.verified
    assert set(design.bounds) >= {h2spec, hinfspec}
    assert design.bounds[hinfspec] <= g
    assert design.bounds[h2spec] == pytest.approx(design.gamma, rel=1e-12)
    K = design.gain()
    assert is_stable(A - B2 @ K, dt)
    cl = closed_loop(A, B1, B2, C, K, dt=dt)
    hinf = ct.linfnorm(cl)[0]
    assert hinf < g
    assert hinf <= design.bounds[hinfspec] * (1 + RTOL_NORM)
    assert ct.norm(cl, 2) <= design.gamma * (1 + RTOL_NORM)
    assert design.gamma >= h2 * (1 - 1e-9)  # never below the unconstrained optimum


def test_hinf_objective_with_h2_constraint():
    A, B1, B2, C, F, _ = _problem(3, 4, 2, False, 0)
    h2, _, _ = h2_riccati(A, B1, B2, C, F)
    b = 1.5 * h2
    sys = lti_system(lpv, A, B1, B2, C, F)
    w, u, z = channels(B1.shape[1], B2.shape[1], C.shape[0])
    h2spec, hinfspec = lpv.H2(w, z, bound=b), lpv.Hinf(w, z)
    design = lpv.synthesize(sys, u, objective=hinfspec, constraints=[h2spec])
    assert design.bounds[h2spec] <= b
    K = design.gain()
    cl = closed_loop(A, B1, B2, C, K, F)
    assert ct.norm(cl, 2) <= design.bounds[h2spec] * (1 + RTOL_NORM)
    assert ct.linfnorm(cl)[0] <= design.gamma * (1 + RTOL_NORM)


def test_mixed_polytopic_common_gain():
    sys, frozen, points, verts = _polytope_case("box1", 0, seed=2)
    assert quadratically_stabilizable(verts, 0) is not None
    p = verts[0]
    w, u, z = channels(p[1].shape[1], p[2].shape[1], p[3].shape[0])
    # A level the constant-Lyapunov H-infinity design certifies, relaxed.
    g = 1.3 * lpv.synthesize(sys, u, objective=lpv.Hinf(w, z)).gamma
    h2spec, hinfspec = lpv.H2(w, z), lpv.Hinf(w, z, bound=g)
    design = lpv.synthesize(sys, u, objective=h2spec, constraints=[hinfspec])
    _check_polytope_bound(design, frozen, points, 0)
    worst = _check_polytope_bound(
        design, frozen, points, 0, bound=design.bounds[hinfspec], which="hinf"
    )
    assert worst < g


# ----------------------------------------------------------------------
# Bad input
# ----------------------------------------------------------------------
def _d_zw_nonzero():
    A = np.array([[-1.0, 1.0], [0.0, 0.5]])
    sys = ct.ss(
        A,
        [[1.0, 0.0], [0.5, 1.0]],
        [[1.0, 0.0], [0.0, 0.0]],
        [[0.3, 0.0], [0.0, 1.0]],  # D_zw = [0.3; 0] != 0
        inputs=["w", "u"],
        outputs=["y", "v"],
    )
    return lpv.PolytopicStateSpace([sys])


def test_h2_with_feedthrough_is_refused():
    sys = _d_zw_nonzero()
    with pytest.raises(ValueError, match="H2"):
        lpv.h2_state_feedback(sys, "w", "u", ["y", "v"])
    with pytest.raises(ValueError, match="H2"):
        lpv.synthesize(sys, "u", objective=lpv.H2("w", ["y", "v"]))
    # The H-infinity problem on the same channel is fine.
    design = lpv.synthesize(sys, "u", objective=lpv.Hinf("w", ["y", "v"]))
    assert design.gamma >= 0.3  # |D_zw| is a lower bound of any L2 gain


def test_bad_objective_and_constraints_types():
    A, B1, B2, C, F, _ = _problem(0, 2, 1, False, 0)
    sys = lti_system(lpv, A, B1, B2, C, F)
    w, u, z = channels(1, 1, C.shape[0])
    with pytest.raises(TypeError, match="objective"):
        lpv.synthesize(sys, u, objective="H2")
    with pytest.raises(TypeError, match="objective"):
        lpv.synthesize(sys, u, objective=3.0)
    with pytest.raises(TypeError, match="constraints"):
        lpv.synthesize(sys, u, objective=lpv.H2(w, z), constraints=[object()])
    with pytest.raises(TypeError, match="constraints"):
        lpv.synthesize(sys, u, objective=lpv.H2(w, z), constraints=["Hinf"])


def test_hinf_constraint_needs_a_bound():
    A, B1, B2, C, F, _ = _problem(0, 2, 1, False, 0)
    sys = lti_system(lpv, A, B1, B2, C, F)
    w, u, z = channels(1, 1, C.shape[0])
    with pytest.raises(ValueError, match="bound|constraints"):
        lpv.synthesize(sys, u, objective=lpv.H2(w, z), constraints=[lpv.Hinf(w, z)])
    with pytest.raises(ValueError, match="bound|constraints"):
        lpv.synthesize(sys, u, objective=lpv.Hinf(w, z), constraints=[lpv.H2(w, z)])


def test_specs_are_hashable_values():
    a, b = lpv.H2(["w0"], ["y0"]), lpv.H2(["w0"], ["y0"])
    assert a == b and hash(a) == hash(b)
    assert lpv.Hinf(bound=2.0) != lpv.Hinf(bound=3.0)
    with pytest.raises(AttributeError):
        a.bound = 1.0
