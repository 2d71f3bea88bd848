"""`observer`: certified LPV observers through the dual state-feedback design."""

from __future__ import annotations

import numpy as np

from ..budget import DEFAULT_TIME_LIMIT, TimeLimitReached
from ..certificate import Certificate
from ..exceptions import CertificationError, InfeasibleError, SynthesisError
from ..stabilizability import check_detectability
from ..synthesis.channels import require_pss
from ..synthesis.compose import synthesize
from ..synthesis.constraints import pole_regions
from ..synthesis.parametric import lyapunov_structure
from ..synthesis.specs import H2, Hinf
from ..systems import PolytopicStateSpace
from .checks import AFFINE_STATEMENT, error_certificate, frozen_checks
from .duality import (
    ErrorData,
    ObserverChannels,
    dual_plant,
    dual_signals,
    dual_spec,
    require_parameter_independent,
)
from .results import ObserverDesign

__all__ = ["observer"]


def observer(
    sys,
    y,
    *,
    u=None,
    w=None,
    z=None,
    objective=None,
    constraints=(),
    gains: str = "scheduled",
    lyapunov: str = "constant",
    rate_bounds=None,
    backoff: float | None = 0.2,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> ObserverDesign:
    """Certified observer ``x_hat' = A x_hat + B_u u + L (y - C_y x_hat - D_yu u)``.

    The gain ``L`` is the transpose of the state-feedback gain of the dual
    plant (`ctrl_lpv.estimation.duality`), designed by the one engine
    (`ctrl_lpv.synthesize`); the certificate is then recomputed on the
    estimation-error system itself (`ctrl_lpv.estimation.checks`). In
    discrete time (``dt > 0``) the estimator is the predictor ``x_hat[k+1]
    = A x_hat[k] + B_u u[k] + L (y[k] - C_y x_hat[k] - D_yu u[k])``.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant, continuous or discrete time.
    y : str, int or list
        Measured outputs.
    u : str, int or list, optional
        Known inputs (fed to the estimator); default none.
    w : str, int or list, optional
        Exogenous inputs (process and sensor noise) of the objective;
        default every input not in `u`. Only with an objective.
    z : str, int or list, optional
        Outputs whose estimation error ``C_z (x - x_hat)`` is weighted
        (their state part); default every state (``z_e = x - x_hat``).
        Only with an objective.
    objective : `Hinf` or `H2`, optional
        ``Hinf()`` / ``H2()`` (no `w`, `z` of their own: given here), with a
        ``bound`` to meet or None to minimise; None: stability of the
        error dynamics alone.
    constraints : pole region or sequence of them, optional
        `ctrl_lpv.halfplane`, `ctrl_lpv.disk`, `ctrl_lpv.sector` regions
        for the frozen error dynamics (discrete time: disks in the unit
        circle).
    gains : {"scheduled", "common"}, optional
        One ``L`` per vertex, ``L(p) = sum_j delta_j(p) L_j`` (default;
        needs ``C_y``, ``D_yu``, ``D_yw`` of the measured outputs
        independent of the parameter), or one ``L`` for the polytope.
    lyapunov : {"constant", "affine"}, optional
        A constant Lyapunov matrix (the bound holds for arbitrarily fast
        parameter variation), or, in continuous time with one common gain
        and no pole regions, ``P(p)`` multi-affine in the box parameters
        with `rate_bounds`; the certificate is then the error system's own
        analysis (`ctrl_lpv.l2_gain_bound`'s path).
    rate_bounds : mapping of str to float, optional
        ``{name: nu}``, ``|dp/dt| <= nu``, for ``lyapunov="affine"``.
    backoff : float or None, optional
        Relax the minimum bound by this fraction (default 0.2) and re-solve
        for a well-conditioned Lyapunov matrix; None or 0 returns the raw
        optimum.
    margin : float, optional
        Margin of the strict LMIs of the dual design in its prescaled
        units (default 1e-6).
    solvers : str or sequence, optional
        Solver name(s) tried in turn, as for `ctrl_lpv.synthesize`.
    time_limit : float or None, optional
        Wall-time budget in seconds (default 600; None for no limit).

    Returns
    -------
    `ObserverDesign`

    Raises
    ------
    InfeasibleError
        A vertex ``(C_y, A_j)`` that is not detectable (named with its
        mode), or a verified infeasibility proof of the dual.
    CertificationError
        If no design certified, or the error system's own certificate
        fails.
    ValueError, TypeError
        For arguments that do not fit (named).

    Examples
    --------
    >>> import control as ct
    >>> import ctrl_lpv as lpv
    >>> plant = lpv.PolytopicStateSpace([ct.ss(
    ...     [[0.0, 1.0], [-2.0, -0.5]], [[0.0, 0.0], [1.0, 1.0]],
    ...     [[1.0, 0.0]], [[0.0, 0.0]], inputs=["u", "d"], outputs=["pos"],
    ...     states=["x", "v"])])
    >>> obs = lpv.observer(plant, "pos", u="u")
    >>> obs.certificate.verified, obs.estimator().output_labels
    (True, ['x_hat', 'v_hat'])
    """
    require_pss(sys)
    if gains not in ("common", "scheduled"):
        raise ValueError(f"gains: expected 'scheduled' or 'common', got {gains!r}")
    if objective is not None:
        if not isinstance(objective, (Hinf, H2)):
            raise TypeError(
                f"objective: expected None, Hinf() or H2(), got {objective!r}"
            )
        if objective.w is not None or objective.z is not None:
            raise ValueError(
                f"objective: {objective} names its own w or z; give them to "
                "observer(w=..., z=...) instead"
            )
    regions = pole_regions(constraints, "an observer")
    ch = ObserverChannels.resolve(sys, y, u, w, z, objective is not None)
    scheduled = gains == "scheduled" and sys.nvertices > 1
    lyapunov_structure(sys, lyapunov, rate_bounds)  # validates both
    affine = lyapunov == "affine"
    if affine:
        _require_affine_fits(sys, scheduled, regions)
    if scheduled:
        require_parameter_independent(sys, ch)
    check_detectability(sys, list(ch.y))
    dual = dual_plant(sys, ch)
    nz = dual.ninputs - len(ch.y) if ch.w else 0
    du, dw, dz = dual_signals(ch, nz)
    dual_objective = None if objective is None else dual_spec(objective, dw, dz)
    try:
        design = synthesize(
            dual, du, objective=dual_objective, constraints=regions,
            gains="scheduled" if scheduled else "common", lyapunov=lyapunov,
            rate_bounds=rate_bounds, backoff=backoff, margin=margin,
            solvers=solvers, time_limit=time_limit,
        )  # fmt: skip
    except (InfeasibleError, CertificationError) as exc:
        if isinstance(exc, TimeLimitReached):
            raise
        raise type(exc)(
            f"{exc}\n(observer: this is the dual state-feedback design, whose "
            f"control inputs {du} are the measured outputs {_names(sys, ch)[0]}, "
            f"exogenous inputs {dw} the weighted errors and outputs {dz} the "
            f"exogenous inputs {_names(sys, ch)[2]}; its bounds are the "
            "observer's)",
            exc.attempts,
            exc.farkas,
        ) from exc
    L = tuple(K.T.copy() for K in design.gains)
    kind = None if objective is None else type(objective).__name__
    if affine:
        gamma, P, certificate = _affine_certificate(
            sys, ch, L[0], objective, rate_bounds, margin
        )
        gamma_opt = None if gamma is None else min(design.gamma_opt, gamma)
    else:
        # The error's Lyapunov matrix is the engine's own variable W = P_dual^-1.
        P = np.linalg.inv(design.P)
        P = 0.5 * (P + P.T)
        gamma, gamma_opt = design.gamma, design.gamma_opt
        certificate = error_certificate(
            ErrorData.of(sys, ch), L, P, continuous=not sys.isdtime(strict=True),
            kind=kind, gamma=gamma, regions=regions,
            labels=[f"vertex {j}" for j in range(sys.nvertices)],
        )  # fmt: skip
    if not certificate.verified:
        raise CertificationError(
            "observer: the dual design certified, but the estimation-error "
            "system's own float64 checks failed:\n"
            + "\n".join(
                f"  {c.what} at {c.where}: {c.value:.3g} (bound {c.bound:.3g})"
                for c in certificate.failed
            )  # fmt: skip
        )
    names = sys.output_labels
    inputs = sys.physical_inputs
    return ObserverDesign(
        system=sys, L=L, gamma=gamma, gamma_opt=gamma_opt,
        bounds={} if objective is None else {objective: gamma},
        certificate=certificate, P=P, lyapunov=lyapunov,
        rate_bounds=_finite_rates(rate_bounds) if affine else None,
        y=tuple(names[i] for i in ch.y), u=tuple(inputs[i] for i in ch.u),
        w=tuple(inputs[i] for i in ch.w), z=tuple(names[i] for i in ch.z),
        dual=design, regions=regions, channels=ch,
    )  # fmt: skip


def _require_affine_fits(sys, scheduled, regions) -> None:
    """``lyapunov="affine"``: continuous time, one gain, no pole regions."""
    if sys.isdtime(strict=True):
        raise ValueError(
            "lyapunov: 'affine' is for continuous time only for observers: the "
            "transpose of the discrete-time inequality pairs P(p[k]) with the "
            "wrong sample, so the dual design would not be an observer design"
        )
    if scheduled:
        raise ValueError(
            "gains: lyapunov='affine' needs gains='common' for observers (the "
            "dual's vertex gains are rational in p, K(p) = -Z(p) W(p)^-1, so "
            "the error system would not be polytopic)"
        )
    if regions:
        raise ValueError(
            "constraints: pole regions need lyapunov='constant' for observers"
        )


def _affine_certificate(sys, ch, L, objective, rate_bounds, margin):
    """The error system's own analysis with ``P(p)`` multi-affine.

    The error system with the one gain `L` is polytopic (vertex ``j``:
    ``(A_j - L C_y,j, B_w,j - L D_yw,j, C_z,j, 0)``); its certified
    analysis (`ctrl_lpv.l2_gain_bound`'s path, with the rate bounds) is the
    certificate, with the frozen error systems as cross-checks.
    """
    from ..analysis import _general_analysis

    err = ErrorData.of(sys, ch)
    vertices = []
    for j in range(sys.nvertices):
        A, B, Cz = err.at(np.eye(sys.nvertices)[j], L)
        if not ch.w:
            B = -L  # sensor errors; only the stability is analysed
        vertices.append((A, B, Cz, np.zeros((Cz.shape[0], B.shape[1]))))
    loop = PolytopicStateSpace(vertices, sys.domain, dt=sys.dt)
    spec = None if objective is None else type(objective)()
    try:
        gamma, P, analysis = _general_analysis(
            loop, spec, "affine", rate_bounds, margin
        )
    except SynthesisError as exc:
        raise CertificationError(
            "observer: the gain of the dual design (lyapunov='affine') did not "
            f"certify on the estimation-error system: {str(exc).splitlines()[0]}"
        ) from exc
    gamma = None if objective is None else gamma
    kind = None if objective is None else type(objective).__name__
    frozen = Certificate(tuple(frozen_checks(err, (L,), True, kind, gamma, ())))
    certificate = Certificate.combine(analysis, frozen, statement=AFFINE_STATEMENT)
    return gamma, P, certificate


def _finite_rates(rate_bounds) -> dict:
    return {k: float(v) for k, v in rate_bounds.items() if float(v) != np.inf}


def _names(sys, ch):
    """``(y, u, w)`` names of the channels."""
    inputs = sys.physical_inputs
    return (
        [sys.output_labels[i] for i in ch.y],
        [inputs[i] for i in ch.u],
        [inputs[i] for i in ch.w],
    )
