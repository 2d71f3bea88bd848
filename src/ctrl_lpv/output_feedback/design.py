"""Output feedback for polytopic LPV plants: the design.

Two stages on one `ctrl_lpv.lmi.LMIProblem` (the certified LMI layer of the
library; every point is checked in float64 before it is used), for any
objective of `ctrl_lpv.output_feedback.objectives`:

``optimal``
    minimise the objective's level subject to its LMIs at every vertex and
    ``[[X, I], [I, Y]] > 0`` (`ctrl_lpv.output_feedback.lmis`);
``center``
    with the bound at most ``(1 + 0.9 backoff)`` times the optimum, maximise
    ``mu`` with ``[[X, mu I], [mu I, Y]] >= 0`` and the Lyapunov part
    tightened by a decay margin. At the optimum ``I - X Y`` is nearly
    singular and the rebuilt controller has huge, ill-conditioned
    matrices; this stage buys a well-conditioned ``M N' = I - X Y`` with
    the back-off, as LPVTools' ``lpvsyn`` does with its default 1.2.

The LMIs, the controller rebuilt from a point and its closed-loop
certificate are what the problem supplies (`ctrl_lpv.output_feedback.
problem`, from the specs through the `~ctrl_lpv.synthesis.spec.Spec`
protocol); this module holds the stages, the renormalisation and the
prescalings around them, and the refusal in the engine's format
(`ctrl_lpv.synthesis.refusals`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import budget
from .._checks import real_number
from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..exceptions import CertificationError, InfeasibleError
from ..lmi import default_solvers, solver_chain
from ..stabilizability import _vertex_modes, check_stabilizability
from ..synthesis.refusals import refusal
from ..synthesis.scaling import pow2
from ..systems import PolytopicStateSpace
from .fixed_modes import describe, slow_fixed_modes
from .mixed import output_feedback_constraints
from .objectives import H2Objective, HinfObjective
from .plant import OutputFeedbackPlant
from .prescale import Prescaling, prescalings
from .problem import build, certified, rebuild
from .results import OutputFeedbackDesign

__all__ = ["hinf_output_feedback", "h2_output_feedback"]


@time_budget
def hinf_output_feedback(
    sys: PolytopicStateSpace,
    w,
    u,
    z,
    y,
    *,
    gains: str = "scheduled",
    constraints=(),
    backoff: float | None = 0.2,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> OutputFeedbackDesign:
    """Certified H-infinity dynamic output feedback of a polytopic plant."""
    return _output_feedback(HinfObjective, sys, w, u, z, y, gains, constraints,
                            backoff, margin, solvers)  # fmt: skip


@time_budget
def h2_output_feedback(
    sys: PolytopicStateSpace,
    w,
    u,
    z,
    y,
    *,
    gains: str = "scheduled",
    constraints=(),
    backoff: float | None = 0.2,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> OutputFeedbackDesign:
    """Certified H2 dynamic output feedback of a polytopic plant."""
    return _output_feedback(H2Objective, sys, w, u, z, y, gains, constraints,
                            backoff, margin, solvers)  # fmt: skip


# One parameter description for both objectives (numpydoc, as rendered).
_PARAMETERS = """\
    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant; ``B2, C2, D12, D21`` (the rows and columns of `u` and
        `y`) must not depend on the parameter and ``D22 = 0``.
    w, u : str, int or list
        Exogenous and control inputs (`w` None: every other input).
    z, y : str, int or list
        Performance and measured outputs (`z` None: every other output).
    gains : {"scheduled", "common"}, optional
        One controller per vertex scheduled with the parameter (default),
        or one LTI controller (only when ``A`` does not depend on the
        parameter: otherwise the problem is not convex).
    constraints : sequence of pole regions and bounds, optional
        `ctrl_lpv.regions.halfplane`, `~ctrl_lpv.regions.disk`,
        `~ctrl_lpv.regions.sector` (or `ctrl_lpv.PoleRegion`): every frozen
        closed-loop eigenvalue in each (discrete time: disks inside the
        unit circle); `ctrl_lpv.Hinf` or `ctrl_lpv.H2` specs with a
        ``bound`` on their own channel ``w -> z`` (a mixed design). All
        share the objective's Lyapunov pair (Scherer, Gahinet and Chilali
        1997).
    backoff : float or None, optional
        Relax the minimum bound by this fraction (default 0.2) and maximise
        the conditioning of the Lyapunov pair for a well-conditioned
        controller. None or 0: the raw optimum, or if its rebuilt
        controller does not certify at the optimum (``I - X Y`` too close
        to singular) the least of the back-offs 1e-5, 1e-4 and 5e-4 that
        does (the optimum's own controller when its certified bound fits
        in it).
    margin : float, optional
        Margin of the strict LMIs relative to the data's norm (default
        1e-6).
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn;
        default Clarabel, then SCS (then CVXOPT and MOSEK if installed).
    time_limit : float or None, optional
        Wall-time budget in seconds (default 600; None for no limit).

    Returns
    -------
    `OutputFeedbackDesign`
        ``.gamma`` the certified bound, ``.gamma_opt`` the optimum's
        estimate, ``.controller()`` the controller I/O system,
        ``.closed_loop(p)`` the frozen closed loop, ``.certificate``.

    Raises
    ------
    ValueError, TypeError
        For arguments that do not fit the plant (named), a parameter-
        dependent ``B2, C2, D12`` or ``D21`` or a nonzero ``D22``.
    InfeasibleError
        A vertex that is not stabilizable from `u` or not detectable from
        `y` (continuous time), or a verified proof that no controller of
        this form exists.
    CertificationError
        If no design passed its float64 certificate.

