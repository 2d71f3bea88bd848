"""Time budgets, progress logging and short refusals (issue 19, DESIGN 4.12).

No wall-clock assertion: the clock (``time.perf_counter``) is patched to
jump past every deadline at the first solver call, and the tests count the
solver calls made after it. Facts used, none taken from ``ctrl_lpv``:

* the H-infinity state-feedback optimum of an LTI plant by Riccati
  bisection (``tests/_independent.hinf_riccati``);
* the constant-Lyapunov (quadratic) optima of ``tests/_pdl_reference``
  (cvxpy programs written from the literature): a Lyapunov matrix constant
  in a parameter holds for every rate of it;
* frozen closed loops recomputed with numpy and python-control.
"""

from __future__ import annotations

import dataclasses
import logging
import time

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _independent import hinf_riccati
from _pdl_reference import mass_spring, pdl_l2_gain, pdl_sf_hinf
from ctrl_lpv import budget
from ctrl_lpv.lmi import problem as lmi_problem
from ctrl_lpv.lmi.conic import ConicResult

IW, IU, IZ = [0], [1], [0, 1]
HINF = dict(objective=lpv.Hinf("w", ["x", "uw"]))
# A gain that stabilises every frozen k > 0: A - B K = [[0, 1], [-k-1, -1.5]].
GAIN = np.array([[1.0, 1.0]])


def pss(box, dt=0):
    """The library's system of a reference `AffineBox` (two inputs w, u)."""
    name = box.names[0]
    base = ct.ss(*box.base, inputs=["w", "u"], outputs=["x", "uw"], states=["x", "v"])
    sys = lpv.PolytopicStateSpace.from_affine(
        base, {name: box.terms[0]}, {name: (float(box.lo[0]), float(box.hi[0]))}
    )
    return sys.sample(dt) if dt else sys


@pytest.fixture(scope="module")
def plant():
    return pss(mass_spring())


@pytest.fixture
def clock(monkeypatch):
    """``time.perf_counter`` with a settable jump, for every module."""
    jump = [0.0]
    real = time.perf_counter
    monkeypatch.setattr(time, "perf_counter", lambda: real() + jump[0])
    return jump


@pytest.fixture
def stalled_solver(monkeypatch, clock):
    """A solver that uses up any budget and fails, as Clarabel or SCS at
    their time limit: each call moves the clock 1e6 s on and returns no
    point. Returns the list of calls."""
    calls = []

    def run(solver, c, data_of, margin, options):
        calls.append(solver)
        clock[0] += 1e6
        return ConicResult("user_limit", None, None, None, 1e6)

    monkeypatch.setattr(lmi_problem, "run", run)
    return calls


def _closed_loop(plant):
    vertices = []
    for A, B, _, _ in plant.vertex_data():
        vertices.append((A - B[:, IU] @ GAIN, B[:, IW], np.eye(2), np.zeros((2, 1))))
    return lpv.PolytopicStateSpace(vertices, domain=plant.domain)


# Every public call that solves LMIs, with arguments that need more than one
# solve.
CALLS = {
    "synthesize": lambda s: lpv.synthesize(s, "u", **HINF),
    "synthesize (H2)": lambda s: lpv.synthesize(
        s, "u", objective=lpv.H2("w", ["x", "uw"])
    ),
    "synthesize (affine)": lambda s: lpv.synthesize(
        s, "u", **HINF, gains="scheduled", lyapunov="affine", rate_bounds={"k": 1.0}
    ),
    "synthesize (Peak)": lambda s: lpv.synthesize(
        s, "u", objective=lpv.Peak("w", ["x", "uw"])
    ),
    "h2_state_feedback": lambda s: lpv.h2_state_feedback(s, "w", "u", ["x", "uw"]),
    "quadratic_stabilization": lambda s: lpv.quadratic_stabilization(s, u="u"),
    "gain_scheduled_stabilization": lambda s: lpv.gain_scheduled_stabilization(
        s, u="u"
    ),
    "hinf_state_feedback": lambda s: lpv.hinf_state_feedback(
        s, w="w", u="u", z=["x", "uw"]
    ),
    "gain_scheduled_hinf": lambda s: lpv.gain_scheduled_hinf(
        s, w="w", u="u", z=["x", "uw"]
    ),
    "quadratic_stability": lambda s: lpv.quadratic_stability(_closed_loop(s)),
    "l2_gain_bound": lambda s: lpv.l2_gain_bound(s, GAIN, "w", "u", ["x", "uw"]),
    "h2_bound": lambda s: lpv.h2_bound(s, GAIN, "w", "u", ["x", "uw"]),
    "saturated_state_feedback": lambda s: lpv.saturated_state_feedback(s, "u", 1.0),
    "saturation_region": lambda s: lpv.saturation_region(s, GAIN, "u", 1.0),
    "ultimate_bound": lambda s: lpv.ultimate_bound(s, w="w", output="x"),
}


