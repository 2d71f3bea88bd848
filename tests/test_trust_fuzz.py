"""Seeded trust fuzz: every design verified, every refusal true (issue 11).

A fast subset of ``benchmarks/fuzz_trust.py`` (sizes capped, see
``generate_case(..., small=True)``). For each generated problem the library
either returns a design, which must pass the independent float64 check of
``tests/_independent.py`` (from its gains and ``P`` alone), or refuses with
an ``InfeasibleError``, in which case an independent search for a verified
design (plain cvxpy LMIs in other scalings and margins, LQR and Riccati
gains) must fail and the message must not state something false (a "not
stabilizable" vertex that is stabilizable). 20 problems, of which the 16
fast ones run by default and all with ``-m slow`` (see `SLOW`); on so few
the issue's "at most 1 % of the problems with a verified design refused"
is checked as "at most one".

Re-run one case verbosely with
``python benchmarks/fuzz_trust.py --case 2026:INDEX --small``.
"""

import control as ct
import numpy as np
import pytest
from scipy import linalg as sla

import ctrl_lpv as lpv
from _independent import (
    Case,
    Region,
    check_design,
    generate_case,
    hinf_riccati,
    run_case,
)

SEED = 2026
NCASES = 20  # more: benchmarks/fuzz_trust.py
PROBE_BUDGET = 4.0  # CPU seconds per refusal
# Cases over ~5 s run with ``-m slow`` (measured CPU seconds, library call
# and probes: 2026:0 38, 2026:13 17, 2026:18 37, 2026:19 31; all four are
# refusals, three of them gain-scheduled H-infinity ladders). The default
# suite keeps the other 16 (every function, scaled, ill-conditioned,
# near-uncontrollable and issue-style cases, the refusal 2026:6 with its
# probe), about 17 s of CPU.
SLOW = {0, 13, 18, 19}


# ----------------------------------------------------------------------
# The checker has teeth (and accepts what is right)
# ----------------------------------------------------------------------
def _lti(A, B, function="quadratic_stabilization", **kw):
    A, B = np.atleast_2d(A).astype(float), np.atleast_2d(B).astype(float)
    n, m = B.shape
    return Case(
        0, 0, function,
        [(A, np.zeros((n, 0)), B, np.eye(n), np.zeros((n, 0)), np.zeros((n, m)))],
        **kw,
    )  # fmt: skip


def _lyap_P(Acl):
    # Ah' Ph + Ph Ah = -I in balanced coordinates x = D xh, P = D^-1 Ph D^-1
    Ah, (d, _) = sla.matrix_balance(Acl, permute=False, separate=True)
    Ph = sla.solve_continuous_lyapunov(Ah.T, -np.eye(len(Acl)))
    return Ph / d[:, None] / d[None, :]


def test_checker_accepts_the_issue_gain():
    # The issue's example: K = [2e4, 0] places both eigenvalues at -1.
    A, B = np.array([[1.0, 0.0], [1e8, -1.0]]), np.array([[1e-4], [0.0]])
    K = np.array([[2e4, 0.0]])
    assert np.allclose(np.linalg.eigvals(A - B @ K), [-1.0, -1.0])
    result = check_design(_lti(A, B), [K], _lyap_P(A - B @ K))
    assert result.verified, str(result)


def test_checker_rejects_wrong_designs():
    A, B = np.array([[0.0, 1.0], [2.0, -1.0]]), np.array([[0.0], [1.0]])
    X = sla.solve_continuous_are(A, B, np.eye(2), np.eye(1))
    K = B.T @ X
    assert check_design(_lti(A, B), [K], X).verified
    # destabilizing gain
    assert not check_design(_lti(A, B), [np.zeros((1, 2))], X).ok
    # P that is not a Lyapunov matrix of the loop
    assert not check_design(_lti(A, B), [K], np.diag([1.0, -1.0])).ok
    # a gain bound below ||K||
    assert not check_design(
        _lti(A, B, gain_bound=0.5 * np.linalg.norm(K, 2)), [K], X
    ).ok
    # a pole region the loop is not in
    far = Region("halfplane", (10.0 * np.abs(np.linalg.eigvals(A - B @ K)).max(),))
    assert not check_design(_lti(A, B, regions=[far]), [K], X).ok


