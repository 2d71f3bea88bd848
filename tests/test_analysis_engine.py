"""The analyses on the one engine, held to independent facts (issue 20).

`quadratic_stability`, `l2_gain_bound`, `h2_bound` and `ultimate_bound` are
analyses of the one engine (`ctrl_lpv.synthesis.general.run_analysis`).
Their hand-built LMI problems were compared with it on fuzz corpora before
they were deleted (`ultimate_bound`: 48 random stable polytopes, n = 1..5,
N = 1..4, one or two disturbances and outputs, and the servo's contact
loop: the same 49 verdicts, new/old bound in [0.99981, 1.00002]). These
tests hold the engine to facts computed here, on seeded random stable
polytopes in continuous and discrete time:

* `quadratic_stability`: ``P > 0`` and the Lyapunov inequality at every
  vertex, recomputed with numpy;
* `l2_gain_bound`: at least python-control's H-infinity norm of the frozen
  loops (vertices and random points), and equal to it for one vertex (at a
  margin of 1e-8, within 1e-5 relative);
* `h2_bound`: at least the H2 norm of the frozen loops (Lyapunov equations
  solved by scipy), and equal to it for one vertex (likewise);
* `ultimate_bound`: the invariance inequality at every vertex recomputed
  with numpy; exact trajectories (piecewise-constant worst-case switching
  and bang-bang inputs, advanced with matrix exponentials) stay in the
  ellipsoid and its output bounds, and approach it at the certified rate;
  for one vertex the bound is at least the exact worst-case peak (the L1
  norm of the impulse response); and it certifies exactly when the
  polytope is quadratically stable.

The whole corpus runs with ``-m slow``; a few of its cases by default.
"""

import control as ct
import numpy as np
import pytest
import scipy.linalg as sla

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import SynthesisError

# Relative agreement with the exact norm of one vertex at the margin
# `EXACT_MARGIN` (at the default margin 1e-6 the bounds of the corpus are
# up to 3e-5 above it: the margin's cost; at 1e-8, 3e-7).
EXACT_RTOL, EXACT_MARGIN = 1e-5, 1e-8


def vertices(seed, n, N, dt):
    """``N`` stable ``n x n`` matrices (Hurwitz, or Schur for `dt`).

    Seeds 1, 4, ... quadratically stable by construction (in coordinates
    ``T``, a skew-symmetric matrix minus a multiple of I, or a contraction),
    the others random around one centre, close (seeds 0, 3, ...) or far
    apart (2, 5, ...: some without a common Lyapunov matrix).
    """
    rng = np.random.default_rng([seed, n, N, int(bool(dt))])
    T = (
        np.diag(2.0 ** rng.integers(-3, 4, size=n))
        @ np.linalg.qr(rng.normal(size=(n, n)))[0]
    )
    Ti = np.linalg.inv(T)
    A0 = rng.normal(size=(n, n))
    out = []
    for _ in range(N):
        if seed % 3 == 1:
            S = rng.normal(size=(n, n))
            if dt:
                Q = np.linalg.qr(S)[0]
                A = T @ (rng.uniform(0.3, 0.95) * Q) @ Ti
            else:
                A = T @ (S - S.T - rng.uniform(0.2, 2.0) * np.eye(n)) @ Ti
        else:
            A = A0 + (0.3 if seed % 3 == 0 else 1.5) * rng.normal(size=(n, n))
            eig = np.linalg.eigvals(A)
            if dt:
                A = A * rng.uniform(0.5, 0.95) / np.abs(eig).max()
            else:
                A = A - (eig.real.max() + rng.uniform(0.1, 1.0)) * np.eye(n)
        out.append(A)
    return out


def plant(seed, n, N, dt):
    """A plant ``(A_j + B K, [E_j, B], [C; 0], [0, 0; 0, 1])`` with the gain
    ``K`` (``u = -K x``) that gives back the stable ``A_j``: inputs ``w``,
    ``u``, outputs ``z``, ``v`` (``v = u``)."""
    rng = np.random.default_rng([seed, n, N, int(bool(dt)), 7])
    K = rng.normal(size=(1, n))
    B = rng.normal(size=(n, 1))
    C = rng.normal(size=(1, n))
    systems = []
    for A in vertices(seed, n, N, dt):
        E = rng.normal(size=(n, 1))
        C2 = np.vstack([C, np.zeros((1, n))])
        D = np.array([[0.0, 0.0], [0.0, 1.0]])
        systems.append(ct.ss(A + B @ K, np.hstack([E, B]), C2, D, dt=dt))
    return lpv.pss(systems, inputs=["w", "u"], outputs=["z", "v"]), K