# ----------------------------------------------------------------------
# The default budget: every call stops at its deadline
# ----------------------------------------------------------------------
@pytest.mark.parametrize("call", CALLS)
def test_every_call_stops_at_the_default_deadline(call, plant, stalled_solver):
    with pytest.raises(lpv.CertificationError) as info:
        CALLS[call](plant)
    message = str(info.value)
    name = call.split(" ")[0]
    first = message.splitlines()[0]
    assert first.startswith(f"time_limit: {budget.DEFAULT_TIME_LIMIT:g} s reached")
    assert f" in {name} " in first and "best point reached: no certified" in first
    assert len(stalled_solver) == 1  # no solver started after the deadline


@pytest.mark.parametrize("call", ["synthesize", "ultimate_bound", "h2_bound"])
def test_refusal_is_short_and_has_no_repeated_lines(call, plant, stalled_solver):
    with pytest.raises(lpv.CertificationError) as info:
        CALLS[call](plant)
    message = str(info.value)
    lines = message.splitlines()
    assert len(lines) == len(set(lines)) and len(message) < 2000


def test_refusal_without_budget_is_short(plant, monkeypatch):
    """Every solve fails (no budget): the ladder's refusal counts repeated
    attempts instead of listing each (it made 10 kB messages)."""
    calls = []

    def run(solver, c, data_of, margin, options):
        calls.append(solver)
        return ConicResult("solver_error", None, None, None, 0.0)

    monkeypatch.setattr(lmi_problem, "run", run)
    with pytest.raises(lpv.CertificationError) as info:
        lpv.synthesize(plant, "u", objective=lpv.H2("w", ["x", "uw"]), time_limit=None)
    message = str(info.value)
    assert len(calls) >= 5  # every rung ran
    assert len(message) < 2000
    assert len(message.splitlines()) == len(set(message.splitlines()))


@pytest.mark.parametrize(
    "call", ["synthesize", "synthesize (affine)", "hinf_state_feedback"]
)
def test_deadline_after_the_first_solve_stops_the_solver(call, plant, monkeypatch):
    """The first solve is real; the clock then jumps past the deadline.
    Whatever the call returns is checked against the plant; no solver runs
    after the deadline."""
    calls, jump = [], [0.0]
    real_run, real_clock = lmi_problem.run, time.perf_counter

    def run(solver, *args):
        calls.append(solver)
        try:
            return real_run(solver, *args)
        finally:
            jump[0] += 1e6

    monkeypatch.setattr(lmi_problem, "run", run)
    monkeypatch.setattr(time, "perf_counter", lambda: real_clock() + jump[0])
    try:
        design = CALLS[call](plant)
    except lpv.CertificationError as exc:
        assert str(exc).startswith("time_limit: 600 s reached")
    else:  # a point certified by the first solve: check it independently
        for p in (1.0, 2.5, 4.0):
            A, B, C, D = ct.ssdata(plant.at({"k": p}))
            K = design.gain({"k": p})
            Acl = A - B[:, IU] @ K
            assert np.linalg.eigvals(Acl).real.max() < 0
            cl = ct.ss(Acl, B[:, IW], C[IZ] - D[np.ix_(IZ, IU)] @ K, D[np.ix_(IZ, IW)])
            assert ct.linfnorm(cl)[0] <= design.gamma * (1 + 1e-9)
    assert len(calls) == 1


def test_time_limit_none_means_no_deadline(plant, clock, monkeypatch):
    """With ``time_limit=None`` a clock jump of a million seconds after each
    solve changes nothing: the design certifies."""
    real_run = lmi_problem.run
    calls = []

    def run(solver, c, data_of, margin, options):
        calls.append(options)
        try:
            return real_run(solver, c, data_of, margin, options)
        finally:
            clock[0] += 1e6

    monkeypatch.setattr(lmi_problem, "run", run)
    design = lpv.synthesize(plant, "u", **HINF, time_limit=None)
    assert design.certificate.verified and len(calls) > 1
    assert all("time_limit" not in kw for kw in calls)  # no solver limit either


