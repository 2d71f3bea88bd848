"""The engine: the fallback ladder over the rungs of one `Problem`.

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

A problem that supplies its own stages (output feedback, through a
`~ctrl_lpv.synthesis.hooked.StageHook`) runs on `run_hooked`: the rungs it
supplies in turn, each run by `~ctrl_lpv.synthesis.hooked.run_rung`.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .. import budget
from ..exceptions import CertificationError, InfeasibleError
from ..lmi.conic import LIFTED
from ..problem_cache import synthesis_cache
from .channels import Partition
from .hooked import run_rung
from .options import guard_size
from .problem import Problem, Structure, build
from .refusals import refusal
from .refutation import Refutations, RungRefuted
from .results import StateFeedbackDesign
from .scaling import frames
from .stages import Rung

# Margins tried in turn, relative to the given one.
MARGIN_FACTORS = (1.0, 1e-3)

# A slower solver's rung (SCS and later, after the first solver failed at
# every prescaling) runs for at most this many times the ladder's time so
# far, and at least `SLOW_FLOOR` seconds. Measured on 52 fuzz problems
# (benchmarks/fuzz_trust.py, seeds 6161, 7373, 5151): SCS certified none
# that Clarabel could not, and spent 20-460 s before each of 9 refusals
# (a refusal after 494 s at n = 9, N = 12).
SLOW_SHARE = 1.0
SLOW_FLOOR = 10.0

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
        raise refusal
    if widened:
        design = dataclasses.replace(design, ladder=(*widened, *design.ladder))
    return design


def _climb(problem: Problem, time_limit):
    """``(design, None, short)`` or ``(None, refusal, short)``: one run of
    the ladder; `short` whether gain steps ended above a gain bound."""
    start = time.perf_counter()
    deadline = budget.deadline()  # the call's (`ctrl_lpv.budget`)
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
    prescalings = frames(plant, problem.continuous, hint)
    structures: dict = {}

    def structure_of(frame) -> Structure:
        key = tuple(tuple((r / frame.a).tolist()) for r in problem.lyap.rates)
        if key not in structures:
            structures[key] = Structure.of(problem, frame.a)
        return structures[key]

    guard_size(structure_of(prescalings[0]), time_limit)
    record, attempts = [], []
    solvers = [[entry] for entry in (problem.chain or _default_chain())]
    margin = problem.margin
    rungs = [(solvers[0], f, factor) for f in prescalings for factor in MARGIN_FACTORS]
    rungs += [(one, prescalings[0], MARGIN_FACTORS[0]) for one in solvers[1:]]
    # Last, Clarabel's lifted form at every prescaling (`LIFTED`): it solves
    # LMIs whose entries span too many decades for the direct form (modes
    # 1e18 apart), where every rung above fails; only then, so that no
    # design found above changes.
    rungs += [([(LIFTED, options)], f, MARGIN_FACTORS[0])
              for name, options in solvers[0][:1] if name.upper() == "CLARABEL"
              for f in prescalings]  # fmt: skip
    refuted = Refutations(problem.method, [f.name for f in prescalings], attempts)
    compiling = verifying = 0.0
    built = time.perf_counter()
    fallback = best = None
    short = False
    stopped = []  # slower solvers stopped at their share of the time

    def rung_of(frame, compiled, rung_margin, chain, until=deadline):
        return Rung(
            problem, structure_of(frame), compiled, frame, rung_margin, chain,
            until, attempts, margin * min(MARGIN_FACTORS),
        )  # fmt: skip

    def checkout(frame):
        s = structure_of(frame)
        return synthesis_cache.checkout(s, lambda s: build(problem, s))

    for one_solver, frame, factor in rungs:
        name = frame.name
        label = f"{one_solver[0][0]}, {name} scaling, margin {margin * factor:g}"
        if fallback is not None and (
            one_solver is not solvers[0] or factor != MARGIN_FACTORS[0]
        ):
            continue
        if name in refuted:
            record.append(f"{label}: not tried (refuted: {refuted.brief(name)})")
            continue
        if deadline is not None and time.perf_counter() > deadline:
            record.append(f"{label}: not tried (time_limit reached)")
            continue
        budget.progress("rung %s", label, rung=label)
        until, share = deadline, None
        if one_solver is not solvers[0]:
            now = time.perf_counter()
            share = max(SLOW_FLOOR, SLOW_SHARE * (now - start))
            until = now + share if deadline is None else min(deadline, now + share)
        with checkout(frame) as (compiled, _):
            rung = rung_of(frame, compiled, margin * factor, one_solver, until)
            rung.carried = refuted.last
            if fallback is not None:
                rung.confirm = fallback[1]
            try:
                found = rung.run()
            except InfeasibleError as exc:
                raise InfeasibleError(
                    f"{problem.method}: {exc}", attempts, exc.farkas
                ) from None
            except RungRefuted as exc:
                found = None
                refuted.add(name, exc)  # raises once every prescaling is
                rung.notes.append(f"refuted: {refuted.brief(name)}")
        compiling += rung.compiling
        verifying += rung.verifying
        short = short or rung.gain_short
        if rung.best is not None and (best is None or rung.best[0] < best[0]):
            best = rung.best
        record.extend(f"{label}: {note}" for note in rung.notes)
        if share is not None and until != deadline and time.perf_counter() >= until:
            stopped.append(f"{one_solver[0][0]} stopped after {share:.3g} s, its "
                           "share of the ladder's time")  # fmt: skip
            record.append(f"{label}: {stopped[-1]}")
        if rung.confirmed:
            if found is not None and found[0].value < fallback[0].value:
                # A raw optimum below the design at hand; the lower estimate.
                estimates = [e for e in (found[1], fallback[1]) if e is not None]
                fallback = (found[0], min(estimates, default=None))
            break
        if found is None:
            continue
        if fallback is not None and found[0].value >= fallback[0].value:
            continue
        fallback = found
        if rung.optimum_certified:
            break
        record.append(
            f"{label}: a design, but its optimum did not certify; other "
            "prescalings asked for a certified one"
        )
    if fallback is None:
        # A prescaling refuted late (by the slower solvers) may refute the
        # ones tried before it: judged without a solver call.
        def judge(frame, carried):
            with checkout(frame) as (compiled, _):
                rung = rung_of(frame, compiled, margin, solvers[0])
                if rung.gate_bounds("stabilize") is None:
                    return  # nothing a refutation could carry to
                rung.carried, rung.solving = carried, False
                rung.run()

        refuted.complete([(f.name, f) for f in prescalings], judge, deadline)
    if fallback is None:
        return None, _refusal(problem, best, record, attempts, rungs, solvers,
                              prescalings, stopped), short  # fmt: skip
    solved = time.perf_counter()
    timing = {
        "build": built - start,
        "compile": compiling,
        "solve": solved - built - compiling - verifying,
        "verify": verifying,
    }
    return _design(problem, *fallback, attempts, timing, record), None, short


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


def _refusal(problem, best, record, attempts, rungs, solvers, prescalings, stopped):
    """The refusal: a short first line, the ladder's detail after it."""
    hint = "".join(f"; weakly controllable: {m}" for m in problem.suspects)
    tried = (
        f"{len(rungs)} rungs (solvers {[one[0][0] for one in solvers]}, "
        f"prescalings {[f.name for f in prescalings]}, margins "
        f"{[problem.margin * f for f in MARGIN_FACTORS]})"
    )
    if stopped:
        tried += (f"; {'; '.join(stopped)} (solvers=[<it>, ...] gives it the "
                  "whole time_limit)")  # fmt: skip
    return refusal(problem.method, None if best is None else best[1], record, tried,
                   attempts, hint)  # fmt: skip


