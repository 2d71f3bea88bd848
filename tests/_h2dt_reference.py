"""Independent references for H2 and discrete-time synthesis (not a test module).

Written from textbook statements with numpy, scipy, python-control and cvxpy
only; no code of ``ctrl_lpv`` decides what the right answer is. Shared by
``tests/test_h2.py`` and ``tests/test_discrete_synthesis.py``.

H2 state feedback (LTI, ``z = [C x; F u]``, ``D_zw = 0``)
---------------------------------------------------------
Continuous time: Zhou, Doyle and Glover, *Robust and Optimal Control* (1996),
chapter 14 (H2 optimal control, state-feedback case): with ``D12 = [0; I]``
the optimal state feedback is ``K = B2' X`` and
``min ||T_zw||_2^2 = ||G_c B1||_2^2 = trace(B1' X B1)``, ``X`` the
stabilizing solution of ``A'X + XA - X B2 B2' X + C'C = 0`` (the LQR
Riccati equation with ``Q = C'C``, ``R = I``). For a general invertible
``F`` the substitution ``u = F^-1 v`` gives the same statement with
``R = F'F`` and ``K = R^-1 B2' X``.

Discrete time, standard DT H2 norm ``||G||_2^2 = sum_k trace(g_k' g_k)``
over the impulse response ``g_0 = D``, ``g_k = C A^(k-1) B`` (what
``control.norm(sys, 2)`` computes for ``dt > 0``). For ``u = -K x`` and
``D_zw = 0``: ``g_0 = 0`` and the response to ``w_0 = e_i`` is the free
response from ``x_1 = B1 e_i``, whose energy ``sum_k z_k'z_k`` is the LQR
cost ``x_1' L_K x_1`` (``L_K`` the closed-loop observability Gramian,
``A_K' L A_K - L + C_K'C_K = 0``). So ``||T_zw||_2^2 = trace(B1' L_K B1)``.
The DT LQR gain ``K = (R + B2'XB2)^-1 B2'XA`` (``X`` the stabilizing DARE
solution, ``Q = C'C``) gives ``L_K = X <= L_K'`` for every stabilizing
``K'`` (it minimises the cost from *every* initial state at once; e.g.
Anderson and Moore, *Optimal Control: Linear Quadratic Methods*, ch. 2;
Lewis, Vrabie and Syrmos, *Optimal Control*, sec. 2.4), hence
``min_K ||T_zw||_2 = sqrt(trace(B1' X B1))``, the same formula as in
continuous time with the DARE. (Not to be confused with the
full-information problem, where ``u_k`` may also use ``w_k`` and the value
is lower.)

Discrete-time H-infinity state feedback (LTI)
---------------------------------------------
Basar and Bernhard, *H-infinity-Optimal Control and Related Minimax Design
Problems* (2nd ed., 1995), chapter 3, closed-loop perfect-state information
(``u_k`` a function of ``x_k`` only), infinite horizon: with ``z = [C x;
u]`` the level ``gamma`` is achievable iff the game DARE (``B = [B2 B1]``,
``R = diag(I, -gamma^2 I)``, ``Q = C'C``) has a stabilizing solution
``X >= 0`` with ``gamma^2 I - B1' X B1 > 0``; the saddle-point controller
``[u; w] = -(R + B'XB)^-1 B'XA x`` is a pure state feedback. The optimum is
found by bisection; each feasible level is also checked by
``control.linfnorm`` of the closed loop with that gain, and the value is
cross-checked against an LMI (`dt_hinf_lmi`, the discrete bounded-real lemma
of de Oliveira, Geromel and Bernussou, Int. J. Control 75(9), 2002).
"""

from __future__ import annotations

import control as ct
import cvxpy as cp
import numpy as np
from scipy import linalg as sla


# ----------------------------------------------------------------------
# H2
# ----------------------------------------------------------------------
def h2_riccati(A, B1, B2, C, F=None, dt=0):
    """LTI H2 state-feedback optimum for ``z = [C x; F u]``.

    Returns ``(h2, X, K)``: ``h2 = sqrt(trace(B1' X B1))``, ``X`` the
    stabilizing CARE (``dt = 0``) or DARE (``dt > 0``) solution with
    ``Q = C'C``, ``R = F'F``, and the optimal ``u = -K x``.
    """
    m = B2.shape[1]
    F = np.eye(m) if F is None else np.asarray(F, float)
    Q = C.T @ C
    R = F.T @ F
    if dt:
        X = sla.solve_discrete_are(A, B2, Q, R)
        K = np.linalg.solve(R + B2.T @ X @ B2, B2.T @ X @ A)
    else:
        X = sla.solve_continuous_are(A, B2, Q, R)
        K = np.linalg.solve(R, B2.T @ X)
    X = 0.5 * (X + X.T)
    return float(np.sqrt(np.trace(B1.T @ X @ B1))), X, K


