"""One rung of the ladder for a problem that supplies its stages.

The ladder (`ctrl_lpv.synthesis.general.run_hooked`) and this rung never
ask which kind of problem they run: the problem supplies, through a
`StageHook`, its rungs (the prescalings it tries), its optimal stage, its
back-off stage objective, the check of a point (for output feedback the
rebuild of a controller and its closed-loop certificate) and the
renormalised re-solve. The rung fixes the order:

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

from .. import budget
from ..exceptions import CertificationError
from .scaling import pow2

__all__ = ["StageHook", "Posed", "run_rung"]

#: A raw optimum counts as certified at its estimate within this.
_AT_ESTIMATE = 1e-6


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


class StageHook(abc.ABC):
    """What a problem supplies to the ladder (see the module docstring)."""

    #: Whether scaling ``z`` scales the objective's bound (renormalisation).
    homogeneous: bool = False
    #: The prefix of the hook's refusals, dropped in the ladder's notes.
    prefix: str = ""
    #: Seconds the problem spent reading its LMIs into conic data, and
    #: certifying points in float64 (the design's ``timing``).
    compiling: float = 0.0
    verifying: float = 0.0

    @abc.abstractmethod
    def reached(self, design, label: str) -> str:
        """The progress line of a certified `design` on rung `label`."""

    @abc.abstractmethod
    def refusal(self, notes, estimates, attempts) -> CertificationError:
        """The refusal after every rung failed (`notes` ``"rung: why"``,
        the rungs' `estimates` of the optimum, the solver `attempts`)."""

    @abc.abstractmethod
    def rungs(self) -> list:
        """The rungs in turn; each has a ``label``."""

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
