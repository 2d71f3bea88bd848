"""The fallback ladder: solvers, prescalings, margins and the stages of each."""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from .. import budget
from ..exceptions import CertificationError, InfeasibleError
from ..lmi import (
    SolveAttempt,
    default_solvers,
    schur_norm_bound,
    symmetric_norm_bound,
)
from ..problem_cache import synthesis_cache
from ..stabilizability import check_stabilizability
from .assembly import Structure, build, load
from .channels import resolve_channels, vertex_channels
from .options import guard_size, validated_options
from .results import Certificate, StateFeedbackDesign
from .scaling import pow2, prescalings
from .verification import verify

# Convex-concave iterations of the gain minimisation, and the relative
# decrease of the squared gain bound below which they stop.
GAIN_ITERATIONS = 4
GAIN_RTOL = 0.05
# Bounds W <= w_max I (scaled units) tried in turn when gamma is given.
FIXED_GAMMA_W_MAX = (1e3, 1e6, 1e9)
# Squared bounds ||Z|| <= sqrt(z_max) of the stabilization stage, in turn:
# the LMIs are homogeneous, so a larger bound admits a smaller decay.
STABILIZE_Z_MAX = (1.0, 1e4, 1e8)
# Margins tried in turn, relative to the given one.
MARGIN_FACTORS = (1.0, 1e-3)
# A given gamma is posed as gamma^2 (1 - GAMMA_SLACK) so that the
# certified bound is met strictly.
GAMMA_SLACK = (1e-6, 1e-3)