def closed_loop(A, B1, B2, C, K, F=None, dt=0):
    """``control.StateSpace`` from `w` to ``z = [C x; F u]`` with ``u = -K x``."""
    m = B2.shape[1]
    F = np.eye(m) if F is None else np.asarray(F, float)
    Cz = np.vstack([C, -F @ K])
    return ct.ss(A - B2 @ K, B1, Cz, np.zeros((Cz.shape[0], B1.shape[1])), dt=dt)


def is_stable(Acl, dt=0, tol=0.0):
    """Hurwitz (``dt = 0``) or Schur (``dt > 0``) with a tolerance."""
    ev = np.linalg.eigvals(Acl)
    if dt:
        return bool(np.max(np.abs(ev)) < 1.0 - tol)
    return bool(np.max(ev.real) < -tol)


def spectral_abscissa(Acl, dt=0):
    """Largest real part (continuous) or spectral radius (discrete)."""
    ev = np.linalg.eigvals(Acl)
    return float(np.max(np.abs(ev)) if dt else np.max(ev.real))


# ----------------------------------------------------------------------
# Discrete-time H-infinity state feedback
# ----------------------------------------------------------------------
def dt_hinf_riccati_at(A, B1, B2, C, gamma, check=True):
    """Game DARE at `gamma` (Basar and Bernhard, ch. 3); ``(X, K)`` or None.

    ``z = [C x; u]``. Returns the stabilizing ``X >= 0`` with
    ``gamma^2 I - B1'XB1 > 0`` and the state-feedback gain ``u = -K x`` of
    the saddle point, after checking that ``A - B2 K`` is Schur and (with
    `check`) that ``control.linfnorm`` of its closed loop is below `gamma`
    (so a returned level is achieved, not only predicted).
    """
    n, m = B2.shape
    nw = B1.shape[1]
    B = np.hstack([B2, B1])
    R = sla.block_diag(np.eye(m), -(gamma**2) * np.eye(nw))
    try:
        X = sla.solve_discrete_are(A, B, C.T @ C, R)
    except (np.linalg.LinAlgError, ValueError):
        return None
    X = 0.5 * (X + X.T)
    scale = max(np.abs(X).max(), 1.0)
    if not np.all(np.isfinite(X)) or np.linalg.eigvalsh(X).min() < -1e-9 * scale:
        return None
    if np.linalg.eigvalsh(gamma**2 * np.eye(nw) - B1.T @ X @ B1).min() <= 0:
        return None
    G = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A)
    K = G[:m]
    if not is_stable(A - B2 @ K, dt=1):
        return None
    if not check:
        return X, K
    norm = ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=1))[0]
    if not norm < gamma * (1 + 1e-9):
        return None
    return X, K


def dt_hinf_riccati(A, B1, B2, C, rtol=1e-7):
    """Infimum of the achievable DT H-infinity level (bisection); ``(gamma, K)``.

    The returned level is checked with ``control.linfnorm`` of the closed
    loop with the returned gain (RuntimeError if it is not achieved).
    """

    def ok(gamma):
        return dt_hinf_riccati_at(A, B1, B2, C, gamma, check=False) is not None

    hi = 1.0
    for _ in range(100):
        if ok(hi):
            break
        hi *= 2.0
    else:
        raise RuntimeError("no feasible gamma found")
    lo = hi / 2.0
    while ok(lo):
        hi, lo = lo, lo / 2.0
        if lo < 1e-9:
            break
    while hi / lo - 1 > rtol:
        mid = np.sqrt(hi * lo)
        if ok(mid):
            hi = mid
        else:
            lo = mid
    found = dt_hinf_riccati_at(A, B1, B2, C, hi)
    if found is None:
        raise RuntimeError(f"level {hi} predicted but not achieved")
    return hi, found[1]


