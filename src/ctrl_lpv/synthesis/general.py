"""The fallback ladder of `synthesize` for specs beyond the paper's.

Rungs: prescalings (balanced, then none) times margins (the given one, then
``1e-3`` of it); in each rung the stages of `_Job`: the minimum of the
objective, its back-off to a well-conditioned point, and the gain
iterations when a `GainBound` is set. Each point is checked by
`ctrl_lpv.lmi.LMIProblem` (every LMI at its coefficient, in float64) and by
`_Job.verify` (the frozen closed loops in the model's units).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from ..exceptions import CertificationError, InfeasibleError
from ..lmi import LMIProblem
from .assembly import region_block
from .ladder import (
    ESTIMATE_MARGIN,
    GAIN_ITERATIONS,
    GAIN_RTOL,
    MARGIN_FACTORS,
    STABILIZE_Z_MAX,
    gain_tangent,
)
from .parametric import coefficients, step_terms
from .results import Certificate, StateFeedbackDesign
from .scaling import Scaling, channel_scales, pow2
from .specs import H2, Stability
from .terms import Terms

# Bounds W <= w_max I (scaled units) tried in turn for a given bound.
_GIVEN_W_MAX = (1e3, 1e6, 1e9)
# A given bound is posed as bound^2 (1 - _BOUND_SLACK), met strictly.
_BOUND_SLACK = 1e-6
_VERIFY_SAMPLES = 64
# The scalar of the continuous-time extended LMIs (prescaled time units,
# where the data are of order one), tried in turn.
_EPSILONS = (1.0, 0.1, 0.01, 0.001)


def run_general(
    sys, iu, specs, channels, objective, regions, gain_bound, scheduled, lyap,
    continuous, backoff, margin, chain, time_limit, method, suspects,
):  # fmt: skip
    """Run the ladder; a certified `StateFeedbackDesign` or an exception."""
    start = time.perf_counter()
    deadline = None if time_limit is None else start + time_limit
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
        spec.check_data([{"Dzw": v[(i, "Dzw")]} for v in original], continuous)
    record, attempts = [], []
    rungs = [(name, f) for name in ("balanced", "none") for f in MARGIN_FACTORS]
    for name, factor in rungs:
        rung = f"{name} scaling, margin {margin * factor:g}"
        if deadline is not None and time.perf_counter() > deadline:
            record.append(f"{rung}: not tried (time_limit {time_limit:g} s)")
            continue
        job = _Job(
            sys, original, specs, objective, regions, gain_bound, scheduled, lyap,
            continuous, name == "balanced", backoff, margin * factor, chain,
            deadline, attempts,
        )  # fmt: skip
        try:
            found = job.run()
        except InfeasibleError as exc:
            raise InfeasibleError(f"{method}: {exc}", attempts, exc.farkas) from None
        record.extend(f"{rung}: {note}" for note in job.notes)
        if found is None:
            continue
        point, gamma_opt = found
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
            regions=regions,
            ladder=tuple(record),
            lyapunov="constant" if lyap.constant else "affine",
            bounds=dict(zip(specs, point.values)),
            rational=point.rational,
        )
    hint = "".join(f"; weakly controllable: {m}" for m in suspects)
    reasons = "; ".join(dict.fromkeys(note.split(": ", 1)[-1] for note in record))
    raise CertificationError(
        f"{method}: no certified solution found after {len(rungs)} rungs "
        f"(prescalings balanced and none, margins "
        f"{[margin * f for f in MARGIN_FACTORS]}); what failed: {reasons}{hint}",
        attempts,
    )


@dataclass(frozen=True)
class _Point:
    """A verified point in the model's units."""

    solution: object
    gains: tuple
    certificate: Certificate
    values: tuple  # certified bound of every spec
    P: object
    rational: tuple | None


