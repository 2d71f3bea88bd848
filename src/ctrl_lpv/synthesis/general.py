"""State feedback on the engine's ladder: the rungs of one `Problem`.

Rungs: the first solver at every prescaling (balanced, Riccati,
unbalanced, none; `ctrl_lpv.synthesis.scaling.frames`) and margin (the
given one, then ``1e-3`` of it); the slower solvers after it at the first
prescaling and the nominal margin only (SCS to 1e-9 takes seconds where
Clarabel takes milliseconds, and rarely certifies what Clarabel could
not). Each rung runs the stages of `ctrl_lpv.synthesis.stages` on a
compiled problem of `synthesis_cache` (`ctrl_lpv.synthesis.problem`):
a call with the structure of an earlier one only sets parameters and
solves. A design whose optimum did not certify may sit far above it (its
back-off starts from an estimate the solver could not meet): the other
prescalings at the nominal margin are asked for one that certifies; if
none does, the first design stands.

The loop over the rungs (the time budget and a slower solver's share of
it, progress lines, notes, timing, the refusal) is the engine's one ladder,
`ctrl_lpv.synthesis.hooked.climb`, which output feedback runs too: state
feedback supplies it a `_StateFeedback` (its rungs, each run as a
`~ctrl_lpv.synthesis.stages.Rung`, and its refutations and fallback).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from .. import budget
from ..exceptions import InfeasibleError
from ..lmi.conic import CHORDAL, LIFTED
from ..problem_cache import synthesis_cache
from .channels import Partition
from .hooked import Climbed, Ladder, climb
from .options import guard_size
from .problem import Problem, Structure, build
from .refutation import Refutations, RungRefuted
from .results import StateFeedbackDesign
from .scaling import frames
from .stages import Rung

# Margins tried in turn, relative to the given one.
MARGIN_FACTORS = (1.0, 1e-3)

# Under a gain bound the back-off (`DEFAULT_BACKOFF` without one) is
# widened, ``1 + b`` squared in turn, up to this many times the optimum
# (fuzz 8484:6: at 1.2 times the optimum the gain steps converge at 10.6
# above a bound of 7.38; a design under it exists at 1.44 times).
DEFAULT_BACKOFF = 0.2
WIDEST_BACKOFF = 4.0


def run_general(
    sys, iu, specs, channels, objective, constraints, scheduled, lyap, continuous,
    backoff, margin, chain, time_limit, method, suspects, fixed=None,
):  # fmt: skip
    """The engine on a plant and specs (the entry of the analyses).

    `specs` are the channel specs (the objective first, if any) with
    their ``(iw, iu, iz)`` `channels`, `constraints` the other specs;
    `fixed` given gains of ``u = -K x`` (an analysis with the inputs kept).
    """
    from .spec import with_stability

    plant = Partition.of(sys, iu, [(iw, iz) for iw, _, iz in channels])
    problem = Problem(
        plant, with_stability((*specs, *constraints)), objective, scheduled, lyap,
        continuous, backoff, margin, chain, method, tuple(suspects),
        None if fixed is None else tuple(fixed),
    )  # fmt: skip
    return run(problem, time_limit)


def run_analysis(loop, spec, lyap, margin, chain=None, method="analysis"):
    """The engine on a closed loop without control inputs (an analysis).

    `loop` is a `PolytopicStateSpace` whose inputs are the channel's
    ``w`` and outputs its ``z``; `spec` the one channel spec (its bound
    minimised), or None for stability alone.
    """
    from ..lmi import solver_chain

    specs = [] if spec is None else [spec]
    channels = [(list(range(loop.ninputs)), [], list(range(loop.noutputs)))]
    return run_general(
        loop, [], specs, channels * len(specs), spec, (), False, lyap,
        not loop.isdtime(strict=True), None, margin, chain or solver_chain(None),
        None, method, (),
    )  # fmt: skip


def run(problem: Problem, time_limit=None) -> StateFeedbackDesign:
    """Run the ladder; a certified `StateFeedbackDesign` or an exception.

    A gain bound is the user's limit, the back-off a default: where every
    rung's gain steps ended above the bound, the ladder runs again with
    the back-off widened (``1 + b`` squared, up to `WIDEST_BACKOFF` times
    the optimum), and the design says so (its ``backoff`` and ``ladder``).
    """
    design, refusal, short = _climb(problem, time_limit)
    objective = problem.objective
    short = short and objective is not None and objective.bound is None
    factor = 1.0 + (problem.backoff or DEFAULT_BACKOFF)
    widened = []
    while design is None and short and factor**2 <= WIDEST_BACKOFF:
        factor **= 2
        widened.append(f"gain_bound not met within backoff={problem.backoff}: "
                       f"the back-off widened to {factor - 1:.4g}")  # fmt: skip
        budget.progress("%s", widened[-1])
        wider = dataclasses.replace(problem, backoff=factor - 1.0)
        design, _, short = _climb(wider, time_limit)
    if design is None:
        if widened:
            # What the widening tried, after the refusal at the back-off asked.
            last = widened[-1].rsplit(" ", 1)[-1]
            refusal = type(refusal)(
                f"{refusal}\nwidened: with the back-off up to {last}, no certified "
                "design under the gain bound either",
                refusal.attempts, refusal.farkas,
            )  # fmt: skip
        raise refusal
    if widened:
        design = dataclasses.replace(design, ladder=(*widened, *design.ladder))
    return design


def _climb(problem: Problem, time_limit):
    """``(design, None, short)`` or ``(None, refusal, short)``: the ladder
    once; `short` whether gain steps ended above a gain bound."""
    started = time.perf_counter()
    ladder = _StateFeedback(problem, time_limit)
    design, refusal = climb(ladder, started)
    return design, refusal, ladder.short


@dataclass(frozen=True)
class _Rung:
    """A rung of state feedback: a solver chain at a prescaling and margin."""

    solvers: list
    frame: object
    factor: float
    label: str
    slow: bool  # not the first solver: run for its share of the time

    @property
    def name(self) -> str:
        return self.label

    @property
    def solver(self) -> str:
        return self.solvers[0][0]


class _StateFeedback(Ladder):
    """State feedback on the engine's ladder (`ctrl_lpv.synthesis.hooked`).

    Its rungs: the first solver at every prescaling and margin, the slower
    solvers at the first prescaling and the nominal margin, Clarabel's
    lifted and chordal forms last (module docstring). Its own capabilities: a
    prescaling refuted by one rung is not tried again (and the rungs tried
    before a late refutation are judged without a solve once every rung
    failed, `Refutations.complete`); a design whose optimum did not
    certify asks the other prescalings at the nominal margin for a
    certified one (then only those rungs are wanted).
    """

    def __init__(self, problem: Problem, time_limit):
        super().__init__()
        self.problem = problem
        self.method = problem.method
        plant = problem.plant
        for i, spec in enumerate(problem.bound_specs):
            channel = plant.channels[i]
            spec.check_data(
                [{"Dzw": D, "w": [plant.system.physical_inputs[k] for k in channel.w],
                  "z": [plant.system.output_labels[k] for k in channel.z]}
                 for D in channel.Dzw],
                problem.continuous,
            )  # fmt: skip
        hints = [s.state_scaling(plant.n) for s in problem.specs]
        hint = next((h for h in hints if h is not None), None)
        self.prescalings = frames(plant, problem.continuous, hint)
        self.structures: dict = {}
        guard_size(self.structure_of(self.prescalings[0]), time_limit)
        self.solvers = [[entry] for entry in (problem.chain or _default_chain())]
        first, margin = self.solvers[0], problem.margin
        plan = [
            (first, f, factor) for f in self.prescalings for factor in MARGIN_FACTORS
        ]
        plan += [
            (one, self.prescalings[0], MARGIN_FACTORS[0]) for one in self.solvers[1:]
        ]
        # Last, Clarabel's lifted form at every prescaling (`LIFTED`), then
        # its chordal form (`CHORDAL`): they solve LMIs whose entries span
        # too many decades for the direct form (modes 1e16-1e18 apart),
        # where every rung above fails, each where the other does not
        # (fuzz 4242:47 lifted, 9595:21 chordal); only then, so that no
        # design found above changes.
        plan += [([(form, options)], f, MARGIN_FACTORS[0])
                 for name, options in first[:1] if name.upper() == "CLARABEL"
                 for form in (LIFTED, CHORDAL)
                 for f in self.prescalings]  # fmt: skip
        self._rungs = [
            _Rung(one, f, factor,
                  f"{one[0][0]}, {f.name} scaling, margin {margin * factor:g}",
                  one is not first)
            for one, f, factor in plan
        ]  # fmt: skip
        self.refuted = Refutations(
            problem.method, [f.name for f in self.prescalings], self.attempts
        )
        # Whether gain steps ended above a gain bound (`run` widens the
        # back-off then).
        self.short = False

    def structure_of(self, frame) -> Structure:
        key = tuple(tuple((r / frame.a).tolist()) for r in self.problem.lyap.rates)
        if key not in self.structures:
            self.structures[key] = Structure.of(self.problem, frame.a)
        return self.structures[key]

    def _rung(self, frame, compiled, rung_margin, chain, until):
        problem = self.problem
        return Rung(
            problem, self.structure_of(frame), compiled, frame, rung_margin, chain,
            until, self.attempts, problem.margin * min(MARGIN_FACTORS),
        )  # fmt: skip

    def _checkout(self, frame):
        problem = self.problem
        return synthesis_cache.checkout(
            self.structure_of(frame), lambda s: build(problem, s)
        )

    # -- the ladder's protocol ---------------------------------------------
    def rungs(self):
        return self._rungs

    def wanted(self, rung, found):
        # With a design at hand, only the first solver at the nominal margin
        # is asked for a certified optimum.
        return found is None or not (rung.slow or rung.factor != MARGIN_FACTORS[0])

    def not_tried(self, rung):
        name = rung.frame.name
        return f"refuted: {self.refuted.brief(name)}" if name in self.refuted else None

    def attempt(self, rung, until, found):
        problem, frame = self.problem, rung.frame
        with self._checkout(frame) as (compiled, _):
            refuting = compiled.lmi.dual_seconds
            one = self._rung(frame, compiled, problem.margin * rung.factor,
                             rung.solvers, until)  # fmt: skip
            one.carried = self.refuted.last
            if found is not None:
                one.confirm = found[1]
            try:
                point = one.run()
            except InfeasibleError as exc:
                raise InfeasibleError(
                    f"{problem.method}: {exc}", self.attempts, exc.farkas
                ) from None
            except RungRefuted as exc:
                point = None
                self.refuted.add(frame.name, exc)  # raises once every prescaling is
                one.notes.append(f"refuted: {self.refuted.brief(frame.name)}")
            finally:
                self.refuting += compiled.lmi.dual_seconds - refuting
        self.compiling += one.compiling
        self.verifying += one.verifying
        self.short = self.short or one.gain_short
        step = Climbed(found, one.notes, one.best)
        if one.confirmed:
            if point is not None and point[0].value < found[0].value:
                # A raw optimum below the design at hand; the lower estimate.
                estimates = [e for e in (point[1], found[1]) if e is not None]
                step.found = (point[0], min(estimates, default=None))
            step.stop = True
        elif point is not None and (found is None or point[0].value < found[0].value):
            step.found = point
            step.stop = one.optimum_certified
            if not step.stop:
                step.notes.append("a design, but its optimum did not certify; other "
                                  "prescalings asked for a certified one")  # fmt: skip
        return step

    def exhausted(self, deadline):
        # A prescaling refuted late (by the slower solvers) may refute the
        # ones tried before it: judged without a solver call.
        margin, first = self.problem.margin, self.solvers[0]

        def judge(frame, carried):
            with self._checkout(frame) as (compiled, _):
                rung = self._rung(frame, compiled, margin, first, deadline)
                if rung.gate_bounds("stabilize") is None:
                    return  # nothing a refutation could carry to
                rung.carried, rung.solving = carried, False
                rung.run()

        self.refuted.complete([(f.name, f) for f in self.prescalings], judge, deadline)

    def design(self, found, timing, notes):
        return _design(self.problem, *found, self.attempts, timing, notes)

    def tried(self):
        problem = self.problem
        return (
            f"{len(self._rungs)} rungs (solvers {[one[0][0] for one in self.solvers]}, "
            f"prescalings {[f.name for f in self.prescalings]}, margins "
            f"{[problem.margin * f for f in MARGIN_FACTORS]})"
        )

    def hint(self):
        return "".join(f"; weakly controllable: {m}" for m in self.problem.suspects)


def _default_chain():
    from ..lmi import default_solvers

    return default_solvers()


def _design(problem, point, gamma_opt, attempts, timing, record):
    plant = problem.plant
    sys = plant.system
    objective = problem.objective
    if objective is not None and objective.bound is None:
        # An estimate from above (see `meets_lmis`), never above what is
        # certified.
        gamma_opt = min(gamma_opt or np.inf, point.value)
    labels = sys.physical_inputs
    channel = plant.channels[0] if plant.channels else None
    bounds = dict(zip(problem.bound_specs, point.bounds))
    bounds |= {problem.specs[q]: value for q, value in point.reported.items()}
    return StateFeedbackDesign(
        system=sys,
        method=problem.method,
        gains=point.gains,
        P=point.P,
        gamma=point.value if objective is not None else None,
        gamma_opt=gamma_opt,
        w=() if channel is None else tuple(labels[i] for i in channel.w),
        u=tuple(labels[i] for i in plant.u),
        z=() if channel is None else tuple(sys.output_labels[i] for i in channel.z),
        certificate=point.certificate,
        attempts=tuple(attempts),
        timing=timing,
        backoff=problem.backoff,
        regions=tuple(s.region for s in problem.specs if s.region is not None),
        ladder=tuple(record),
        lyapunov="constant" if problem.lyap.constant else "affine",
        bounds=bounds,
        rational=point.rational,
        values={problem.specs[q]: v for q, v in point.values.items()},
    )