def run_ladder(
    sys, w, u, z, method, scheduled, gamma, regions, backoff, gain_bound, margin,
    solvers, time_limit=None, hinf=False,
):  # fmt: skip
    start = time.perf_counter()
    iw, iu, iz = resolve_channels(sys, w, u, z, hinf)
    regions, backoff, gamma, gain_bound, margin, chain, time_limit = validated_options(
        regions, backoff, gamma, gain_bound, margin, solvers, time_limit
    )
    suspects = check_stabilizability(sys, iu)
    deadline = budget.deadline()  # the call's (`ctrl_lpv.budget`)
    original = vertex_channels(sys, iw, iu, iz)
    guard_size(Structure.of(original, hinf, scheduled, regions, gain_bound), time_limit)

    record: list[str] = []
    attempts: list[SolveAttempt] = []
    compiling = verifying = 0.0
    built = time.perf_counter()
    # The ladder: each solver in turn (the slow ones last), then the
    # prescalings, then the margins; the stages have rungs of their own.
    solver_rungs = [[entry] for entry in (chain or default_solvers())]
    if not solver_rungs:
        raise RuntimeError("no SDP solver installed: install clarabel or scs")
    scalings = list(prescalings(original))
    # The slower solvers after the first get the first prescaling and the
    # nominal margin only (SCS to 1e-9 takes seconds where Clarabel takes
    # milliseconds, and rarely certifies what Clarabel could not).
    rungs = [
        (solver_rungs[0], scaling, f) for scaling in scalings for f in MARGIN_FACTORS
    ]
    rungs += [(one, scalings[0], MARGIN_FACTORS[0]) for one in solver_rungs[1:]]
    # A design whose minimum-gamma point did not certify has an estimate
    # gamma* that may be off (by 3.5 % on an ill-conditioned LTI problem in
    # balanced coordinates): the other prescalings at the nominal margin are
    # asked for one that certifies; if none does, the first design stands.
    fallback = None
    refuted = Refutations(method, [name for name, _ in scalings], attempts)

    def make_job(scaling, rung_margin, one_solver):
        job = _Job(
            original, scaling, regions, scheduled, hinf, gamma, backoff,
            gain_bound, rung_margin, one_solver, deadline,
        )  # fmt: skip
        job.floor_margin = margin * min(MARGIN_FACTORS)
        return job

    for one_solver, (scaling_name, scaling), factor in rungs:
        rung = f"{one_solver[0][0]}, {scaling_name} scaling, margin {margin * factor:g}"
        if fallback is not None and (
            one_solver is not solver_rungs[0] or factor != MARGIN_FACTORS[0]
        ):
            continue
        if scaling_name in refuted:
            record.append(f"{rung}: not tried (refuted: {refuted.brief(scaling_name)})")
            continue
        if deadline is not None and time.perf_counter() > deadline:
            record.append(f"{rung}: not tried (time_limit reached)")
            continue
        budget.progress("rung %s", rung, rung=rung)
        job = make_job(scaling, margin * factor, one_solver)
        job.carried = refuted.last
        try:
            found = job.run(attempts)
        except InfeasibleError as exc:
            raise InfeasibleError(f"{method}: {exc}", attempts, exc.farkas) from None
        except RungRefuted as exc:
            found = None
            refuted.add(scaling_name, exc)  # raises once every scaling is
            job.notes.append(f"refuted: {refuted.brief(scaling_name)}")
        compiling += job.compiling
        verifying += job.verifying
        record.extend(f"{rung}: {note}" for note in job.notes)
        if found is None:
            continue
        if fallback is None or (
            found[0].gamma is not None and found[0].gamma < fallback[0].gamma
        ):
            fallback = found
        if job.estimate_certified:
            break
        record.append(
            f"{rung}: a design, but its minimum-gamma point did not certify; "
            "other prescalings asked for a certified one"
        )
    if fallback is None:
        # A prescaling refuted late (by the slower solvers) may refute the
        # ones tried before it: judged without a solver call.
        refuted.complete(
            scalings,
            lambda base: make_job(base, margin, solver_rungs[0]),
            lambda job: job.run(attempts),
        )
    if fallback is not None:
        point, gamma_opt = fallback
        if hinf and gamma is None:
            # An estimate from above (see `meets_lmis`), never above what
            # is certified.
            gamma_opt = min(gamma_opt or np.inf, point.gamma)
        solved = time.perf_counter()
        labels = sys.physical_inputs
        return StateFeedbackDesign(
            system=sys,
            method=method,
            gains=point.gains,
            P=point.P,
            gamma=point.gamma,
            gamma_opt=gamma_opt,
            w=tuple(labels[i] for i in iw),
            u=tuple(labels[i] for i in iu),
            z=tuple(sys.output_labels[i] for i in iz),
            certificate=point.certificate,
            attempts=tuple(attempts),
            timing={
                "build": built - start,
                "compile": compiling,
                "solve": solved - built - compiling - verifying,
                "verify": verifying,
            },
            backoff=backoff,
            regions=regions,
            ladder=tuple(record),
        )
    hint = "".join(f"; weakly controllable: {m}" for m in suspects)
    raise CertificationError(
        f"{method}: no certified solution found after {len(rungs)} rungs "
        f"(solvers {[one[0][0] for one in solver_rungs]}, prescalings "
        f"{[name for name, _ in scalings]}, margins "
        f"{[margin * f for f in MARGIN_FACTORS]}); what failed: "
        + _summary(record)
        + hint,
        attempts,
    )


def _summary(record) -> str:
    """The ladder's notes without repeats (rung prefix dropped), counted."""
    counts: dict[str, int] = {}
    for note in record:
        reason = note.split(": ", 1)[-1]
        counts[reason] = counts.get(reason, 0) + 1
    return "; ".join(
        f"{reason} (x{count})" if count > 1 else reason
        for reason, count in counts.items()
    )


@dataclass(frozen=True)
class _Point:
    """A fully verified point, in the model's units."""

    solution: object  # the LMISolution, in the scaled units of its job
    gains: tuple
    certificate: Certificate
    gamma: float | None
    P: np.ndarray


