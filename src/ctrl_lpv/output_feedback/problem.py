"""What the output-feedback problem supplies to the stages: its LMIs, the
controller rebuilt from a point, and the closed-loop certificate.

`build` poses the LMIs on one `~ctrl_lpv.lmi.LMIProblem` from the specs
(`ctrl_lpv.output_feedback.objectives`, `.regions`, `.mixed`, read through
the `~ctrl_lpv.synthesis.spec.Spec` protocol with the views of
`ctrl_lpv.output_feedback.views`) and what is output feedback's own: the
Lyapunov pair ``[[X, I], [I, Y]] > 0``, the controller variables after the
change of variables, and the back-off stage's conditioning of ``I - X Y``.
`rebuild` turns a point into vertex controllers (`ctrl_lpv.output_feedback.
reconstruct`) and `certified` certifies them on the closed loop
(`ctrl_lpv.output_feedback.checks`): with the rebuilt Lyapunov matrix, or
where that fails or certifies more than the limit, with the closed loop's
own least bound found from it (`closed_loop_analysis`). The stages that
call them are the hook output feedback supplies to the engine's ladder
(`ctrl_lpv.output_feedback.stages`).
"""

from __future__ import annotations

import numpy as np

from ..exceptions import CertificationError
from ..lmi import LMIProblem
from . import lmis
from .checks import closed_loop_analysis, closed_loop_certificate
from .reconstruct import closed_loop_lyapunov, controller_matrices, factor
from .results import OutputFeedbackDesign
from .views import VertexTerms, declare_specs

__all__ = ["build", "rebuild", "certified"]

#: Beyond eig(X Y) >= 100, I - X Y is as well conditioned as X and Y.
_MU_MAX = 10.0


def build(plant, objective, scheduled, margin, weigh=True):
    n, N = plant.n, plant.nvertices
    m, p = plant.B2.shape[1], plant.C2.shape[0]
    scale = max(
        np.linalg.norm(np.block([[plant.A[j], plant.B1[j]],
                                 [plant.C1[j], plant.D11[j]]]), 2)
        for j in range(N)
    )  # fmt: skip
    lmi = LMIProblem(margin=margin * max(scale, 1.0))
    lmi.variable("X", (n, n), symmetric=True)
    lmi.variable("Y", (n, n), symmetric=True)
    declare_specs(lmi, plant, objective.parts())
    for k in range(N if scheduled else 1):
        lmi.variable(f"Ah{k}", (n, n))
        lmi.variable(f"Bh{k}", (n, p))
        lmi.variable(f"Ch{k}", (m, n))
        if objective.proper:
            lmi.variable(f"Dh{k}", (m, p))
    zero = np.zeros((m, p))

    def hats(v, j):
        k = j if scheduled else 0
        Dh = getattr(v, f"Dh{k}") if objective.proper else zero
        return (getattr(v, f"Ah{k}"), getattr(v, f"Bh{k}"), getattr(v, f"Ch{k}"), Dh)

    lmi.add("[[X, I], [I, Y]] > 0", lmis.lyapunov_pair)
    # The back-off stage adds a decay margin relative to P (see
    # `ctrl_lpv.output_feedback.lmis`), so that the rebuilt loop certifies.
    lmi.parameter("decay", value=0.0, nonneg=True)
    # The margin of strict LMIs is absolute. Relative to the data's largest
    # norm it would tighten the -gamma I blocks of the performance channels
    # by a large fraction of gamma on a stiff plant (fast weights: scale
    # 4e4, gamma near 1 on the LPVTools spinning disks, whose optimum came
    # out 10 % high at vertex (9, 25), and whose polytopic design was
    # refused). Instead each performance LMI is posed after the congruence
    # diag(I / w, I) on its state and performance blocks (w a power of two
    # with w^2 ~ scale: the same inequality, exactly), so that all its
    # blocks are of order one, with the margin relative to that.
    weight = 2.0 ** np.round(0.5 * np.log2(max(scale, 1.0))) if weigh else 1.0
    lmi.margin = margin * max(scale / weight**2, 1.0)
    for j in range(N):
        for part in objective.parts():
            t = VertexTerms(plant, j, hats)
            for name, blocks, perf in part.lmis(t, plant.continuous):
                lmi.add(name, _weighted(blocks, perf, weight))
    # The back-off stage: the level within the back-off, and eig(X Y) >=
    # mu^2 pushed up (``[[X, mu I], [mu I, Y]] >= 0``, linear in mu): I - X Y
    # then has no eigenvalue in (1 - mu^2, 0], whatever the scale of X, Y.
    lmi.parameter("level_max", value=1.0)
    lmi.variable("mu", (1, 1), symmetric=True)
    lmi.add("level <= (1 + backoff) level_opt",
            lambda v: [[v.level - v.level_max]], strict=False,
            stages=["center"])  # fmt: skip
    eye = np.eye(n)
    lmi.add("[[X, mu I], [mu I, Y]] >= 0",
            lambda v: [[-v.X], [-v.mu * eye, -v.Y]],
            strict=False, stages=["center"])  # fmt: skip
    lmi.add("mu <= mu_max", lambda v: [[v.mu - _MU_MAX]], strict=False,
            stages=["center"], normalization=True)  # fmt: skip
    return lmi, hats, weight