def test_solvers_get_the_time_left(plant, monkeypatch):
    seen = []
    real_run = lmi_problem.run

    def run(solver, c, data_of, margin, options):
        seen.append(options)
        return real_run(solver, c, data_of, margin, options)

    monkeypatch.setattr(lmi_problem, "run", run)
    lpv.synthesize(plant, "u", **HINF, solvers=["SCS", "CLARABEL"], time_limit=50.0)
    limits = [kw.get("time_limit_secs", kw.get("time_limit")) for kw in seen]
    assert seen and all(limit is not None and 0 < limit <= 50.0 for limit in limits)
    assert limits == sorted(limits, reverse=True)  # the time left shrinks


def test_a_slower_solver_gets_its_share_of_the_time(plant, clock, monkeypatch):
    """After the first solver failed at every prescaling, a slower one runs
    for its share of the ladder's time (at least `SLOW_FLOOR`), not for the
    whole budget: SCS stalled at 1e3 s per solve is called once, with a
    limit of the share, and the refusal says it was stopped."""
    from ctrl_lpv.synthesis.hooked import SLOW_FLOOR

    seen = []

    def run(solver, c, data_of, margin, options):
        seen.append((solver, options.get("time_limit_secs", options.get("time_limit"))))
        if solver == "SCS":
            clock[0] += 1e3
            return ConicResult("user_limit", None, None, None, 1e3)
        return ConicResult("solver_error", None, None, None, 0.0)

    monkeypatch.setattr(lmi_problem, "run", run)
    with pytest.raises(lpv.CertificationError) as info:
        lpv.synthesize(plant, "u", **HINF, time_limit=None)
    scs = [limit for solver, limit in seen if solver == "SCS"]
    assert len(scs) == 1 and SLOW_FLOOR - 1.0 <= scs[0] <= SLOW_FLOOR + 1.0, seen
    assert "its share of the ladder's time" in str(info.value)
    assert not isinstance(info.value, lpv.TimeLimitReached)


def test_margin_retries_get_the_time_left_then(plant, clock, monkeypatch):
    """Every attempt (margin retries too) gets the time left when it starts:
    each solve takes 10 s on the patched clock, every point misses its
    margin, so each solver is retried; the limits must shrink by 10 s."""
    from ctrl_lpv.lmi import LMIProblem

    seen = []
    real_run, real_check = lmi_problem.run, LMIProblem.check

    def run(solver, c, data_of, margin, options):
        seen.append(options.get("time_limit_secs", options.get("time_limit")))
        try:
            return real_run(solver, c, data_of, margin, options)
        finally:
            clock[0] += 10.0

    def missing(self, values, stage="default"):
        return tuple(
            dataclasses.replace(c, value=c.bound + abs(c.bound))
            if c.strict else c
            for c in real_check(self, values, stage)
        )  # fmt: skip

    monkeypatch.setattr(lmi_problem, "run", run)
    monkeypatch.setattr(LMIProblem, "check", missing)
    with pytest.raises(lpv.CertificationError, match="^time_limit: 50 s reached"):
        lpv.quadratic_stability(_closed_loop(plant), time_limit=50.0)
    assert len(seen) == 5  # Clarabel and two retries, SCS and one retry
    for k, limit in enumerate(seen):
        assert limit <= 50.0 - 10.0 * k + 1e-3


def test_reading_a_stage_stops_at_the_deadline(plant, clock, monkeypatch):
    """The block functions are read one inequality at a time, each after a
    look at the clock: a deadline passed while reading stops before the
    next inequality and before any solver."""
    from ctrl_lpv.lmi import blocks
    from ctrl_lpv.problem_cache import synthesis_cache

    synthesis_cache.clear()  # a problem compiled by an earlier test is not read

    real_columns, solved = blocks.columns, []

    def columns(*args, **kwargs):
        clock[0] += 1e6
        return real_columns(*args, **kwargs)

    monkeypatch.setattr(blocks, "columns", columns)

    def run(solver, c, data_of, margin, options):
        data_of(True)  # reads the stage first, as the real one does
        solved.append(solver)

    monkeypatch.setattr(lmi_problem, "run", run)
    with pytest.raises(lpv.CertificationError, match="^time_limit: 600 s reached"):
        CALLS["synthesize (H2)"](plant)
    assert solved == []


def test_time_limit_is_validated(plant):
    for bad, error in [("10", TypeError), (True, TypeError), (-1.0, ValueError)]:
        with pytest.raises(error, match="^time_limit: "):
            lpv.l2_gain_bound(plant, GAIN, "w", "u", "x", time_limit=bad)