def test_checker_rejects_a_gamma_below_the_norm():
    A, B1, B2 = np.array([[1.0]]), np.array([[1.0]]), np.array([[2.0]])
    C1, D12 = np.array([[1.0], [0.0]]), np.array([[0.0], [1.0]])
    gamma_opt, _, _ = hinf_riccati(A, B1, B2, C1, D12)
    assert gamma_opt == pytest.approx(0.5, rel=1e-5)  # b1 / b2 for a > 0
    from _independent import hinf_riccati_at

    gamma = 1.2 * gamma_opt
    X, K = hinf_riccati_at(A, B1, B2, C1, D12, gamma, eps=1e-6)
    case = Case(0, 0, "hinf_state_feedback", [(A, B1, B2, C1, np.zeros((2, 1)), D12)])
    assert check_design(case, [K], X / gamma**2, gamma).verified
    norm = ct.linfnorm(ct.ss(A - B2 @ K, B1, C1 - D12 @ K, 0))[0]
    result = check_design(case, [K], X / gamma**2, 0.9 * norm)
    assert not result.ok


# ----------------------------------------------------------------------
# The issue's examples
# ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "A, B",
    [
        ([[1.0, 0.0], [1e8, -1.0]], [[1e-4], [0.0]]),
        (np.diag([1e9, -1e-9]), [[1.0], [1e-9]]),
    ],
    ids=["triangular-1e8", "diag-1e9"],
)
def test_badly_scaled_stabilizable_plant_gets_a_design(A, B):
    case = _lti(A, B)
    case.stabilizable_by_construction = True
    design = lpv.quadratic_stabilization(case.system(lpv), u=["u0"])
    result = check_design(case, design.gains, design.P)
    assert result.ok, str(result)


@pytest.mark.parametrize("seed, index", [(4242, 47), (6161, 12), (9595, 21)])
def test_modes_nine_decades_apart_get_a_design(seed, index):
    # A = diag(1e8..1e9, -1e-9..1e-6), B = [1; tiny], H-infinity: every
    # prescaling hides the slow mode (time-scaled) or leaves LMI entries
    # 1e18 apart (none), where Clarabel stopped in a numerical error; a
    # design exists (the independent probe finds one in raw coordinates).
    # 4242:47 and 6161:12 solve in Clarabel's lifted form; 9595:21 (its
    # optimum's W spans 1e-6..2.5e9) only in its chordal form, whose cones
    # on the LMI's cliques are each equilibrated on their own.
    case = generate_case(seed, index)
    assert any("A=diag(" in tag for tag in case.tags)
    record = run_case(case, lpv, probe_budget=PROBE_BUDGET)
    assert record["outcome"] == "design", record["message"][:300]
    assert record["check_ok"], record["hard"]


@pytest.mark.slow
def test_the_family_of_modes_sixteen_decades_apart_gets_designs():
    # 60 draws of the family of 9595:21 (N = 4, A = diag(a f_j, -1e-9..-1e-6),
    # B = [1; 1e-9..1e-6], a in 1e6..1e9): main at 8fb4359 refused 1 (draw
    # 51), every one a design here, each passing the independent check.
    failed = []
    for s in range(60):
        rng = np.random.default_rng(1000 + s)
        a, vertices = 10.0 ** rng.uniform(6, 9), []
        for j in range(4):
            A = np.diag([a * (1 + 0.1 * j), -(10.0 ** -rng.uniform(6, 9))])
            B = np.array([[1.0], [10.0 ** -rng.uniform(6, 9)]])
            C = np.array([[1.0, 0.0], [0.0, 0.0]])
            vertices.append((A, np.full((2, 1), 0.5), B, C, np.zeros((2, 1)),
                             np.array([[0.0], [1.0]])))  # fmt: skip
        function = "hinf_state_feedback" if s % 2 else "gain_scheduled_hinf"
        case = Case(9, s, function, vertices)
        try:
            design = case.call(lpv)
        except lpv.SynthesisError as exc:
            failed.append((s, str(exc).splitlines()[0]))
            continue
        result = check_design(case, design.gains, design.P, design.gamma)
        if not result.ok:
            failed.append((s, str(result)))
    assert not failed, failed


def test_an_optimum_far_above_the_data_gets_a_design():
    # Fuzz 7373:15: LTI H-infinity, a mode at 0 reached through B of 1e-6.
    # The prescaled data are of order one but the optimum is about 3e4 (a
    # -g I block of 1e9 to 1e10): the solvers called the LMIs infeasible
    # at every prescaling. Posed again with z scaled for a bound far above
    # the data's, the optimal stage solves.
    case = generate_case(7373, 15)
    assert case.N == 1 and any("weak B" in tag for tag in case.tags)
    record = run_case(case, lpv, probe_budget=PROBE_BUDGET)
    assert record["outcome"] == "design", record["message"][:300]
    assert record["check_ok"], record["hard"]
    design = case.call(lpv)
    A, B1, B2, C, D1, D2 = case.vertices[0]
    K = design.gains[0]
    norm = ct.linfnorm(ct.ss(A - B2 @ K, B1, C - D2 @ K, D1))[0]
    assert norm <= design.gamma
    # Within the default back-off of the Riccati bisection's optimum (an
    # upper bound of the true one).
    riccati = hinf_riccati(A, B1, B2, C, D2)[0]
    assert 1e4 < design.gamma <= 1.2 * riccati