class _Job:
    """One rung of the ladder: a scaling and a margin, all stages.

    `run` returns ``(point, gamma_opt)`` for the best certified `_Point` of
    this rung, or None (`notes` says why); an
    `InfeasibleError` escapes only with a proof that needs no normalisation.
    """

    def __init__(
        self, original, scaling, regions, scheduled, hinf, gamma, backoff,
        gain_bound, margin, chain, deadline,
    ):  # fmt: skip
        self.original = original
        self.scaling = scaling
        self.data = [scaling.apply(v) for v in original]
        self.regions = tuple(r.time_scaled(scaling.a) for r in regions)
        self.scheduled = scheduled
        self.hinf = hinf
        self.gamma = gamma
        self.backoff = backoff
        self.gain_bound = gain_bound
        self.margin = margin
        self.chain = chain
        self.deadline = deadline
        self.structure = Structure.of(self.data, hinf, scheduled, regions, gain_bound)
        self.notes: list[str] = []
        self.compiling = self.verifying = 0.0
        # The smallest margin any rung with this prescaling tries (`refute`;
        # set by the ladder), another prescaling's refutation (`carry`), and
        # whether to solve at all (not when only judging `carried`).
        self.floor_margin = margin
        self.carried = None
        self.solving = True
        # Whether gamma_opt comes from a point that certified (True where
        # there is no estimate to doubt: stabilization, a given gamma).
        self.estimate_certified = True

    def run(self, attempts):
        s = self.structure
        with synthesis_cache.checkout(s, build) as (compiled, _):
            load(compiled, s, self.data, self.scaling, self.regions, self.margin)
            self.compiled = compiled
            self.lmi = compiled.lmi
            self.attempts = attempts
            if s.hinf:
                return self._hinf() if self.solving else None
            return self._stabilize()

    # -- one solve -----------------------------------------------------
    def _solve(self, stage, objective, certify=True, proof=False):
        """Solve a stage; None if it gave no certified point.

        A verified infeasibility proof that needs no normalisation is
        re-raised when `proof` is set (the stage poses the user's problem
        itself, with its variables bounded by the data: a given gamma);
        otherwise it only ends this branch, and the note says what it
        proved.
        """
        lmi = self.lmi
        first = self.chain[0][0] if self.chain else None
        self.compiling += lmi.compile(stage, objective, first)
        return solve_stage(self, stage, objective, certify, proof)

    def _accept(self, sol, label, bounded=False):
        """Full verification of a point: a `_Point`, or None.

        `bounded` also asks for the gain bound (met only after the gain
        stage, in general).
        """
        if sol is None or not sol.certified:
            return None
        scaling = self.scaling
        gains = tuple(
            scaling.unscale_K(-getattr(sol, f"Z{k}") @ np.linalg.inv(sol.W))
            for k in range(self.structure.nZ)
        )
        if bounded and self.gain_bound is not None:
            worst = max(np.linalg.norm(K, 2) for K in gains)
            if worst > self.gain_bound:
                self.notes.append(
                    f"{label}: gain norm {worst:.4g} above gain_bound "
                    f"{self.gain_bound:g}"
                )
                return None
        certified = (
            float(np.sqrt(scaling.unscale_g(float(sol.g[0, 0])))) if self.hinf else None
        )
        if self.hinf and self.gamma is not None:
            if not certified < self.gamma:
                self.notes.append(
                    f"{label}: certified gamma {certified:.8g} not below the "
                    f"required {self.gamma:.8g}"
                )
                return None
        started = time.perf_counter()
        # Inverted in scaled units, where W~ is well conditioned, then
        # scaled back exactly (powers of two).
        P = scaling.unscale_P(np.linalg.inv(sol.W))
        certificate = verify(
            self.original, self.data, sol, gains, self.lmi.margin, self.scheduled,
            P, certified,
        )  # fmt: skip
        self.verifying += time.perf_counter() - started
        if not certificate.verified:
            self.notes.append(
                f"{label}: closed-loop verification failed ({certificate.summary})"
            )
            return None
        budget.reached(
            f"a certified point ({label})"
            + ("" if certified is None else f", gamma {certified:.6g}"),
            certified,
        )
        return _Point(sol, gains, certificate, certified, P)

    def gate_bounds(self, stage):
        """Bounds on the variables of a point `stage` accepts, or None.

        Every design of this job passes through an accepted point of the
        stabilization stage (the others start from one), posed with
        ``W <= I`` and ``||Z_k||^2 <= z_max`` up to the largest of
        `STABILIZE_Z_MAX`: what `refute` needs to call the rung refuted.
        """
        s = self.structure
        if stage != "stabilize" or s.hinf:
            return None
        z = schur_norm_bound(max(STABILIZE_Z_MAX), (s.m, s.n))
        return {"W": symmetric_norm_bound(1.0, s.n)} | {f"Z{k}": z for k in range(s.nZ)}

    # -- stage sequences -------------------------------------------------
    def _stabilize(self):
        lmi = self.lmi
        lmi.set_parameter("w_max", 1.0)
        carry(self, "stabilize", self.carried)
        if not self.solving:
            return None
        best = None
        for z_max in STABILIZE_Z_MAX:
            lmi.set_parameter("z_max", z_max)
            sol = self._solve("stabilize", lambda v: -v.t[0, 0], proof=True)
            best = self._accept(sol, f"stabilize (z_max {z_max:g})")
            if best is not None:
                break
        if best is None:
            return None
        if self.gain_bound is None:
            return best, None
        return self._minimise_gain(best, None)

    def _normalise_gamma(self, gamma, grow: bool = False) -> bool:
        """Rescale z so that ``gamma^2`` is about 1 in scaled units.

        A ``-g I`` block of 1e3 beside data of order one costs the solvers
        three digits (measured: Clarabel's "optimal" points then miss the
        H-infinity LMI by 1e-4), and one of 1e-6 is of the order of the
        margin, which then decides the optimum (measured: 30 % above the
        Riccati value). The scaling of z is exact (a power of two) and
        leaves ``W`` and ``Z`` unchanged. It is made larger, and smaller
        only with `grow` (an optimum far below one: its z rows grow).
        Returns whether it changed.
        """
        sz = pow2(gamma * self.scaling.sw)
        if sz == self.scaling.sz or (sz < self.scaling.sz and not grow):
            return False
        self.scaling = dataclasses.replace(self.scaling, sz=sz)
        self.data = [self.scaling.apply(v) for v in self.original]
        load(
            self.compiled, self.structure, self.data, self.scaling, self.regions,
            self.margin,
        )  # fmt: skip
        return True

    def _hinf(self):
        lmi = self.lmi
        if self.gamma is not None:
            # A required gamma, posed slightly below so it is met strictly.
            self._normalise_gamma(self.gamma)
            to_scaled = (self.scaling.sw / self.scaling.sz) ** 2
            best = None
            for slack in GAMMA_SLACK:
                lmi.set_parameter("g_max", self.gamma**2 * to_scaled * (1 - slack))
                for w_max in FIXED_GAMMA_W_MAX:
                    lmi.set_parameter("w_max", w_max)
                    sol = self._solve("center", lambda v: -v.t[0, 0], proof=True)
                    best = self._accept(sol, f"gamma given (w_max {w_max:g})")
                    if best is not None:
                        break
                if best is not None:
                    break
            if best is None:
                return None
            if self.backoff is None and self.gain_bound is None:
                return best, None
            return self._minimise_gain(best, None)

        # Not a proof stage: gamma is free, so a certificate that excludes a
        # ball of (W, Z, gamma^2) leaves designs with a huge gamma possible.
        raw = self._solve("optimal", lambda v: v.g[0, 0], certify=False)
        if raw is None:
            return None
        # gamma* from the nominal-margin point, even when the raw point only
        # certified with a larger margin (and so a larger gamma).
        g_opt = float((raw.nominal or raw).g[0, 0])
        if not (np.isfinite(g_opt) and g_opt > 0):
            self.notes.append(
                f"optimal: the solver's gamma^2 = {g_opt:g} is not positive"
            )
            return None
        # What is reported comes from points that meet the LMIs; g_opt,
        # the solver's word, only sets where the back-off starts.
        met = [self._gamma_of(p) for p in (raw.nominal, raw) if meets_lmis(p)]
        if abs(np.log2(g_opt)) > 2:
            # The stages after this one are posed with gamma^2 about 1, and
            # the optimum is estimated again there; W and Z do not depend on
            # z's scale, so the first point stands if that solve fails.
            old_sz = self.scaling.sz
            if self._normalise_gamma(
                float(np.sqrt(self.scaling.unscale_g(g_opt))), grow=True
            ):
                rescale = (old_sz / self.scaling.sz) ** 2
                g_opt *= rescale
                raw.values["g"] = raw.values["g"] * rescale
                again = self._solve("optimal", lambda v: v.g[0, 0], certify=False)
                g_again = (
                    None if again is None else float((again.nominal or again).g[0, 0])
                )
                if g_again is not None and 0 < g_again < g_opt:
                    raw, g_opt = again, g_again
                if again is not None:
                    met += [self._gamma_of(p) for p in (again.nominal, again)
                            if meets_lmis(p)]  # fmt: skip
        gamma_opt = min(met, default=None)
        raw_design = self._accept(raw, "raw optimum")
        # The estimate is the nominal-margin point's: trusted when that
        # point itself certified.
        self.estimate_certified = raw_design is not None and reached_optimum(raw)
        if not self.backoff:
            if raw_design is not None:
                if self.gain_bound is None:
                    return raw_design, gamma_opt
                return self._minimise_gain(raw_design, gamma_opt)
            self.notes.append("raw optimum: not certified; backing off")
        w_star = max(float(np.linalg.eigvalsh(raw.W)[-1]), 1e-12)
        best = back_off(self, self._accept, g_opt, w_star, raw_design)
        if best is None:
            return None
        if not self.backoff and self.gain_bound is None:
            return best, gamma_opt
        return self._minimise_gain(best, gamma_opt)

    def _gamma_of(self, sol) -> float:
        """The bound of a point's ``g`` in the model's units."""
        return float(np.sqrt(self.scaling.unscale_g(float(sol.g[0, 0]))))

    def _minimise_gain(self, best, gamma_opt):
        """Convex-concave gain iterations from a certified point.

        Returns the design tuple with `gamma_opt`, or None if a gain bound
        is not met by any certified point.
        """
        s = self.structure
        for _ in range(GAIN_ITERATIONS):
            sol = best.solution
            Z = [getattr(sol, f"Z{k}") for k in range(s.nZ)]
            gain_tangent(self.lmi, self.scaling, sol.W, Z, self.gain_bound)
            candidate = self._accept(
                self._solve("gain", lambda v: v.kappa[0, 0]), "gain stage"
            )
            if candidate is None:
                break  # the previous point is certified: keep it
            best = candidate
            # kappa is relative to the previous point's squared gain.
            if float(candidate.solution.kappa[0, 0]) > 1 - GAIN_RTOL:
                break
        if self._accept(best.solution, "final point", bounded=True) is None:
            return None
        return best, gamma_opt


