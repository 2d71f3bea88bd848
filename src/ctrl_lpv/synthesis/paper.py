"""The paper's Lemma 1, Lemma 2, Theorem 1 and Theorem 2 (Section III), and H2.

Each is a thin wrapper of `synthesize` with its specs.
"""

from __future__ import annotations

from collections.abc import Sequence

from .._checks import real_number
from ..budget import DEFAULT_TIME_LIMIT, time_budget
from ..regions import LMIRegion
from ..systems import PolytopicStateSpace
from .compose import synthesize
from .constraints import GainBound
from .options import validated_regions
from .results import StateFeedbackDesign
from .specs import H2, Hinf


@time_budget
def quadratic_stabilization(
    sys: PolytopicStateSpace,
    u=None,
    *,
    regions: Sequence[LMIRegion] = (),
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """Common state feedback that quadratically stabilizes the polytope.

    Lemma 1 of the paper: find ``W > 0`` and ``Z`` with
    ``A_j W + W A_j' + B_j Z + Z' B_j' < 0`` at every vertex; the gain is
    ``K = -Z W^-1`` for ``u = -K x`` and ``P = W^-1``.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant; all states are measured.
    u : str, int or list
        Control inputs (names or indices); required.
    regions : LMIRegion or sequence of LMIRegion, optional
        Pole regions (`halfplane`, `disk`, `sector`) that every frozen
        closed loop must lie in; default none.
    gain_bound : float, optional
        Upper bound on the spectral norm of the gain, in the model's units.
        The first point maximises ``t`` subject to ``t I <= W <= I``,
        ``A_cl W + W A_cl' <= -t I`` and ``||Z|| <= 1`` (scaled units; the
        bound on ``||Z||`` is relaxed to 100, then 1e4, if that gives no
        certified point): a well-conditioned Lyapunov matrix with a decay
        margin and moderate gains, returned as it is without `gain_bound`.
        With it, the gain is then minimised under the bound by
        convex-concave iterations (a sufficient condition, see the module
        documentation), and a design whose gain still exceeds the bound is
        not returned (`CertificationError`).
    margin : float, optional
        Margin of the strict LMIs, posed as ``F <= -margin I`` in the
        prescaled units; positive and below 1, default 1e-6. When no point
        certifies, the first solver is tried again with ``1e-3 * margin``.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn
        (``options``: keywords of that solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`

    Raises
    ------
    InfeasibleError
        If a vertex is not stabilizable (the mode and its PBH residual).
    CertificationError
        If no certified design was found, with every fallback tried.

    Examples
    --------
    >>> import control as ct
    >>> v1 = ct.ss([[0.0, 1.0], [1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    >>> v2 = ct.ss([[0.0, 1.0], [3.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    >>> design = quadratic_stabilization(PolytopicStateSpace([v1, v2]), u=0)
    >>> design.certificate.verified
    True
    """
    return _paper(
        sys, None, u, None, False, None, regions, None, gain_bound,
        margin, solvers, time_limit,
    )  # fmt: skip


@time_budget
def gain_scheduled_stabilization(
    sys: PolytopicStateSpace,
    u=None,
    *,
    regions: Sequence[LMIRegion] = (),
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """Vertex gains that quadratically stabilize the polytope.

    Theorem 1 of the paper: one ``Z_j`` per vertex with a common ``W``,
    LMIs (20) at every vertex and (21) for every pair; the scheduled gain
    is ``K(delta) = sum_j delta_j K_j`` with ``K_j = -Z_j W^-1``.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant; all states are measured.
    u : str, int or list
        Control inputs (names or indices); required.
    regions : LMIRegion or sequence of LMIRegion, optional
        Pole regions (`halfplane`, `disk`, `sector`) that every frozen
        closed loop must lie in; default none.
    gain_bound : float, optional
        Upper bound on the spectral norm of every vertex gain ``K_j``, in
        the model's units. The first point maximises ``t`` subject to
        ``t I <= W <= I``, ``A_cl W + W A_cl' <= -t I`` and ``||Z_j|| <= 1``
        (scaled units; the bound on ``||Z_j||`` is relaxed to 100, then 1e4,
        if that gives no certified point): a well-conditioned Lyapunov
        matrix with a decay margin and moderate gains, returned as it is
        without `gain_bound`. With it, the gain is then minimised under the
        bound by convex-concave iterations (a sufficient condition, see the
        module documentation), and a design whose gain still exceeds the
        bound is not returned (`CertificationError`).
    margin : float, optional
        Margin of the strict LMIs, posed as ``F <= -margin I`` in the
        prescaled units; positive and below 1, default 1e-6. When no point
        certifies, the first solver is tried again with ``1e-3 * margin``.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn
        (``options``: keywords of that solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`
        With one gain per vertex.

    Raises
    ------
    InfeasibleError
        If a vertex is not stabilizable (the mode and its PBH residual).
    CertificationError
        If no certified design was found, with every fallback tried.
    """
    return _paper(
        sys, None, u, None, True, None, regions, None, gain_bound,
        margin, solvers, time_limit,
    )  # fmt: skip


@time_budget
def hinf_state_feedback(
    sys: PolytopicStateSpace,
    w=None,
    u=None,
    z=None,
    *,
    gamma: float | None = None,
    regions: Sequence[LMIRegion] = (),
    backoff: float | None = 0.2,
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """Common state feedback with a certified H-infinity bound.

    Lemma 2 of the paper: LMI (19) at every vertex, in ``W``, ``Z`` and
    ``g = gamma^2``; ``||z||_2 < gamma ||w||_2`` for every admissible
    parameter trajectory (quadratic H-infinity performance).

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant, with the exogenous inputs `w` and control inputs `u`
        among its inputs and the performance outputs `z` among its outputs.
    w : str, int or list, optional
        Exogenous inputs; default every physical input not in `u`.
    u : str, int or list
        Control inputs.
    z : str, int or list, optional
        Performance outputs; default all outputs.
    gamma : float, optional
        Required bound, met strictly; if given the LMIs are solved for
        feasibility at this gamma instead of minimising it.
    regions : LMIRegion or sequence of LMIRegion, optional
        Pole regions (`halfplane`, `disk`, `sector`) that every frozen
        closed loop must lie in; default none.
    backoff : float or None, optional
        Relax the minimum gamma by this fraction (default 0.2), then
        re-solve for a well-conditioned ``W`` and the smallest gain norm.
        None (or 0) returns the raw minimum-gamma point, whose gains are
        often very large.
    gain_bound : float, optional
        Upper bound on the spectral norm of the gain, in the model's units,
        imposed in the gain-minimisation stage (convex-concave iterations, a
        sufficient condition, see the module documentation) that follows the
        back-off or a given `gamma`; a design whose gain still exceeds it is
        not returned (`CertificationError`); with ``backoff=None`` the
        gain stage starts from the raw minimum-gamma point.
    margin : float, optional
        Margin of the strict LMIs, posed as ``F <= -margin I`` in the
        prescaled units; positive and below 1, default 1e-6. When no point
        certifies, the first solver is tried again with ``1e-3 * margin``.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn
        (``options``: keywords of that solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`
        With `gamma` the certified bound and `gamma_opt` the minimum.

    Raises
    ------
    InfeasibleError
        If a vertex is not stabilizable or, for a given `gamma`, a dual
        certificate proves the LMIs infeasible.
    CertificationError
        If no certified design was found (with what was tried).
    """
    return _paper(
        sys, w, u, z, False, gamma, regions, backoff, gain_bound,
        margin, solvers, time_limit, hinf=True,
    )  # fmt: skip


@time_budget
def gain_scheduled_hinf(
    sys: PolytopicStateSpace,
    w=None,
    u=None,
    z=None,
    *,
    gamma: float | None = None,
    regions: Sequence[LMIRegion] = (),
    backoff: float | None = 0.2,
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> StateFeedbackDesign:
    """Vertex gains with a certified H-infinity bound.

    Theorem 2 of the paper: LMIs (24) at every vertex and (25) for every
    pair of vertices, with a common ``W`` and one ``Z_j`` per vertex.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The plant, with `w` and `u` among its inputs and `z` among its
        outputs.
    w : str, int or list, optional
        Exogenous inputs; default every physical input not in `u`.
    u : str, int or list
        Control inputs.
    z : str, int or list, optional
        Performance outputs; default all outputs.
    gamma : float, optional
        Required bound, met strictly; if given the LMIs are solved for
        feasibility at this gamma instead of minimising it.
    regions : LMIRegion or sequence of LMIRegion, optional
        Pole regions (`halfplane`, `disk`, `sector`) that every frozen
        closed loop must lie in; default none.
    backoff : float or None, optional
        Relax the minimum gamma by this fraction (default 0.2), then
        re-solve for a well-conditioned ``W`` and small vertex gains; None
        or 0 returns the raw minimum-gamma point.
    gain_bound : float, optional
        Upper bound on the spectral norm of every vertex gain ``K_j``, in
        the model's units, imposed in the gain-minimisation stage
        (convex-concave iterations, a sufficient condition, see the module
        documentation) that follows the back-off or a given `gamma`; a
        design whose gain still exceeds it is not returned
        (`CertificationError`); with ``backoff=None`` the gain stage starts
        from the raw minimum-gamma point.
    margin : float, optional
        Margin of the strict LMIs, posed as ``F <= -margin I`` in the
        prescaled units; positive and below 1, default 1e-6. When no point
        certifies, the first solver is tried again with ``1e-3 * margin``.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn
        (``options``: keywords of that solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `StateFeedbackDesign`
        With one gain per vertex, `gamma` the certified bound and
        `gamma_opt` the minimum.

    Raises
    ------
    InfeasibleError
        If a vertex is not stabilizable or, for a given `gamma`, a dual
        certificate proves the LMIs infeasible.
    CertificationError
        If no certified design was found (with what was tried).
    """
    return _paper(
        sys, w, u, z, True, gamma, regions, backoff, gain_bound,
        margin, solvers, time_limit, hinf=True,
    )  # fmt: skip


def _paper(
    sys, w, u, z, scheduled, gamma, regions, backoff, gain_bound, margin,
    solvers, time_limit, hinf=False,
):  # fmt: skip
    """The paper's function as a call of `synthesize`.

    `synthesize` sends the paper's cases (continuous time, a constant
    Lyapunov matrix) to the engine tuned for them. The options are checked
    here first, so that an error names this function's arguments.
    """
    gamma = real_number(gamma, "gamma", allow_none=True, positive=True, below=1e150)
    gain_bound = real_number(gain_bound, "gain_bound", allow_none=True, positive=True)
    bound = (GainBound(gain_bound),) if gain_bound is not None else ()
    return synthesize(
        sys, u, objective=Hinf(w, z, bound=gamma) if hinf else None,
        constraints=validated_regions(regions) + bound,
        gains="scheduled" if scheduled else "common", backoff=backoff,
        margin=margin, solvers=solvers, time_limit=time_limit,
    )  # fmt: skip


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