def test_a_gain_bound_beyond_the_backoff_gets_a_design():
    # Fuzz 8484:6: H-infinity with gain_bound 7.38 at the default back-off.
    # At gamma <= 1.2 gamma* the convex-concave steps converge at a gain
    # of 10.6; a design under the bound exists at 1.44 gamma* (the probe's,
    # 1.707). The bound is the user's limit: the back-off widens.
    case = generate_case(8484, 6)
    assert case.gain_bound is not None
    record = run_case(case, lpv, probe_budget=PROBE_BUDGET)
    assert record["outcome"] == "design", record["message"][:300]
    assert record["check_ok"], record["hard"]
    design = case.call(lpv)
    assert max(np.linalg.norm(K, 2) for K in design.gains) <= case.gain_bound
    # What it cost is stated: the back-off it was certified within.
    assert design.backoff > 0.2
    assert 1.2 * design.gamma_opt < design.gamma
    assert design.gamma <= (1 + design.backoff) * design.gamma_opt * (1 + 1e-6)
    assert "widened" in design.ladder[0]


def test_uncontrollable_unstable_mode_is_refused_as_such():
    # x2' = 0.5 x2 is not reached by u (exactly): not stabilizable, vertex 1.
    v0 = (np.array([[-1.0, 1.0], [0.0, -2.0]]), np.array([[1.0], [1.0]]))
    v1 = (np.array([[-1.0, 1.0], [0.0, 0.5]]), np.array([[1.0], [0.0]]))
    case = Case(0, 0, "quadratic_stabilization", [
        (A, np.zeros((2, 0)), B, np.eye(2), np.zeros((2, 0)), np.zeros((2, 1)))
        for A, B in (v0, v1)
    ])  # fmt: skip
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.quadratic_stabilization(case.system(lpv), u=["u0"])
    assert type(info.value) is lpv.InfeasibleError
    assert "vertex 1" in str(info.value) and "not stabilizable" in str(info.value)


# ----------------------------------------------------------------------
# The fuzz
# ----------------------------------------------------------------------
# 2026:14 (settled in exact rational arithmetic by a study of the paper
# engine, removed with it): the library used to verify and return
# P = inv(W) unsymmetrised (4.9e-17 relative), for which P A + A' P' passed
# (-4.64e-9) while sym(P), the storage function x'Px, fails the
# bounded-real inequality (+3.98e-4). The library now symmetrises P
# (Scaling.unscale_P); the case must be a true design or a true refusal.
DISPUTED: dict[int, str] = {}


class _Records(dict):
    """Each case run once, on first use (deselected cases never run)."""

    def __missing__(self, index):
        case = generate_case(SEED, index, small=True)
        self[index] = (case, run_case(case, lpv, probe_budget=PROBE_BUDGET))
        return self[index]


@pytest.fixture(scope="module")
def records():
    return _Records()


def _marks(i):
    marks = [pytest.mark.xfail(reason=DISPUTED[i])] if i in DISPUTED else []
    return marks + ([pytest.mark.slow] if i in SLOW else [])


@pytest.mark.parametrize(
    "index", [pytest.param(i, marks=_marks(i)) for i in range(NCASES)]
)
def test_generated_problem(records, index):
    case, rec = records[index]
    what = case.describe()
    if rec["outcome"] == "design":
        assert rec["check_ok"], f"{what}: returned design fails: {rec['hard']}"
        assert not rec.get("design_on_proved_infeasible"), what
        return
    assert rec["verdict"] != "uncaught exception", (
        f"{what}: {rec['class']}: {rec['message']}"
    )
    assert not rec["false_statement"], (
        f"{what}: {rec['class']} ({rec['kind']}): {rec['false_statement']}: "
        f"{rec['message'][:300]}"
    )


def _false_refusals(records, indices):
    false = []
    for index in indices:
        case, rec = records[index]
        if rec["outcome"] == "refusal" and rec["verdict"] == "false refusal":
            false.append(case.describe())
    return false


def test_false_refusal_rate(records):
    # The issue's bound is 1 % of the problems with a verified design; on a
    # subset this small one refusal is already 5 %: at most one is allowed
    # here, the rate is measured on larger runs by benchmarks/fuzz_trust.py.
    fast = [i for i in range(NCASES) if i not in SLOW]
    false = _false_refusals(records, fast)
    assert len(false) <= 1, false


@pytest.mark.slow
def test_false_refusal_rate_all_cases(records):
    false = _false_refusals(records, range(NCASES))
    assert len(false) <= 1, false
