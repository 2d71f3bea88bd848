"""One rung of the engine's ladder: a prescaling, a margin, every stage.

A `Rung` loads its problem's parameters for one prescaling (a
`~ctrl_lpv.synthesis.scaling.Frame`) and margin, and runs the stages:

* stability alone: the decay maximised ("stabilize"), then the
  convex-concave steps of a gain bound;
* a bound to minimise: the raw optimum ("optimal"), posed again only when
  it did not certify or the margin is not negligible against it (its
  bound rescaled to order one, or a margin far below the data's scale for
  the estimate) and, for an H2 optimum without a back-off, in
  coordinates where its ``W`` is the identity (`Rung._shaped`); then the
  back-off under ``bound <= (1 + backoff) bound*`` in one extra solve:
  one convex-concave step of the gain in the model's
  units from the certified optimum ("bounded", `~.gains.GainSteps`, its
  tangent exact at the optimum's ``W``). Where the optimum's ``W`` is
  pinned at the margin (an eigenvalue below `PINNED` margins) or ill
  conditioned (`ILL_CONDITIONED`), where a tangent there keeps the gain
  large (measured 3x on the two-mass Theorem 2 design, 1.9x on the 2 ms
  servo), or the optimum did not certify, the smallest gain under the
  bound instead ("gain", tangent at a point of the margin's order) and one
  step from there; the centering stage of the old back-off ("center":
  ``W``'s smallest eigenvalue maximised) only where these do not certify;
* a given bound: the same back-off under it (a "center" point where it
  does not certify, or without a back-off).

Each point is checked by `ctrl_lpv.lmi.LMIProblem` (every LMI at its
coefficient, in float64) and on the frozen loops in the model's units
(`~ctrl_lpv.synthesis.points.check_point`); `run` returns the best
verified point, or None with the rung's notes saying why. Nothing outside
the rung writes into it but the ladder, before it runs (a refutation to
carry, an estimate to confirm); the decay search gets functions and
returns what it found.
"""

from __future__ import annotations

import time

import numpy as np

from .. import budget
from ..lmi import default_solvers, schur_norm_bound, symmetric_norm_bound
from .decay import DecaySearch, search_decay
from .gains import STEP_GAP_TOL, STEP_SPAN, GainSteps
from .points import Ws as _Ws
from .points import check_point
from .problem import load, set_eps
from .refutation import carry, meets_lmis, reached_optimum, solve_stage
from .scaling import pow2, shaped_frame

# Squared bounds ||Z|| <= sqrt(z_max) of the stabilization stage, in turn:
# the LMIs are homogeneous, so a larger bound admits a smaller decay.
STABILIZE_Z_MAX = (1.0, 1e4, 1e8)
# Bounds W <= w_max I (scaled units) tried in turn for a given bound.
GIVEN_W_MAX = (1e3, 1e6, 1e9)
# The scalar of the continuous-time extended LMIs (prescaled time units,
# where the data are of order one), tried in turn.
EPSILONS = (100.0, 30.0, 10.0, 3.0, 1.0, 0.1, 0.01)
# A raw optimum is posed again with its bound rescaled to order one when
# the margin is more than this fraction of its squared bound, and estimated
# again at a margin far below the data's scale when the margin pins its W
# (an eigenvalue below PINNED margins): the margin then shifts the optimum
# by more than the solvers' accuracy (measured: 30 % above the Riccati
# value at a bound of 1e-6; 0.35 % and 0.6 % on H2 problems).
MARGIN_FRACTION = 2e-5
PINNED = 10.0
# The default back-off steps once from the optimum unless the optimum's W
# is pinned or its condition number is above this: there the tangent,
# exact at W only, keeps the gain large (measured with
# benchmarks/study_backoff.py: 38 random polytopes with W's condition
# number 1.2-28 within 0.91-1.05x of the smallest-gain path's gain; one
# at 67 at 1.29x; the 2 ms servo, 7e5, at 1.9x).
ILL_CONDITIONED = 50.0
# (1e-2 of the margin: the shift is linear in the margin, and a point at
# 1e-4 of it missed its LMIs and cost a retry every time.)
_ESTIMATE_MARGIN = 1e-2
# Where the optimal stage gives no point, it is posed once more with z
# scaled by this (the squared bound by its square, 2^-20): for an optimum far
# above the data's scale (`Rung._solve_far_above`).
FAR_ABOVE = 2.0**10
# An H2 raw optimum whose W has a condition number above RESHAPE_CONDITION
# or an eigenvalue below RESHAPE_MARGINS margins is solved again in
# coordinates where that W is the identity (`Rung._shaped`), at most
# RESHAPES times. In discrete time the margin's shift of the bound is about
# margin / ((1 - |pole|^2) lambda_min(W)), large for poles near 1: measured
# on the Kalman filter of the motor-encoder contact model (poles within
# 1e-3 of 1), 3.8e-4 above the Riccati value after one shaping (W's
# condition number 18), 6.6e-5 after a second (condition 1.003); hence 10,
# not the 1e3 at which the solvers' tolerances begin to matter.
RESHAPE_CONDITION = 10.0
RESHAPE_MARGINS = 1e4
RESHAPES = 3
# An optimum within this of an earlier rung's estimate confirms it.
CONFIRM_RTOL = 1e-5


