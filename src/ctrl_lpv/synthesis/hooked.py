"""The engine's ladder: one loop over the rungs a problem supplies.

A problem supplies its rungs and runs each of them through a `Ladder`:
state feedback (`ctrl_lpv.synthesis.general`: solver x prescaling x
margin, each a `~ctrl_lpv.synthesis.stages.Rung`) and output feedback
(`ctrl_lpv.output_feedback.stages`, a `StageHook`: prescalings, each run
by `run_rung`). The loop `climb` is the same for both and owns what they
share: the rungs in turn, the time budget (a rung after the deadline is
not tried; a slower solver's rung runs for its share of the ladder's
time), the progress lines, the notes (the design's ``ladder``), the best
point reached, the ``timing`` dict and the refusal (its short first line,
`ctrl_lpv.synthesis.refusals`). What only one kind of problem has (state
feedback's refutations carried between rungs and its "the optimum did not
certify: ask the other prescalings" fallback) is the problem's `Ladder`:
which rungs it still wants, which it knows are refuted, when it stops,
what it concludes when every rung failed.

A `StageHook` problem (output feedback) supplies the stages of a rung
instead, and `run_rung` fixes their order:

* the optimal stage; its level is the estimate of the optimum;
* the back-offs of `StageHook.backoffs` in turn (the one asked for, or for
  ``backoff=None`` the raw optimum and then the least relaxation whose
  point certifies), each through the problem's back-off stage; a raw
  optimum that certifies only a little above the estimate is held and
  returned as the answer of the first back-off it fits in;
* on failure, with an estimate far from one and a homogeneous problem,
  the same once more with ``z`` scaled by a power of two (exact, as the
  state-feedback `~ctrl_lpv.synthesis.stages.Rung._normalise`), certified
  on the plant itself.

A point that does not certify is a `~ctrl_lpv.exceptions.CertificationError`
from the hook; the rung returns ``(design, None, estimate)`` or ``(None,
refusal, estimate)``.
"""

from __future__ import annotations

import abc
import dataclasses
import time
from dataclasses import dataclass, field

from .. import budget
from ..exceptions import CertificationError
from .refusals import refusal
from .scaling import pow2

__all__ = ["Climbed", "Ladder", "StageHook", "Posed", "climb", "ladder", "run_rung"]

#: A raw optimum counts as certified at its estimate within this.
_AT_ESTIMATE = 1e-6

# A slower solver's rung (SCS and later, after the first solver failed at
# every prescaling) runs for at most this many times the ladder's time so
# far, and at least `SLOW_FLOOR` seconds. Measured on 52 fuzz problems
# (benchmarks/fuzz_trust.py, seeds 6161, 7373, 5151): SCS certified none
# that Clarabel could not, and spent 20-460 s before each of 9 refusals
# (a refusal after 494 s at n = 9, N = 12).
SLOW_SHARE = 1.0
SLOW_FLOOR = 10.0


@dataclass
class Climbed:
    """What one rung gave the ladder (`Ladder.attempt`).

    Attributes
    ----------
    found : object or None
        The problem's answer so far (passed to the next rung, and to
        `Ladder.design` at the end), None while there is none.
    notes : list of str
        Why points of the rung were not taken (the ladder prefixes the
        rung's name).
    best : tuple or None
        ``(value, text)`` of the best point the rung reached (a certified
        point or an estimate): the refusal names the smallest.
    stop : bool
        Whether the ladder stops here (`found` is the answer).
    """

    found: object = None
    notes: list = field(default_factory=list)
    best: tuple | None = None
    stop: bool = False


class Ladder(abc.ABC):
    """What a problem supplies to the engine's ladder (`climb`).

    Its rungs each have a ``label`` (the progress line), a ``name`` (the
    prefix of its notes) and ``slow`` (a slower solver: run for its share
    of the ladder's time, `SLOW_SHARE`; named by the rung's ``solver``
    when stopped there).
    """

    #: The call, the first word of a refusal.
    method: str = ""

    def __init__(self):
        # The solver attempts (a refusal's ``attempts``); seconds the rungs
        # spent reading LMIs into conic data and certifying points in
        # float64 (the design's ``timing``).
        self.attempts: list = []
        self.compiling = self.verifying = 0.0
        # Seconds the rungs spent verifying dual certificates (a refusal's
        # time line).
        self.refuting = 0.0

    @abc.abstractmethod
    def rungs(self) -> list:
        """The rungs in turn."""

    def wanted(self, rung, found) -> bool:
        """Whether `rung` may still improve on `found` (else passed over
        without a note)."""
        return found is None

    def not_tried(self, rung) -> str | None:
        """Why `rung` is known to fail without solving it (noted), or None."""
        return None

    @abc.abstractmethod
    def attempt(self, rung, until, found) -> Climbed:
        """Run `rung` (its solvers stop at `until`, a ``perf_counter``
        value, or None) given the answer `found` so far."""

    def exhausted(self, deadline) -> None:
        """Called when every rung failed, before the refusal (a problem
        that can prove infeasibility without a solve raises it here)."""
        return None

    @abc.abstractmethod
    def design(self, found, timing: dict, notes: tuple):
        """The design of `found`, with its `timing` and ladder `notes`."""

    @abc.abstractmethod
    def tried(self) -> str:
        """What the ladder tried (the refusal's ``tried:`` line)."""

    def hint(self) -> str:
        """A likely cause of a refusal, where the data show one."""
        return ""


