"""The fallback ladder of `synthesize` for specs beyond the paper's.

Rungs: prescalings (balanced, then none) times margins (the given one, then
``1e-3`` of it); in each rung the stages of `_Job`: the minimum of the
objective, its back-off to a well-conditioned point, and the gain
iterations when a `GainBound` is set. Each point is checked by
`ctrl_lpv.lmi.LMIProblem` (every LMI at its coefficient, in float64) and by
`_Job.verify` (the frozen closed loops in the model's units).

Prescaling
----------
The state, input and time scalings ``x = T x~``, ``u = Su u~``,
``t~ = a t`` (``a = 1`` in discrete time) are those of the paper's engine;
each spec ``i`` adds powers of two ``w = sw_i w~`` and ``z = sz_i z~``.
With one ``W = kappa T W~ T`` for every spec (``kappa = a / sw^2`` of the
base scaling), the prescaled LMIs are congruent to the model's when the
identity block of spec ``i``'s ``w`` is weighted by ``rho_i =
sw_i^2 kappa / a`` (congruence by ``diag(T^-1 / sqrt(a kappa), sw_i
sqrt(kappa / a), ...)``), and the squared bounds map back as
``gamma^2 = g~ kappa sz_i^2 / a`` (H-infinity) and ``h = h~ kappa sz_i^2``
(H2, where ``Y`` scales like ``C W C'``). All factors are powers of two, so
the congruence is exact in floating point.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import budget
from ..exceptions import CertificationError, InfeasibleError
from ..lmi import default_solvers, schur_norm_bound, symmetric_norm_bound
from ..regions import LMIRegion
from .constraints import GainBound, Saturation
from .decay import LAMBDAS, search_decay
from .frozen import verify_frozen
from .ladder import (
    GAIN_ITERATIONS,
    GAIN_RTOL,
    MARGIN_FACTORS,
    STABILIZE_Z_MAX,
    Refutations,
    RungRefuted,
    back_off,
    carry,
    gain_tangent,
    meets_lmis,
    reached_optimum,
    solve_stage,
)
from .options import guard_estimate
from .parametric import coefficient_count, coefficients
from .problem import EPSILONS, build_problem
from .results import Certificate, StateFeedbackDesign
from .scaling import Scaling, channel_scales, pow2, riccati_scaling
from .specs import H2, Peak

# Bounds W <= w_max I (scaled units) tried in turn for a given bound.
_GIVEN_W_MAX = (1e3, 1e6, 1e9)


def run_general(
    sys, iu, specs, channels, objective, constraints, scheduled, lyap, continuous,
    backoff, margin, chain, time_limit, method, suspects,
):  # fmt: skip
    """Run the ladder; a certified `StateFeedbackDesign` or an exception.

    `constraints` are the constraint specs (pole regions, at most one
    `GainBound`, at most one `Saturation`), in the model's units.
    """
    start = time.perf_counter()
    deadline = budget.deadline()  # the call's (`ctrl_lpv.budget`)
    original = []
    for A, B, C, D in sys.vertex_data():
        vertex = {"A": A, "B2": B[:, iu]}
        for i, (iw, _, iz) in enumerate(channels):
            vertex[(i, "Bw")] = B[:, iw]
            vertex[(i, "Cz")] = C[iz]
            vertex[(i, "Dzw")] = D[np.ix_(iz, iw)]
            vertex[(i, "Dzu")] = D[np.ix_(iz, iu)]
        original.append(vertex)
    for i, spec in enumerate(specs):
        iw, _, iz = channels[i]  # names for the messages
        w_names = [sys.physical_inputs[k] for k in iw]
        z_names = [sys.output_labels[k] for k in iz]
        spec.check_data(
            [{"Dzw": v[(i, "Dzw")], "w": w_names, "z": z_names} for v in original],
            continuous,
        )
    _guard(sys, original, specs, constraints, lyap, time_limit)
    record, attempts = [], []
    scalings = _prescalings(original, specs, continuous)
    # The first solver climbs every rung; the slower ones after it get the
    # first prescaling at the nominal margin only (SCS to 1e-9 takes
    # seconds where Clarabel takes milliseconds, and rarely certifies what
    # Clarabel could not).
    solvers = [[entry] for entry in (chain or default_solvers())]
    rungs = [
        (solvers[0], name, base, f) for name, base in scalings for f in MARGIN_FACTORS
    ]
    rungs += [(one, *scalings[0], MARGIN_FACTORS[0]) for one in solvers[1:]]
    # A design whose optimum did not certify may sit far above it (its
    # back-off starts from an estimate the solver could not meet): the
    # other prescalings at the nominal margin are asked for one that
    # certifies; if none does, the first design stands.
    fallback = None
    refuted = Refutations(method, [name for name, _ in scalings], attempts)

    def make_job(base, rung_margin, one_solver):
        job = _Job(
            sys, original, specs, objective, constraints, scheduled, lyap,
            continuous, base, backoff, rung_margin, one_solver, deadline,
            attempts,
        )  # fmt: skip
        job.floor_margin = margin * min(MARGIN_FACTORS)
        return job

    for one_solver, name, base, factor in rungs:
        rung = f"{one_solver[0][0]}, {name} scaling, margin {margin * factor:g}"
        if fallback is not None and (
            one_solver is not solvers[0] or factor != MARGIN_FACTORS[0]
        ):
            continue
        if name in refuted:
            record.append(f"{rung}: not tried (refuted: {refuted.brief(name)})")
            continue
        if deadline is not None and time.perf_counter() > deadline:
            record.append(f"{rung}: not tried (time_limit reached)")
            continue
        budget.progress("rung %s", rung, rung=rung)
        job = make_job(base, margin * factor, one_solver)
        job.carried = refuted.last
        try:
            found = job.run()
        except InfeasibleError as exc:
            raise InfeasibleError(f"{method}: {exc}", attempts, exc.farkas) from None
        except RungRefuted as exc:
            found = None
            refuted.add(name, exc)  # raises once every prescaling is
            job.notes.append(f"refuted: {refuted.brief(name)}")
        record.extend(f"{rung}: {note}" for note in job.notes)
        if found is None:
            continue
        if fallback is not None and found[0].values[0] >= fallback[0].values[0]:
            continue
        fallback = found
        if job.optimum_certified:
            break
        record.append(
            f"{rung}: a design, but its optimum did not certify; other "
            "prescalings asked for a certified one"
        )
    if fallback is None:
        # A prescaling refuted late (by the slower solvers) may refute the
        # ones tried before it: judged without a solver call.
        refuted.complete(
            scalings,
            lambda base: make_job(base, margin, solvers[0]),
            lambda job: job.run() if job.gate_bounds("stabilize") else None,
        )
    if fallback is not None:
        point, gamma_opt = fallback
        if objective is not None and objective.bound is None:
            # An estimate from above (see `meets_lmis`), never above what
            # is certified.
            gamma_opt = min(gamma_opt or np.inf, point.values[0])
        labels = sys.physical_inputs
        iw, _, iz = channels[0] if specs else ((), (), ())
        return StateFeedbackDesign(
            system=sys,
            method=method,
            gains=point.gains,
            P=point.P,
            gamma=point.values[0] if objective is not None else None,
            gamma_opt=gamma_opt,
            w=tuple(labels[i] for i in iw),
            u=tuple(labels[i] for i in iu),
            z=tuple(sys.output_labels[i] for i in iz),
            certificate=point.certificate,
            attempts=tuple(attempts),
            timing={"total": time.perf_counter() - start},
            backoff=backoff,
            regions=tuple(c for c in constraints if isinstance(c, LMIRegion)),
            ladder=tuple(record),
            lyapunov="constant" if lyap.constant else "affine",
            bounds=dict(zip(specs, point.values))
            | ({} if job.saturation is None else {job.saturation: point.level}),
            rational=point.rational,
        )
    hint = "".join(f"; weakly controllable: {m}" for m in suspects)
    reasons = budget.digest("; ".join(note.split(": ", 1)[-1] for note in record))
    raise CertificationError(
        f"{method}: no certified solution found after {len(rungs)} rungs "
        f"(solvers {[one[0][0] for one in solvers]}, prescalings "
        f"{[name for name, _ in scalings]}, margins "
        f"{[margin * f for f in MARGIN_FACTORS]}); what failed: {reasons}{hint}",
        attempts,
    )


def _guard(sys, original, specs, constraints, lyap, time_limit) -> None:
    """The size guard of the paper's engine, on this engine's LMI count."""
    n, m = original[0]["B2"].shape
    per_point = sum(2 if isinstance(s, (H2, Peak)) else 1 for s in specs) or 1
    regions = [c for c in constraints if isinstance(c, LMIRegion)]
    per_coefficient = len(regions)
    saturation = _saturation(constraints)
    if saturation is not None:
        per_point += 1
        per_coefficient += m + len(saturation.points)
    ncoef = coefficient_count(sys.domain, sys.nvertices)
    nlmis = ncoef * (len(lyap.rates) * per_point + per_coefficient)
    channels = max(
        [original[0][(i, "Bw")].shape[1] + original[0][(i, "Cz")].shape[0]
         for i in range(len(specs))] or [0]
    )  # fmt: skip
    largest = max([2 * n + channels] + [r.M.shape[0] * n for r in regions])
    guard_estimate(nlmis, nlmis * largest**2, largest, time_limit)


def _prescalings(original, specs, continuous):
    """``(name, Scaling)`` tried in turn: balanced, Riccati, none.

    The first performance channel shapes them (none: stability alone).
    """
    first = [
        (v["A"], v[(0, "Bw")], v["B2"], v[(0, "Cz")], v[(0, "Dzw")], v[(0, "Dzu")])
        if specs
        else (v["A"], v["B2"][:, :0], v["B2"], v["A"][:0], np.zeros((0, 0)),
              np.zeros((0, v["B2"].shape[1])))
        for v in original
    ]  # fmt: skip
    balanced = Scaling.of(first, balance=True, time_scaling=continuous)
    out = [("balanced", balanced)]
    if first[0][2].shape[1]:
        shaped = riccati_scaling(first, balanced, continuous)
        if shaped is not None:
            out.append(("Riccati", shaped))
    n, m = first[0][2].shape
    out.append(("none", Scaling(np.ones(n), np.ones(m), 1.0, 1.0, balanced.a)))
    return out


def _saturation(constraints):
    return next((c for c in constraints if isinstance(c, Saturation)), None)


# Margin of the solve that only estimates the optimum, relative to the margin.
_ESTIMATE_MARGIN = 1e-4


@dataclass(frozen=True)
class _Point:
    """A verified point in the model's units."""

    solution: object
    gains: tuple
    certificate: Certificate
    values: tuple  # certified bound of every spec
    P: object
    rational: tuple | None
    level: float | None = None  # largest x0' P x0 of a Saturation spec