def dt_hinf_lmi(A, B1, B2, C, K=None):
    """DT H-infinity level by the discrete bounded-real lemma (own cvxpy LMI).

    de Oliveira, Geromel and Bernussou (2002): ``||C(zI - A)^-1 B + D|| <
    gamma`` iff some ``Q > 0`` has ``[[Q, AQ, B, 0], [QA', Q, 0, QC'], [B',
    0, I, D'], [0, CQ, D, gamma^2 I]] > 0``. With ``K`` given this is the
    analysis of ``u = -K x`` (closed loop ``A - B2 K``, ``[C; -K]``);
    without, ``AQ -> AQ - B2 Y``, ``[C; -K] Q -> [CQ; -Y]`` is the synthesis
    LMI over ``(Q, Y)``. Returns the minimum ``gamma``.
    """
    n, m = B2.shape
    nw = B1.shape[1]
    nz = C.shape[0] + m
    Q = cp.Variable((n, n), symmetric=True)
    mu = cp.Variable()
    if K is None:
        Y = cp.Variable((m, n))
        AQ = A @ Q - B2 @ Y
        CQ = cp.vstack([C @ Q, -Y])
    else:
        AQ = (A - B2 @ K) @ Q
        CQ = np.vstack([C, -K]) @ Q
    M = cp.bmat(
        [
            [Q, AQ, B1, np.zeros((n, nz))],
            [AQ.T, Q, np.zeros((n, nw)), CQ.T],
            [B1.T, np.zeros((nw, n)), np.eye(nw), np.zeros((nw, nz))],
            [np.zeros((nz, n)), CQ, np.zeros((nz, nw)), mu * np.eye(nz)],
        ]
    )
    eps = 1e-9
    cons = [0.5 * (M + M.T) >> eps * np.eye(M.shape[0]), Q >> eps * np.eye(n)]
    prob = cp.Problem(cp.Minimize(mu), cons)
    prob.solve(solver=cp.CLARABEL)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        raise RuntimeError(f"dt_hinf_lmi: {prob.status}")
    return float(np.sqrt(mu.value))


# ----------------------------------------------------------------------
# Problems
# ----------------------------------------------------------------------
def random_lti(rng, n=None, m=None, nw=None, dt=0, scaled=False):
    """A random LTI problem ``(A, B1, B2, C, F, T)``, ``z = [C x; F u]``.

    ``(A, B2)`` stabilizable (random B2). Discrete time: ``A`` has a
    spectral radius in about ``[0.3, 1.6]`` (often unstable). `scaled`:
    the coordinates ``x -> T x`` with ``T = diag(10^U(-3, 3))`` (a badly
    conditioned realisation of the same problem; the optimum is invariant)
    and ``F = diag(10^U(-1.5, 1.5))``. Returns the problem in the scaled
    coordinates and the scaling ``T`` (identity when not scaled).
    """
    n = int(rng.integers(1, 7)) if n is None else n
    m = int(rng.integers(1, 4)) if m is None else m
    nw = int(rng.integers(1, 3)) if nw is None else nw
    A = rng.standard_normal((n, n))
    if dt:
        rho = np.max(np.abs(np.linalg.eigvals(A)))
        A = A / rho * rng.uniform(0.3, 1.6)
    else:
        A = A * rng.uniform(0.3, 1.5)
    B1 = rng.standard_normal((n, nw))
    B2 = rng.standard_normal((n, m))
    p = int(rng.integers(1, n + 1))
    C = rng.standard_normal((p, n))
    F = np.eye(m)
    T = np.eye(n)
    if scaled:
        T = np.diag(10.0 ** rng.uniform(-3, 3, n))
        F = np.diag(10.0 ** rng.uniform(-1.5, 1.5, m))
        Ti = np.diag(1.0 / np.diag(T))
        A, B1, B2, C = T @ A @ Ti, T @ B1, T @ B2, C @ Ti
    return A, B1, B2, C, F, T


def _names(nw, m, p, n):
    return dict(
        inputs=[f"w{i}" for i in range(nw)] + [f"u{i}" for i in range(m)],
        outputs=[f"y{i}" for i in range(p)] + [f"v{i}" for i in range(m)],
        states=[f"x{i}" for i in range(n)],
    )


def _ss(A, B1, B2, C, F, dt):
    """``control.StateSpace`` with inputs ``[w; u]`` and ``z = [C x; F u]``."""
    n, nw, m, p = A.shape[0], B1.shape[1], B2.shape[1], C.shape[0]
    F = np.eye(m) if F is None else np.asarray(F, float)
    D = np.block([[np.zeros((p, nw)), np.zeros((p, m))], [np.zeros((m, nw)), F]])
    return ct.ss(
        A,
        np.hstack([B1, B2]),
        np.vstack([C, np.zeros((m, n))]),
        D,
        dt=dt,
        **_names(nw, m, p, n),
    )


def _dt_kwargs(dt):
    return {"dt": dt} if dt else {}


def lti_system(lpv, A, B1, B2, C, F=None, dt=0):
    """The problem as a one-vertex ``ctrl_lpv.PolytopicStateSpace``.

    Inputs ``w0.., u0..``; outputs ``y0..`` (``C x``) then ``v0..``
    (``F u``); states ``x0..``.
    """
    return vertex_system(lpv, [(A, B1, B2, C)], F=F, dt=dt)