"""
hinf_output_feedback.__doc__ = (
    """\
Certified H-infinity dynamic output feedback of a polytopic plant.

    A full-order controller ``xk' = Ak(p) xk + Bk(p) y``, ``u = Ck(p) xk +
    Dk(p) y`` (continuous or discrete time, as the plant) that minimises
    the bound on the L2 gain (H-infinity norm) from `w` to `z` for every
    parameter trajectory in the polytope: one Lyapunov pair ``(X, Y)``,
    one controller per vertex interpolated with the plant's convex
    coordinates (Apkarian, Gahinet and Becker 1995), the change of
    variables of Scherer, Gahinet and Chilali (1997).

"""
    + _PARAMETERS
    + """    Examples
    --------
    >>> import control as ct
    >>> import ctrl_lpv as lpv
    >>> G = ct.ss([[0.0, 1.0], [-1.0, 0.5]], [[0.0, 0.0], [1.0, 1.0]],
    ...           [[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]],
    ...           [[0.0, 0.0], [0.0, 1.0], [0.1, 0.0]],
    ...           inputs=["w", "u"], outputs=["z1", "z2", "y"])
    >>> d = lpv.hinf_output_feedback(lpv.pss([G]), "w", "u", ["z1", "z2"], "y")
    >>> d.certificate.verified and d.gamma >= float(ct.linfnorm(d.closed_loop())[0])
    True
"""
)
h2_output_feedback.__doc__ = (
    """\
Certified H2 dynamic output feedback of a polytopic plant.

    A strictly proper full-order controller ``xk' = Ak(p) xk + Bk(p) y``,
    ``u = Ck(p) xk`` (continuous or discrete time, as the plant) that
    minimises the bound on the H2 norm from `w` to `z` at every frozen
    parameter value (the plant needs ``D11 = 0``): one Lyapunov pair ``(X,
    Y)``, one controller per vertex interpolated with the plant's convex
    coordinates (Apkarian, Gahinet and Becker 1995), the change of
    variables of Scherer, Gahinet and Chilali (1997).

