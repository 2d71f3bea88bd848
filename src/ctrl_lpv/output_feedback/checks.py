"""The certificate of an output-feedback design, on the closed loop itself.

The LMI checks of the solver's point (`ctrl_lpv.lmi.LMIProblem`) prove the
transformed inequalities; what runs is the controller rebuilt from them, so
the certificate is recomputed from the returned controller matrices: ``P``
from ``(X, Y, M, N)``, then at every vertex the objective's closed-loop
inequalities (`ctrl_lpv.output_feedback.objectives`) and ``P > 0``, each by
the library's rounding-aware `ctrl_lpv.certificate.negative_definite`.
Because the plant's ``B2, C2, D12, D21`` do not depend on the parameter and
the controller is interpolated with the plant's convex coordinates, the
closed loop is affine in them: the vertex inequalities with one ``P`` hold
on the whole polytope. Frozen norms from python-control at the verification
points cross-check the bound.
"""

from __future__ import annotations

import control as ct
import numpy as np
from scipy.linalg import matrix_balance

from ..certificate import Certificate, Check, negative_definite, rounding_bound
from ..exceptions import CertificationError
from ..lmi import LMIProblem
from ..synthesis.frozen import verification_points
from ..synthesis.results import residual_check
from .reconstruct import closed_loop
from .views import FrozenLoop, declare_specs

__all__ = ["closed_loop_certificate", "closed_loop_analysis", "frozen_residuals"]


def closed_loop_certificate(plant, objective, controllers, P, values) -> Certificate:
    """Float64 checks that the vertex controllers meet the objective's bound
    (and its constraints: pole regions, bounds of other channels).

    `values` holds ``"level"`` and the objective's other variables at the
    point (e.g. the H2 bounds ``Q_j``).
    """
    loops = _part_loops(plant, objective, controllers)
    checks = [negative_definite(-P, what="P > 0", where="closed loop", group="LMI")]
    for part, its in loops.items():
        for j, loop in enumerate(its):
            checks += part.loop_checks(loop, P, values, j, plant.continuous)
    if not all(c.passed for c in checks):
        # An ill-conditioned P (a slow mode that no controller moves, e.g. a
        # weight's pole unobservable from y, beside fast ones) leaves a
        # slack far below the rounding of the check in these coordinates:
        # the same certificate in the coordinates where P is about I.
        normalised = _normalised_checks(plant, objective, loops, P, values)
        if normalised is not None and all(c.passed for c in normalised):
            checks = normalised
    bound = objective.bound(values["level"])
    checks.append(frozen_norms(plant, objective, controllers, bound))
    checks += frozen_residuals(plant, objective, controllers, P, values)
    checks += [c.frozen_check(plant, controllers) for c in objective.constraints]
    return Certificate(tuple(checks), statement=objective.statement(bound))


#: Solves of the analysis in the rebuilt P's coordinates, each at the margin
#: the previous one's certificate asked for (times `_MARGIN_GROWTH`).
_ANALYSIS_SOLVES = 4
_MARGIN_GROWTH = 1.25


def closed_loop_analysis(plant, objective, controllers, margin, chain, P=None):
    """``(P, values)``: the closed loop's own least quadratic bound.

    Used when ``P`` rebuilt from the design's ``(X, Y)`` is too ill-
    conditioned for its float64 check, or certifies too large a bound: the
    objective's LMIs on the closed loop in a fresh ``P`` (size ``2 n``),
    minimising its level.

    With the rebuilt `P` (positive definite), first in the coordinates
    where it is ``I`` (``x = T x~``, `_normalised_checks`): the rebuilt
    point is nearly feasible there, and every block of the LMIs is of order
    one but ``A~``. The margin is then absolute, starting at `margin`, and
    raised to what the certificate of the previous solve asked for
    (`_normalised_checks`; its rounding grows with ``||A~||`` and the
    conditioning of the new P): the least level that certifies. Measured
    on the LPVTools spinning disks (weight poles at -0.04 and -4e4, the
    back-off stage's controller): the balanced coordinates end in a
    numerical error at Clarabel's first iteration, these certify 1.1625 at
    margin 1e-2 (1.2031 with the margin relative to ``||A~|| = 4e4``, as in
    balanced coordinates). Then, or without `P`, in balanced coordinates
    with the margin relative to the data's norm.
    """
    loops = _part_loops(plant, objective, controllers)
    if P is not None:
        found = _analysis_in_p_coordinates(plant, objective, loops, P, margin, chain)
        if found is not None:
            return found
    t = _balancing(loops[objective])
    loops = {part: [_balanced(loop, t) for loop in its] for part, its in loops.items()}
    scale = max(np.linalg.norm(np.block([[A, B], [C, D]]), 2)
                for A, B, C, D in loops[objective])  # fmt: skip
    P, values = _least_level(plant, objective, loops, margin * max(scale, 1.0), chain)
    return P / t[:, None] / t[None, :], values


