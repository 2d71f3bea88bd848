"""Refusals of the right class: no common Lyapunov matrix (issue 19).

Polytopes without a common quadratic Lyapunov function (proven here
independently of ctrl_lpv) must be refused with `InfeasibleError`, whose
message states the relative-margin bound of the verified dual certificate
and the larger relative margin the certificate would need, after few solver
calls (not the whole ladder); polytopes that have one, or that a gain can
stabilize, must still get a certified design.

Independent proofs used:

* two Hurwitz matrices with a common ``P`` (``A_j' P + P A_j < 0``) have the
  same ``P`` for ``A_2^-1`` (``A_2^-T (A_2' P + P A_2) A_2^-1 = P A_2^-1 +
  A_2^-T P``), so every convex combination of ``A_1`` and ``A_2^-1`` is
  then Hurwitz: one that is not proves that no common ``P`` exists (the
  pairs of 2x2 matrices below have every convex combination of ``A_1`` and
  ``A_2`` Hurwitz, yet fail this test: Shorten and Narendra's condition);
* a dual point found with plain cvxpy: PSD ``Y_j`` with ``sum_j A_j Y_j +
  Y_j A_j'`` positive definite in float64, beyond its rounding; then
  ``sum_j <A_j' P + P A_j, Y_j> = <P, sum_j A_j Y_j + Y_j A_j'>`` would be
  both negative and positive for a common ``P``.
"""

import re

import cvxpy as cp
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv.lmi import (
    LMIProblem,
    schur_norm_bound,
    symmetric_norm_bound,
)

EPS = np.finfo(float).eps


def random_pair(seed):
    """Two Hurwitz 2x2 vertices ``A0 + 0.25 N(0, 1)`` (``A0``: 3 N(0, 1),
    spectral abscissa -0.2)."""
    rng = np.random.default_rng(seed)
    A0 = 3 * rng.normal(size=(2, 2))
    A0 -= (np.linalg.eigvals(A0).real.max() + 0.2) * np.eye(2)
    return [A0 + 0.25 * rng.normal(size=(2, 2)) for _ in range(2)]