"""
    + _PARAMETERS
    + """    Examples
    --------
    >>> import control as ct
    >>> import ctrl_lpv as lpv
    >>> G = ct.ss([[0.0, 1.0], [-1.0, 0.5]], [[0.0, 0.0], [1.0, 1.0]],
    ...           [[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]],
    ...           [[0.0, 0.0], [0.0, 1.0], [0.1, 0.0]],
    ...           inputs=["w", "u"], outputs=["z1", "z2", "y"])
    >>> d = lpv.h2_output_feedback(lpv.pss([G]), "w", "u", ["z1", "z2"], "y")
    >>> d.certificate.verified and d.gamma >= float(ct.norm(d.closed_loop(), 2))
    True
"""
)


def _output_feedback(kind, sys, w, u, z, y, gains, constraints, backoff, margin,
                     solvers):  # fmt: skip
    if gains not in ("scheduled", "common"):
        raise ValueError(f"gains: expected 'scheduled' or 'common', got {gains!r}")
    plant = OutputFeedbackPlant.of(sys, w, u, z, y)
    parts, channels = output_feedback_constraints(constraints, sys, u, y,
                                                  plant.continuous)  # fmt: skip
    plant = dataclasses.replace(plant, channels=channels)
    objective = kind(parts)
    for part in objective.parts():
        part.check(plant)
    if gains == "common" and any(not np.array_equal(A, plant.A[0]) for A in plant.A):
        raise ValueError(
            "gains: a common (LTI) output-feedback controller of a plant whose "
            "A depends on the parameter is not a convex problem; use "
            "gains='scheduled'"
        )
    backoff = 0.0 if backoff is None else real_number(backoff, "backoff", minimum=0.0)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    chain = solver_chain(solvers) or default_solvers()
    if plant.continuous:
        _require_stabilizable_detectable(plant)
    settings = (gains == "scheduled", backoff, margin, chain)
    # The prescalings in turn (`ctrl_lpv.output_feedback.prescale`); a
    # refusal in the engine's format (`ctrl_lpv.synthesis.refusals`).
    kinds = prescalings(plant)
    notes, estimates, attempts = [], [], []
    for kind in kinds:
        # One rung per prescaling, logged as the engine's rungs are.
        label = f"{chain[0][0]}, {_PRESCALED[kind]}, margin {margin:g}"
        budget.progress("rung %s", label, rung=label)
        design, failure, bound_opt = _prescaled(plant, objective, kind, settings)
        if design is not None:
            budget.reached(f"a certified point ({label}), {objective.name} "
                           f"{design.gamma:.6g}", design.gamma)  # fmt: skip
            return design
        if not isinstance(failure, CertificationError):
            raise failure
        reason = str(failure).removeprefix("output feedback: ")
        notes.append(f"{_PRESCALED[kind]}: {reason}")
        attempts.extend(failure.attempts)
        if bound_opt is not None:
            estimates.append(bound_opt)
    best = None
    if estimates:
        best = (f"the optimum's estimate, {objective.name} {min(estimates):.6g} "
                "(not certified)")  # fmt: skip
    fixed = slow_fixed_modes(plant)
    # The likely cause, named: such a mode keeps the certificate's slack
    # along it at its own slow rate.
    hint = (f". Slow modes no controller moves: {describe(fixed)}; a quadratic "
            "certificate's slack along them is of the order of their rate "
            "(remedy: move the slow pole into the controller, or a smaller "
            "margin)") if fixed else ""  # fmt: skip
    backoffs = (settings[1], *_RAW_BACKOFFS) if settings[1] else _RAW_BACKOFFS
    tried = (f"{len(kinds)} prescalings ("
             + ", then ".join(_PRESCALED[k] for k in kinds)
             + f"), back-offs {list(backoffs)}, solvers {[n for n, _ in chain]}, "
             f"margin {margin:g}")  # fmt: skip
    raise refusal(f"{objective.label} output feedback", best, notes, tried, attempts,
                  hint)  # fmt: skip


#: How the prescalings of `ctrl_lpv.output_feedback.prescale` are named.
_PRESCALED = {
    "Riccati": "the Riccati-balanced prescaling",
    "none": "the plant's own coordinates",
}


def _prescaled(plant, objective, kind, settings):
    """``(design, None, bound_opt)`` or ``(None, refusal, bound_opt)`` in
    one prescaling (``bound_opt`` the optimum's estimate, or None)."""
    design, failure, bound_opt = _in_units(plant, objective, kind, 1.0, settings)
    if (
        design is None
        and bound_opt is not None
        and not 0.5 <= bound_opt <= 2.0
        and objective.homogeneous
    ):
        # Renormalised so that the bound is near 1 (z scaled by s, a power
        # of two as the engine's `Rung._normalise`: exact, the controllers
        # the same, the bound scaled by s): then certified again on the
        # plant itself.
        scale = 1.0 / pow2(bound_opt)
        budget.progress("renormalised: z scaled by %g", scale)
        design, _, _ = _in_units(plant, objective, kind, scale, settings,
                                 bound_opt)  # fmt: skip
    return design, None if design is not None else failure, bound_opt


def _in_units(plant, objective, kind, scale, settings, known=None):
    """`_solve` on `plant` with ``z`` scaled by `scale`, certified on `plant`.

    ``(design, refusal, bound_opt)``, the optimum in the plant's units;
    the design's bound is limited relative to the `known` optimum (that of
    an earlier solve) when there is one.
    """
    if scale == 1.0:
        return _solve(plant, kind, objective, *settings)
    _, backoff, margin, chain = settings
    scaled, failure, bound_opt = _solve(plant.scaled(scale), kind, objective,
                                        *settings)  # fmt: skip
    bound_opt = None if bound_opt is None else bound_opt / scale
    if scaled is None:
        return None, failure, bound_opt
    P, values = objective.rescaled(scaled.P, scaled.values, scale)
    limit = (1.0 + backoff) * (known or bound_opt) * (1.0 + 1e-3)
    try:
        design = certified(plant, objective, scaled.controllers, P, values,
                            scaled.gamma_opt / scale, limit,
                            (margin, chain[:1]), scaled.condition)  # fmt: skip
    except CertificationError as exc:
        return None, exc, bound_opt
    return design, None, bound_opt


def _solve(plant, kind, objective, scheduled, backoff, margin, chain):
    """``(design, None, bound_opt)``, or ``(None, refusal, bound_opt)``.

    The LMIs are posed on `plant` prescaled (`kind`, computed on `plant`,
    whose ``z`` may have been scaled: that moves the balance of ``X`` and
    ``Y``); the design is certified on `plant` itself.
    """
    prescaling = Prescaling.of(kind, plant)
    scaled = prescaling.apply(plant)
    rate = max(np.linalg.norm(A, 2) for A in scaled.A) if plant.continuous else 1.0
    # The performance LMIs weighed against the state blocks first (see
    # `problem.build`); if the solvers fail on them (the weight assumes a bound
    # near 1: a large bound unbalances them the other way), as posed before.
    for weigh in (True, False):
        lmi, hats, weight = build(scaled, objective, scheduled, margin, weigh)
        # A trace term far below the solver's tolerance on the level keeps X
        # and Y bounded in the directions the bound does not constrain (there
        # the central path drifts to 1e5 and the solve ends inaccurate).
        try:
            optimal = lmi.solve(
                lambda v: (
                    v.level[0, 0] + _TRACE_WEIGHT * (np.trace(v.X) + np.trace(v.Y))
                ),
                stage="optimal",
                solvers=chain,
            )
            break
        except CertificationError as exc:
            if not weigh or weight == 1.0:
                return None, exc, None
    # The solver's point at the nominal margin, when only a larger margin
    # certified, is the better estimate of the optimum.
    bound_opt = objective.bound((optimal.nominal or optimal).level[0, 0])
    # The raw optimum's I - X Y is often too close to singular for the
    # rebuilt controller to certify: then the smallest back-off that does.
    # When the back-off stage itself fails (badly scaled data), the same
    # sequence, within the back-off asked for.
    failure = None
    raw = backoff == 0
    # backoff=None: the optimum's own controller often certifies a little
    # above the optimum estimate (rounding through a nearly singular
    # I - X Y). It is held, and returned as the answer of the first
    # back-off it fits in: a back-off stage b certifies at (1 + b) times
    # the estimate, no better (and at 1e-5 the stage is often too hard for
    # the solvers, which then sent the design to the less accurate
    # renormalised solve).
    held = None
    for b in (backoff, *_RAW_BACKOFFS) if backoff > 0 else _RAW_BACKOFFS:
        if held is not None and held.gamma <= (1.0 + b) * bound_opt * (1.0 + 1e-6):
            return held, None, bound_opt
        # The decay margin is relative to the data's fastest rate: too much
        # for a stiff plant, then the back-off stage is tried without it.
        for decay in (_DECAY * b * rate, 0.0) if b else (0.0,):
            try:
                point = _point(lmi, objective, optimal, b, bound_opt, decay, chain)
                bmax = _RAW_BACKOFFS[-1] if raw and b == 0 else max(b, backoff)
                limit = (1.0 + bmax) * bound_opt * (1.0 + 1e-6)
                target = max((1.0 + b) * bound_opt,
                             objective.bound(point.level[0, 0]))  # fmt: skip
                design = rebuild(plant, prescaling, objective, point, hats,
                                 bound_opt, (target, limit),
                                 (margin, chain[:1]))  # fmt: skip
                if raw and b == 0 and design.gamma > bound_opt * (1.0 + 1e-6):
                    held = design
                    continue
                return design, None, bound_opt
            except CertificationError as exc:
                failure = exc
    if held is not None:
        return held, None, bound_opt
    return None, failure, bound_opt


def _point(lmi, objective, optimal, b, bound_opt, decay, chain):
    """The optimal point (``b = 0``) or the back-off stage's.

    The back-off stage only chooses a better point: a proof that its LMIs
    are infeasible (they add a decay margin and a bound on the level) says
    nothing of the design problem, so it is not a refusal of the design.
    """
    if b == 0:
        return optimal
    # Solved a little inside the bound it is certified at: the gap is the
    # closed loop's slack after the reconstruction.
    lmi.set_parameter("level_max", objective.level((1.0 + _INSIDE * b) * bound_opt))
    lmi.set_parameter("decay", decay)
    try:
        # The first solver only: this stage chooses a better point, and the
        # fallbacks (SCS to 1e-9) cost minutes at n = 8 for a point that the
        # next back-off or the optimal point may give as well.
        return lmi.solve(lambda v: -v.mu[0, 0], stage="center", solvers=chain[:1])
    except InfeasibleError as exc:
        raise CertificationError(
            f"output feedback: the back-off stage at {b:g} is infeasible ({exc})",
            exc.attempts,
        ) from None


_TRACE_WEIGHT = 1e-7
#: Decay margin of the back-off stage per unit back-off, relative to the
#: data's rate (``max ||A_j||`` in continuous time, 1 in discrete time).
_DECAY = 0.1

#: The back-off stage solves at ``(1 + _INSIDE backoff)`` times the optimum.
_INSIDE = 0.9

#: Back-offs tried in turn for ``backoff=None``: the raw optimum, then the
#: least relaxation whose controller certifies.
_RAW_BACKOFFS = (0.0, 1e-5, 1e-4, 5e-4)


def _require_stabilizable_detectable(plant):
    """PBH tests at every vertex: stabilizable from u, detectable from y."""
    sys = plant.system
    check_stabilizability(sys, list(plant.u))
    for j, A in enumerate(plant.A):
        # Detectability of (C2, A) is stabilizability of (A', C2').
        for found in _vertex_modes(A.T, plant.C2.T, sys.state_labels, j):
            if found.uncontrollable:
                raise InfeasibleError(
                    f"vertex {j} is not detectable: the mode with eigenvalue "
                    f"{found.eigenvalue:.6g} is unobservable from y = "
                    f"{plant.names('y')} (PBH residual {found.residual:.1e}, "
                    "relative); no controller reading y stabilizes it"
                )