# ----------------------------------------------------------------------
# Progress through logging
# ----------------------------------------------------------------------
def test_progress_is_logged_per_rung_and_stage(plant, caplog):
    with caplog.at_level(logging.INFO, logger="ctrl_lpv"):
        lpv.synthesize(plant, "u", objective=lpv.H2("w", ["x", "uw"]))
    text = [r.getMessage() for r in caplog.records if r.name.startswith("ctrl_lpv")]
    assert text[0].startswith("synthesize: started (time_limit 600 s)")
    assert any(t.startswith("synthesize: rung ") for t in text)
    assert any(t.startswith("synthesize: stage 'optimal'") for t in text)
    assert text[-1].startswith("synthesize: done in ")


def test_nothing_is_logged_unless_asked(plant, caplog):
    with caplog.at_level(logging.WARNING, logger="ctrl_lpv"):
        lpv.l2_gain_bound(plant, GAIN, "w", "u", ["x", "uw"])
    assert not [r for r in caplog.records if r.name.startswith("ctrl_lpv")]


# ----------------------------------------------------------------------
# Causes of the slow cases: degenerate boxes, huge rates
# ----------------------------------------------------------------------
@pytest.mark.parametrize("gains", ["scheduled", "common"])
def test_degenerate_box_is_the_lti_problem(gains):
    """``k in [2, 2 + 1e-12]`` is the LTI plant at ``k = 2``: its design
    meets the Riccati optimum of that plant (before: a refusal after 110 s)."""
    box = mass_spring((2.0, 2.0 + 1e-12))
    design = lpv.synthesize(
        pss(box), "u", **HINF, gains=gains, lyapunov="affine",
        rate_bounds={"k": 1.0}, backoff=None, time_limit=60.0,
    )  # fmt: skip
    A, B, C, D = box.at(np.array([2.0]))
    optimum = hinf_riccati(A, B[:, IW], B[:, IU], C[IZ], D[np.ix_(IZ, IU)])[0]
    assert optimum * (1 - 1e-6) <= design.gamma <= optimum * (1 + 1e-3)
    lti = lpv.hinf_state_feedback(
        lpv.PolytopicStateSpace([pss(box).at({"k": 2.0})]), w="w", u="u",
        z=["x", "uw"], backoff=None,
    )  # fmt: skip
    assert design.gamma == pytest.approx(lti.gamma, rel=1e-3)


@pytest.mark.parametrize("gains", ["scheduled", "common"])
def test_huge_rate_bound_is_the_constant_lyapunov_problem(gains):
    """A rate bound of 1e12 on ``k in [1, 4]`` gives the constant-Lyapunov
    optimum of the reference program (before: no answer in 120 s)."""
    box = mass_spring()
    design = lpv.synthesize(
        pss(box), "u", **HINF, gains=gains, lyapunov="affine",
        rate_bounds={"k": 1e12}, backoff=None, time_limit=60.0,
    )  # fmt: skip
    ref = pdl_sf_hinf(box, IW, IU, IZ, None, scheduled=gains == "scheduled")
    assert ref.feasible
    assert design.gamma == pytest.approx(ref.gamma, rel=2e-3)


def test_huge_rate_bound_in_analysis_is_the_quadratic_bound():
    box = mass_spring()
    cl = box.closed_loop(GAIN, IW, IU, IZ)
    bound = lpv.l2_gain_bound(
        pss(box), GAIN, "w", "u", ["x", "uw"], lyapunov="affine",
        rate_bounds={"k": 1e12}, time_limit=60.0,
    )  # fmt: skip
    ref = pdl_l2_gain(cl, None)
    assert ref.feasible and bound.gamma == pytest.approx(ref.gamma, rel=2e-3)


def test_discrete_rate_bound_above_the_width_is_the_width():
    """``|p[k+1] - p[k]|`` cannot exceed the width of the box: a larger
    bound poses the same problem as the width itself."""
    sys = pss(mass_spring(), dt=0.05)
    kwargs = dict(**HINF, gains="scheduled", lyapunov="affine", backoff=None)
    huge = lpv.synthesize(sys, "u", rate_bounds={"k": 1e12}, **kwargs)
    width = lpv.synthesize(sys, "u", rate_bounds={"k": 3.0}, **kwargs)
    assert huge.gamma == width.gamma


# ----------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------
def test_digest_counts_clauses_that_differ_only_in_numbers():
    text = "a: miss 0.1; b; a: miss 0.25; a: miss 3e-5; c"
    assert budget.digest(text) == "a: miss 0.1 (x3); b; c"
    assert len(budget.digest("x; " * 10_000 + "y" * 5000, limit=100)) == 100