class Rung(GainSteps):
    """A prescaling and a margin: the stages (see the module docstring).

    The ladder (`ctrl_lpv.synthesis.general`) builds one per rung and
    reads `run`'s result, `notes` and `optimum_certified`; the solver
    attempts go into the shared `attempts` list.
    """

    def __init__(self, problem, structure, compiled, frame, margin, chain,
                 deadline, attempts, floor_margin):  # fmt: skip
        self.problem = problem
        self.structure = structure
        self.shape = structure.shape(problem)
        self.compiled = compiled
        self.lmi = compiled.lmi
        self.margin = margin
        self.chain = chain
        self.deadline = deadline
        self.attempts = attempts
        # The smallest margin any rung with this prescaling tries (`refute`),
        # another prescaling's refutation (`carry`), and whether to solve at
        # all (not when only judging `carried`).
        self.floor_margin = floor_margin
        self.carried = None
        self.solving = True
        self.notes: list[str] = []
        # Whether the optimum's estimate comes from a point that certified
        # (True where there is no estimate to doubt).
        self.optimum_certified = True
        self.compiling = self.verifying = 0.0
        self.settings: dict = {}  # searched parameters (eps, a decay)
        # ``(value, text)`` of the best point reached (for a refusal).
        self.best = None
        # The estimate of the optimum of a design found by an earlier rung
        # whose optimum did not certify (set by the ladder), and whether
        # this rung's optimum confirmed it (then it stops there).
        self.confirm = None
        self.confirmed = False
        # Whether the gain steps ended above a gain bound (the ladder may
        # widen the back-off: `ctrl_lpv.synthesis.general.run`).
        self.gain_short = False
        self._load(frame)

    @property
    def scaling(self):
        return self.frame.scaling

    def _load(self, frame) -> None:
        self.frame = frame
        self.data = load(self.compiled, self.problem, self.structure, frame,
                         self.margin)  # fmt: skip
        for name, value in self.settings.items():
            self._set(name, value)

    def _set(self, name, value) -> None:
        self.settings[name] = value
        if name == "eps":
            set_eps(self.lmi, self.problem, self.structure, self.data, value)
        else:
            self.lmi.set_parameter(name, value)

    # -- the rung --------------------------------------------------------
    def run(self):
        """``(point, gamma_opt)``, or None (`notes` say why)."""
        decay = self.problem.decay
        if decay is not None:
            return self._search(*decay)
        if not (self.problem.slack and self.problem.continuous):
            return self.stages()
        # The extended LMIs hold for each fixed eps; none is best for every
        # problem: a feasibility problem takes the first that certifies, a
        # minimisation the smallest certified bound. Their optimum at one
        # eps is not the problem's, so no other prescaling is asked for it.
        best = None
        for eps in EPSILONS:
            self._set("eps", eps)
            found = self.stages()
            if found is None:
                self.notes.append(f"extended LMIs, eps = {eps:g}: no certified point")
                continue
            if not self._minimise:
                return found
            if best is None or found[0].value < best[0].value:
                best = found
        self.optimum_certified = True
        return best

    @property
    def _minimise(self) -> bool:
        objective = self.problem.objective
        return objective is not None and objective.bound is None

    def _search(self, q, name, grid):
        # The spec's grid in this rung's units (`Spec.decay_grid`).
        grid = self.problem.specs[q].decay_grid(self.problem.continuous, self.frame)
        first = (self.chain or default_solvers())[:1]
        chain = self.chain

        def diverted(function):
            start = len(self.notes)
            try:
                return function()
            finally:
                notes = self.notes[start:]
                del self.notes[start:]
                self._diverted = notes

        def raw_optimum(lam):
            self._set(name, lam)
            self.chain = first
            try:
                raw = diverted(lambda: self.solve("optimal", _g0, certify=False))
            finally:
                self.chain = chain
            value = np.inf if raw is None else float((raw.nominal or raw).g0[0, 0])
            return value, self._diverted

        def stages(lam, first_only):
            self._set(name, lam)
            self.chain = first if first_only else chain
            try:
                found = diverted(self.stages)
            finally:
                self.chain = chain
            return found, self._diverted

        search = DecaySearch(
            tuple(grid), self.problem.continuous, self._minimise, self.frame.a,
            len(chain or default_solvers()) > 1,
        )  # fmt: skip
        found, notes = search_decay(search, raw_optimum, stages)
        self.notes.extend(notes)
        return found

    def stages(self):
        if self.problem.objective is None:
            return self._stabilize()
        if self.problem.objective.bound is not None:
            return self._given()
        return self._optimal()

    # -- one solve -----------------------------------------------------
    def solve(self, stage, objective, certify=True, proof=False):
        first = self.chain[0][0] if self.chain else None
        self.compiling += self.lmi.compile(stage, objective, first)
        return solve_stage(self, stage, objective, certify, proof)

    @property
    def _proves(self) -> bool:
        """Whether a refutation of this rung's LMIs refutes the problem's.

        Not for the extended LMIs, nor with a searched decay: they are
        posed at one fixed eps or lambda, and another may be feasible.
        """
        problem = self.problem
        return not (problem.slack and problem.continuous) and problem.decay is None

    @property
    def _w_bounds(self) -> tuple[float, ...]:
        """The bounds ``W <= w_max I`` of the stabilization stage, in turn.

        A spec that fixes W's scale (a region's points) may need more.
        """
        return (1.0, *GIVEN_W_MAX) if self.problem.fixes_scale else (1.0,)

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
        if stage != "stabilize" or self.problem.objective is not None:
            return None
        if not self._proves:
            return None
        s = self.structure
        w = symmetric_norm_bound(max(self._w_bounds), s.n)
        z = schur_norm_bound(max(STABILIZE_Z_MAX), (s.m, s.n))
        return {f"W{e}": w for e in range(self.problem.lyap.count)} | {
            f"Z{k}": z for k in range(s.nZ)
        }

    # -- stages ----------------------------------------------------------
    def _stabilize(self):
        carry(self, "stabilize", self.carried)
        if not self.solving:
            return None
        for w_max in self._w_bounds:
            self.lmi.set_parameter("w_max", w_max)
            for z_max in STABILIZE_Z_MAX:
                self.lmi.set_parameter("z_max", z_max)
                sol = self.solve("stabilize", _minus_t, proof=self._proves)
                best = self.accept(sol, f"stabilize (w_max {w_max:g}, z_max {z_max:g})")
                if best is not None:
                    return self._gain_bound(best, None)
        return None

    def _given(self):
        objective = self.problem.objective
        if not self.solving:
            return None
        # Posed with the bound of order one (an exact rescaling of z).
        g = objective.to_scaled(objective.bound, self.frame, 0)
        self._normalise(g, grow_only=True)
        g = objective.to_scaled(objective.bound, self.frame, 0)
        best = None
        for slack in (1e-6, 1e-3):
            self.lmi.set_parameter("g_max", g * (1 - slack))
            if self.problem.backoff:
                best = self._smallest_gain(proof=self._proves)
            for w_max in GIVEN_W_MAX if best is None else ():
                self.lmi.set_parameter("w_max", w_max)
                sol = self.solve("center", _minus_t, proof=self._proves)
                best = self.accept(sol, f"bound given (w_max {w_max:g})")
                if best is not None:
                    break
            if best is not None:
                break
        if best is None:
            return None
        return self._gain_bound(best, None, refine=bool(self.problem.backoff))

    def _solve_optimal(self):
        """The optimal stage's point and its squared bound, or ``(None, 0)``."""
        raw = self.solve("optimal", _g0, certify=False)
        if raw is None:
            return None, 0.0
        g_opt = float((raw.nominal or raw).g0[0, 0])
        if not (np.isfinite(g_opt) and g_opt > 0):
            self.notes.append(
                f"optimal: the solver's bound^2 = {g_opt:g} is not positive"
            )
            return None, 0.0
        return raw, g_opt

    def _solve_far_above(self):
        """The optimal stage posed again for a bound far above the data's.

        The prescalings bring the data to order one, not the optimum: a
        weakly controllable mode sets a bound of 1e4 to 1e5 beside data
        of order one (fuzz 7373:15, a mode at 0 reached through 1e-6), a
        ``-g I`` block of 1e10 where the solvers called the LMIs
        infeasible at every prescaling. Posed again with z scaled by
        `FAR_ABOVE` (exact, a power of two, and ``W`` and ``Z`` unchanged),
        it solves; `_optimal` then rescales the bound to order one as for
        any optimum. ``(None, 0)`` and the frame as it was where it does not.
        Only where a solver called the LMIs infeasible: with the bound free
        they are feasible wherever any design exists.
        """
        frame = self.frame
        self._load(frame.with_sz(0, frame.sz(0) * FAR_ABOVE))
        raw, g_opt = self._solve_optimal()
        if raw is None:
            self._load(frame)
        return raw, g_opt

    def _normalise(self, g, grow_only=False) -> bool:
        """Rescale z so that the objective's squared bound is about 1.

        A ``-g I`` block of 1e3 beside data of order one costs the solvers
        three digits (measured: Clarabel's "optimal" points then miss the
        H-infinity LMI by 1e-4), and one of 1e-6 is of the order of the
        margin, which then decides the optimum (measured: 30 % above the
        Riccati value). The scaling of z is exact (a power of two), a
        parameter of the problem (no compilation), and leaves ``W`` and
        ``Z`` unchanged. Returns whether it changed.
        """
        sz = pow2(self.frame.sz(0) * np.sqrt(g))
        if sz == self.frame.sz(0) or (grow_only and sz < self.frame.sz(0)):
            return False
        self._load(self.frame.with_sz(0, sz))
        return True

    def _optimal(self):
        start = len(self.attempts)
        raw, g_opt = self._solve_optimal()
        if raw is None and _called_infeasible(self.attempts[start:]):
            raw, g_opt = self._solve_far_above()
        if raw is None:
            return None
        points = [(raw, self.frame)]
        raw_design = self.accept(raw, "raw optimum")
        # Not certified at the nominal margin (a larger one costs the bound
        # what it costs the LMIs), or a margin that shifts the bound.
        failed = raw_design is None or raw.nominal is not None
        if failed or self.margin > MARGIN_FRACTION * g_opt:
            # Posed again with the bound of order one, where that changes
            # the scaling (W and Z do not depend on z's).
            frame = self.frame
            if self._normalise(g_opt):
                g_opt *= (frame.sz(0) / self.frame.sz(0)) ** 2
                again, g_again = self._solve_optimal()
                if again is not None:
                    points.append((again, self.frame))
                    g_opt = min(g_opt, g_again)
                    other = self.accept(again, "raw optimum (bound rescaled)")
                    if other is not None and (
                        raw_design is None or other.value < raw_design.value
                    ):
                        raw, raw_design = again, other
        raw, raw_design, g_opt = self._shaped(raw, raw_design, g_opt, points)
        spectra = [np.linalg.eigvalsh(W) for W in _Ws(raw)]
        W_star = max(float(e[-1]) for e in spectra)
        pinned = min(float(e[0]) for e in spectra) < PINNED * self.margin
        # A tangent at an ill-conditioned W is a poor bound away from it.
        tangent_poor = pinned or any(e[-1] > ILL_CONDITIONED * e[0] for e in spectra)
        if pinned:
            # The optimum re-estimated at a margin far below the data's
            # scale: it needs no certificate, the designs keep the margin.
            self.lmi.margin = self.margin * _ESTIMATE_MARGIN
            estimate, g_estimate = self._solve_optimal()
            self.lmi.margin = self.margin
            if estimate is not None:
                points.append((estimate, self.frame))
                g_opt = min(g_opt, g_estimate)
        # What is reported comes from points that meet the LMIs; g_opt,
        # the solver's word, only sets where the back-off starts.
        objective = self.problem.objective
        met = [
            objective.to_model(float(p.g0[0, 0]), f, 0)
            for sol, f in points for p in (sol.nominal, sol) if meets_lmis(p)
        ]  # fmt: skip
        gamma_opt = min(met, default=None)
        if gamma_opt is not None:
            self._reached(gamma_opt, f"the optimum's estimate, {objective} "
                                     f"{gamma_opt:.6g} (not certified)")  # fmt: skip
        self.optimum_certified = raw_design is not None and reached_optimum(raw)
        if (
            self.confirm is not None
            and gamma_opt is not None
            and gamma_opt >= self.confirm * (1 - CONFIRM_RTOL)
        ):
            # No better than the design at hand: no back-off needed here.
            # Without a back-off the design at hand is a raw optimum that
            # may have certified only at a larger margin (above the
            # optimum): this rung's raw optimum, if it certified, competes.
            self.confirmed = self.optimum_certified
            self.notes.append(
                f"optimum {gamma_opt:.8g}: no better than the design's estimate"
                + (" (confirmed)" if self.confirmed else "")
            )
            if self.problem.backoff or raw_design is None:
                return None
        backoff = self.problem.backoff
        if not backoff:
            if raw_design is not None:
                # A gain bound the raw optimum breaks costs the default
                # back-off: at the optimum the gain is hardly free.
                self.lmi.set_parameter("g_max", g_opt * 1.2**2)
                return self._gain_bound(raw_design, gamma_opt)
            self.notes.append("raw optimum: not certified; backing off")
        w_star = max(W_star, 1e-12)
        best = None
        if backoff:
            self.lmi.set_parameter("g_max", g_opt * (1 + backoff) ** 2)
            if raw_design is not None and not tangent_poor:
                # One convex-concave step from the optimum (see the module
                # docstring): the back-off in one extra solve.
                best = self._gain_step(
                    raw_design, "back-off (one gain step)", STEP_SPAN, STEP_GAP_TOL
                )
                if best is not None:
                    return self._gain_bound(best, gamma_opt)
            best = self._smallest_gain()
        if best is None:
            best = self._center(g_opt, w_star, raw_design)
        if best is None:
            return None
        return self._gain_bound(best, gamma_opt, refine=bool(backoff))

    def _shaped(self, raw, raw_design, g_opt, points):
        """The raw optimum posed again where its ``W`` is the identity.

        Where the raw optimum's ``W`` is far from a multiple of the
        identity (`RESHAPE_CONDITION`, `RESHAPE_MARGINS`), the margin and
        the solver's tolerances, not the problem, decide its bound
        (`~.scaling.shaped_frame`): the optimal stage is solved again in
        coordinates shaped by that ``W``, with the bound of order one, up
        to `RESHAPES` times while the certified bound improves. The rung
        goes on in the frame of the best point. Returns ``(raw, raw_design,
        g_opt)``, `g_opt` (the smallest squared bound a solver reported) in
        that frame's units; the points solved are appended to `points`.
        """
        problem, objective = self.problem, self.problem.objective
        # One constant W and an objective whose optimum a finite gain
        # attains (`shapeable`: H2). Not H-infinity, whose optimum is often
        # an infimum approached by unbounded gains: shaped, the raw optimum
        # of tests/test_riccati_hinf.py's problem 13 had gains of 3e10 (a
        # pole at -1.2e9) and a certified bound 34.3994419 that float64
        # references cannot confirm (python-control's linfnorm: 34.3994956;
        # the peak evaluated with 60 digits: 34.3994095, below the bound).
        # Only for the raw optimum itself (no back-off): the back-off's
        # steps from a shaped optimum land on other gains (the two-mass
        # drive observer's 40 % smaller, its torque estimate in the backlash
        # simulation twice as far off), and from the better bound in the
        # rung's own frame they did not certify; both await their own study.
        if not (problem.lyap.constant and objective.shapeable and not problem.backoff):
            return raw, raw_design, g_opt
        # Bounds compared across frames in the model's units.
        model = objective.to_model(g_opt, self.frame, 0)
        for _ in range(RESHAPES):
            (W,) = _Ws(raw)
            e = np.linalg.eigvalsh(W)
            if not e[0] > 0 or (
                e[-1] <= RESHAPE_CONDITION * e[0]
                and e[0] >= RESHAPE_MARGINS * self.margin
            ):
                break
            before = self.frame
            frame = shaped_frame(before, W, self.problem.plant)
            # The bound of order one there (exact: a power of two on z).
            g = objective.to_scaled(model, frame, 0)
            self._load(frame.with_sz(0, pow2(frame.sz(0) * np.sqrt(g))))
            again, g_again = self._solve_optimal()
            if again is not None and self.margin > MARGIN_FRACTION * g_again:
                # Far below the estimate it was scaled by: once more at order one.
                if self._normalise(g_again):
                    again, g_again = self._solve_optimal()
            if again is None:
                self._load(before)
                break
            points.append((again, self.frame))
            model = min(model, objective.to_model(g_again, self.frame, 0))
            other = self.accept(again, "raw optimum (shaped)")
            if other is None or (
                raw_design is not None and not other.value < raw_design.value
            ):
                self._load(before)
                break
            raw, raw_design = again, other
        return raw, raw_design, objective.to_scaled(model, self.frame, 0)

    def _center(self, g_opt, w_star, raw_design):
        """The centering back-off from the minimum ``g_opt``.

        Re-solves with ``g <= factor^2 g_opt`` and ``W <= w_max I``
        (``w_max`` the optimal point's ``lambda_max(W)``, then 1e3 times
        it), maximising the smallest eigenvalue of ``W``; factors ``1 + b,
        1 + b/2, 1 + b/8, 1 + 2 b`` for the back-off ``b``, or just above 1
        without one (the raw optimum did not certify). Returns the first
        point that certifies, else `raw_design` (None if that is None too).
        """
        b = self.problem.backoff
        factors = (
            (1 + b, 1 + b / 2, 1 + b / 8, 1 + 2 * b) if b else (1.001, 1.01, 1.05, 1.2)
        )
        for factor in factors:
            self.lmi.set_parameter("g_max", g_opt * factor**2)
            for w_max in (w_star, 1e3 * w_star):
                self.lmi.set_parameter("w_max", w_max)
                sol = self.solve("center", _minus_t)
                point = self.accept(sol, f"back-off x{factor:g} (w_max {w_max:.3g})")
                if point is not None:
                    return point
        if raw_design is not None:
            self.notes.append("back-off: no certified point; the raw optimum is kept")
            self.lmi.set_parameter("g_max", g_opt * (1 + 1e-9))
        return raw_design

    # -- verification ----------------------------------------------------
    def _reached(self, value, text) -> None:
        value = np.inf if value is None else value
        if self.best is None or value < self.best[0]:
            self.best = (value, text)

    def accept(self, sol, label, final=False, frame=None):
        """A verified `~ctrl_lpv.synthesis.points.Point`, or None with a note.

        A gain bound is checked on the `final` point only (the gain stage
        starts from points above it).
        """
        if sol is None or not sol.certified:
            return None
        started = time.perf_counter()
        point, failed = check_point(
            self.problem, self.shape, frame or self.frame, sol, self.settings,
            self.lmi.margin, final or self.problem.gain_limit is None,
        )  # fmt: skip
        self.verifying += time.perf_counter() - started
        if point is None:
            self.notes.append(f"{label}: {failed}")
            return None
        problem = self.problem
        value = point.value if problem.objective is not None else None
        described = "".join(
            f", {s} {v:.6g}" for s, v in zip(problem.bound_specs, point.bounds)
        )
        text = f"a certified point ({label}){described}"
        worst = max((np.linalg.norm(K, 2) for K in point.gains), default=0.0)
        self._reached(value, f"{text}, gain norm {worst:.4g}")
        budget.reached(text, value)
        return point


def _g0(v):
    return v.g0[0, 0]


def _minus_t(v):
    return -v.t[0, 0]


def _called_infeasible(attempts) -> bool:
    """Whether a solver called a stage's LMIs infeasible (verified or not)."""
    return any(a.status.startswith("infeasible") for a in attempts)