def back_off(job, accept, g_opt, w_star, raw_design):
    """The back-off stage of a ladder job from the minimum ``g_opt``.

    Re-solves with ``g <= factor^2 g_opt`` and ``W <= w_max I`` (``w_max``
    the optimal point's ``lambda_max(W)``, then 1e3 times it), maximising
    the smallest eigenvalue of ``W``; factors ``1 + b, 1 + b/2, 1 + b/8,
    1 + 2 b`` for the back-off ``b``, or just above 1 without one (the raw
    optimum did not certify). Returns the first point `accept` certifies,
    else `raw_design` (None if that is None too).
    """
    b = job.backoff
    factors = (
        (1 + b, 1 + b / 2, 1 + b / 8, 1 + 2 * b) if b else (1.001, 1.01, 1.05, 1.2)
    )
    for factor in factors:
        job.lmi.set_parameter("g_max", g_opt * factor**2)
        for w_max in (w_star, 1e3 * w_star):
            job.lmi.set_parameter("w_max", w_max)
            sol = solve_stage(job, "center", lambda v: -v.t[0, 0])
            point = accept(sol, f"back-off x{factor:g} (w_max {w_max:.3g})")
            if point is not None:
                return point
    if raw_design is not None:
        job.notes.append("back-off: no certified point; the raw optimum is kept")
        job.lmi.set_parameter("g_max", g_opt * (1 + 1e-9))
    return raw_design