SIZES = [(1, 1), (2, 1), (2, 3), (3, 2), (4, 4)]
DTS = [0, 0.1]
CORPUS = [(seed, n, N, dt) for seed in range(6) for n, N in SIZES for dt in DTS]
FAST = [(1, 2, 3, 0), (0, 3, 2, 0.1), (3, 2, 1, 0), (4, 4, 4, 0.1)]


def frozen_loops(sys, K, count=8, seed=0):
    """The closed loops ``w -> [z; v]`` at the vertices and random points."""
    rng = np.random.default_rng(seed)
    data = list(sys.vertex_data())
    weights = list(np.eye(len(data)))
    if len(data) > 1:
        weights += list(rng.dirichlet(np.ones(len(data)), size=count))
    for d in weights:
        A, B, C, D = (sum(x * M[i] for x, M in zip(d, data)) for i in range(4))
        yield ct.ss(A - B[:, 1:] @ K, B[:, :1], C - D[:, 1:] @ K, D[:, :1], dt=sys.dt)


def h2_norm(loop) -> float:
    """The H2 norm from the controllability Gramian (scipy)."""
    A, B, C, D = (np.asarray(M) for M in (loop.A, loop.B, loop.C, loop.D))
    if loop.dt:
        X = sla.solve_discrete_lyapunov(A, B @ B.T)
        return float(np.sqrt(np.trace(C @ X @ C.T + D @ D.T)))
    X = sla.solve_continuous_lyapunov(A, -B @ B.T)
    return float(np.sqrt(np.trace(C @ X @ C.T)))


def quadratically_stable(As, dt) -> bool:
    try:
        lpv.quadratic_stability(lpv.pss([ct.ss(A, np.zeros((len(A), 1)),
                                               np.zeros((1, len(A))), 0, dt=dt)
                                         for A in As]))  # fmt: skip
    except SynthesisError:  # a refusal or a proof
        return False
    return True


# ----------------------------------------------------------------------
# quadratic_stability, l2_gain_bound, h2_bound
# ----------------------------------------------------------------------
def check_quadratic_stability(case):
    seed, n, N, dt = case
    As = vertices(*case)
    sys = lpv.pss([ct.ss(A, np.zeros((n, 1)), np.zeros((1, n)), 0, dt=dt) for A in As])
    try:
        result = lpv.quadratic_stability(sys)
    except SynthesisError:  # a refusal or a proof
        assert N > 1 and seed % 3 != 1, "a quadratically stable polytope refused"
        return
    assert result.certificate.verified and "closed loop" in str(result.certificate)
    P = result.P
    assert np.allclose(P, P.T) and np.linalg.eigvalsh(P)[0] > 0
    for A in As:
        M = A.T @ P @ A - P if dt else A.T @ P + P @ A
        assert np.linalg.eigvalsh(0.5 * (M + M.T))[-1] < 0


def check_bound(case, analysis, norm):
    """`analysis` (`l2_gain_bound` or `h2_bound`) against `norm` of the
    frozen loops: above it everywhere, equal to it for one vertex."""
    sys, K = plant(*case)
    try:
        margin = EXACT_MARGIN if case[2] == 1 else 1e-6
        bound = analysis(sys, K, "w", "u", ["z", "v"], margin)
    except SynthesisError:  # a refusal or a proof
        assert case[2] > 1 and case[0] % 3 != 1
        return
    norms = [norm(loop) for loop in frozen_loops(sys, K)]
    assert bound.certificate.verified
    assert bound.gamma >= max(norms) * (1 - 1e-9)
    if case[2] == 1:
        assert bound.gamma == pytest.approx(norms[0], rel=EXACT_RTOL)


ANALYSES = {
    "quadratic_stability": check_quadratic_stability,
    "l2_gain_bound": lambda case: check_bound(
        case, lpv.l2_gain_bound, lambda loop: float(ct.linfnorm(loop)[0])
    ),
    "h2_bound": lambda case: check_bound(case, lpv.h2_bound, h2_norm),
}


@pytest.mark.parametrize("case", FAST)
@pytest.mark.parametrize("analysis", ANALYSES)
def test_analysis_holds_against_the_facts(analysis, case):
    ANALYSES[analysis](case)


@pytest.mark.slow
@pytest.mark.parametrize("case", CORPUS)
@pytest.mark.parametrize("analysis", ANALYSES)
def test_whole_corpus_analysis_holds_against_the_facts(analysis, case):
    ANALYSES[analysis](case)


# ----------------------------------------------------------------------
# ultimate_bound
# ----------------------------------------------------------------------
UB_SIZES = [(1, 1, 1, 1), (2, 1, 1, 1), (2, 2, 1, 2), (3, 2, 2, 1), (4, 3, 2, 2)]
UB_CORPUS = [(seed, *size) for seed in range(6) for size in UB_SIZES]
UB_FAST = [(0, 2, 2, 1, 2), (1, 3, 2, 2, 1), (3, 2, 1, 1, 1)]


