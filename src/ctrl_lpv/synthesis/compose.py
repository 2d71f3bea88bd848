"""`synthesize`: state feedback from composable objectives and constraints.

The paper's cases (continuous time, a constant Lyapunov matrix, no
objective or an H-infinity objective, pole regions and a gain bound) go to
the tuned engine of `ctrl_lpv.synthesis.ladder`, the one the four paper
functions use. Everything else (H2, several performance specs, parameter-
dependent Lyapunov matrices, discrete time) is assembled here from the spec
classes of `ctrl_lpv.synthesis.specs` over the relaxation of
`ctrl_lpv.synthesis.parametric`, and solved by the fallback ladder of
`ctrl_lpv.synthesis.general`, with the same certificate policy: a design
is returned only when every LMI checks in float64 and the frozen closed
loops pass their own checks in the model's units.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..exceptions import SynthesisError
from ..regions import LMIRegion
from ..stabilizability import check_stabilizability
from ..systems import PolytopicStateSpace
from .channels import require_pss, resolve_channels
from .constraints import GainBound, Saturation
from .general import run_general
from .ladder import run_ladder
from .options import validated_options, validated_regions
from .parametric import lyapunov_structure
from .results import StateFeedbackDesign
from .specs import H2, PERFORMANCE, Peak

__all__ = ["synthesize", "h2_state_feedback"]

_METHODS = {
    (False, False): "Lemma 1",
    (False, True): "Lemma 2",
    (True, False): "Theorem 1",
    (True, True): "Theorem 2",
}


@time_budget
def synthesize(
    sys: PolytopicStateSpace,
    u=None,
    *,
    objective=None,
    constraints=(),
    gains: str = "common",
    lyapunov: str = "constant",
    rate_bounds=None,
    backoff: float | None = 0.2,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """Certified state feedback ``u = -K x`` for composable specifications.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant, continuous (``dt = 0``) or discrete time (``dt > 0`` or
        True); all states are measured.
    u : str, int or list
        Control inputs.
    objective : `Hinf`, `H2` or `Peak`, optional
        The bound to minimise (``bound=None``) or to meet (a given
        ``bound``); None asks for stability alone (Hurwitz or Schur).
        `Peak` bounds ``|z(t)|`` for every ``w`` with ``|w_i(t)| <=
        w_max_i`` from inside an invariant ellipsoid (the design's ``P``).
    constraints : spec or sequence of specs, optional
        `Hinf`, `H2` and `Peak` specs with a ``bound`` (mixed objectives;
        at most one `Peak` in all), pole regions (`halfplane`, `disk`,
        `sector`: here, not in a ``regions`` argument; in discrete time
        only disks inside the unit circle, in the z-plane), at most one
        `GainBound` and at most one `Saturation` (continuous time: a region
        of attraction under input saturation containing given states; with
        `Peak`, invariant under the bounded disturbances).
    gains : {"common", "scheduled"}, optional
        One gain for the whole polytope, or one per vertex scheduled with
        the parameter (default "common").
    lyapunov : {"constant", "affine"}, optional
        A constant Lyapunov matrix (quadratic stability and performance,
        valid for arbitrarily fast parameters), or one multi-affine in the
        box parameters (needs `rate_bounds`). With "affine" a scheduled
        gain is ``K(p) = -Z(p) W(p)^-1``, rational in ``p``; a common gain
        comes from the extended (slack-variable) LMIs, ``K = -Z G^-1``.
    rate_bounds : mapping of str to float, optional
        ``{name: nu}``: ``|dp/dt| <= nu`` (continuous) or
        ``|p[k+1] - p[k]| <= nu`` (discrete); ``nu = 0`` for a
        time-invariant parameter. A parameter not listed (or ``inf``) may
        vary arbitrarily fast and the Lyapunov matrix does not depend on it;
        nor on a parameter whose bound exceeds 1e3 crossings of its
        interval per time unit of the data, or whose interval is too narrow
        to change the data (sound: see `ctrl_lpv.synthesis.parametric`).
    backoff : float or None, optional
        Relax the minimum bound by this fraction (default 0.2) and re-solve
        for a well-conditioned Lyapunov matrix; None or 0 returns the raw
        optimum.
    margin : float, optional
        Margin of the strict LMIs in the prescaled units, positive and below
        1 (default 1e-6); ``1e-3 * margin`` is tried when nothing certifies.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn;
        default Clarabel, then SCS (then CVXOPT and MOSEK if installed).
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`
        ``.gamma`` the certified bound of the objective (None without one),
        ``.gamma_opt`` an estimate of the optimum from above, ``.bounds``
        the certified bound of every `Hinf`, `H2` and `Peak` spec (for a
        `Saturation` spec with points, the largest ``x0' P x0``, below 1).

    Raises
    ------
    InfeasibleError
        A vertex that is not stabilizable, or a verified infeasibility proof.
    CertificationError
        If no certified design was found (with what was tried).
    ValueError, TypeError
        For specifications that do not fit the system (named).

    Examples
    --------
    >>> import control as ct
    >>> from ctrl_lpv import H2, Hinf, PolytopicStateSpace, synthesize
    >>> v1 = ct.ss([[0.0, 1.0], [1.0, 0.0]], [[0.0, 0.0], [1.0, 1.0]],
    ...            [[1.0, 0.0]], [[0.0, 0.0]], inputs=["w", "u"])
    >>> v2 = ct.ss([[0.0, 1.0], [3.0, 0.0]], [[0.0, 0.0], [1.0, 1.0]],
    ...            [[1.0, 0.0]], [[0.0, 0.0]], inputs=["w", "u"])
    >>> design = synthesize(PolytopicStateSpace([v1, v2]), "u",
    ...                     objective=H2("w"), constraints=[Hinf("w", bound=2.0)])
    >>> design.certificate.verified and design.bounds[Hinf("w", bound=2.0)] < 2.0
    True
    """
    require_pss(sys)
    if gains not in ("common", "scheduled"):
        raise ValueError(f"gains: expected 'common' or 'scheduled', got {gains!r}")
    scheduled = gains == "scheduled"
    if objective is not None and not isinstance(objective, PERFORMANCE):
        raise TypeError(
            f"objective: expected None, Hinf(...), H2(...) or Peak(...), got "
            f"{objective!r}"
        )
    performance, constraints = _split_constraints(constraints)
    regions = tuple(c for c in constraints if isinstance(c, LMIRegion))
    gain_bound = next((c for c in constraints if isinstance(c, GainBound)), None)
    saturation = next((c for c in constraints if isinstance(c, Saturation)), None)
    continuous = not sys.isdtime(strict=True)
    if (
        continuous
        and lyapunov == "constant"
        and rate_bounds is None
        and not performance
        and saturation is None
        and not isinstance(objective, (H2, Peak))
    ):
        hinf = objective is not None
        design = run_ladder(
            sys, objective.w if hinf else None, u, objective.z if hinf else None,
            _METHODS[(scheduled, hinf)], scheduled,
            objective.bound if hinf else None, regions, backoff,
            None if gain_bound is None else gain_bound.bound, margin, solvers,
            time_limit, hinf=hinf,
        )  # fmt: skip
        bounds = {objective: design.gamma} if hinf else {}
        return dataclasses.replace(design, bounds=bounds)

    lyap = lyapunov_structure(sys, lyapunov, rate_bounds)
    _, backoff, _, _, margin, chain, time_limit = validated_options(
        (), backoff, None, None, margin, solvers, time_limit
    )
    if not continuous:
        for region in regions:
            _require_unit_disk(region)
    specs = ([objective] if objective is not None else []) + performance
    _, iu, _ = resolve_channels(sys, None, u, None, hinf=False)
    channels = [resolve_channels(sys, s.w, u, s.z, hinf=True) for s in specs]
    if not lyap.constant and not scheduled and regions:
        raise ValueError(
            "constraints: pole regions with a common gain and lyapunov='affine' "
            "are not implemented (the extended LMIs have no region form here); "
            "use gains='scheduled' or a constant Lyapunov matrix"
        )
    if saturation is not None:
        if not continuous:
            raise ValueError(
                "constraints: Saturation is implemented for continuous time only"
            )
        if not lyap.constant and not scheduled:
            raise ValueError(
                "constraints: Saturation with a common gain and lyapunov='affine' is "
                "not implemented (the extended LMIs have no sector form here); use "
                "gains='scheduled' or a constant Lyapunov matrix"
            )
        if not iu:
            raise ValueError("constraints: Saturation needs control inputs u")
        saturation.check_sizes(sys.nstates, len(iu))
    if sum(isinstance(s, Peak) for s in specs) > 1:
        raise ValueError("constraints: at most one Peak spec (one invariant ellipsoid)")
    if any(isinstance(s, Peak) for s in specs) and not lyap.constant and not scheduled:
        raise ValueError(
            "constraints: Peak with a common gain and lyapunov='affine' is not "
            "implemented (the extended LMIs have no invariance form here); use "
            "gains='scheduled' or a constant Lyapunov matrix"
        )
    if gain_bound is not None and not lyap.constant:
        raise ValueError(
            "constraints: GainBound is implemented for a constant Lyapunov matrix only"
        )
    if continuous:
        suspects = check_stabilizability(sys, iu)
    else:
        suspects = ()
    method = _describe(objective, performance, scheduled, lyapunov, continuous)
    design = run_general(
        sys, iu, specs, channels, objective, constraints, scheduled, lyap,
        continuous, backoff, margin, chain, time_limit, method, suspects,
    )  # fmt: skip
    if lyap.constant:
        return design
    # The certificate holds for these rates only: kept for `save`/`load`.
    finite = {k: float(v) for k, v in rate_bounds.items() if float(v) != np.inf}
    design = dataclasses.replace(design, rate_bounds=finite)
    if continuous and not (scheduled or performance or constraints):
        design = _with_primal_analysis(
            design, objective, iu, channels, rate_bounds, margin
        )
    return design


def _with_primal_analysis(design, objective, iu, channels, rate_bounds, margin):
    """The design's gain with the smaller of its bound and its analysis's.

    A common gain with a parameter-dependent Lyapunov function comes from
    the extended LMIs in ``W(p) = P(p)^-1``; the analysis of the gain it
    returns, with ``P(p)`` itself multi-affine (`ctrl_lpv.l2_gain_bound`),
    certifies another family of Lyapunov functions. Keeping the better of
    the two makes the synthesis contain the analysis (a gain that cannot
    act gets the analysis's bound).
    """
    if objective is None or objective.bound is not None:
        return design
    from ..analysis import _closed_loop, _general_analysis

    iw, _, iz = channels[0]
    try:
        closed = _closed_loop(design.system, design.gains, iw, iu, iz, "affine")
        gamma, P, certificate = _general_analysis(
            closed, type(objective)(), "affine", rate_bounds, margin
        )
    except SynthesisError as exc:
        note = f"primal analysis of the gain: {str(exc).splitlines()[0]}"
        return dataclasses.replace(design, ladder=(*design.ladder, note))
    if not (certificate.verified and gamma < design.gamma):
        return design
    note = (
        f"primal analysis of the gain: bound {gamma:.6g} (extended LMIs "
        f"{design.gamma:.6g}), P(p) multi-affine"
    )
    return dataclasses.replace(
        design, gamma=gamma, gamma_opt=min(design.gamma_opt or np.inf, gamma),
        P=P, certificate=certificate, bounds={objective: gamma}, primal=True,
        ladder=(*design.ladder, note),
    )  # fmt: skip


def _split_constraints(constraints):
    """The performance specs, and the other constraint specs."""
    if isinstance(constraints, (LMIRegion, GainBound, Saturation, *PERFORMANCE)):
        constraints = (constraints,)
    try:
        constraints = tuple(constraints)
    except TypeError:
        raise TypeError(
            f"constraints: expected a spec or a sequence of specs, got {constraints!r}"
        ) from None
    performance, others = [], []
    for item in constraints:
        if isinstance(item, PERFORMANCE):
            if item.bound is None:
                raise ValueError(
                    f"constraints: {item} needs a bound (only the objective is "
                    "minimised)"
                )
            performance.append(item)
        elif isinstance(item, (LMIRegion, GainBound, Saturation)):
            others.append(item)
        else:
            raise TypeError(
                f"constraints: expected Hinf, H2, Peak, GainBound, Saturation or "
                f"pole regions, got {item!r}"
            )
    for kind in (GainBound, Saturation):
        if sum(isinstance(item, kind) for item in others) > 1:
            raise ValueError(f"constraints: at most one {kind.__name__}")
    return performance, tuple(others)


def _require_unit_disk(region: LMIRegion) -> None:
    """A discrete-time region must be a disk inside the unit circle."""
    L, M = region.L, region.M
    is_disk = (
        L.shape == (2, 2)
        and np.array_equal(M, [[0.0, 1.0], [0.0, 0.0]])
        and L[0, 0] == L[1, 1]
        and L[0, 1] == L[1, 0]
    )
    if not is_disk:
        raise ValueError(
            f"constraints: {region} is a continuous-time region; a discrete-time "
            "system takes disk(radius, center) regions of the z-plane"
        )
    radius, center = -L[0, 0], -L[0, 1]
    if abs(center) + radius > 1:
        raise ValueError(
            f"constraints: {region} is not inside the unit circle, so it does not "
            "imply stability"
        )


def _describe(objective, performance, scheduled, lyapunov, continuous) -> str:
    goal = "stability" if objective is None else type(objective).__name__
    extra = "".join(f" + {type(s).__name__} bound" for s in performance)
    return (
        f"synthesize ({goal}{extra}, {'vertex' if scheduled else 'common'} gains, "
        f"{lyapunov} Lyapunov, {'continuous' if continuous else 'discrete'} time)"
    )


@time_budget
def h2_state_feedback(
    sys: PolytopicStateSpace,
    w=None,
    u=None,
    z=None,
    *,
    gamma: float | None = None,
    gains: str = "common",
    regions: Sequence[LMIRegion] = (),
    backoff: float | None = 0.2,
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """State feedback with a certified H2 bound (quadratic, constant ``P``).

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant, continuous or discrete time, with `w` and `u` among its
        inputs and `z` among its outputs (continuous time: no feedthrough
        from `w` to `z`).
    w : str, int or list, optional
        Exogenous inputs; default every physical input not in `u`.
    u : str, int or list
        Control inputs.
    z : str, int or list, optional
        Performance outputs; default all outputs.
    gamma : float, optional
        Required H2 bound, met strictly, instead of the minimum.
    gains : {"common", "scheduled"}, optional
        One gain, or one per vertex (default "common").
    regions : LMIRegion or sequence of LMIRegion, optional
        Pole regions every frozen closed loop must lie in.
    backoff : float or None, optional
        Relax the minimum by this fraction (default 0.2) for a
        well-conditioned design; None or 0 returns the raw optimum.
    gain_bound : float, optional
        Bound on the spectral norm of the gain(s), model units.
    margin : float, optional
        Margin of the strict LMIs (prescaled units), default 1e-6.
    solvers : str or sequence, optional
        Solvers tried in turn (see `synthesize`).
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`
        ``.gamma`` the certified H2 bound, ``.gamma_opt`` an estimate of
        the optimum from above (see `StateFeedbackDesign`).

    Raises
    ------
    InfeasibleError
        If a vertex is not stabilizable.
    CertificationError
        If no certified design was found.
    """
    bound = (GainBound(gain_bound),) if gain_bound is not None else ()
    constraints = validated_regions(regions) + bound
    return synthesize(
        sys, u, objective=H2(w, z, bound=gamma), constraints=constraints, gains=gains,
        backoff=backoff, margin=margin, solvers=solvers, time_limit=time_limit,
    )  # fmt: skip