def vertex_system(lpv, vertices, F=None, dt=0, name="h2dt"):
    """``PolytopicStateSpace`` of vertices ``(A, B1, B2, C)`` (simplex domain).

    ``z = [C x; F u]``; the parameter is the vector of convex coordinates.
    """
    verts = [_ss(*v, F, dt) for v in vertices]
    return lpv.PolytopicStateSpace(verts, name=name, **_dt_kwargs(dt))


def affine_system(lpv, M0, terms, F=None, dt=0, name="h2dt"):
    """``PolytopicStateSpace.from_affine`` of `random_box_polytope` data.

    Parameters ``p0, p1, ..`` in ``[-1, 1]``.
    """
    base = _ss(*M0, F, dt)
    n, m = M0[0].shape[0], M0[2].shape[1]
    lpv_terms = {
        f"p{i}": (
            t[0],
            np.hstack([t[1], t[2]]),
            np.vstack([t[3], np.zeros((m, n))]),
            0,
        )
        for i, t in enumerate(terms)
    }
    bounds = {f"p{i}": (-1.0, 1.0) for i in range(len(terms))}
    return lpv.PolytopicStateSpace.from_affine(
        base, lpv_terms, bounds, name=name, **_dt_kwargs(dt)
    )


def channels(nw, m, p):
    """``(w, u, z)`` signal names of the systems built here."""
    return (
        tuple(f"w{i}" for i in range(nw)),
        tuple(f"u{i}" for i in range(m)),
        tuple(f"y{i}" for i in range(p)) + tuple(f"v{i}" for i in range(m)),
    )


def random_box_polytope(rng, nparams, n, m, nw, dt=0, spread=0.3):
    """Affine family ``M(p) = M0 + sum_i p_i M_i`` over ``p in [-1, 1]^k``.

    Returns ``(M0, terms)`` with ``M = (A, B1, B2, C)``: ``A`` and ``B2``
    vary, ``B1`` and ``C`` do not.
    """
    A0, B10, B20, C0, _, _ = random_lti(rng, n, m, nw, dt=dt)
    if dt:
        rho = np.max(np.abs(np.linalg.eigvals(A0)))
        A0 = A0 / rho * 1.05  # moderately unstable center
    terms = []
    for _ in range(nparams):
        terms.append(
            (
                spread * rng.standard_normal((n, n)) / np.sqrt(n),
                np.zeros((n, nw)),
                spread * rng.standard_normal((n, m)) / np.sqrt(n),
                np.zeros_like(C0),
            )
        )
    return (A0, B10, B20, C0), terms


def affine_at(M0, terms, p):
    """``M0 + sum_i p_i M_i`` for the tuples of `random_box_polytope`."""
    return tuple(
        M0[k] + sum(pi * t[k] for pi, t in zip(p, terms)) for k in range(len(M0))
    )


def box_corners(nparams):
    """Corners of ``[-1, 1]^k``."""
    import itertools

    return [np.array(c, float) for c in itertools.product((-1.0, 1.0), repeat=nparams)]


def quadratically_stabilizable(vertices, dt=0, disk=None):
    """Own LMI: a common ``W > 0`` and gain ``K = Z W^-1`` for all vertices.

    Continuous: ``A_j W - B_j Z + (.)' < 0``; discrete (or `disk` ``(r,
    c)``: eigenvalues in ``|z - c| < r``, the unit disk by default):
    ``[[r W, (A_cl - c I) W], [., r W]] > 0`` with ``A_cl W = A_j W - B_j Z``
    (Schur complement of ``(A_cl - cI) W (A_cl - cI)' < r^2 W``).
    `vertices` are ``(A, B1, B2, C)`` tuples. Returns the common gain ``K``
    (checked: every vertex closed loop stable, or in the disk) or None.
    """
    n, m = vertices[0][2].shape
    W = cp.Variable((n, n), symmetric=True)
    Z = cp.Variable((m, n))
    cons = [W >> np.eye(n)]
    r, c = (1.0, 0.0) if disk is None else disk
    for A, _, B2, _ in vertices:
        AW = A @ W - B2 @ Z
        if dt or disk is not None:
            S = AW - c * W
            M = cp.bmat([[r * W, S.T], [S, r * W]])
            cons.append(0.5 * (M + M.T) >> 1e-6 * np.eye(2 * n))
        else:
            cons.append(AW + AW.T << -1e-6 * np.eye(n))
    prob = cp.Problem(cp.Minimize(0), cons)
    try:
        prob.solve(solver=cp.CLARABEL)
    except cp.SolverError:
        return None
    if W.value is None:
        return None
    K = Z.value @ np.linalg.inv(W.value)
    for A, _, B2, _ in vertices:
        ev = np.linalg.eigvals(A - B2 @ K)
        if disk is not None:
            if not np.all(np.abs(ev - c) < r):
                return None
        elif not is_stable(A - B2 @ K, dt):
            return None
    return K