def climb(problem: Ladder, started=None):
    """``(design, None)`` or ``(None, refusal)``: the ladder over the rungs
    of `problem` (module docstring). `started`: when the call began (what
    it did before the ladder counts as the ``timing``'s "build")."""
    begun = time.perf_counter()
    started = begun if started is None else started
    deadline = budget.deadline()  # the call's (`ctrl_lpv.budget`)
    record, stopped = [], []  # notes; slower solvers stopped at their share
    found = best = None
    for rung in problem.rungs():
        if not problem.wanted(rung, found):
            continue
        why = problem.not_tried(rung)
        if why is None and deadline is not None and time.perf_counter() > deadline:
            why = "time_limit reached"
        if why is not None:
            record.append(f"{rung.name}: not tried ({why})")
            continue
        budget.progress("rung %s", rung.label, rung=rung.label)
        until, share = deadline, None
        if rung.slow:
            now = time.perf_counter()
            share = max(SLOW_FLOOR, SLOW_SHARE * (now - started))
            until = now + share if deadline is None else min(deadline, now + share)
        step = problem.attempt(rung, until, found)
        if step.best is not None and (best is None or step.best[0] < best[0]):
            best = step.best
        record.extend(f"{rung.name}: {note}" for note in step.notes)
        if share is not None and until != deadline and time.perf_counter() >= until:
            stopped.append(f"{rung.solver} stopped after {share:.3g} s, its share "
                           "of the ladder's time")  # fmt: skip
            record.append(f"{rung.name}: {stopped[-1]}")
        found = step.found
        if step.stop:
            break
    if found is None:
        problem.exhausted(deadline)
        tried = problem.tried()
        if stopped:
            tried += (f"; {'; '.join(stopped)} (solvers=[<it>, ...] gives it the "
                      "whole time_limit)")  # fmt: skip
        tried += "; " + spent_on(problem, time.perf_counter() - begun)
        best = None if best is None else best[1]
        return None, refusal(problem.method, best, record, tried, problem.attempts,
                             problem.hint())  # fmt: skip
    spent = time.perf_counter() - begun
    timing = {
        "build": begun - started,
        "compile": problem.compiling,
        "solve": spent - problem.compiling - problem.verifying,
        "verify": problem.verifying,
    }
    return problem.design(found, timing, tuple(record)), None


def spent_on(problem: Ladder, seconds: float) -> str:
    """Where a ladder's `seconds` went: each solver, the dual certificates,
    reading the LMIs, the float64 checks (a refusal's last line; measured
    on fuzz 5757:26, 33 s: SCS 11 s at its share, Clarabel's forms 10 s,
    dual certificates 8.7 s, reading 2.2 s)."""
    solvers: dict = {}
    for a in problem.attempts:
        solvers[a.solver] = solvers.get(a.solver, 0.0) + a.seconds - a.compile_seconds
    parts = [f"{name} {s:.2g} s" for name, s in solvers.items()]
    others = (
        ("dual certificates", problem.refuting),
        ("reading the LMIs", problem.compiling),
        ("checks", problem.verifying),
    )
    parts += [f"{what} {s:.2g} s" for what, s in others if s > 0]
    return f"time {seconds:.3g} s" + (f": {', '.join(parts)}" if parts else "")


def ladder(problem: Ladder, started=None):
    """The certified design of `climb`, or its refusal raised."""
    design, refused = climb(problem, started)
    if design is None:
        raise refused
    return design


