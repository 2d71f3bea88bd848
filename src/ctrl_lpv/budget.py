"""Time budgets of the public calls: deadline, progress log, time-limit refusal.

Every public synthesis and analysis call runs under a budget of
`DEFAULT_TIME_LIMIT` seconds (its ``time_limit=`` argument; ``None`` for
none). The decorator `time_budget` opens the budget for the duration of
the call, in a context variable, so that the solve loop of
`ctrl_lpv.lmi.LMIProblem` reads it without every helper passing it on:

* each solver gets the time left as its own limit (Clarabel's
  ``time_limit``, SCS's ``time_limit_secs``);
* a problem whose reading is estimated (`compile_seconds`) to exceed the
  time left is not started;
* `check`, called before each solve, compilation, dual-certificate check,
  rung and search step, raises `TimeLimitReached` once the deadline has
  passed.

A call inside another (a wrapper calling `synthesize`) keeps the earlier
deadline of the two. When the budget runs out, the call raises a
`TimeLimitReached` (a `~ctrl_lpv.CertificationError`) whose first line is
``time_limit: <limit> s reached ...`` with the best point reached; what
was tried follows, without repeats (`digest`). A certified design found
before the deadline is still returned.

Progress goes to the ``logging`` logger ``"ctrl_lpv"`` (children
``"ctrl_lpv.budget"``, ``"ctrl_lpv.lmi"``, ...): at INFO a line when a
call starts and ends, per rung, per stage solved and per certified point;
at DEBUG each stage's start and each solver attempt. Enable it with, e.g.,
``logging.basicConfig(level=logging.INFO)``.
"""

from __future__ import annotations

import contextvars
import functools
import inspect
import logging
import re
import time
from dataclasses import dataclass, field

from ._checks import real_number
from .exceptions import CertificationError

__all__ = [
    "DEFAULT_TIME_LIMIT",
    "TimeLimitReached",
    "check",
    "compile_seconds",
    "deadline",
    "digest",
    "progress",
    "reached",
    "remaining",
    "time_budget",
]

#: Default wall-time budget of a public call, in seconds.
DEFAULT_TIME_LIMIT = 600.0

logger = logging.getLogger(__name__)

# Reading an LMI's block function into conic data (`ctrl_lpv.lmi.blocks`)
# takes 0.7 to 1.6 ms per LMI of 64 to 256 entries (one BLAS thread, quiet
# machine; benchmarks/bench_synthesis.py): the estimate is about three
# times that, for a loaded machine.
_SECONDS_PER_LMI = 3e-3
_SECONDS_PER_ENTRY = 1.5e-5
# Longest detail part of a time-limit refusal, in characters.
_DETAIL_CHARS = 1500


def compile_seconds(nlmis: int, entries: int) -> float:
    """Estimated seconds to read `nlmis` LMIs of `entries` entries in all."""
    return _SECONDS_PER_LMI * nlmis + _SECONDS_PER_ENTRY * entries


@dataclass
class _Budget:
    """The budget of one call (see the module docstring)."""

    name: str
    limit: float | None
    start: float
    deadline: float | None
    parent: _Budget | None = None
    place: dict = field(default_factory=dict)  # rung, stage (see `progress`)
    best: tuple | None = None  # (description, value or None)

    def chain(self):
        budget = self
        while budget is not None:
            yield budget
            budget = budget.parent

    def binding(self) -> _Budget:
        """The budget whose deadline applies (this call's or an outer one's)."""
        return min(
            (b for b in self.chain() if b.deadline is not None),
            key=lambda b: b.deadline,
            default=self,
        )


_CURRENT: contextvars.ContextVar[_Budget | None] = contextvars.ContextVar(
    "ctrl_lpv_budget", default=None
)


class TimeLimitReached(CertificationError):
    """The time budget of a call ran out before a certified result.

    The first line of the message is ``time_limit: <limit> s reached in
    <call> ...; best point reached: ...``; the later lines say what was
    tried. A `~ctrl_lpv.CertificationError`: the problem may be feasible.

    Attributes
    ----------
    time_limit : float
        The budget that ran out, in seconds.
    best : str or None
        The best point reached, if any.
    """

    def __init__(
        self, message, attempts=(), farkas=None, time_limit=None, best=None,
        final=False,
    ):  # fmt: skip
        super().__init__(message, attempts, farkas)
        self.time_limit = time_limit
        self.best = best
        # Whether this is a call's refusal (not a check inside the call).
        self.final = final


def deadline() -> float | None:
    """``time.perf_counter()`` value at which the current budget ends."""
    budget = _CURRENT.get()
    return None if budget is None else budget.binding().deadline


def remaining() -> float:
    """Seconds left in the current budget (``inf`` without one)."""
    end = deadline()
    return float("inf") if end is None else end - time.perf_counter()


def check(where: str, needed: float = 0.0) -> None:
    """Raise `TimeLimitReached` if fewer than `needed` seconds are left.

    Parameters
    ----------
    where : str
        What was about to start (for the message).
    needed : float, optional
        Estimated seconds it needs (0: only a passed deadline stops it).
    """
    budget = _CURRENT.get()
    if budget is None:
        return
    left = remaining()
    if left > needed and left > 0:
        return
    owner = budget.binding()
    if left <= 0:
        text = f"reached before {where}"
    else:
        text = f"too short for {where} (about {needed:.2g} s, {left:.2g} s left)"
    raise TimeLimitReached(
        f"time_limit: {_limit_text(budget)} {text}",
        time_limit=owner.limit,
        best=_best(budget),
    )