def meets_lmis(sol) -> bool:
    """Whether a solver's point meets its stage's LMIs, non-strictly, in float64.

    The objective of such a point is never below the problem's infimum
    (the strict LMIs' feasible set has the non-strict one as its
    closure), so it may be reported as an estimate of the optimum; a point
    that misses them may report anything (measured: 95 % below the
    Riccati optimum of an H2 problem).
    """
    return sol is not None and all(
        c.max_eig <= 0.0 if c.strict else c.passed for c in sol.checks
    )


def reached_optimum(sol) -> bool:
    """Whether a solver's point is its optimum: solved to the solver's full
    accuracy, at the nominal margin.

    An "optimal_inaccurate" point may certify and still lie far above the
    optimum (measured: 3.5 times the Riccati H2 optimum).
    """
    return (
        sol is not None
        and sol.nominal is None
        and bool(sol.attempts)
        and sol.attempts[-1].status == "optimal"
    )


def solve_stage(job, stage, objective, certify=True, proof=False):
    """Solve one stage of a ladder job; None if it gave no certified point.

    `job` has ``lmi``, ``chain``, ``deadline``, ``attempts`` and ``notes``.
    A verified infeasibility proof that needs no normalisation is re-raised
    when `proof` is set (the stage poses the user's problem itself, with
    its variables bounded by the data); otherwise it only ends this branch,
    and the note says what it proved.
    """
    try:
        sol = job.lmi.solve(
            objective, stage=stage, solvers=job.chain, certify=certify,
            deadline=job.deadline,
        )  # fmt: skip
    except InfeasibleError as exc:
        job.attempts.extend(exc.attempts)
        if proof and not exc.farkas.normalized:
            raise
        refute(job, stage, exc.farkas)
        job.notes.append(f"{stage}: {exc.farkas}")
        return None
    except CertificationError as exc:
        job.attempts.extend(exc.attempts)
        refute(job, stage, exc.farkas)
        job.notes.append(f"{stage}: {exc}")
        return None
    job.attempts.extend(sol.attempts)
    return sol