class Posed(abc.ABC):
    """The stages of one rung of a problem, posed (see `StageHook.pose`)."""

    @abc.abstractmethod
    def optimal(self):
        """The optimal stage's point; a `CertificationError` if none."""

    @abc.abstractmethod
    def estimate(self, point) -> float:
        """The optimum's estimate (the objective's bound) from `point`."""

    @abc.abstractmethod
    def backoff_stages(self, optimal, b: float, estimate: float):
        """Callables, tried in turn, each returning the point of the back-off
        stage at back-off `b` (`optimal` itself for ``b = 0``) or raising a
        `CertificationError`."""

    @abc.abstractmethod
    def check(self, point, b: float, estimate: float, limit: float):
        """The design certified from `point` within `limit`, or a
        `CertificationError`."""


class StageHook(Ladder):
    """A problem that supplies the stages of its rungs (output feedback):
    each rung is run by `run_rung` (see the module docstring); the first
    certified design is the answer."""

    #: Whether scaling ``z`` scales the objective's bound (renormalisation).
    homogeneous: bool = False
    #: The prefix of the hook's refusals, dropped in the ladder's notes.
    prefix: str = ""

    @abc.abstractmethod
    def reached(self, design, label: str) -> str:
        """The progress line of a certified `design` on rung `label`."""

    @abc.abstractmethod
    def estimated(self, estimate: float) -> str:
        """The best point reached, for a refusal, from the smallest of the
        rungs' estimates of the optimum."""

    @abc.abstractmethod
    def pose(self, rung, scale: float) -> Posed:
        """The stages of `rung` on the plant with ``z`` scaled by `scale`."""

    @abc.abstractmethod
    def backoffs(self) -> tuple[float, ...]:
        """The back-offs tried in turn; ``0.0`` first for the raw optimum."""

    @abc.abstractmethod
    def in_units(self, design, scale: float, limit: float):
        """`design` of the plant scaled by `scale` certified on the plant
        within `limit`, or a `CertificationError`."""

    def attempt(self, rung, until, found) -> Climbed:
        design, failure, estimate = run_rung(self, rung)
        if design is not None:
            budget.reached(self.reached(design, rung.label), design.gamma)
            return Climbed(found=design, stop=True)
        if not isinstance(failure, CertificationError):
            raise failure
        self.attempts.extend(failure.attempts)
        return Climbed(
            notes=[str(failure).removeprefix(self.prefix)],
            best=None if estimate is None else (estimate, self.estimated(estimate)),
        )

    def design(self, found, timing, notes):
        return dataclasses.replace(found, timing=timing, ladder=notes)


def run_rung(hook: StageHook, rung):
    """``(design, failure, estimate)`` of one rung (module docstring)."""
    design, failure, estimate = _in_units(hook, rung, 1.0)
    if (
        design is None
        and estimate is not None
        and not 0.5 <= estimate <= 2.0
        and hook.homogeneous
    ):
        scale = 1.0 / pow2(estimate)
        budget.progress("renormalised: z scaled by %g", scale)
        design, _, _ = _in_units(hook, rung, scale, estimate)
    return design, None if design is not None else failure, estimate


def _in_units(hook, rung, scale, known=None):
    """The stages with ``z`` scaled by `scale`, certified on the plant; the
    bound limited relative to the `known` optimum when there is one."""
    if scale == 1.0:
        return _stages(hook, hook.pose(rung, 1.0))
    scaled, failure, estimate = _stages(hook, hook.pose(rung, scale))
    estimate = None if estimate is None else estimate / scale
    if scaled is None:
        return None, failure, estimate
    # Within the back-off asked for (0 for the raw optimum's sequence).
    limit = (1.0 + hook.backoffs()[0]) * (known or estimate) * (1.0 + 1e-3)
    try:
        return hook.in_units(scaled, scale, limit), None, estimate
    except CertificationError as exc:
        return None, exc, estimate


def _stages(hook, posed):
    """``(design, None, estimate)`` or ``(None, refusal, estimate)``."""
    try:
        optimal = posed.optimal()
    except CertificationError as exc:
        return None, exc, None
    estimate = posed.estimate(optimal)
    backoffs = hook.backoffs()
    raw = backoffs[0] == 0
    asked = backoffs[0]
    failure = held = None
    for b in backoffs:
        if held is not None and held.gamma <= (1.0 + b) * estimate * (1 + _AT_ESTIMATE):
            return held, None, estimate
        for stage in posed.backoff_stages(optimal, b, estimate):
            try:
                point = stage()
                bmax = backoffs[-1] if raw and b == 0 else max(b, asked)
                limit = (1.0 + bmax) * estimate * (1 + _AT_ESTIMATE)
                design = posed.check(point, b, estimate, limit)
                if raw and b == 0 and design.gamma > estimate * (1 + _AT_ESTIMATE):
                    held = design
                    continue
                return design, None, estimate
            except CertificationError as exc:
                failure = exc
    if held is not None:
        return held, None, estimate
    return None, failure, estimate