def _least_level(plant, objective, loops, margin, chain):
    """``(P, values)`` minimising the level of the `loops`' LMIs."""
    n = loops[objective][0][0].shape[0]
    lmi = LMIProblem(margin=margin)
    lmi.variable("P", (n, n), symmetric=True)
    declare_specs(lmi, plant, objective.parts())
    lmi.add("P > 0", lambda v: [[-v.P]])
    for part, its in loops.items():
        for j, loop in enumerate(its):
            for name, blocks in part.loop_lmis(loop, j, plant.continuous):
                lmi.add(name, blocks)
    sol = lmi.solve(lambda v: v.level[0, 0], solvers=chain)
    values = {k: np.asarray(x) for k, x in sol.values.items() if k != "P"}
    values["level"] = float(sol.level[0, 0])
    return sol.P, values


def _analysis_in_p_coordinates(plant, objective, loops, P, margin, chain):
    """`closed_loop_analysis` in the coordinates where `P` is ``I``:
    ``(P, values)`` whose LMI checks pass, or None."""
    factors = _normalising(P)
    if factors is None:
        return None
    R, T = factors
    moved = {part: [(R @ A @ T, R @ B, C @ T, D) for A, B, C, D in its]
             for part, its in loops.items()}  # fmt: skip
    for _ in range(_ANALYSIS_SOLVES):
        try:
            Pt, values = _least_level(plant, objective, moved, margin, chain)
        except CertificationError:
            return None
        found = R.T @ Pt @ R
        found = 0.5 * (found + found.T)
        asked = _lmi_checks_margin(plant, objective, loops, found, values)
        if asked is None:
            return found, values
        if not asked > margin:
            return None  # not the rounding: a larger margin would not help
        margin = _MARGIN_GROWTH * asked
    return None


def _lmi_checks_margin(plant, objective, loops, P, values):
    """None if the closed-loop LMI checks of `closed_loop_certificate` pass
    at ``(P, values)``; else the margin its P-normalised checks ask for (0
    when those do not apply)."""
    checks = [negative_definite(-P, what="P > 0", where="closed loop", group="LMI")]
    for part, its in loops.items():
        for j, loop in enumerate(its):
            checks += part.loop_checks(loop, P, values, j, plant.continuous)
    if all(c.passed for c in checks):
        return None
    normalised = _normalised_checks(plant, objective, loops, P, values)
    if normalised is None:
        return 0.0
    if all(c.passed for c in normalised):
        return None
    return max((-c.bound for c in normalised if c.bound < 0), default=0.0)


def _normalised_checks(plant, objective, loops, P, values):
    """The closed-loop checks in the coordinates ``x = T x~`` where the
    Lyapunov matrix is ``I``, or None if `P` is not positive definite.

    ``P = V diag(s) V'``; ``R = diag(s)^1/2 V'`` and ``T = V diag(s)^-1/2``
    (about ``R^-1``) are float64 matrices. The statement proved is about
    ``P_c = R' R`` and the exact inverse ``R^-1 = T (R T)^-1``: with ``E =
    R T - I``, the loop in the new coordinates is ``(R A T (I + E)^-1, R B,
    C T (I + E)^-1, D)``, and its inequalities with ``P~ = I`` are those of
    the loop with ``P_c`` after the congruence by ``R^-1`` (same inertia).
    The computed ``(R A T, R B, C T)`` differ from it by the rounding of
    the products and by ``||E|| / (1 - ||E||)`` relative: the inequalities
    are checked with that perturbation as their margin (``2 (dA + dB +
    dC)`` bounds its effect on every inequality with ``P~ = I``).
    """
    factors = _normalising(P)
    if factors is None:
        return None
    R, T = factors
    n = P.shape[0]
    E = R @ T - np.eye(n)
    e = _norm2(E) + rounding_bound(n, _norm2(np.abs(R) @ np.abs(T)))
    if not e < 0.5:
        return None
    grow = e / (1.0 - e)
    checks, margin = [], 0.0
    transformed = {}
    for part, its in loops.items():
        transformed[part] = []
        for A, B, C, D in its:
            At, Bt, Ct = R @ A @ T, R @ B, C @ T
            aR, aT = np.abs(R), np.abs(T)
            dA = rounding_bound(n, _norm2(aR @ np.abs(A) @ aT)) + grow * _norm2(At)
            dB = rounding_bound(n, _norm2(aR @ np.abs(B)))
            dC = rounding_bound(n, _norm2(np.abs(C) @ aT)) + grow * _norm2(Ct)
            margin = max(margin, 2.0 * (dA + dB + dC))
            transformed[part].append((At, Bt, Ct, D))
    checks.append(Check("P-normalising coordinates (||R T - I||)", e, 0.5, strict=True,
                        where="closed loop", group="LMI"))  # fmt: skip
    for part, its in transformed.items():
        for j, loop in enumerate(its):
            checks += part.loop_checks(
                loop, np.eye(n), values, j, plant.continuous, margin=margin,
                what=", P-normalised",
            )  # fmt: skip
    return checks