class RungRefuted(Exception):
    """No point a rung's stage could accept exists (a verified dual shows it).

    Raised by `refute` out of a ladder job, so that its rung ends at once;
    the ladder then skips every rung with the same prescaling.

    Attributes
    ----------
    farkas : `ctrl_lpv.lmi.FarkasCertificate`
        The certificate.
    margin : float
        The smallest margin any rung of the prescaling tries.
    bounds : dict of str to float
        Bounds on the variables of an accepted point (`gate_bounds`).
    """

    def __init__(self, farkas, margin, bounds, scaling):
        super().__init__(farkas.exclusion(margin, bounds))
        self.farkas = farkas
        self.margin = margin
        self.bounds = bounds
        self.scaling = scaling


def refute(job, stage, farkas) -> None:
    """Raise `RungRefuted` if `farkas` leaves `stage` nothing to accept.

    The stage must be the job's gate (``job.gate_bounds(stage)`` bounds
    the variables of every point it accepts), and the certificate must
    exclude every point within them at the smallest margin that any rung
    with the job's prescaling tries (``job.floor_margin``): the LMIs of
    those rungs differ only by their margin, so none of them can return
    a design (`ctrl_lpv.lmi.FarkasCertificate.excludes`).
    """
    bounds = job.gate_bounds(stage)
    if farkas is None or bounds is None:
        return
    if farkas.excludes(job.floor_margin, bounds):
        raise RungRefuted(farkas, job.floor_margin, bounds, job.scaling.matrix)


