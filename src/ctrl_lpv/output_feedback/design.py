"""Output feedback for polytopic LPV plants: the design.

The public calls: the arguments checked, the plant partitioned into
``w, u, z, y``, the objective and its constraints as specs
(`ctrl_lpv.output_feedback.objectives`, `.mixed`), then the engine's
ladder (`ctrl_lpv.synthesis.hooked.ladder`) over the stages output
feedback supplies (`ctrl_lpv.output_feedback.stages`: prescalings, the
optimal and back-off stages on the LMIs of `ctrl_lpv.output_feedback.
problem`, the controller rebuilt and certified on the closed loop). A
refusal is in the engine's format (`ctrl_lpv.synthesis.refusals`).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .._checks import real_number
from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..exceptions import InfeasibleError
from ..lmi import default_solvers, solver_chain
from ..stabilizability import _vertex_modes, check_stabilizability
from ..synthesis.hooked import ladder
from ..systems import PolytopicStateSpace
from .mixed import output_feedback_constraints
from .objectives import H2Objective, HinfObjective
from .plant import OutputFeedbackPlant
from .prescale import prescalings
from .problem import rebuild
from .results import OutputFeedbackDesign
from .stages import OutputFeedbackStages

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
    started = time.perf_counter()
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
    # The engine's ladder over the rungs output feedback supplies
    # (`ctrl_lpv.output_feedback.stages`); `prescalings` and `rebuild` are
    # read here, at the call.
    hook = OutputFeedbackStages(plant, objective, gains == "scheduled", backoff,
                                margin, chain, prescalings(plant), rebuild)  # fmt: skip
    return ladder(hook, started)


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