def _normalising(P):
    """``(R, T)`` with ``R' R ~ P`` and ``T ~ R^-1`` (float64, from the
    eigenvectors of `P`), or None if `P` is not positive definite."""
    P = 0.5 * (P + P.T)
    if not np.all(np.isfinite(P)):
        return None
    s, V = np.linalg.eigh(P)
    if not s.min() > 0:
        return None
    return np.sqrt(s)[:, None] * V.T, V / np.sqrt(s)[None, :]


def _norm2(M):
    return float(np.linalg.norm(M, 2))


def _part_loops(plant, objective, controllers) -> dict:
    """The vertex closed loops of each part's channel, by part."""
    return {part: [_vertex_loop(part.plant_of(plant), controllers, j)
                   for j in range(plant.nvertices)]
            for part in objective.parts()}  # fmt: skip


def _vertex_loop(plant, controllers, j):
    e = np.zeros(plant.nvertices)
    e[j] = 1.0
    return closed_loop(plant, plant.data(e), controllers[j])


def _balancing(loops):
    """``diag T`` of balanced state coordinates ``x = T x~`` of the loops.

    A quadratic bound is invariant under a common change of state
    coordinates (``P = T^-T P~ T^-1``), and the reconstruction scales the
    controller's states by orders of magnitude: balancing first keeps the
    solvers accurate.
    """
    _, (t, _) = matrix_balance(sum(np.abs(L[0]) for L in loops), permute=False,
                               separate=True)  # fmt: skip
    return t


def _balanced(loop, t):
    """`loop` in the coordinates ``x = diag(t) x~``."""
    A, B, C, D = loop
    return A * (t[None, :] / t[:, None]), B / t[:, None], C * t[None, :], D


def frozen_residuals(plant, objective, controllers, P, values) -> list[Check]:
    """Cross-checks: each spec's residual (`Spec.residual`) at its worst
    verification point, as the state-feedback engine's frozen checks
    (`ctrl_lpv.synthesis.frozen`): the vertices and points between them,
    where the vertex inequalities claim the closed loop too."""
    worst = {part: (-np.inf, "") for part in objective.parts()}
    for delta, p in verification_points(plant.system):
        loop = FrozenLoop.of(plant, delta, controllers, P, values)
        for part, (value, _) in worst.items():
            residual = part.residual(loop, plant.continuous)
            if not residual <= value:
                point = delta if p is None else p
                worst[part] = (residual, f"p = {np.round(point, 6).tolist()}")
    return [residual_check(f"{part} (frozen closed loop)", value, where,
                           cross_check=True)
            for part, (value, where) in worst.items()]  # fmt: skip


def frozen_norms(plant, objective, controllers, bound, what="") -> Check:
    """Cross-check: the frozen closed loops' norms from python-control."""
    worst, where = -np.inf, ""
    dt = 0 if plant.continuous else plant.system.dt
    for delta, p in verification_points(plant.system):
        K = tuple(np.tensordot(delta, np.array(M), axes=1) for M in zip(*controllers))
        loop = closed_loop(plant, plant.data(delta), K)
        norm = objective.frozen_norm(ct.ss(*loop, dt))
        if not norm <= worst:
            point = delta if p is None else p
            worst, where = norm, f"p = {np.round(point, 6).tolist()}"
    return Check(
        f"frozen {objective.label} norm{what} (python-control)", worst, bound,
        strict=True,
        cross_check=True, where=where, group="frozen",
    )  # fmt: skip
