"""H-infinity output feedback for polytopic LPV plants: the design.

Two stages on one `ctrl_lpv.lmi.LMIProblem` (the certified LMI layer of the
library; every point is checked in float64 before it is used):

``optimal``
    minimise ``gamma`` subject to the bounded-real LMIs at every vertex and
    ``[[X, I], [I, Y]] > 0`` (`ctrl_lpv.output_feedback.lmis`);
``center``
    with ``gamma <= (1 + backoff) gamma_opt`` and ``X, Y <= r I`` (``r``
    the larger norm of the optimal point's ``X, Y``), maximise ``t`` with
    ``[[X, I], [I, Y]] >= t I``. At the optimum ``I - X Y`` is nearly
    singular and the rebuilt controller has huge, ill-conditioned
    matrices; this stage buys a well-conditioned ``M N' = I - X Y`` with
    the back-off, as LPVTools' ``lpvsyn`` does with its default 1.2.

The controller is then rebuilt (`ctrl_lpv.output_feedback.reconstruct`) and
certified on the closed loop (`ctrl_lpv.output_feedback.checks`).
"""

from __future__ import annotations

import numpy as np

from .._checks import real_number
from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..exceptions import CertificationError, InfeasibleError
from ..lmi import LMIProblem, solver_chain
from ..stabilizability import _vertex_modes, check_stabilizability
from ..systems import PolytopicStateSpace
from . import lmis
from .checks import closed_loop_analysis, closed_loop_certificate
from .plant import OutputFeedbackPlant
from .reconstruct import closed_loop_lyapunov, controller_matrices, factor
from .results import OutputFeedbackDesign

__all__ = ["hinf_output_feedback"]