class _Job:
    """One rung: a prescaling and a margin, every stage."""

    def __init__(
        self, sys, original, specs, objective, regions, gain_bound, scheduled, lyap,
        continuous, balance, backoff, margin, chain, deadline, attempts,
    ):  # fmt: skip
        self.sys = sys
        self.original = original
        self.specs = specs
        self.objective = objective
        self.scheduled = scheduled
        self.lyap = lyap
        self.continuous = continuous
        self.backoff = backoff
        self.gain_bound = gain_bound
        self.margin = margin
        self.chain = chain
        self.deadline = deadline
        self.attempts = attempts
        self.notes: list[str] = []
        first = [
            (v["A"], v[(0, "Bw")], v["B2"], v[(0, "Cz")], v[(0, "Dzw")], v[(0, "Dzu")])
            if specs
            else (
                v["A"],
                v["B2"][:, :0],
                v["B2"],
                v["A"][:0],
                np.zeros((0, 0)),
                np.zeros((0, v["B2"].shape[1])),
            )  # fmt: skip
            for v in original
        ]
        base = Scaling.of(first, balance=balance, time_scaling=continuous)
        if not balance:
            n, m = first[0][0].shape[0], first[0][2].shape[1]
            a = base.a if continuous else 1.0
            base = Scaling(np.ones(n), np.ones(m), 1.0, 1.0, a)
        self.scaling = base
        self.channel = []
        for i in range(len(specs)):
            data = [
                (v["A"], v[(i, "Bw")], v["B2"], v[(i, "Cz")], v[(i, "Dzw")],
                 v[(i, "Dzu")])
                for v in original
            ]  # fmt: skip
            self.channel.append(list(channel_scales(data, base.T, base.Su, base.a)))
        self.regions = tuple(r.time_scaled(base.a) for r in regions)
        self.coefficients = coefficients(sys.domain, sys.nvertices)
        self.rates = [r / base.a for r in lyap.rates]
        self.index = {spec: i for i, spec in enumerate(specs)}
        # A common gain with a parameter-dependent W: the extended LMIs.
        self.slack = not (lyap.constant or scheduled) and self._nZ() > 0

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
        (derivations in the module docstring of `ctrl_lpv.synthesis.specs`).
        """
        _, sz = self.channel[i]
        a, kappa = self.scaling.a, self.scaling.w_factor
        if isinstance(self.specs[i], H2):
            return kappa * sz**2
        return kappa * sz**2 / a

    def _rho(self):
        a, kappa = self.scaling.a, self.scaling.w_factor
        return {i: sw**2 * kappa / a for i, (sw, _) in enumerate(self.channel)}

    def _scaled_data(self):
        T, Su, a = self.scaling.T, self.scaling.Su, self.scaling.a
        Ti = 1.0 / T
        out = []
        for v in self.original:
            d = {
                "A": Ti[:, None] * v["A"] * T / a,
                "B2": Ti[:, None] * v["B2"] * Su / a,
            }
            for i, (sw, sz) in enumerate(self.channel):
                d[(i, "Bw")] = Ti[:, None] * v[(i, "Bw")] * sw / a
                d[(i, "Cz")] = v[(i, "Cz")] * T / sz
                d[(i, "Dzw")] = v[(i, "Dzw")] * sw / sz
                d[(i, "Dzu")] = v[(i, "Dzu")] * Su / sz
            out.append(d)
        return out

    # -- the problem -----------------------------------------------------
    def build(self) -> None:
        data = self._scaled_data()
        rho = self._rho()
        n, m = data[0]["A"].shape[0], data[0]["B2"].shape[1]
        nZ = self._nZ()
        lmi = LMIProblem(margin=self.margin)
        for ell in range(self.lyap.count):
            lmi.variable(f"W{ell}", (n, n), symmetric=True)
            lmi.add(f"W{ell} > 0", lambda v, e=ell: [[-getattr(v, f"W{e}")]])
        for k in range(nZ):
            lmi.variable(f"Z{k}", (m, n))
        for i, spec in enumerate(self.specs):
            lmi.variable(f"g{i}", (1, 1))
            if isinstance(spec, H2):
                nz = data[0][(i, "Cz")].shape[0]
                lmi.variable(f"Y{i}", (nz, nz), symmetric=True)
        for name in ("t", "kappa"):
            lmi.variable(name, (1, 1))
        if self.slack:
            lmi.variable("G", (n, n))
            lmi.parameter("eps", nonneg=True, value=_EPSILONS[0])
        lmi.parameter("g_max", (1, 1), nonneg=True, value=np.ones((1, 1)))
        lmi.parameter("w_max", nonneg=True, value=1.0)
        lmi.parameter("z_max", nonneg=True, value=1.0)

        def terms(v, c, r):
            return Terms(v, c, r, self.lyap, data, self.index, rho, self.scheduled,
                         self.continuous)  # fmt: skip

        zero = SimpleNamespace(**{
            name: np.zeros(item.shape)
            for name, item in (*lmi._vars.items(), *lmi._params.items())
        })  # fmt: skip
        performance = self.specs or [Stability()]
        for c in self.coefficients:
            for r in self.rates:
                at = c.label + (f", rate {np.round(r * self.scaling.a, 12).tolist()}"
                                if len(self.rates) > 1 else "")  # fmt: skip
                for spec in performance:
                    named = spec.lmis(terms(zero, c, r), self.continuous)
                    for q, (name, _) in enumerate(named):

                        def blocks(v, spec=spec, q=q, c=c, r=r):
                            return spec.lmis(terms(v, c, r), self.continuous)[q][1]

                        lmi.add(f"{name} {at}", blocks)
                if not self.specs:
                    # The decay of the stabilization stage, as in Lemma 1.
                    def decay(v, c=c, r=r):
                        blocks = Stability().lmis(terms(v, c, r), self.continuous)[0][1]
                        return _shifted(blocks, v.t[0, 0] * c.const)

                    lmi.add(f"decay {at}", decay, strict=False,
                            stages=("stabilize",), normalization=True)  # fmt: skip
            for q, region in enumerate(self.regions):

                def region_lmi(v, c=c, region=region):
                    t = terms(v, c, self.rates[0])
                    return [[region_block(region.L, region.M, t.W(), t.AW(), 1.0)]]

                lmi.add(f"region {q} {c.label}", region_lmi)
        for i, spec in enumerate(self.specs):
            g = f"g{i}"
            if isinstance(spec, H2):
                nw = data[0][(i, "Cz")].shape[0]
                lmi.add(f"trace Y{i} < h{i}", lambda v, i=i, nw=nw, g=g: [[
                    sum(getattr(v, f"Y{i}")[k : k + 1, k : k + 1] for k in range(nw))
                    - getattr(v, g)
                ]])  # fmt: skip
            if spec.bound is not None:
                fixed = spec.bound**2 / self._to_model(i) * (1 - _BOUND_SLACK)
                lmi.add(f"{spec} bound", lambda v, g=g, fixed=fixed: [
                    [getattr(v, g) - fixed]], strict=False)  # fmt: skip
            elif i == 0:
                lmi.add("g <= g_max", lambda v: [[v.g0 - v.g_max]], strict=False,
                        stages=("center", "gain"))  # fmt: skip
        for ell in range(self.lyap.count):
            lmi.add(f"W{ell} <= w_max I",
                    lambda v, e=ell: [[getattr(v, f"W{e}") - v.w_max * np.eye(n)]],
                    strict=False, stages=("center", "stabilize"),
                    normalization=True)  # fmt: skip
            lmi.add(f"W{ell} >= t I",
                    lambda v, e=ell: [[v.t[0, 0] * np.eye(n) - getattr(v, f"W{e}")]],
                    strict=False, stages=("center", "stabilize"),
                    normalization=True)  # fmt: skip
        for k in range(nZ):
            lmi.add(f"||Z{k}||^2 <= z_max", lambda v, k=k: [
                [-v.z_max * np.eye(n)], [getattr(v, f"Z{k}"), -np.eye(m)]],
                strict=False, stages=("stabilize",), normalization=True)  # fmt: skip
        if self.gain_bound is not None:
            T, Su = np.diag(self.scaling.T), np.diag(self.scaling.Su)
            lmi.parameter("gain_Ginv", (n, n), value=np.eye(n))
            lmi.parameter("gain_Ginv_K", (n, n), value=np.eye(n))
            lmi.parameter("kappa_max", nonneg=True, value=1.0)
            # As in the paper's engine (see `gain_tangent`).
            for k in range(nZ):

                def gain_lmi(v, k=k):
                    G = v.gain_Ginv
                    return [
                        [-(T @ v.W0 @ G + G.T @ v.W0 @ T - np.eye(n))],
                        [Su @ getattr(v, f"Z{k}") @ v.gain_Ginv_K,
                         -v.kappa[0, 0] * np.eye(m)],
                    ]  # fmt: skip

                lmi.add(f"||K{k}||^2 <= kappa", gain_lmi, strict=False,
                        stages=("gain",))  # fmt: skip
            lmi.add("kappa <= kappa_max",
                    lambda v: [[v.kappa - v.kappa_max * np.eye(1)]],
                    strict=False, stages=("gain",))  # fmt: skip
        self.lmi = lmi

    # -- stages ----------------------------------------------------------
    def run(self):
        self.build()
        if not (self.slack and self.continuous):
            return self._stages()
        # The extended LMIs hold for each fixed eps; none is best for every
        # problem: a feasibility problem takes the first that certifies, a
        # minimisation the smallest certified bound.
        best = None
        for eps in _EPSILONS:
            self.lmi.set_parameter("eps", eps)
            found = self._stages()
            if found is None:
                self.notes.append(f"extended LMIs, eps = {eps:g}: no certified point")
                continue
            if self.objective is None or self.objective.bound is not None:
                return found
            if best is None or found[0].values[0] < best[0].values[0]:
                best = found
        return best

    def _stages(self):
        if self.objective is None:
            return self._stabilize()
        if self.objective.bound is not None:
            return self._given()
        return self._optimal()

    def _solve(self, stage, objective, certify=True, proof=False):
        try:
            sol = self.lmi.solve(objective, stage=stage, solvers=self.chain,
                                 certify=certify, deadline=self.deadline)  # fmt: skip
        except InfeasibleError as exc:
            self.attempts.extend(exc.attempts)
            if proof and not exc.farkas.normalized:
                raise
            self.notes.append(f"{stage}: {exc.farkas}")
            return None
        except CertificationError as exc:
            self.attempts.extend(exc.attempts)
            self.notes.append(f"{stage}: {exc}")
            return None
        self.attempts.extend(sol.attempts)
        return sol

    def _stabilize(self):
        best = None
        for z_max in STABILIZE_Z_MAX:
            self.lmi.set_parameter("z_max", z_max)
            sol = self._solve("stabilize", lambda v: -v.t[0, 0], proof=True)
            best = self.accept(sol, f"stabilize (z_max {z_max:g})")
            if best is not None:
                break
        return None if best is None else self._gain_stage(best, None)

    def _given(self):
        best = None
        for w_max in _GIVEN_W_MAX:
            self.lmi.set_parameter("w_max", w_max)
            sol = self._solve("center", lambda v: -v.t[0, 0], proof=True)
            best = self.accept(sol, f"bound given (w_max {w_max:g})")
            if best is not None:
                break
        return None if best is None else self._gain_stage(best, None)

    def _optimal(self):
        raw = self._solve("optimal", lambda v: v.g0[0, 0], certify=False)
        if raw is None:
            return None
        g_opt = float((raw.nominal or raw).g0[0, 0])
        if not (np.isfinite(g_opt) and g_opt > 0):
            self.notes.append(
                f"optimal: the solver's bound^2 = {g_opt:g} is not positive"
            )
            return None
        if g_opt > 4:
            # Pose the later stages with a bound of order one (see the ladder
            # of the paper's functions) by a power-of-two channel scaling:
            # of z, whose block the bound sits on.
            self.channel[0][1] *= pow2(np.sqrt(g_opt))
            self.build()
            raw = self._solve("optimal", lambda v: v.g0[0, 0], certify=False)
            if raw is None:
                return None
            g_opt = float((raw.nominal or raw).g0[0, 0])
        # The estimate with a margin far below the data (see the ladder's).
        self.lmi.margin = self.margin * ESTIMATE_MARGIN
        estimate = self._solve("optimal", lambda v: v.g0[0, 0], certify=False)
        self.lmi.margin = self.margin
        if estimate is not None:
            g_est = float((estimate.nominal or estimate).g0[0, 0])
            if np.isfinite(g_est) and 0 < g_est < g_opt:
                g_opt = g_est
        gamma_opt = float(np.sqrt(g_opt * self._to_model(0)))
        raw_design = self.accept(raw, "raw optimum")
        if not self.backoff:
            if raw_design is not None:
                return self._gain_stage(raw_design, gamma_opt)
            self.notes.append("raw optimum: not certified; backing off")
            factors = (1.001, 1.01, 1.05, 1.2)
        else:
            b = self.backoff
            factors = (1 + b, 1 + b / 2, 1 + b / 8, 1 + 2 * b)
        w_star = max(
            max(float(np.linalg.eigvalsh(getattr(raw, f"W{e}"))[-1]), 1e-12)
            for e in range(self.lyap.count)
        )
        best = None
        for factor in factors:
            self.lmi.set_parameter("g_max", np.array([[g_opt * factor**2]]))
            for w_max in (w_star, 1e3 * w_star):
                self.lmi.set_parameter("w_max", w_max)
                sol = self._solve("center", lambda v: -v.t[0, 0])
                best = self.accept(sol, f"back-off x{factor:g} (w_max {w_max:.3g})")
                if best is not None:
                    break
            if best is not None:
                break
        if best is None:
            if raw_design is None:
                return None
            self.notes.append("back-off: no certified point; the raw optimum is kept")
            best = raw_design
            self.lmi.set_parameter("g_max", np.array([[g_opt * (1 + 1e-9)]]))
        return self._gain_stage(best, gamma_opt)

    def _gain_stage(self, best, gamma_opt):
        if self.gain_bound is None:
            return best, gamma_opt
        nZ = len(best.gains)
        for _ in range(GAIN_ITERATIONS):
            sol = best.solution
            Z = [getattr(sol, f"Z{k}") for k in range(nZ)]
            gain_tangent(self.lmi, self.scaling, sol.W0, Z, self.gain_bound)
            candidate = self.accept(
                self._solve("gain", lambda v: v.kappa[0, 0]), "gain stage"
            )
            if candidate is None:
                break
            best = candidate
            if float(candidate.solution.kappa[0, 0]) > 1 - GAIN_RTOL:
                break
        worst = max(np.linalg.norm(K, 2) for K in best.gains)
        if worst > self.gain_bound:
            self.notes.append(
                f"final point: gain norm {worst:.4g} above gain_bound "
                f"{self.gain_bound:g}"
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
                tuple(factor * (sc.Su[:, None] * Z * sc.T) for Z in Zs),
                tuple(sc.unscale_W(Ws[self.lyap.index[j]]) for j in range(nZ)),
            )
        certificate = self.verify(sol, gains, values, Ws, Zs)
        if not certificate.verified:
            self.notes.append(
                f"{label}: closed-loop verification failed ({certificate})"
            )
            return None
        Ps = tuple(sc.unscale_P(np.linalg.inv(W)) for W in Ws)
        P = (
            Ps[0]
            if self.lyap.constant
            else tuple(Ps[self.lyap.index[j]] for j in range(self.sys.nvertices))
        )
        return _Point(sol, gains, certificate, values, P, rational)

    def _points(self):
        """Convex coordinates (and box points) of the verification points."""
        sys, N = self.sys, self.sys.nvertices
        rng = np.random.default_rng(12345)
        domain = sys.domain
        if hasattr(domain, "lower") and N > 1:
            points = list(domain.points)
            points += list(
                rng.uniform(
                    domain.lower, domain.upper, size=(_VERIFY_SAMPLES, domain.nparams)
                )
            )
            points.append(0.5 * (domain.lower + domain.upper))
            return [(domain._weights(np.asarray(p, float)), np.asarray(p, float))
                    for p in points]  # fmt: skip
        deltas = list(np.eye(N))
        if N > 1:
            deltas += list(rng.dirichlet(np.ones(N), size=_VERIFY_SAMPLES))
        return [(d, None) for d in deltas]

    def _moved(self, Ws, delta, p, rate):
        """``dW/dt`` (continuous) or ``W`` at the next sample, model units."""
        lyap, sc = self.lyap, self.scaling
        N = len(delta)
        if self.continuous:
            dW = np.zeros_like(Ws[0])
            for j in range(N):
                for w, f in step_terms(lyap, j, rate, True):
                    dW = dW + delta[j] * f * Ws[w]
            return sc.unscale_W(dW)
        nxt = delta
        if p is not None and not lyap.constant:
            domain = self.sys.domain
            nxt = domain._weights(np.clip(p + rate, domain.lower, domain.upper))
        return sc.unscale_W(
            np.tensordot(nxt, np.stack([Ws[lyap.index[j]] for j in range(N)]), axes=1)
        )

    def verify(self, sol, gains, values, Ws, Zs) -> Certificate:
        """Frozen closed loops in the model's units at vertices and samples."""
        sc, lyap = self.scaling, self.lyap
        worst_eig = worst_lyap = worst_spec = -np.inf
        npoints = 0
        performance = self.specs or [Stability()]
        bounds = values or (None,)
        for delta, p in self._points():

            def mix(items, delta=delta):
                return np.tensordot(delta, np.stack(items), axes=1)

            A = mix([v["A"] for v in self.original])
            B2 = mix([v["B2"] for v in self.original])
            if not Zs:
                K = np.zeros((0, A.shape[0]))
            elif self.scheduled and not lyap.constant:
                Wt = mix([Ws[lyap.index[j]] for j in range(len(delta))])
                K = sc.unscale_K(-mix(Zs) @ np.linalg.inv(Wt))
            elif self.scheduled:
                K = mix(gains)
            else:
                K = gains[0]
            Acl = A - B2 @ K
            eig = np.linalg.eigvals(Acl)
            worst_eig = max(worst_eig, (eig.real.max() if self.continuous
                                        else np.abs(eig).max() - 1))  # fmt: skip
            for region in self.regions:
                L = region.L * sc.a
                for s in eig:
                    F = L + region.M * s + region.M.T * np.conj(s)
                    worst_spec = max(worst_spec, float(np.linalg.eigvalsh(F)[-1]))
            W_here = mix([Ws[lyap.index[j]] for j in range(len(delta))])
            P = sc.unscale_P(np.linalg.inv(W_here))
            W = sc.unscale_W(W_here)
            for rate in lyap.rates:
                W_moved = self._moved(Ws, delta, p, rate)
                if self.continuous:
                    # d(W^-1)/dt = -W^-1 (dW/dt) W^-1.
                    P_moved = -P @ W_moved @ P
                else:
                    P_moved = np.linalg.inv(W_moved) if not lyap.constant else P
                npoints += 1
                loop = (Acl, None, None, None, P, P_moved, W, W_moved)
                for i, (spec, bound) in enumerate(zip(performance, bounds)):
                    frozen = loop
                    if not isinstance(spec, Stability):
                        Bw, Cz, Dzu, Dzw = (
                            mix([v[(i, key)] for v in self.original])
                            for key in ("Bw", "Cz", "Dzu", "Dzw")
                        )
                        frozen = (Acl, Bw, Cz - Dzu @ K, Dzw, P, P_moved, W, W_moved)
                    worst_spec = max(
                        worst_spec, spec.residual(frozen, bound, self.continuous)
                    )
                worst_lyap = max(
                    worst_lyap, Stability().residual(loop, None, self.continuous)
                )
        return Certificate(
            lmi_checks=sol.checks,
            margin=self.lmi.margin,
            max_closed_loop_real=float(worst_eig),
            max_lyapunov_eig=float(worst_lyap),
            npoints=npoints,
            max_original_eig=float(worst_spec),
        )


def _shifted(blocks, shift):
    """`blocks` plus ``shift I`` on the diagonal (``2 X`` stands for ``X + X'``)."""
    out = [list(row) for row in blocks]
    for i, row in enumerate(out):
        size = row[i].shape[0]
        row[i] = row[i] + shift * np.eye(size)
    return out