def _weighted(blocks, perf, w):
    """`blocks` after the congruence that divides the block rows and columns
    not in `perf` (the state blocks) by `w` (exact for a power of two)."""
    if w == 1.0:
        return blocks

    def weighted(v):
        out = []
        rows = blocks(v)
        d = [1.0 if i in perf else 1.0 / w for i in range(len(rows))]
        for i, row in enumerate(rows):
            out.append([
                b if isinstance(b, (int, float)) and b == 0
                else b * (d[i] * d[k])
                for k, b in enumerate(row)
            ])  # fmt: skip
        return out

    return weighted


def rebuild(plant, prescaling, objective, point, hats, bound_opt, bounds, analysis):
    """The controllers rebuilt from `point` (a point of the prescaled
    problem), mapped back to `plant` and certified on its closed loop."""
    X, Y = point.X, point.Y
    target, limit = bounds
    try:
        factors = factor(X, Y)
    except np.linalg.LinAlgError:
        raise CertificationError(
            "output feedback: I - X Y is singular at the solver's point; "
            "no controller can be rebuilt (try a larger backoff)",
            point.attempts,
        ) from None
    v = _Values(point.values)
    scaled = prescaling.apply(plant)
    controllers = tuple(
        prescaling.controller(controller_matrices(scaled, j, X, Y, hats(v, j), factors))
        for j in range(plant.nvertices)
    )
    P = prescaling.lyapunov(closed_loop_lyapunov(X, Y, factors))
    values = dict(point.values, level=objective.level(target))
    condition = float(np.linalg.cond(np.eye(plant.n) - X @ Y))
    return certified(plant, objective, controllers, P, values, bound_opt, limit,
                      analysis, condition, point.attempts)  # fmt: skip


def certified(plant, objective, controllers, P, values, bound_opt, limit,
               analysis, condition, attempts=()):  # fmt: skip
    """`OutputFeedbackDesign` if the closed loop certifies within `limit`."""
    certificate = closed_loop_certificate(plant, objective, controllers, P, values)
    bound = objective.bound(values["level"])
    if not certificate.verified or bound > limit:
        # The rebuilt P is exact but ill-conditioned (its slack scales with
        # 1 / ||Pi1||^2), or it certifies the point's own level, above the
        # limit (a back-off stage's point that did not converge): the closed
        # loop's own Lyapunov matrix instead, from the rebuilt one.
        try:
            found = closed_loop_analysis(plant, objective, controllers, *analysis, P=P)
        except CertificationError:
            if not certificate.verified:
                raise
            found = None
        if found is not None:
            other = closed_loop_certificate(plant, objective, controllers, *found)
            better = objective.bound(found[1]["level"])
            if not certificate.verified or (other.verified and better < bound):
                (P, values), certificate, bound = found, other, better
    if bound > limit:
        # The point's own bound (certified at a margin above the nominal
        # one), or what the rebuilt controller keeps of it after rounding
        # through an ill-conditioned I - X Y, exceeds the back-off.
        raise CertificationError(
            f"output feedback: the rebuilt controller certifies an "
            f"{objective.name} bound of {bound:.6g}, above {limit:.6g} (I - X Y "
            f"has condition {condition:.3g})",
            attempts,
        )
    if not certificate.verified:
        worst = certificate.worst
        raise CertificationError(
            f"output feedback: the rebuilt controller failed its closed-loop "
            f"certificate at {objective.name} bound {bound:.6g}: {worst.what} at "
            f"{worst.where} ({worst.value:.3g} against {worst.bound:.3g})",
            attempts,
        )
    return OutputFeedbackDesign(
        plant=plant,
        objective=objective.spec(plant),
        limits=tuple(c.spec for c in objective.constraints if hasattr(c, "spec")),
        controllers=controllers,
        gamma=bound,
        gamma_opt=bound_opt,
        P=P,
        values=values,
        certificate=certificate,
        condition=condition,
    )


class _Values:
    def __init__(self, values):
        self.__dict__.update(values)