class _Job:
    """One rung: a prescaling and a margin, every stage."""

    def __init__(
        self, sys, original, specs, objective, constraints, scheduled, lyap,
        continuous, base, backoff, margin, chain, deadline, attempts,
    ):  # fmt: skip
        self.sys = sys
        self.constraints = constraints
        self.saturation = _saturation(constraints)
        self.gain_bound = next(
            (c for c in constraints if isinstance(c, GainBound)), None
        )
        self.original = original
        self.specs = specs
        self.objective = objective
        self.scheduled = scheduled
        self.lyap = lyap
        self.continuous = continuous
        self.backoff = backoff
        self.margin = margin
        self.chain = chain
        self.deadline = deadline
        self.attempts = attempts
        self.notes: list[str] = []
        # The smallest margin any rung with this prescaling tries (`refute`;
        # set by the ladder), another prescaling's refutation (`carry`), and
        # whether to solve at all (not when only judging `carried`).
        self.floor_margin = margin
        self.carried = None
        self.solving = True
        # Whether the optimum's estimate comes from a point that certified
        # (True where there is no estimate to doubt).
        self.optimum_certified = True
        self.scaling = base
        self.channel = []
        for i in range(len(specs)):
            data = [
                (v["A"], v[(i, "Bw")], v["B2"], v[(i, "Cz")], v[(i, "Dzw")],
                 v[(i, "Dzu")])
                for v in original
            ]  # fmt: skip
            self.channel.append(list(channel_scales(data, base.T, base.Su, base.a)))
        self.coefficients = coefficients(sys.domain, sys.nvertices)
        self.rates = [r / base.a for r in lyap.rates]
        self.index = {spec: i for i, spec in enumerate(specs)}
        # A common gain with a parameter-dependent W: the extended LMIs.
        self.slack = not (lyap.constant or scheduled) and self._nZ() > 0
        self.eps = EPSILONS[0]
        self.peak = next((s for s in specs if isinstance(s, Peak)), None)
        self.lam = LAMBDAS[continuous][0]

    def _nZ(self) -> int:
        """Number of ``Z`` variables (none for an analysis, without inputs)."""
        if self.original[0]["B2"].shape[1] == 0:
            return 0
        return self.sys.nvertices if self.scheduled else 1

    # -- units -----------------------------------------------------------
    def _to_model(self, i) -> float:
        """Factor from a spec's scaled squared bound to the model's units.

        With ``W = kappa T W~ T`` for every spec (``kappa`` the base
        scaling's `w_factor`), the prescaled LMIs are congruent to the
        model's when the identity block of a channel is weighted by `_rho`
        (see the module docstring).
        """
        _, sz = self.channel[i]
        a, kappa = self.scaling.a, self.scaling.w_factor
        if isinstance(self.specs[i], (H2, Peak)):
            return kappa * sz**2
        return kappa * sz**2 / a

    def run(self):
        self.lmi = build_problem(self)
        if self.peak is not None:
            return search_decay(self)
        if not (self.slack and self.continuous):
            return self.stages()
        # The extended LMIs hold for each fixed eps; none is best for every
        # problem: a feasibility problem takes the first that certifies, a
        # minimisation the smallest certified bound. Their optimum at one
        # eps is not the problem's, so no other prescaling is asked for it.
        best = None
        for eps in EPSILONS:
            # Kept on the job: a rebuild (the bound's rescaling) reads it.
            self.eps = eps
            self.lmi.set_parameter("eps", eps)
            found = self.stages()
            if found is None:
                self.notes.append(f"extended LMIs, eps = {eps:g}: no certified point")
                continue
            if self.objective is None or self.objective.bound is not None:
                return found
            if best is None or found[0].values[0] < best[0].values[0]:
                best = found
        self.optimum_certified = True
        return best

    def stages(self):
        if self.objective is None:
            return self._stabilize()
        if self.objective.bound is not None:
            return self._given()
        return self._optimal()

    @property
    def _proves(self) -> bool:
        """Whether a refutation of this job's LMIs refutes the problem's LMIs.

        Not for the extended LMIs, nor with a `Peak` spec: they are posed
        at one fixed eps or lambda, and another may be feasible.
        """
        return not (self.slack and self.continuous) and self.peak is None

    def solve(self, stage, objective, certify=True, proof=False):
        return solve_stage(self, stage, objective, certify, proof)

    @property
    def _w_bounds(self) -> tuple[float, ...]:
        """The bounds ``W <= w_max I`` of the stabilization stage, in turn.

        Points of a Saturation spec fix W's scale: W <= I may exclude them.
        """
        return (1.0,) if self.saturation is None else (1.0, *_GIVEN_W_MAX)

    def gate_bounds(self, stage):
        """Bounds on the variables of a point `stage` accepts, or None.

        Without an objective every design passes through an accepted point
        of the stabilization stage, posed with ``W_l <= w_max I`` (the
        largest `w_max` that `_stabilize` tries) and ``||Z_k||^2 <= z_max``
        up to the largest of `STABILIZE_Z_MAX`. None where a refutation
        does not carry over to the rung (`_proves`). Variables without a
        bound here (a spec's, the slack ``G``) leave a certificate that
        reads them no claim.
        """
        if stage != "stabilize" or self.objective is not None or not self._proves:
            return None
        n, m = self.original[0]["B2"].shape
        w = symmetric_norm_bound(max(self._w_bounds), n)
        z = schur_norm_bound(max(STABILIZE_Z_MAX), (m, n))
        return {f"W{e}": w for e in range(self.lyap.count)} | {
            f"Z{k}": z for k in range(self._nZ())
        }

    def _stabilize(self):
        carry(self, "stabilize", self.carried)
        if not self.solving:
            return None
        best = None
        for w_max in self._w_bounds:
            self.lmi.set_parameter("w_max", w_max)
            for z_max in STABILIZE_Z_MAX:
                self.lmi.set_parameter("z_max", z_max)
                sol = self.solve("stabilize", lambda v: -v.t[0, 0], proof=self._proves)
                best = self.accept(sol, f"stabilize (w_max {w_max:g}, z_max {z_max:g})")
                if best is not None:
                    return self._gain_stage(best, None)
        return None

    def _given(self):
        best = None
        for w_max in _GIVEN_W_MAX:
            self.lmi.set_parameter("w_max", w_max)
            sol = self.solve("center", lambda v: -v.t[0, 0], proof=self._proves)
            best = self.accept(sol, f"bound given (w_max {w_max:g})")
            if best is not None:
                break
        return None if best is None else self._gain_stage(best, None)

    def _solve_optimal(self):
        """The optimal stage's point and its squared bound, or ``(None, 0)``."""
        raw = self.solve("optimal", lambda v: v.g0[0, 0], certify=False)
        if raw is None:
            return None, 0.0
        g_opt = float((raw.nominal or raw).g0[0, 0])
        if not (np.isfinite(g_opt) and g_opt > 0):
            self.notes.append(
                f"optimal: the solver's bound^2 = {g_opt:g} is not positive"
            )
            return None, 0.0
        return raw, g_opt

    def _optimal(self):
        raw, g_opt = self._solve_optimal()
        if raw is not None and g_opt > 4:
            # Pose the later stages with a bound of order one (see the ladder
            # of the paper's functions) by a power-of-two channel scaling:
            # of z, whose block the bound sits on.
            self.channel[0][1] *= pow2(np.sqrt(g_opt))
            self.lmi = build_problem(self)
            raw, g_opt = self._solve_optimal()
        if raw is None:
            return None
        # The optimum re-estimated with a margin far below the data's scale:
        # an absolute margin that is not small against the optimal W shifts
        # it (measured: 0.6 % on a discrete-time H2 problem at 1e-6, 5e-7
        # after); the estimate needs no certificate, the designs keep the
        # margin.
        self.lmi.margin = self.margin * _ESTIMATE_MARGIN
        estimate = self.solve("optimal", lambda v: v.g0[0, 0], certify=False)
        self.lmi.margin = self.margin
        if estimate is not None:
            g_est = float((estimate.nominal or estimate).g0[0, 0])
            if np.isfinite(g_est) and 0 < g_est < g_opt:
                g_opt = g_est
        # What is reported comes from points that meet the LMIs; g_opt,
        # the solver's word, only sets where the back-off starts.
        met = [p for p in (raw.nominal, raw, estimate, estimate and estimate.nominal)
               if meets_lmis(p)]  # fmt: skip
        gamma_opt = min(
            (float(np.sqrt(float(p.g0[0, 0]) * self._to_model(0))) for p in met),
            default=None,
        )
        raw_design = self.accept(raw, "raw optimum")
        self.optimum_certified = raw_design is not None and reached_optimum(raw)
        if not self.backoff:
            if raw_design is not None:
                return self._gain_stage(raw_design, gamma_opt)
            self.notes.append("raw optimum: not certified; backing off")
        w_star = max(
            max(float(np.linalg.eigvalsh(getattr(raw, f"W{e}"))[-1]), 1e-12)
            for e in range(self.lyap.count)
        )
        best = back_off(self, self.accept, g_opt, w_star, raw_design)
        if best is None:
            return None
        return self._gain_stage(best, gamma_opt)

    def _gain_stage(self, best, gamma_opt):
        if self.gain_bound is None:
            return best, gamma_opt
        nZ = len(best.gains)
        for _ in range(GAIN_ITERATIONS):
            sol = best.solution
            Z = [getattr(sol, f"Z{k}") for k in range(nZ)]
            gain_tangent(self.lmi, self.scaling, sol.W0, Z, self.gain_bound.bound)
            candidate = self.accept(
                self.solve("gain", lambda v: v.kappa[0, 0]), "gain stage"
            )
            if candidate is None:
                break
            best = candidate
            if float(candidate.solution.kappa[0, 0]) > 1 - GAIN_RTOL:
                break
        worst = max(np.linalg.norm(K, 2) for K in best.gains)
        if worst > self.gain_bound.bound:
            self.notes.append(
                f"final point: gain norm {worst:.4g} above {self.gain_bound}"
            )
            return None
        return best, gamma_opt

    # -- verification ----------------------------------------------------
    def accept(self, sol, label):
        """A verified `_Point`, or None with a note."""
        if sol is None or not sol.certified:
            return None
        sc = self.scaling
        Ws = [getattr(sol, f"W{e}") for e in range(self.lyap.count)]
        nZ = self._nZ()
        Zs = [getattr(sol, f"Z{k}") for k in range(nZ)]
        if self.slack:
            vertex_W = [sol.G]
        else:
            vertex_W = [
                Ws[self.lyap.index[j if self.scheduled else 0]] for j in range(nZ)
            ]
        gains = tuple(sc.unscale_K(-Z @ np.linalg.inv(W)) for Z, W in zip(Zs, vertex_W))
        values = tuple(
            float(np.sqrt(float(getattr(sol, f"g{i}")[0, 0]) * self._to_model(i)))
            for i in range(len(self.specs))
        )
        for spec, value in zip(self.specs, values):
            if spec.bound is not None and not value < spec.bound:
                self.notes.append(f"{label}: {spec} certified {value:.8g}, not below")
                return None
        rational = None
        if not self.lyap.constant and Zs and not self.slack:
            factor = sc.w_factor
            rational = (
                tuple(factor * (sc.Su[:, None] * (Z @ sc.matrix.T)) for Z in Zs),
                tuple(sc.unscale_W(Ws[self.lyap.index[j]]) for j in range(nZ)),
            )
        certificate, level = verify_frozen(self, sol, gains, values, Ws, Zs)
        if not certificate.verified:
            self.notes.append(
                f"{label}: closed-loop verification failed ({certificate.summary})"
            )
            return None
        budget.reached(
            f"a certified point ({label})"
            + "".join(f", {s} {v:.6g}" for s, v in zip(self.specs, values)),
            values[0] if values and self.objective is not None else None,
        )
        Ps = tuple(sc.unscale_P(np.linalg.inv(W)) for W in Ws)
        P = (
            Ps[0]
            if self.lyap.constant
            else tuple(Ps[self.lyap.index[j]] for j in range(self.sys.nvertices))
        )
        return _Point(sol, gains, certificate, values, P, rational, level)
