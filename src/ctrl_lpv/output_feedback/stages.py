"""What output feedback supplies to the engine's ladder: its stage hook.

The engine's ladder and its staged rung (`ctrl_lpv.synthesis.hooked`:
`climb`, `run_rung`) fix the order of the stages; this hook
supplies output feedback's own numerics on one `ctrl_lpv.lmi.LMIProblem`
(`ctrl_lpv.output_feedback.problem.build`; every point is checked in
float64 before it is used):

rungs
    the prescalings of `ctrl_lpv.output_feedback.prescale` in turn, at the
    margin asked for (no margin rungs: a larger margin only shifts the
    optimum of the change of variables);
``optimal``
    minimise the objective's level subject to its LMIs at every vertex and
    ``[[X, I], [I, Y]] > 0``, the performance LMIs weighed against the
    state blocks first, then as posed;
back-off (``center``)
    with the level at most ``(1 + 0.9 b)`` times the optimum's, maximise
    ``mu`` with ``[[X, mu I], [mu I, Y]] >= 0`` and the Lyapunov part
    tightened by a decay margin (then without it). At the optimum ``I - X
    Y`` is nearly singular and the rebuilt controller has huge,
    ill-conditioned matrices; this stage buys a well-conditioned ``M N' =
    I - X Y`` with the back-off, as LPVTools' ``lpvsyn`` does with its
    default 1.2. Its point is only a candidate (read even where the solver
    stopped without converging, its own inequalities unchecked): the check
    decides;
check
    the controller rebuilt from the point and certified on the closed loop
    (`ctrl_lpv.output_feedback.problem.rebuild`).
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass

import numpy as np

from ..exceptions import CertificationError, InfeasibleError
from ..synthesis.hooked import Posed, StageHook
from .fixed_modes import decay_limit, describe, slow_fixed_modes
from .prescale import Prescaling
from .problem import build, certified

__all__ = ["OutputFeedbackStages"]

#: A trace term far below the solver's tolerance on the level keeps X and Y
#: bounded in the directions the bound does not constrain (there the central
#: path drifts to 1e5 and the solve ends inaccurate).
_TRACE_WEIGHT = 1e-7

#: Decay margin of the back-off stage per unit back-off, relative to the
#: data's rate (``max ||A_j||`` in continuous time, 1 in discrete time).
_DECAY = 0.1

#: The back-off stage solves at ``(1 + _INSIDE backoff)`` times the optimum.
_INSIDE = 0.9

#: Back-offs tried in turn for ``backoff=None``: the raw optimum, then the
#: least relaxation whose controller certifies.
_RAW_BACKOFFS = (0.0, 1e-5, 1e-4, 5e-4)

#: How the prescalings of `ctrl_lpv.output_feedback.prescale` are named.
_PRESCALED = {
    "Riccati": "the Riccati-balanced prescaling",
    "none": "the plant's own coordinates",
}


@dataclass(frozen=True)
class _Rung:
    kind: str
    label: str
    name: str
    slow: bool = False  # every rung starts with the first solver


class OutputFeedbackStages(StageHook):
    """The hook of one output-feedback problem.

    `kinds` are the prescalings tried (`ctrl_lpv.output_feedback.prescale.
    prescalings`), `rebuild` the point's check
    (`ctrl_lpv.output_feedback.problem.rebuild`).
    """

    prefix = "output feedback: "

    def __init__(self, plant, objective, scheduled, backoff, margin, chain,
                 kinds, rebuild):  # fmt: skip
        super().__init__()
        self.method = f"{objective.label} output feedback"
        self.plant = plant
        self.objective = objective
        self.scheduled = scheduled
        self.backoff = backoff
        self.margin = margin
        self.chain = chain
        self.kinds = tuple(kinds)
        self.rebuild = rebuild
        self.homogeneous = objective.homogeneous

    def rungs(self):
        return [
            _Rung(
                k,
                f"{self.chain[0][0]}, {_PRESCALED[k]}, margin {self.margin:g}",
                _PRESCALED[k],
            )  # fmt: skip
            for k in self.kinds
        ]

    def backoffs(self):
        b = self.backoff
        return (b, *_RAW_BACKOFFS) if b else _RAW_BACKOFFS

    def pose(self, rung, scale):
        plant = self.plant if scale == 1.0 else self.plant.scaled(scale)
        return _Posed(self, plant, rung.kind)

    def in_units(self, design, scale, limit):
        P, values = self.objective.rescaled(design.P, design.values, scale)
        with _timed(self):
            return certified(
                self.plant, self.objective, design.controllers, P, values,
                design.gamma_opt / scale, limit, (self.margin, self.chain[:1]),
                design.condition,
            )  # fmt: skip

    def reached(self, design, label):
        return f"a certified point ({label}), {self.objective.name} {design.gamma:.6g}"

    def estimated(self, estimate):
        return (f"the optimum's estimate, {self.objective.name} {estimate:.6g} "
                "(not certified)")  # fmt: skip

    def hint(self):
        fixed = slow_fixed_modes(self.plant)
        # The likely cause, named: such a mode keeps the certificate's slack
        # along it at its own slow rate.
        return (f". Slow modes no controller moves: {describe(fixed)}; a "
                "quadratic certificate's slack along them is of the order of "
                "their rate (remedy: move the slow pole into the controller, or "
                "a smaller margin)") if fixed else ""  # fmt: skip

    def tried(self):
        return (f"{len(self.kinds)} prescalings ("
                + ", then ".join(_PRESCALED[k] for k in self.kinds)
                + f"), back-offs {list(self.backoffs())}, solvers "
                f"{[n for n, _ in self.chain]}, margin {self.margin:g}")  # fmt: skip


class _Posed(Posed):
    """One rung's LMIs on `plant` prescaled (`kind`, computed on `plant`,
    whose ``z`` may have been scaled: that moves the balance of ``X`` and
    ``Y``); its points are certified on `plant` itself."""

    def __init__(self, hook, plant, kind):
        self.hook = hook
        self.plant = plant
        self.prescaling = Prescaling.of(kind, plant)
        self.scaled = self.prescaling.apply(plant)
        norms = [np.linalg.norm(A, 2) for A in self.scaled.A]
        self.rate = max(norms) if plant.continuous else 1.0
        self.lmi = self.hats = self.decay_limit = None

    def optimal(self):
        hook = self.hook
        # The performance LMIs weighed against the state blocks first (see
        # `problem.build`); if the solvers fail on them (the weight assumes a
        # bound near 1: a large bound unbalances them the other way), as
        # posed before.
        for weigh in (True, False):
            self.lmi, self.hats, weight = build(
                self.scaled, hook.objective, hook.scheduled, hook.margin, weigh
            )
            try:
                return self._solve(
                    "optimal",
                    lambda v: (
                        v.level[0, 0] + _TRACE_WEIGHT * (np.trace(v.X) + np.trace(v.Y))
                    ),
                    hook.chain,
                )
            except CertificationError:
                if not weigh or weight == 1.0:
                    raise

    def estimate(self, point):
        # The solver's point at the nominal margin, when only a larger margin
        # certified, is the better estimate of the optimum.
        return self.hook.objective.bound((point.nominal or point).level[0, 0])

    def backoff_stages(self, optimal, b, estimate):
        if b == 0:
            return [lambda: optimal]
        # The decay margin is relative to the data's fastest rate: too much
        # for a stiff plant, then the back-off stage is tried without it.
        # Where a fixed mode is slower than the margin, no closed loop has it
        # (`decay_limit`): its stage, infeasible, is not posed.
        decay = _DECAY * b * self.rate
        if self.decay_limit is None:
            self.decay_limit = decay_limit(self.plant)
        decays = (decay, 0.0) if decay < self.decay_limit else (0.0,)
        return [lambda d=d: self._center(b, estimate, d) for d in decays]

    def _center(self, b, estimate, decay):
        """The back-off stage's point.

        It only chooses a better point: a proof that its LMIs are infeasible
        (they add a decay margin and a bound on the level) says nothing of
        the design problem, so it is not a refusal of the design.
        """
        objective = self.hook.objective
        # Solved a little inside the bound it is certified at: the gap is the
        # closed loop's slack after the reconstruction.
        level_max = objective.level((1.0 + _INSIDE * b) * estimate)
        self.lmi.set_parameter("level_max", level_max)
        self.lmi.set_parameter("decay", decay)
        try:
            # The first solver only: this stage chooses a better point, and
            # the fallbacks (SCS to 1e-9) cost minutes at n = 8 for a point
            # that the next back-off or the optimal point may give as well.
            # Nor need its point be converged or meet its own inequalities
            # (the bound on the level, the conditioning of X, Y): only the
            # rebuilt controller's closed-loop certificate counts, at the
            # level it certifies (`check`). On a stiff plant Clarabel stops
            # here without converging (LPVTools spinning disks: numerical
            # error after 15-21 iterations, primal residual 1e-12, gap 0.3
            # %), the level 5e-5 to 6e-4 above its bound.
            return self._solve("center", lambda v: -v.mu[0, 0], self.hook.chain[:1],
                               certify=False, unconverged=True)  # fmt: skip
        except InfeasibleError as exc:
            raise CertificationError(
                f"output feedback: the back-off stage at {b:g} is infeasible ({exc})",
                exc.attempts,
            ) from None

    def _solve(self, stage, objective, solvers, **options):
        """Read the stage's LMIs (timed as "compile"), then solve."""
        self.hook.compiling += self.lmi.compile(stage, objective, solvers[0][0])
        return self.lmi.solve(objective, stage=stage, solvers=solvers, **options)

    def check(self, point, b, estimate, limit):
        hook = self.hook
        target = max((1.0 + b) * estimate, hook.objective.bound(point.level[0, 0]))
        with _timed(hook):
            return hook.rebuild(self.plant, self.prescaling, hook.objective, point,
                                self.hats, estimate, (target, limit),
                                (hook.margin, hook.chain[:1]))  # fmt: skip


@contextlib.contextmanager
def _timed(hook):
    """Count the time inside as the hook's "verify" (float64 certificates)."""
    started = time.perf_counter()
    try:
        yield
    finally:
        hook.verifying += time.perf_counter() - started