def issue_polytope(seed):
    """Two or three 3x3 vertices ``A0 + 0.25 N(0, 1)`` (the issue's draw;
    ``benchmarks/study_true_refusals.py``)."""
    rng = np.random.default_rng([2019, seed])
    n, nvert = 2 + (seed // 2) % 2, 2 + seed % 2
    A0 = 3 * rng.normal(size=(n, n))
    A0 -= (np.linalg.eigvals(A0).real.max() + 0.2) * np.eye(n)
    return [A0 + 0.25 * rng.normal(size=A0.shape) for _ in range(nvert)]


def max_real_on_segment(A, B, count=2001):
    return max(
        np.linalg.eigvals((1 - t) * A + t * B).real.max()
        for t in np.linspace(0, 1, count)
    )


def dual_witness(As, discrete=False) -> float:
    """Least eigenvalue of ``sum A_j Y_j + Y_j A_j'`` less a rounding bound,
    ``Y_j`` PSD of total trace 1 from plain cvxpy (> 0: no common P).

    `discrete`: ``sum A_j Y_j A_j' - Y_j`` instead, the dual of the Stein
    inequalities ``A_j' P A_j - P < 0``.
    """
    n = As[0].shape[0]

    def image(A, Y):
        return A @ Y @ A.T - Y if discrete else A @ Y + Y @ A.T

    Ys = [cp.Variable((n, n), symmetric=True) for _ in As]
    t = cp.Variable()
    S = sum(image(A, Y) for A, Y in zip(As, Ys))
    constraints = [Y >> 0 for Y in Ys] + [sum(cp.trace(Y) for Y in Ys) == 1]
    constraints.append(0.5 * (S + S.T) >> t * np.eye(n))
    cp.Problem(cp.Maximize(t), constraints).solve(solver="CLARABEL")
    projected = []
    for Y in Ys:
        lam, V = np.linalg.eigh(0.5 * (Y.value + Y.value.T))
        projected.append((V * np.clip(lam, 0, None)) @ V.T)
    total = sum(np.trace(Y) for Y in projected)
    Sv = sum(image(A, Y) for A, Y in zip(As, projected)) / total
    rounding = 1e3 * n * EPS * sum((np.abs(A).sum() + 1) ** 2 for A in As)
    return float(np.linalg.eigvalsh(0.5 * (Sv + Sv.T))[0] - rounding)


def autonomous(As, B=None):
    n = As[0].shape[0]
    B = np.zeros((n, 1)) if B is None else np.asarray(B, float)
    return lpv.PolytopicStateSpace(
        [(A, B, np.eye(n), np.zeros((n, B.shape[1]))) for A in As]
    )


def stated_margins(message):
    """Every (bound, needed) pair of relative margins the message states."""
    number = r"([0-9][0-9.]*(?:e[+-]?[0-9]+)?)"
    pairs = re.findall(
        rf"relative margin at most {number}, the certificate needs {number}", message
    )
    return [(float(a), float(b)) for a, b in pairs]


# ----------------------------------------------------------------------
# The independent proofs hold for the cases used below
# ----------------------------------------------------------------------
NO_CQLF_PAIRS = (0, 33)  # seeds of `random_pair`
NO_CQLF_ISSUE = (22, 19)  # seeds of `issue_polytope` (3x3; 2, 3 vertices)


@pytest.mark.parametrize("seed", NO_CQLF_PAIRS)
def test_pairs_have_no_common_lyapunov_matrix(seed):
    A1, A2 = random_pair(seed)
    for A in (A1, A2):
        assert np.linalg.eigvals(A).real.max() < 0
    # Every convex combination of the vertices is Hurwitz: the refusal is
    # not about an unstable frozen point...
    assert max_real_on_segment(A1, A2) < -1e-3
    # ... but one of A1 and A2^-1 is not: no common P.
    assert max_real_on_segment(A1, np.linalg.inv(A2)) > 1e-4
    # The independent dual agrees.
    assert dual_witness([A1, A2]) > 0


@pytest.mark.parametrize("seed", NO_CQLF_ISSUE)
def test_issue_polytopes_have_no_common_lyapunov_matrix(seed):
    As = issue_polytope(seed)
    assert As[0].shape == (3, 3)
    assert max(np.linalg.eigvals(A).real.max() for A in As) < 0
    assert dual_witness(As) > 1e-9


# ----------------------------------------------------------------------
# Refused as infeasible, with the statement, without the whole ladder
# ----------------------------------------------------------------------
def check_statement(exc):
    message = str(exc)
    assert re.search("no certifiable (design|Lyapunov matrix) exists", message)
    margins = stated_margins(message)
    # one pair per prescaling of the ladder (the model's own units among
    # them), each bound below the need
    named = re.findall(r"(\w+): relative margin at most", message)
    assert len(named) == len(margins) >= 2 and {"balanced", "none"} <= set(named)
    for bound, needed in margins:
        assert 0 < bound < needed
    assert exc.farkas is not None and exc.farkas.relative_margin < margins[0][1]


@pytest.mark.parametrize("seed", NO_CQLF_PAIRS)
@pytest.mark.parametrize(
    "design",
    [
        lambda s: lpv.quadratic_stabilization(s, u=[0]),
        lambda s: lpv.gain_scheduled_stabilization(s, u=[0]),
        lambda s: lpv.synthesize(s, [0]),
    ],
    ids=["Lemma 1", "Theorem 1", "synthesize"],
)
def test_no_common_lyapunov_matrix_is_infeasible(seed, design):
    # The input matrix is zero: no gain can help.
    with pytest.raises(lpv.InfeasibleError) as info:
        design(autonomous(random_pair(seed)))
    assert type(info.value) is lpv.InfeasibleError
    check_statement(info.value)
    # Refused before climbing the ladder: it used to make about 30 solver
    # attempts (7 rungs, three z_max bounds each, margin retries, SCS).
    assert len(info.value.attempts) <= 6


@pytest.mark.parametrize("seed", NO_CQLF_ISSUE)
def test_issue_polytope_is_infeasible(seed):
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.quadratic_stabilization(autonomous(issue_polytope(seed)), u=[0])
    check_statement(info.value)


@pytest.mark.parametrize("seed", NO_CQLF_PAIRS + NO_CQLF_ISSUE[:1])
def test_quadratic_stability_is_infeasible(seed):
    As = issue_polytope(seed) if seed in NO_CQLF_ISSUE else random_pair(seed)
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.quadratic_stability(autonomous(As))
    # The analysis is the engine's stabilize stage: the same proof.
    check_statement(info.value)


def test_discrete_time_analysis_is_infeasible():
    # The general engine (discrete time), on a sampled pair whose Stein
    # inequalities have an independent dual witness.
    from scipy.linalg import expm

    As = [expm(0.5 * A) for A in random_pair(0)]
    assert max(np.abs(np.linalg.eigvals(A)).max() for A in As) < 1
    assert dual_witness(As, discrete=True) > 0
    sys = lpv.PolytopicStateSpace(
        [(A, np.zeros((2, 1)), np.eye(2), np.zeros((2, 1))) for A in As], dt=0.5
    )
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.quadratic_stability(sys)
    check_statement(info.value)


# ----------------------------------------------------------------------
# What can be certified still is
# ----------------------------------------------------------------------
def test_stabilizable_polytope_still_designs():
    # The same vertices with an input on the second state: a gain helps.
    As, B = random_pair(0), np.array([[0.0], [1.0]])
    design = lpv.quadratic_stabilization(autonomous(As, B), u=[0])
    (K,) = design.gains
    P = design.P
    assert np.linalg.eigvalsh(P)[0] > 0
    for A in As:
        Acl = A - B @ K
        assert np.linalg.eigvals(Acl).real.max() < 0
        assert np.linalg.eigvalsh(Acl.T @ P + P @ Acl)[-1] < 0


def test_common_lyapunov_matrix_is_found():
    # A pair with a common P (found by plain cvxpy below): certified.
    As = random_pair(1)
    n = 2
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    constraints = [P >> t * np.eye(n), P << np.eye(n)]
    constraints += [A.T @ P + P @ A << -t * np.eye(n) for A in As]
    cp.Problem(cp.Maximize(t), constraints).solve(solver="CLARABEL")
    assert t.value > 1e-3
    result = lpv.quadratic_stability(autonomous(As))
    for A in As:
        assert np.linalg.eigvalsh(A.T @ result.P + result.P @ A)[-1] < 0
    design = lpv.quadratic_stabilization(autonomous(As), u=[0])
    assert design.certificate.verified


# ----------------------------------------------------------------------
# The claim itself: what a certificate excludes, and the norm bounds
# ----------------------------------------------------------------------
def cone_problem():
    """``p > 0`` and ``-p > 0``: a cone with no point but 0."""
    lmi = LMIProblem(margin=1e-6)
    lmi.variable("p", (1, 1), symmetric=True)
    lmi.variable("q", (1, 1), symmetric=True)  # read by no inequality
    lmi.add("p > 0", lambda v: [[-v.p]])
    lmi.add("-p > 0", lambda v: [[v.p]])
    return lmi


def test_certificate_excludes_only_within_bounds_and_margins():
    lmi = cone_problem()
    proof = lmi.farkas([np.eye(1), np.eye(1)])
    assert proof.homogeneous and proof.strict_only and not proof.normalized
    assert proof.variables == ("p",)  # q enters no inequality: no bound needed
    # |p| <= 1 and a margin of 5e-7 needed: impossible.
    assert proof.excludes(1e-6, {"p": 1.0})
    # Without a bound on p, or with no margin to speak of, no claim.
    assert not proof.excludes(1e-6, {})
    assert not proof.excludes(0.0, {"p": 1.0})


def test_certificate_with_a_weak_bound_excludes_nothing():
    # Y = (0.9, 0.1): g = 0.8 per unit of p, a relative margin of 0.8: a
    # point with p = -1 has margin ... -max(1, -1) < 0, so the LMIs are
    # infeasible, but the bound says only "margin <= 0.8 |p|": no claim
    # at a margin the certificate accepts for |p| <= 1.
    lmi = cone_problem()
    lmi_duals = [np.array([[0.9]]), np.array([[0.1]])]
    amap = lmi._affine_map(lmi._active("default"))
    from ctrl_lpv.lmi import _certificate

    y = amap.stack(lmi_duals)
    proof = _certificate(
        "default", amap, y, np.arange(2), amap.sizes, np.zeros(2, bool),
        np.ones(2, bool), lmi._column_groups(),
    )  # fmt: skip
    assert proof.used_relative_margin() >= 0.8 - 1e-12
    assert not proof.excludes(1e-6, {"p": 1.0})


def largest_passing(check, direction):
    """Largest ``s`` with ``check(s * direction)`` passing (bisection)."""
    low, high = 0.0, 1.0
    while check(high * direction):
        high *= 2
    for _ in range(80):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if check(mid * direction) else (low, mid)
    return low


@pytest.mark.parametrize("w_max", [1.0, 1e-3, 1e3])
def test_symmetric_norm_bound_holds_for_what_the_check_accepts(w_max):
    n = 4
    lmi = LMIProblem()
    lmi.variable("W", (n, n), symmetric=True)
    lmi.add("W > 0", lambda v: [[-v.W]])
    lmi.add("W <= w", lambda v: [[v.W - w_max * np.eye(n)]], strict=False)
    lmi.margin = 1e-300  # only the side constraint matters here

    def passes(W):
        return all(c.passed for c in lmi.check({"W": W}))

    rng = np.random.default_rng(3)
    bound = symmetric_norm_bound(w_max, n)
    for _ in range(5):
        G = rng.normal(size=(n, n))
        direction = G @ G.T + 0.1 * np.eye(n)
        W = largest_passing(passes, direction) * direction
        free = W[np.triu_indices(n)]
        assert np.linalg.norm(free) <= bound
    # and it is nearly reached (by the largest multiple of I that passes)
    W = largest_passing(passes, np.eye(n))
    assert bound <= 1.01 * np.sqrt(n) * W


@pytest.mark.parametrize("z_max", [1.0, 1e4, 1e8])
def test_schur_norm_bound_holds_for_what_the_check_accepts(z_max):
    n, m = 3, 2
    lmi = LMIProblem()
    lmi.variable("Z", (m, n))
    lmi.add(
        "||Z||^2 <= z",
        lambda v: [[-z_max * np.eye(n)], [v.Z, -np.eye(m)]],
        strict=False,
    )
    rng = np.random.default_rng(4)
    bound = schur_norm_bound(z_max, (m, n))

    def passes(Z):
        return all(c.passed for c in lmi.check({"Z": Z}))

    for _ in range(5):
        direction = rng.normal(size=(m, n))
        Z = largest_passing(passes, direction) * direction
        assert np.linalg.norm(Z) <= bound