@time_budget
def hinf_output_feedback(
    sys: PolytopicStateSpace,
    w,
    u,
    z,
    y,
    *,
    gains: str = "scheduled",
    backoff: float | None = 0.2,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> OutputFeedbackDesign:
    """Certified H-infinity dynamic output feedback of a polytopic plant.

    A full-order controller ``xk' = Ak(p) xk + Bk(p) y``, ``u = Ck(p) xk +
    Dk(p) y`` (continuous or discrete time, as the plant) that minimises
    the bound on the L2 gain (H-infinity norm) from `w` to `z` for every
    parameter trajectory in the polytope: one Lyapunov pair ``(X, Y)``,
    one controller per vertex interpolated with the plant's convex
    coordinates (Apkarian, Gahinet and Becker 1995), the change of
    variables of Scherer, Gahinet and Chilali (1997).

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
    backoff : float or None, optional
        Relax the minimum bound by this fraction (default 0.2) and maximise
        the conditioning of the Lyapunov pair for a well-conditioned
        controller. None or 0: the raw optimum, or if its rebuilt
        controller does not certify (``I - X Y`` too close to singular)
        the least of the back-offs 1e-5, 1e-4 and 1e-3 that does.
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

    Examples
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
    if gains not in ("scheduled", "common"):
        raise ValueError(f"gains: expected 'scheduled' or 'common', got {gains!r}")
    plant = OutputFeedbackPlant.of(sys, w, u, z, y)
    if gains == "common" and any(not np.array_equal(A, plant.A[0]) for A in plant.A):
        raise ValueError(
            "gains: a common (LTI) output-feedback controller of a plant whose "
            "A depends on the parameter is not a convex problem; use "
            "gains='scheduled'"
        )
    backoff = 0.0 if backoff is None else real_number(backoff, "backoff", minimum=0.0)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    chain = solver_chain(solvers)
    if plant.continuous:
        _require_stabilizable_detectable(plant)
    lmi, hats = _problem(plant, gains == "scheduled", margin)
    rate = max(np.linalg.norm(A, 2) for A in plant.A) if plant.continuous else 1.0
    # A trace term far below the solver's tolerance on gamma keeps X and Y
    # bounded in the directions the bound does not constrain (there the
    # central path drifts to 1e5 and the solve ends inaccurate).
    optimal = lmi.solve(
        lambda v: v.g[0, 0] + _TRACE_WEIGHT * (np.trace(v.X) + np.trace(v.Y)),
        stage="optimal",
        solvers=chain,
    )
    # The solver's point at the nominal margin, when only a larger margin
    # certified, is the better estimate of the optimum.
    gamma_opt = float((optimal.nominal or optimal).g[0, 0])
    # The raw optimum's I - X Y is often too close to singular for the
    # rebuilt controller to certify: then the smallest back-off that does.
    # When the back-off stage itself fails (badly scaled data), the same
    # sequence, within the back-off asked for.
    failure = None
    for b in (backoff, *_RAW_BACKOFFS) if backoff > 0 else _RAW_BACKOFFS:
        try:
            if b == 0:
                lmi.set_parameter("decay", 0.0)
                point = optimal
            else:
                # Solved a little inside the bound it is certified at: the
                # gap is the closed loop's slack after the reconstruction.
                lmi.set_parameter("g_max", (1.0 + _INSIDE * b) * gamma_opt)
                lmi.set_parameter("decay", _DECAY * b * rate)
                point = lmi.solve(lambda v: -v.mu[0, 0], stage="center",
                                  solvers=chain)  # fmt: skip
            target = max((1.0 + b) * gamma_opt, float(point.g[0, 0]))
            limit = (1.0 + max(b, backoff)) * gamma_opt * (1.0 + 1e-6)
            return _design(plant, point, hats, gamma_opt, (target, limit),
                           (margin, chain))  # fmt: skip
        except CertificationError as exc:
            failure = exc
    raise failure


_TRACE_WEIGHT = 1e-7
#: Beyond eig(X Y) >= 100, I - X Y is as well conditioned as X and Y.
_MU_MAX = 10.0

#: Decay margin of the back-off stage per unit back-off, relative to the
#: data's rate (``max ||A_j||`` in continuous time, 1 in discrete time).
_DECAY = 0.1

#: The back-off stage solves at ``(1 + _INSIDE backoff) gamma_opt``.
_INSIDE = 0.9

#: Back-offs tried in turn for ``backoff=None``: the raw optimum, then the
#: least relaxation whose controller certifies.
_RAW_BACKOFFS = (0.0, 1e-5, 1e-4, 5e-4)


def _problem(plant, scheduled, margin):
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
    lmi.variable("g", (1, 1), symmetric=True)
    copies = N if scheduled else 1
    for k in range(copies):
        lmi.variable(f"Ah{k}", (n, n))
        lmi.variable(f"Bh{k}", (n, p))
        lmi.variable(f"Ch{k}", (m, n))
        lmi.variable(f"Dh{k}", (m, p))

    def hats(v, j):
        k = j if scheduled else 0
        return tuple(getattr(v, f"{h}{k}") for h in ("Ah", "Bh", "Ch", "Dh"))

    lmi.add("[[X, I], [I, Y]] > 0", lmis.lyapunov_pair)
    # The back-off stage adds a decay margin relative to P (see
    # `lmis.bounded_real`), so that the rebuilt closed loop certifies.
    lmi.parameter("decay", value=0.0, nonneg=True)
    for j in range(N):
        lmi.add(
            f"bounded real vertex {j}",
            lambda v, j=j: lmis.bounded_real(plant, j, v, hats(v, j), v.decay[()]),
        )
    # The back-off stage: gamma within the back-off, and eig(X Y) >= mu^2
    # pushed up (``[[X, mu I], [mu I, Y]] >= 0``, linear in mu): I - X Y
    # then has no eigenvalue in (1 - mu^2, 0], whatever the scale of X, Y.
    lmi.parameter("g_max", value=1.0)
    lmi.variable("mu", (1, 1), symmetric=True)
    lmi.add("gamma <= (1 + backoff) gamma_opt", lambda v: [[v.g - v.g_max]],
            strict=False, stages=["center"])  # fmt: skip
    eye = np.eye(n)
    lmi.add("[[X, mu I], [mu I, Y]] >= 0",
            lambda v: [[-v.X], [-v.mu * eye, -v.Y]],
            strict=False, stages=["center"])  # fmt: skip
    lmi.add("mu <= mu_max", lambda v: [[v.mu - _MU_MAX]], strict=False,
            stages=["center"], normalization=True)  # fmt: skip
    return lmi, hats


def _design(plant, point, hats, gamma_opt, bounds, analysis):
    X, Y = point.X, point.Y
    gamma, limit = bounds
    try:
        factors = factor(X, Y)
    except np.linalg.LinAlgError:
        raise CertificationError(
            "hinf_output_feedback: I - X Y is singular at the solver's point; "
            "no controller can be rebuilt (try a larger backoff)",
            point.attempts,
        ) from None
    v = _Values(point.values)
    controllers = tuple(
        controller_matrices(plant, j, X, Y, hats(v, j), factors)
        for j in range(plant.nvertices)
    )
    P = closed_loop_lyapunov(X, Y, factors)
    certificate = closed_loop_certificate(plant, controllers, P, gamma)
    if not certificate.verified:
        # The rebuilt P is exact but ill-conditioned (its slack scales with
        # 1 / ||Pi1||^2): the closed loop's own Lyapunov matrix instead.
        P, gamma = closed_loop_analysis(plant, controllers, *analysis)
        certificate = closed_loop_certificate(plant, controllers, P, gamma)
    if gamma > limit:
        # The point's own gamma (certified at a margin above the nominal
        # one), or what the rebuilt controller keeps of it after rounding
        # through an ill-conditioned I - X Y, exceeds the back-off.
        raise CertificationError(
            f"hinf_output_feedback: the controller rebuilt at gamma = "
            f"{point.g[0, 0]:.6g} certifies {gamma:.6g}, above {limit:.6g} "
            f"(I - X Y has condition {np.linalg.cond(np.eye(plant.n) - X @ Y):.3g})",
            point.attempts,
        )
    if not certificate.verified:
        worst = certificate.worst
        raise CertificationError(
            f"hinf_output_feedback: the rebuilt controller failed its closed-loop "
            f"certificate at gamma = {gamma:.6g}: {worst.what} at {worst.where} "
            f"({worst.value:.3g} against {worst.bound:.3g})",
            point.attempts,
        )
    return OutputFeedbackDesign(
        plant=plant,
        controllers=controllers,
        gamma=gamma,
        gamma_opt=gamma_opt,
        P=P,
        certificate=certificate,
        condition=float(np.linalg.cond(np.eye(plant.n) - X @ Y)),
    )


class _Values:
    def __init__(self, values):
        self.__dict__.update(values)


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