# The places a call goes through, outermost first (see `progress`).
_PLACES = ("rung", "stage")


def progress(message: str, *args, level: int = logging.INFO, **place) -> None:
    """Log a progress line; `place` (``rung=``, ``stage=``) records where
    the call is, for a time-limit refusal (a new rung clears the stage)."""
    budget = _CURRENT.get()
    for b in () if budget is None else budget.chain():
        for key, value in place.items():
            for deeper in _PLACES[_PLACES.index(key) :]:
                b.place.pop(deeper, None)
            b.place[key] = value
    if logger.isEnabledFor(level):
        text = message % args if args else message
        logger.log(level, "%s: %s", budget.name if budget else "ctrl_lpv", text)


def _where(budget: _Budget) -> str:
    place = budget.place
    return ", ".join(f"{k} '{place[k]}'" for k in _PLACES if k in place) or "start"


def reached(description: str, value: float | None = None) -> None:
    """Record a certified point of the current call, for a time-limit refusal.

    The point with the smallest `value` is the best (one without a value
    only when there is none with).
    """
    budget = _CURRENT.get()
    for b in () if budget is None else budget.chain():
        if b.best is None or (
            value is not None and (b.best[1] is None or value < b.best[1])
        ):
            b.best = (description, value)
    logger.info("%s: reached %s", budget.name if budget else "ctrl_lpv", description)


def _best(budget: _Budget) -> str | None:
    return None if budget.best is None else budget.best[0]


def digest(text: str, limit: int = _DETAIL_CHARS) -> str:
    """`text`'s clauses (split at ``"; "``) without repeats, at most `limit` long.

    Clauses that differ only in their numbers count as repeats; each kept
    clause says how often it occurred.
    """
    counts: dict[str, list] = {}
    for clause in re.split(r";\s+|\n", text):
        clause = clause.strip()
        if not clause:
            continue
        key = re.sub(r"[-+]?\d[\d.e+-]*", "#", clause)
        if key in counts:
            counts[key][1] += 1
        else:
            counts[key] = [clause, 1]
    parts = [c if n == 1 else f"{c} (x{n})" for c, n in counts.values()]
    out = "; ".join(parts)
    if len(out) > limit:
        out = out[: limit - 1].rstrip() + "…"
    return out


def _limit_text(budget: _Budget) -> str:
    limit = budget.binding().limit
    return "the deadline" if limit is None else f"{limit:g} s"


def _refusal(budget: _Budget, exc: CertificationError | None) -> TimeLimitReached:
    """The time-limit refusal of `budget`'s call, with `exc`'s details."""
    owner = budget.binding()
    elapsed = time.perf_counter() - budget.start
    best = _best(budget)
    # A check may stop a call before the deadline: what is left is too
    # short for the next step (a compilation).
    what = "reached" if _expired(budget) else "too short"
    first = (
        f"time_limit: {_limit_text(budget)} {what} in {budget.name} after "
        f"{elapsed:.3g} s; best point reached: "
        f"{best or 'no certified point'} (last: {_where(budget)})"
    )
    details = ""
    if exc is not None:
        details = "\nwhat was tried: " + digest(str(exc))
    return TimeLimitReached(
        first + details,
        getattr(exc, "attempts", ()),
        getattr(exc, "farkas", None),
        time_limit=owner.limit,
        best=best,
        final=True,
    )


def _expired(budget: _Budget) -> bool:
    end = budget.binding().deadline
    return end is not None and time.perf_counter() >= end


def time_budget(function):
    """Run `function` under the budget of its ``time_limit`` argument.

    `function` must have a ``time_limit`` parameter (seconds, or None for
    no limit); it is validated here. A `~ctrl_lpv.CertificationError`
    raised once the deadline has passed becomes the time-limit refusal
    (`TimeLimitReached`); an `~ctrl_lpv.InfeasibleError` (a proof) and
    other errors pass unchanged.
    """
    signature = inspect.signature(function)
    default = signature.parameters["time_limit"].default
    name = function.__name__

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        bound = signature.bind_partial(*args, **kwargs)
        limit = bound.arguments.get("time_limit", default)
        limit = real_number(limit, "time_limit", allow_none=True, positive=True)
        start = time.perf_counter()
        budget = _Budget(
            name, limit, start, None if limit is None else start + limit,
            _CURRENT.get(),
        )  # fmt: skip
        token = _CURRENT.set(budget)
        logger.info(
            "%s: started (time_limit %s)",
            name,
            "none" if limit is None else f"{limit:g} s",
        )
        try:
            result = function(*args, **kwargs)
        except CertificationError as exc:
            # The refusal names the call whose budget ran out: an inner
            # call that ran out of an outer budget leaves it to the outer.
            final = isinstance(exc, TimeLimitReached) and exc.final
            ran_out = _expired(budget) or isinstance(exc, TimeLimitReached)
            if ran_out and not final and budget.binding() is budget:
                raise _refusal(budget, exc) from None
            logger.info("%s: refused after %.3g s", name, time.perf_counter() - start)
            raise
        finally:
            _CURRENT.reset(token)
        logger.info("%s: done in %.3g s", name, time.perf_counter() - start)
        return result

    return wrapper
