"""`synthesize`: state feedback from composable objectives and constraints.

The call is checked here, at the boundary: the specs (each a
`~ctrl_lpv.synthesis.spec.Spec`, pole regions wrapped by
`~ctrl_lpv.synthesis.constraints.as_spec`) validate themselves against the
design, the plant is partitioned once into its channels
(`~ctrl_lpv.synthesis.channels.Partition`) and every vertex is tested for
stabilizability. The immutable `~ctrl_lpv.synthesis.problem.Problem` then
goes to the one engine (`ctrl_lpv.synthesis.general`), whose certificate
policy is the same for every spec: a design is returned only when every
LMI checks in float64 and the frozen closed loops pass their own checks
in the model's units.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..exceptions import SynthesisError
from ..stabilizability import check_stabilizability
from ..systems import PolytopicStateSpace
from .channels import Partition, require_pss, resolve_channels
from .constraints import as_spec
from .general import run
from .options import validated_options
from .parametric import lyapunov_structure
from .problem import Problem
from .results import StateFeedbackDesign
from .spec import DesignContext, Spec, with_stability
from .specs import H2, Hinf

__all__ = ["synthesize"]

# The paper's names of its four cases (continuous time, a constant
# Lyapunov matrix, no objective or an H-infinity one; regions and a gain
# bound allowed), by (scheduled, objective).
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
    y=None,
    objective=None,
    constraints=(),
    gains: str | None = None,
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
    sys : `PolytopicStateSpace` or `GriddedStateSpace`
        The plant, continuous (``dt = 0``) or discrete time (``dt > 0`` or
        True); all states are measured. On a `GriddedStateSpace`
        (continuous time): gains at the grid points, interpolated as
        python-control's ``create_statefbk_iosystem(...,
        gainsched_method="linear")`` does, with one Lyapunov matrix or,
        with ``lyapunov="affine"`` and `rate_bounds`, one multilinear on
        the grid cells (`ctrl_lpv.synthesis.gridded_rates`), an `Hinf`
        objective or none, certified by `ctrl_lpv.certify` with the same
        rates; a `GriddedDesign` is returned (``y`` and ``constraints``
        are not implemented there).
    u : str, int or list
        Control inputs.
    y : str, int or list, optional
        Measured outputs: a full-order dynamic output-feedback controller
        (`ctrl_lpv.hinf_output_feedback` or `ctrl_lpv.h2_output_feedback`,
        whose `OutputFeedbackDesign` is returned; `objective` must be an
        `Hinf` or `H2` without a bound, `lyapunov` "constant";
        `constraints` pole regions and `Hinf`/`H2` bounds). None (default):
        every state is measured, ``u = -K x``.
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
        `GainBound` and at most one `Saturation` (a region of attraction
        under input saturation containing given states, in continuous or
        discrete time; with `Peak`, invariant under the bounded
        disturbances).
    gains : {"common", "scheduled"}, optional
        One gain for the whole polytope, or one per vertex scheduled with
        the parameter (default "common"; with `y`, "scheduled").
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
    `StateFeedbackDesign` (`GriddedDesign` on a `GriddedStateSpace`)
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
    if _is_gridded(sys):
        from .gridded import synthesize_gridded

        return synthesize_gridded(
            sys, u, y=y, objective=objective, constraints=constraints,
            gains=gains, lyapunov=lyapunov, rate_bounds=rate_bounds,
            backoff=backoff, margin=margin, solvers=solvers,
        )  # fmt: skip
    require_pss(sys)
    if y is not None:
        return _output_feedback(
            sys, u, y, objective, constraints, gains, lyapunov, rate_bounds,
            backoff, margin, solvers, time_limit,
        )  # fmt: skip
    gains = "common" if gains is None else gains
    if gains not in ("common", "scheduled"):
        raise ValueError(f"gains: expected 'common' or 'scheduled', got {gains!r}")
    scheduled = gains == "scheduled"
    if objective is not None and not (
        isinstance(objective, Spec) and objective.channel
    ):
        raise TypeError(
            f"objective: expected None, Hinf(...), H2(...) or Peak(...), got "
            f"{objective!r}"
        )
    performance, constraints = _split_constraints(constraints)
    _check_unique(([objective] if objective is not None else []) + performance
                  + list(constraints))  # fmt: skip
    continuous = not sys.isdtime(strict=True)
    lyap = lyapunov_structure(sys, lyapunov, rate_bounds)
    _, backoff, _, _, margin, chain, time_limit = validated_options(
        (), backoff, None, None, margin, solvers, time_limit
    )
    specs = ([objective] if objective is not None else []) + performance
    _, iu, _ = resolve_channels(sys, None, u, None, hinf=False)
    channels = [resolve_channels(sys, s.w, u, s.z, hinf=True) for s in specs]
    context = DesignContext(continuous, scheduled, lyap.constant, sys.nstates, len(iu))
    for spec in (*specs, *constraints):
        spec.validate(context)
    suspects = check_stabilizability(sys, iu) if continuous else ()
    method = _describe(objective, performance, scheduled, lyapunov, continuous,
                       constraints)  # fmt: skip
    plant = Partition.of(sys, iu, [(iw, iz) for iw, _, iz in channels])
    problem = Problem(
        plant, with_stability((*specs, *constraints)), objective, scheduled, lyap,
        continuous, backoff, margin, chain, method, tuple(suspects),
    )  # fmt: skip
    design = run(problem, time_limit)
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


def _is_gridded(sys) -> bool:
    from ..systems import GriddedStateSpace

    return isinstance(sys, GriddedStateSpace)


def _output_feedback(sys, u, y, objective, constraints, gains, lyapunov,
                     rate_bounds, backoff, margin, solvers, time_limit):  # fmt: skip
    """`synthesize` with measured outputs `y`: what is implemented, or why not."""
    from ..output_feedback import h2_output_feedback, hinf_output_feedback

    if not isinstance(objective, (Hinf, H2)) or objective.bound is not None:
        raise ValueError(
            "objective: output feedback (y given) minimises an Hinf(w, z) or "
            f"H2(w, z) objective without a bound; got {objective!r}"
        )
    design = hinf_output_feedback if isinstance(objective, Hinf) else h2_output_feedback
    if lyapunov != "constant" or rate_bounds is not None:
        raise ValueError(
            "lyapunov: output feedback (y given) is implemented with one "
            "constant Lyapunov pair (valid for arbitrarily fast parameters); "
            "parameter-dependent pairs with rate bounds are not"
        )
    return design(
        sys, objective.w, u, objective.z, y,
        gains="scheduled" if gains is None else gains, constraints=constraints,
        backoff=backoff, margin=margin, solvers=solvers, time_limit=time_limit,
    )  # fmt: skip


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
    """The bound specs with a channel, and the other specs."""
    if isinstance(constraints, Spec) or not hasattr(constraints, "__iter__"):
        constraints = (constraints,)
    try:
        constraints = tuple(constraints)
    except TypeError:
        raise TypeError(
            f"constraints: expected a spec or a sequence of specs, got {constraints!r}"
        ) from None
    if any(isinstance(item, (str, bytes)) for item in constraints):
        raise TypeError(f"constraints: expected specs, got {constraints!r}")
    performance, others = [], []
    for item in map(as_spec, constraints):
        if item.channel:
            if item.bound is None:
                raise ValueError(
                    f"constraints: {item} needs a bound (only the objective is "
                    "minimised)"
                )
            performance.append(item)
        else:
            others.append(item)
    return performance, tuple(others)


def _check_unique(specs) -> None:
    """At most one of each spec that shares its multipliers (`Spec.unique`)."""
    kinds = [type(spec) for spec in specs if spec.unique]
    for kind in dict.fromkeys(kinds):
        if kinds.count(kind) > 1:
            raise ValueError(f"constraints: at most one {kind.__name__}")


def _describe(objective, performance, scheduled, lyapunov, continuous, constraints):
    """The paper's name of its four cases, else what the call asks."""
    if (
        continuous
        and lyapunov == "constant"
        and not performance
        and all(s.paper_case for s in constraints)
        and (objective is None or objective.paper_case)
    ):
        return _METHODS[(scheduled, objective is not None)]
    goal = "stability" if objective is None else type(objective).__name__
    extra = "".join(f" + {type(s).__name__} bound" for s in performance)
    return (
        f"synthesize ({goal}{extra}, {'vertex' if scheduled else 'common'} gains, "
        f"{lyapunov} Lyapunov, {'continuous' if continuous else 'discrete'} time)"
    )
