"""The gain steps of a rung: the smallest gain, the convex-concave steps.

A mixin of `~ctrl_lpv.synthesis.stages.Rung` (its problem, frame, LMIs,
`solve` and `accept`). The gain ``K = -Z X^-1`` is bounded through the
tangent linearisation of ``(T X)'(T X)`` (sufficient everywhere, exact at
the linearisation point; `~ctrl_lpv.synthesis.problem.gain_tangent_blocks`):
at a point of the margin's order for the smallest gain ("gain", prescaled
units), at the previous point for a convex-concave step ("bounded", the
model's units, which a `GainBound` imposes; the default back-off's one
step from the optimum).
"""

from __future__ import annotations

import numpy as np

# Convex-concave steps under a gain bound, and the relative decrease of
# the squared gain below which they stop.
GAIN_ITERATIONS = 4
GAIN_RTOL = 0.05
# W <= w_max I far above a point's W, where W is free (scaled units).
W_SPAN = 1e6
# The same for the default back-off's one step from the optimum: the same
# point in fewer iterations (measured at n = 8, N = 16: 29 Clarabel
# iterations against 39, and 24 for the optimum itself). W_SPAN stays for
# the steps under a gain bound and the refine step, whose points it sets
# (the servo's designs were measured with it).
STEP_SPAN = 1e2
# Clarabel's duality-gap tolerances (absolute and relative) for that step:
# its point is a heuristic one, verified in float64 like any other, so the
# digits of kappa below this buy nothing; its last iterations bought them
# (measured on random polytopes at N = 16, n = 4/8/8/12/12: 27/29/31/35/32
# iterations with its default 1e-8, 24/27/29/32/29 with this; the largest
# gain within 6e-5 relative).
STEP_GAP_TOL = 1e-5
W_FREE = 1e6


class GainSteps:
    """The gain steps (see the module docstring)."""

    def _smallest_gain(self, proof=False):
        """One solve of the smallest gain under the stage's bounds.

        The squared prescaled gain norm is bounded by its tangent
        linearisation at ``W0 = 2 margin I`` (`_tangent`): sufficient
        everywhere, exact at ``W0``, its domain ``W >= margin I`` (what the
        strict ``W > 0`` asks anyway). Far above ``W0`` it bounds the gain
        on the Lyapunov ellipsoid, which a larger ``W`` relaxes: the
        minimisation keeps ``W`` large and well conditioned and the gain
        small, with ``W`` free (``W <= w_max I`` far above). Returns the
        verified point, or None.
        """
        if not self.structure.nZ:
            return None
        self.lmi.set_parameter("w_max", W_FREE)
        self._tangent(2 * self.margin * np.eye(self.structure.n))
        sol = self.solve("gain", _kappa, proof=proof)
        return self.accept(sol, "back-off (smallest gain)")

    def _tangent(self, W0, kappa0=None) -> None:
        """Set the tangent bound's parameters (see
        `~ctrl_lpv.synthesis.problem.gain_tangent_blocks`).

        With `kappa0` (the squared gain at the previous point, whose
        scaled ``W`` is `W0`; ``kappa`` is relative to it): the "bounded"
        stage's bound in the model's units, capped at the previous gain
        and a gain bound. Without: the "gain" stage's bound of the
        prescaled gain at ``W0 = w0 I``, whose domain is ``W >= w0 / 2``.
        """
        n = W0.shape[0]
        if kappa0 is None:
            w0 = float(np.linalg.eigvalsh(W0)[-1])
            H, C, HK = np.eye(n), w0 * np.eye(n), np.eye(n)
        else:
            H, C = np.linalg.inv(self.frame.scaling.matrix @ W0), np.eye(n)
            HK = H / np.sqrt(kappa0)
            limit = self.problem.gain_limit
            ratio = 1.0 if limit is None else min(limit / np.sqrt(kappa0), 1.0)
            self.lmi.set_parameter("kappa_max", ratio**2)
        for name, value in (("gain_H", H), ("gain_C", C), ("gain_HK", HK)):
            self.lmi.set_parameter(name, value)

    def _gain_bound(self, best, gamma_opt, refine=False):
        """Convex-concave steps of the gain norm from a certified point.

        Each linearises ``||K_k||^2 <= kappa`` (model units) at the
        previous point (exact there, sufficient everywhere) and re-solves:
        one step to `refine` a back-off point, and under a gain bound until
        the squared gain improves by less than `GAIN_RTOL` (a design whose
        gain stays above the bound is not returned).
        """
        limit = self.problem.gain_limit
        steps = GAIN_ITERATIONS if limit is not None else int(refine)
        for _ in range(steps):
            candidate = self._gain_step(best)
            if candidate is None:
                break
            best = candidate
            if float(candidate.solution.kappa[0, 0]) > 1 - GAIN_RTOL:
                break
        if limit is None:
            return best, gamma_opt
        worst = max(np.linalg.norm(K, 2) for K in best.gains)
        if worst > limit:
            self.gain_short = True
            self.notes.append(
                f"final point: gain norm {worst:.4g} above the bound (gain_bound "
                f"{limit:g})"
            )
            return None
        final = self.accept(best.solution, "final point", final=True, frame=best.frame)
        return None if final is None else (final, gamma_opt)

    def _gain_step(self, point, label="gain stage", span=W_SPAN, gap_tol=None):
        """One convex-concave step of the gain norm from a certified point.

        ``||K_k||^2 <= kappa ||K(point)||^2`` (model units) linearised at
        the point's ``W`` (exact there, so the point itself is feasible,
        ``kappa <= 1``); the verified result, or None. `gap_tol`, if given,
        is Clarabel's duality-gap tolerance for this solve.
        """
        if not self.structure.nZ:
            return None
        kappa0 = max(float(np.linalg.norm(K, 2)) ** 2 for K in point.gains)
        if kappa0 == 0.0:
            return None
        W0 = _W(point)
        # No bound on W here (W <= w_max I far above the point's).
        self.lmi.set_parameter("w_max", span * float(np.linalg.eigvalsh(W0)[-1]))
        self._tangent(W0, kappa0)
        chain = self.chain
        if gap_tol is not None:
            self.chain = _with_gap_tol(chain, gap_tol)
        try:
            sol = self.solve("bounded", _kappa)
        finally:
            self.chain = chain
        return self.accept(sol, label)


def _with_gap_tol(chain, tol):
    """`chain` with Clarabel's duality-gap tolerances set to `tol`."""
    loose = {"tol_gap_abs": tol, "tol_gap_rel": tol}
    return [
        (name, {**options, **loose} if name.upper() == "CLARABEL" else options)
        for name, options in chain
    ]


def _W(point):
    """A point's constant ``W`` (prescaled units)."""
    return point.solution.W0


def _kappa(v):
    return v.kappa[0, 0]