def run_hooked(hook, started=None):
    """The ladder over the rungs a problem supplies through its
    `~ctrl_lpv.synthesis.hooked.StageHook` (output feedback): the first
    certified design, with the `timing` of a state-feedback design and the
    notes of the rungs passed over as its `ladder`, or the hook's refusal
    with every rung's notes. `started`: when the call began (its checks
    count as "build")."""
    begun = time.perf_counter()
    notes, estimates, attempts = [], [], []
    for rung in hook.rungs():
        budget.progress("rung %s", rung.label, rung=rung.label)
        design, failure, estimate = run_rung(hook, rung)
        if design is not None:
            budget.reached(hook.reached(design, rung.label), design.gamma)
            spent = time.perf_counter() - begun
            timing = {
                "build": begun - (begun if started is None else started),
                "compile": hook.compiling,
                "solve": spent - hook.compiling - hook.verifying,
                "verify": hook.verifying,
            }
            return dataclasses.replace(design, timing=timing, ladder=tuple(notes))
        if not isinstance(failure, CertificationError):
            raise failure
        notes.append(f"{rung.name}: {str(failure).removeprefix(hook.prefix)}")
        attempts.extend(failure.attempts)
        if estimate is not None:
            estimates.append(estimate)
    raise hook.refusal(notes, estimates, attempts)