def carry(job, stage, source) -> None:
    """Judge another prescaling's refutation on this job's LMIs (`refute`).

    The LMIs of two prescalings are congruent: ``x = T x~`` turns each
    block of ``n`` rows of the stabilization LMIs by ``T^-1`` (up to
    positive factors), so the dual ``Y`` of prescaling ``T_r`` becomes
    ``K' Y K``, ``K = kron(I, T_r^-1 T_s)``, in prescaling ``T_s``. That is
    only a start: `ctrl_lpv.lmi.LMIProblem.farkas` polishes it and bounds
    it on this job's own LMIs in float64, so the claim is this rung's own,
    whatever the start (a block whose size is not a multiple of ``n`` is
    left as it is). Costs no solver call.
    """
    if source is None or job.gate_bounds(stage) is None:
        return
    R = np.linalg.solve(source.scaling, job.scaling.matrix)
    n = R.shape[0]
    duals = []
    for Y in source.farkas.duals:
        d = Y.shape[0]
        K = np.kron(np.eye(d // n), R) if d % n == 0 else np.eye(d)
        duals.append(K.T @ Y @ K)
    try:
        proof = job.lmi.farkas(duals, stage)
    except ValueError:  # another stage structure: nothing to carry
        return
    refute(job, stage, proof)


class Refutations:
    """The prescalings of a ladder refuted so far; the refusal once all are.

    Parameters
    ----------
    method : str
        Names the call in the message.
    names : list of str
        Every prescaling the ladder tries (each rung uses one of them).
    attempts : list
        The ladder's solver attempts (kept by the refusal).
    """

    def __init__(self, method, names, attempts):
        self.method = method
        self.names = list(names)
        self.attempts = attempts
        self.found: dict[str, RungRefuted] = {}

    def __contains__(self, name) -> bool:
        return name in self.found

    @property
    def last(self) -> RungRefuted | None:
        """The latest refutation (a start for the next prescaling), if any."""
        return next(reversed(self.found.values()), None)

    def brief(self, name) -> str:
        """Short form: the two relative margins of one prescaling."""
        exc = self.found[name]
        needed = exc.farkas.accepted_relative_margin(exc.margin, exc.bounds)
        return (
            f"relative margin at most {exc.farkas.used_relative_margin():.2g}, "
            f"the certificate needs {needed:.2g}"
        )

    def complete(self, scalings, make_job, run) -> None:
        """Judge the latest refutation on every prescaling not refuted.

        `make_job(scaling)` is a ladder job (its `floor_margin` set), and
        `run(job)` runs it; the job only loads its LMIs and `carry`-es the
        refutation (no solver call). Raises `InfeasibleError` if that
        refutes every prescaling.
        """
        for name, scaling in scalings:
            if self.last is None or name in self:
                continue
            job = make_job(scaling)
            if job.deadline is not None and time.perf_counter() > job.deadline:
                return
            job.carried, job.solving = self.last, False
            try:
                run(job)
            except RungRefuted as exc:
                self.add(name, exc)

    def add(self, name, exc: RungRefuted) -> None:
        """Record a refuted prescaling; raise `InfeasibleError` once every
        prescaling is refuted."""
        self.found[name] = exc
        if any(other not in self.found for other in self.names):
            return
        first = self.found[self.names[0]]
        per_scaling = "; ".join(f"{n}: {self.brief(n)}" for n in self.names)
        what = "Lyapunov matrix" if self.method == "analysis" else "design"
        raise InfeasibleError(
            f"{self.method}: no certifiable {what} exists: a dual certificate "
            f"verified in float64 bounds the relative margin (-max lambda_max "
            f"/ ||x||, x the free entries of {', '.join(first.farkas.variables)} "
            f"in the prescaled units) of every point of the "
            f"'{first.farkas.stage}' LMIs below the least one the certificate "
            f"accepts (a margin of {first.margin / 2:.3g} at the smallest margin "
            f"tried, {first.margin:g}, within the stage's bounds on the "
            f"variables), in every prescaling tried: {per_scaling}. A solution "
            f"with a smaller relative margin is not excluded, but none could "
            f"pass the certificate",
            self.attempts,
            first.farkas,
        )


def gain_tangent(lmi, scaling, W, Z, gain_bound):
    """Linearise the gain bound at the scaled point ``(W, Z)``.

    ``K = Su Z~ W~^-1 T^-1``, so ``||K||^2 <= kappa0 kappa`` iff
    ``(Su Z~)'(Su Z~) <= kappa0 kappa (T W~)'(T W~)``. The right side is
    bounded below by its tangent at ``G0 = T W~0``,
    ``G0' T W~ + W~ T G0 - G0' G0``, linear in ``W~`` and exact at ``W~0``;
    by a Schur complement the bound is then an LMI, sufficient everywhere
    and tight at ``W~0``. The congruence with ``G0^-1`` makes it well
    conditioned (the identity at ``W~0``) and ``kappa0``, the squared gain at
    ``(W, Z)``, makes ``kappa`` of order one. Re-linearising at each new
    point (a convex-concave iteration) lowers the gain monotonically.

    Returns
    -------
    float
        ``kappa0``.
    """
    Ginv = np.linalg.inv(scaling.matrix @ W)
    Winv = np.linalg.inv(W)
    kappa0 = max(
        float(np.linalg.norm(scaling.unscale_K(Zk @ Winv), 2)) ** 2 for Zk in Z
    )
    lmi.set_parameter("gain_Ginv", Ginv)
    lmi.set_parameter("gain_Ginv_K", Ginv / np.sqrt(kappa0))
    if gain_bound is not None:
        # A bound far above the current gain is inactive: cap it in float64.
        ratio = min(gain_bound / np.sqrt(kappa0), 1e100)
        lmi.set_parameter("kappa_max", ratio**2)
    return kappa0