def disturbed(seed, n, N, nw, ny):
    """Vertices ``(A_j, E_j)``, output rows ``C`` and peaks ``w_max``."""
    rng = np.random.default_rng([seed, n, N, nw, ny, 11])
    As = vertices(seed, n, N, 0)
    Es = [rng.normal(size=(n, nw)) for _ in range(N)]
    return As, Es, rng.normal(size=(ny, n)), rng.uniform(0.2, 3.0, size=nw)


def exact_steps(As, Es, h):
    """``(Phi_j, Gamma_j)``: ``x+ = Phi_j x + Gamma_j w`` over a step `h`
    with vertex ``j`` and ``w`` held (exact for such trajectories)."""
    out = []
    for A, E in zip(As, Es):
        n, nw = E.shape
        M = np.zeros((n + nw, n + nw))
        M[:n, :n], M[:n, n:] = A, E
        F = sla.expm(M * h)
        out.append((F[:n, :n], F[:n, n:]))
    return out


def worst_trajectory(res, As, Es, x0, steps, h):
    """Each step, the vertex and the bang-bang input that increase ``x'Px``
    fastest (held over the step: an admissible trajectory)."""
    P, wmax = res.P, res.w_max
    maps = exact_steps(As, Es, h)
    x, xs = np.array(x0, float), [np.array(x0, float)]
    for _ in range(steps):
        best = None
        for (Phi, Gam), A, E in zip(maps, As, Es):
            w = wmax * np.where(E.T @ P @ x >= 0, 1.0, -1.0)
            rate = x @ P @ (A @ x + E @ w)
            if best is None or rate > best[0]:
                best = (rate, Phi @ x + Gam @ w)
        x = best[1]
        xs.append(x)
    return np.array(xs).T


def check_ultimate_bound(case):
    As, Es, C, w_max = disturbed(*case)
    try:
        res = lpv.ultimate_bound((As, Es), w_max=w_max, output=C)
    except SynthesisError:  # a refusal or a proof
        assert not quadratically_stable(As, 0)
        return
    assert quadratically_stable(As, 0)  # P is a common Lyapunov matrix
    assert res.certificate.verified
    P, lam, mu, rho = res.P, res.decay, res.mu, res.rho
    assert rho == pytest.approx(mu.sum() / lam, rel=1e-12)
    D = np.diag(w_max)
    for A, E in zip(As, Es):
        M = np.block([[A.T @ P + P @ A + lam * P, P @ E @ D],
                      [D @ E.T @ P, -np.diag(mu)]])  # fmt: skip
        d = 1 / np.sqrt(np.abs(np.diag(M)))
        assert np.linalg.eigvalsh(M * d[:, None] * d)[-1] < 0
    W = np.linalg.inv(P)
    np.testing.assert_allclose(
        res.bounds, np.sqrt(rho * np.einsum("ij,jk,ik->i", C, W, C)), rtol=1e-9
    )
    # Exact worst-case trajectories from the origin and from outside.
    h = 0.02 / max(np.linalg.norm(A, 2) for A in As)
    steps = int(min(4000, 8 / (lam * h)))
    t = h * np.arange(steps + 1)
    for x0 in (np.zeros(len(P)), 3 * np.sqrt(rho) * np.linalg.cholesky(W)[:, 0]):
        x = worst_trajectory(res, As, Es, x0, steps, h)
        V = np.einsum("it,ij,jt->t", x, P, x)
        assert np.all(V <= res.level_bound(V[0], t) * (1 + 1e-7) + 1e-12)
        if not x0.any():
            assert np.all(V <= rho * (1 + 1e-7))
            assert np.all(np.abs(C @ x).max(axis=1) <= res.bounds * (1 + 1e-7))
    if len(As) == 1:
        # The exact worst-case peak of each output: sum_i w_max_i times the
        # L1 norm of the impulse response from w_i (no bound is below it).
        tt = np.linspace(0.0, 30.0 / lam, 30001)
        for k in range(len(C)):
            peak = 0.0
            for i in range(len(w_max)):
                _, y = ct.impulse_response(ct.ss(As[0], Es[0][:, [i]], C[[k]], 0), tt)
                peak += w_max[i] * np.trapezoid(np.abs(np.ravel(y)), tt)
            assert res.bounds[k] >= peak * (1 - 1e-3)


@pytest.mark.parametrize("case", UB_FAST)
def test_ultimate_bound_holds_against_the_facts(case):
    check_ultimate_bound(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", UB_CORPUS)
def test_whole_corpus_ultimate_bound_holds_against_the_facts(case):
    check_ultimate_bound(case)
