"""Certified state-feedback synthesis for polytopic systems.

Four entry points, after the paper's Lemma 1, Lemma 2, Theorem 1 and
Theorem 2 (Section III):

=============================  =============  ===================
function                       gain           performance
=============================  =============  ===================
`quadratic_stabilization`      common K       quadratic stability
`hinf_state_feedback`          common K       H-infinity bound
`gain_scheduled_stabilization` vertex K_j     quadratic stability
`gain_scheduled_hinf`          vertex K_j     H-infinity bound
=============================  =============  ===================

All return a `StateFeedbackDesign` whose gains follow python-control's sign
convention ``u = -K x`` (the paper writes ``u = K x``: ``K = -Z W^-1`` here).
A design is only returned with its certificate (see `Certificate`).

Numerical policy
----------------
1. Before solving, every vertex is checked stabilizable (PBH test); a
   non-stabilizable vertex raises `InfeasibleError` naming the vertex and
   the uncontrollable mode.
2. The data are prescaled by powers of two (state balancing, input, w and z
   normalisation, and a time scaling), so that the scaled LMIs are exactly
   congruent to the original ones and a certificate of one is a certificate
   of the other.
3. Strict inequalities are posed as ``F <= -margin I`` in scaled units.
4. Back-off (default 20 %): after the minimum ``gamma*``, the problem is
   re-solved with ``gamma <= (1 + backoff) gamma*``, first maximising the
   smallest eigenvalue of ``W`` under ``W <= lambda_max(W*)`` (a
   well-conditioned Lyapunov matrix), then minimising the gain norm in the
   model's units by a convex-concave iteration: the bound
   ``||K_j||^2 <= kappa`` is linearised at the previous point (exact there,
   sufficient everywhere) and re-solved until it improves by less than 5 %.
   Each stage is one cvxpy problem built with parameters (DPP): its
   iterations and the margin retries re-solve without recompiling.
5. Every returned design is verified in float64: every LMI, the closed-loop
   Lyapunov inequality and Hurwitz stability at every vertex and at sampled
   interior points.

Re-solves
---------
The prescaled vertex data, the margin, the pole-region offsets and every
stage bound are cvxpy parameters, so a compiled problem depends only on the
structure of the call (function, dimensions, number of vertices, region
shapes, whether a gain bound is set); the power-of-two state and input
scalings, read as constants by the gain stage alone, rebuild that stage
when they change (rarely: not for new weights or gammas). `synthesis_cache`
keeps compiled problems by structure: a gamma or back-off sweep, new
performance weights (the rows of ``C`` and ``D`` of z) or another plant of
the same size reuse them, and a call then costs the solver and the
verification only (``design.timing["compile"]`` is 0). Each call sets every
parameter and verifies its own result from scratch, so a reused problem
gives the same certified design as a fresh one.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
from scipy.linalg import matrix_balance

from ._checks import real_number, signal_indices
from .exceptions import CertificationError, InfeasibleError, ProblemSizeWarning
from .lmi import LMICheck, LMIProblem, SolveAttempt, default_solvers, solver_chain
from .problem_cache import synthesis_cache
from .regions import LMIRegion
from .stabilizability import check_stabilizability
from .systems import PolytopicStateSpace

__all__ = [
    "StateFeedbackDesign",
    "Certificate",
    "quadratic_stabilization",
    "hinf_state_feedback",
    "gain_scheduled_stabilization",
    "gain_scheduled_hinf",
]

# Rounding level below which the Jacobi-normalised inequality with the
# returned P, in the model's units, must stay (a few eps times its size).
ORIGINAL_UNITS_TOL = 1e-12
# Number of random interior points at which closed loops are verified.
_VERIFY_SAMPLES = 64
# Convex-concave iterations of the gain minimisation, and the relative
# decrease of the squared gain bound below which they stop.
_GAIN_ITERATIONS = 4
_GAIN_RTOL = 0.05
# Bounds W <= w_max I (scaled units) tried in turn when gamma is given.
_FIXED_GAMMA_W_MAX = (1e3, 1e6, 1e9)
# Squared bounds ||Z|| <= sqrt(z_max) of the stabilization stage, in turn:
# the LMIs are homogeneous, so a larger bound admits a smaller decay.
_STABILIZE_Z_MAX = (1.0, 1e4, 1e8)
# Margins tried in turn, relative to the given one.
_MARGIN_FACTORS = (1.0, 1e-3)
# A given gamma is posed as gamma^2 (1 - _GAMMA_SLACK) so that the
# certified bound is met strictly.
_GAMMA_SLACK = (1e-6, 1e-3)
# Compile-time and memory estimates of a problem (see `_guard_size`): a
# warning above _WARN_COMPILE_SECONDS, a refusal above the time limit or
# half the memory.
_COMPILE_SECONDS_PER_LMI = 0.05
_COMPILE_SECONDS_PER_ENTRY = 1e-5
_WARN_COMPILE_SECONDS = 30.0
_BYTES_PER_ENTRY = 400  # cvxpy's compiled problem, measured order of magnitude


# ----------------------------------------------------------------------
# Results
# ----------------------------------------------------------------------
@dataclass(frozen=True)
class Certificate:
    """Independent float64 verification of a design.

    Attributes
    ----------
    lmi_checks : tuple of `ctrl_lpv.lmi.LMICheck`
        Largest eigenvalue of every LMI at the returned point (scaled units,
        exactly congruent to the original LMIs).
    margin : float
        Margin the strict LMIs were posed with (scaled units).
    max_closed_loop_real : float
        Largest real part of the closed-loop eigenvalues over the vertices
        and the sampled interior points (original units).
    max_lyapunov_eig : float
        Largest eigenvalue of ``A_cl W + W A_cl'`` over the same points,
        divided by ``||W||`` (must be negative).
    npoints : int
        Number of parameter points checked (vertices plus samples).
    max_original_eig : float
        Largest eigenvalue, over the same points, of the Lyapunov (or
        bounded-real, with `gamma`) inequality written with the returned
        ``P`` and gains in the model's units, after a Jacobi normalisation
        (must be below the rounding level `ORIGINAL_UNITS_TOL`).
    verified : bool
        True when every check passed. A design is only returned verified.
    """

    lmi_checks: tuple[LMICheck, ...]
    margin: float
    max_closed_loop_real: float
    max_lyapunov_eig: float
    npoints: int
    max_original_eig: float = -1.0

    @property
    def verified(self) -> bool:
        """Whether every LMI and closed-loop check passed."""
        return (
            all(c.passed for c in self.lmi_checks)
            and self.max_closed_loop_real < 0
            and self.max_lyapunov_eig < 0
            and self.max_original_eig < ORIGINAL_UNITS_TOL
        )

    @property
    def worst_lmi(self) -> LMICheck:
        """The strict LMI with the smallest distance to its bound."""
        strict = [c for c in self.lmi_checks if c.strict]
        return max(strict, key=lambda c: c.max_eig)

    def __str__(self) -> str:
        worst = self.worst_lmi
        return (
            f"{'verified' if self.verified else 'NOT verified'}: "
            f"{len(self.lmi_checks)} LMIs, worst {worst.name} "
            f"lambda_max = {worst.max_eig:.3g} (margin {self.margin:.1g}); "
            f"closed loop max Re = {self.max_closed_loop_real:.4g} "
            f"over {self.npoints} points"
        )


@dataclass(frozen=True)
class StateFeedbackDesign:
    """A certified state-feedback design for a polytopic system.

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The design model.
    method : str
        Which result was used ("Lemma 1", "Lemma 2", "Theorem 1",
        "Theorem 2").
    gains : tuple of ndarray
        ``m x n`` gains for ``u = -K x``: one common gain, or one per vertex.
    P : ndarray
        Lyapunov matrix ``P = W^-1`` of ``V(x) = x' P x`` (original units).
    gamma : float or None
        Certified bound on the L2 gain from `w` to `z` (None without a
        performance channel).
    gamma_opt : float or None
        The minimum ``gamma*`` the solver found before back-off (None if not
        computed). With back-off it is an estimate whose point need not pass
        the certificate; only `gamma` is certified.
    w, u, z : tuple of str
        Exogenous inputs, control inputs and performance outputs.
    certificate : `Certificate`
        The float64 verification.
    attempts : tuple of `ctrl_lpv.lmi.SolveAttempt`
        Every solver attempt of every stage.
    timing : dict
        Seconds spent: "build" (checks and the stabilizability test),
        "compile" (building and compiling the cvxpy problems; 0 when they
        were reused from `synthesis_cache`), "solve" (solver calls,
        parameter application and certificates) and "verify" (closed
        loops).
    backoff : float or None
        Back-off used.
    regions : tuple of `LMIRegion`
        Pole regions the design was constrained to.
    ladder : tuple of str
        What the fallback ladder tried before this design certified (empty
        when the first point did): each rung (prescaling, margin, stage
        bound) and why it was passed over.
    """

    system: PolytopicStateSpace
    method: str
    gains: tuple[np.ndarray, ...]
    P: np.ndarray
    gamma: float | None
    gamma_opt: float | None
    w: tuple[str, ...]
    u: tuple[str, ...]
    z: tuple[str, ...]
    certificate: Certificate
    attempts: tuple[SolveAttempt, ...]
    timing: dict = field(default_factory=dict)
    backoff: float | None = None
    regions: tuple[LMIRegion, ...] = ()
    ladder: tuple[str, ...] = ()

    @property
    def scheduled(self) -> bool:
        """Whether the design has one gain per vertex."""
        return len(self.gains) > 1

    @property
    def states(self) -> tuple[str, ...]:
        """State labels (the measured signals of the controller)."""
        return tuple(self.system.state_labels)

    def gain(self, p=None) -> np.ndarray:
        """Gain ``K(delta(p)) = sum_j delta_j K_j`` at parameter value `p`.

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value; ignored (may be omitted) for a common gain.

        Returns
        -------
        ndarray
            ``m x n`` gain for ``u = -K x``.
        """
        if not self.scheduled:
            return self.gains[0].copy()
        if p is None:
            raise ValueError("p: a scheduled design needs the parameter value")
        delta = self.system.weights(p)
        return np.tensordot(delta, np.stack(self.gains), axes=1)

    def closed_loop(self, p) -> tuple[np.ndarray, ...]:
        """Closed-loop ``(A, B_w, C_z, D_zw)`` matrices at `p`."""
        frozen = self.system.at(p)
        iw, iu, iz = _indices(self.system, self.w, self.u, self.z)
        K = self.gain(p)
        A = frozen.A - frozen.B[:, iu] @ K
        C = frozen.C[iz] - frozen.D[np.ix_(iz, iu)] @ K
        return A, frozen.B[:, iw], C, frozen.D[np.ix_(iz, iw)]

    def controller(self, *args, **kwargs):
        """State-feedback controller ``u = -K x`` as a python-control I/O system.

        Calls `ctrl_lpv.controllers.state_feedback` on this design; its
        inputs are named after the design model's states, so that
        `control.interconnect` connects it to the plant by name.

        Parameters
        ----------
        scheduling : None, "inputs" or callable, optional
            For vertex gains only (None for a common gain): where the
            parameter comes from. ``"inputs"`` (the default for vertex
            gains) adds one input per parameter, named after it; a callable
            ``p = f(t, x)`` computes it from time and the design model's
            state vector, returning an array or a dict ``{name: value}``.
            The parameter is projected onto the domain.
        reference : bool, optional, keyword-only
            If True, add inputs ``<state>_d`` (desired states) and
            ``<input>_d`` (feedforward): ``u = ud - K (x - xd)``. Default
            False.
        states : sequence of str or mapping, optional, keyword-only
            Names of the measured-state inputs: one per measured state, or
            ``{state label: input name}`` renaming some. Default: the design
            model's state labels.
        integrals : mapping of str to str, optional, keyword-only
            ``{integral state label: integrated signal}`` integrated by the
            controller itself; default those recorded by
            `integral_augmentation` (``{}`` reads every state as an input).
        name : str, optional, keyword-only
            System name.

        Returns
        -------
        `control.NonlinearIOSystem`
            Inputs: the measured states (plus integrated outputs, references
            and parameter inputs as requested); outputs: the control inputs
            ``u``; states: the controller's integral states, if any.

        Raises
        ------
        ValueError
            For a `scheduling` that does not fit the design, `states` of the
            wrong length or with unknown labels, or `integrals` naming
            unknown states or signals.
        TypeError
            If `integrals` is not a mapping.
        """
        from .controllers import state_feedback

        return state_feedback(self, *args, **kwargs)

    def __str__(self) -> str:
        lines = [
            f"StateFeedbackDesign ({self.method}, "
            f"{'vertex gains' if self.scheduled else 'common gain'}, u = -K x)",
            f"  system: {self.system.name}, {self.system.nvertices} vertices, "
            f"{self.system.nstates} states",
            f"  w = {list(self.w)}, u = {list(self.u)}, z = {list(self.z)}",
        ]
        if self.gamma is not None:
            opt = f"{self.gamma_opt:.5g}" if self.gamma_opt is not None else "n/a"
            backoff = "off" if self.backoff is None else f"{self.backoff:g}"
            lines.append(
                f"  gamma = {self.gamma:.5g} certified (gamma* = {opt}, "
                f"back-off {backoff})"
            )
        if self.regions:
            lines.append(f"  pole regions: {', '.join(map(str, self.regions))}")
        with np.printoptions(precision=5, suppress=False, linewidth=100):
            for j, K in enumerate(self.gains):
                label = f"K[{j}]" if self.scheduled else "K"
                lines.append(f"  {label} = {np.array2string(K, prefix='  K = ')}")
        lines.append(f"  certificate: {self.certificate}")
        solved = [a for a in self.attempts if a.certified]
        solver = solved[-1].solver if solved else "none"
        lines.append(
            f"  solver: {solver}, {len(self.attempts)} attempt(s); time "
            + ", ".join(f"{k} {v:.3f} s" for k, v in self.timing.items())
        )
        return "\n".join(lines)

    def __repr__(self) -> str:
        gamma = "" if self.gamma is None else f", gamma={self.gamma:.5g}"
        return (
            f"<StateFeedbackDesign {self.method}: {len(self.gains)} gain(s)"
            f"{gamma}, verified={self.certificate.verified}>"
        )


# ----------------------------------------------------------------------
# Public synthesis functions
# ----------------------------------------------------------------------
def quadratic_stabilization(
    sys: PolytopicStateSpace,
    u=None,
    *,
    regions: Sequence[LMIRegion] = (),
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = None,
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
        (``options``: keywords of that cvxpy solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float, optional
        Wall-time limit of the whole call, in seconds (default none):
        solvers get the time left and no fallback is started after it; a
        problem whose estimated compile time exceeds it is refused before
        any solve. Both end in `CertificationError`.

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
    return _synthesize(
        sys, None, u, None, "Lemma 1", False, None, regions, None, gain_bound,
        margin, solvers, time_limit,
    )  # fmt: skip


def gain_scheduled_stabilization(
    sys: PolytopicStateSpace,
    u=None,
    *,
    regions: Sequence[LMIRegion] = (),
    gain_bound: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = None,
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
        (``options``: keywords of that cvxpy solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float, optional
        Wall-time limit of the whole call, in seconds (default none):
        solvers get the time left and no fallback is started after it; a
        problem whose estimated compile time exceeds it is refused before
        any solve. Both end in `CertificationError`.

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
    return _synthesize(
        sys, None, u, None, "Theorem 1", True, None, regions, None, gain_bound,
        margin, solvers, time_limit,
    )  # fmt: skip


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
    time_limit: float | None = None,
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
        (``options``: keywords of that cvxpy solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float, optional
        Wall-time limit of the whole call, in seconds (default none):
        solvers get the time left and no fallback is started after it; a
        problem whose estimated compile time exceeds it is refused before
        any solve. Both end in `CertificationError`.

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
    return _synthesize(
        sys, w, u, z, "Lemma 2", False, gamma, regions, backoff, gain_bound,
        margin, solvers, time_limit, hinf=True,
    )  # fmt: skip


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
    time_limit: float | None = None,
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
        (``options``: keywords of that cvxpy solver); default Clarabel,
        then SCS, then CVXOPT and MOSEK if installed. A solver that is not
        installed is a `ValueError`.
    time_limit : float, optional
        Wall-time limit of the whole call, in seconds (default none):
        solvers get the time left and no fallback is started after it; a
        problem whose estimated compile time exceeds it is refused before
        any solve. Both end in `CertificationError`.

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
    return _synthesize(
        sys, w, u, z, "Theorem 2", True, gamma, regions, backoff, gain_bound,
        margin, solvers, time_limit, hinf=True,
    )  # fmt: skip


# ----------------------------------------------------------------------
# The engine
# ----------------------------------------------------------------------
def _require_pss(sys):
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}; wrap an "
            "LTI system as PolytopicStateSpace([sys])"
        )


def _indices(sys, w, u, z):
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    iw = signal_indices(w, inputs, "w")
    iz = signal_indices(z, sys.output_labels, "z")
    return iw, iu, iz


def _resolve_channels(sys, w, u, z, hinf):
    _require_pss(sys)
    if u is None:
        raise ValueError("u: name the control input(s), e.g. u=['Tm']")
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    if not iu:
        raise ValueError("u: at least one control input is required")
    if not hinf:
        return [], iu, []
    iw = (
        [i for i in range(len(inputs)) if i not in iu]
        if w is None
        else signal_indices(w, inputs, "w")
    )
    iz = (
        list(range(sys.noutputs))
        if z is None
        else signal_indices(z, sys.output_labels, "z")
    )
    if not iw:
        raise ValueError("w: at least one exogenous input is required")
    if not iz:
        raise ValueError("z: at least one performance output is required")
    if set(iw) & set(iu):
        raise ValueError("w, u: an input cannot be both exogenous and control")
    return iw, iu, iz


def _norm(M) -> float:
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def _pow2(x: float) -> float:
    """Nearest power of two, so that scaling is exact in floating point."""
    return float(2.0 ** np.round(np.log2(x))) if x > 0 else 1.0


@dataclass(frozen=True)
class _Scaling:
    """Exact (power-of-two) prescaling; see the module docstring."""

    T: np.ndarray  # state scaling, x = T x~
    Su: np.ndarray  # input scaling, u = Su u~
    sw: float  # w = sw w~
    sz: float  # z = sz z~
    a: float  # time scaling, t~ = a t

    @classmethod
    def of(cls, vertices, balance: bool = True) -> _Scaling:
        n = vertices[0][0].shape[0]
        if balance:
            absA = sum(np.abs(v[0]) for v in vertices)
            _, (t, _) = matrix_balance(absA, permute=False, separate=True)
            T = np.array([_pow2(x) for x in t])
        else:
            T = np.ones(n)
        a = _pow2(max(np.linalg.norm(v[0] * (T / T[:, None]), 2) for v in vertices))
        Su = np.array(
            [
                _pow2(a / c) if c > 0 else 1.0
                for c in np.max(
                    [np.linalg.norm(v[2] / T[:, None], axis=0) for v in vertices],
                    axis=0,
                )
            ]
        )
        nb1 = max(_norm(v[1] / T[:, None]) for v in vertices)
        sw = _pow2(a / nb1) if nb1 > 0 else 1.0
        nz = max(_norm(np.hstack([v[3] * T, v[4] * sw, v[5] * Su])) for v in vertices)
        sz = _pow2(nz) if nz > 0 else 1.0
        return cls(T, Su, sw, sz, a)

    def apply(self, v):
        A, B1, B2, C, D1, D2 = v
        Ti = 1.0 / self.T
        return (
            Ti[:, None] * A * self.T / self.a,
            Ti[:, None] * B1 * self.sw / self.a,
            Ti[:, None] * B2 * self.Su / self.a,
            C * self.T / self.sz,
            D1 * self.sw / self.sz,
            D2 * self.Su / self.sz,
        )

    @property
    def w_factor(self) -> float:
        """W = w_factor * T W~ T and Z = w_factor * Su Z~ T."""
        return self.a / self.sw**2

    def unscale_W(self, Wt):
        return self.w_factor * (self.T[:, None] * Wt * self.T)

    def unscale_P(self, Pt):
        """``P = W^-1`` from ``P~ = W~^-1``."""
        return Pt / (self.w_factor * self.T[:, None] * self.T)

    def unscale_K(self, Kt):
        # u = -K x with u = Su u~, x = T x~ and u~ = -K~ x~.
        return self.Su[:, None] * Kt / self.T

    def unscale_g(self, g):
        return g * (self.sz / self.sw) ** 2


def _vertex_channels(sys, iw, iu, iz):
    out = []
    for A, B, C, D in sys.vertex_data():
        out.append(
            (
                A,
                B[:, iw],
                B[:, iu],
                C[iz] if iz else np.zeros((0, A.shape[0])),
                D[np.ix_(iz, iw)],
                D[np.ix_(iz, iu)],
            )
        )
    return out


def _region_block(L, M, W, q, twice):
    """``twice kron(L, W) + 2 kron(M, q)`` of a pole region.

    Its symmetric part, the only part `assemble` keeps, is the region's
    ``twice kron(L, W) + kron(M, q) + kron(M', q')``. With cvxpy objects it
    is assembled from the blocks ``twice L[a, b] W + 2 M[a, b] q``: cvxpy's
    ``kron`` of a constant and an expression with parameters is not DPP, a
    scalar times it is.
    """
    if isinstance(W, np.ndarray):
        return twice * np.kron(L, W) + 2 * np.kron(M, q)
    k = M.shape[0]

    def block(a, b):
        out = twice * L[a, b] * W
        return out + 2 * M[a, b] * q if M[a, b] else out

    return cp.bmat([[block(a, b) for b in range(k)] for a in range(k)])


def _pairs(N, scheduled):
    """Index pairs (j, k): vertices, then (if scheduled) every pair j < k."""
    pairs = [(j, j) for j in range(N)]
    if scheduled:
        pairs += list(itertools.combinations(range(N), 2))
    return pairs


# ----------------------------------------------------------------------
# Compiled problems: structure, parameter values, cache
# ----------------------------------------------------------------------
@dataclass(frozen=True)
class _Structure:
    """What fixes the compiled problem; everything else is a parameter.

    The prescaled vertex data, the margin, the time-scaled region offsets
    ``L`` and the stage bounds are cvxpy parameters. The region matrices
    ``M`` enter ``kron(M, A_cl W)``, a product with the data, so they are
    part of the structure (DPP allows a parameter times a variable, not a
    parameter times a parameter).
    """

    hinf: bool
    scheduled: bool
    n: int
    m: int
    nw: int
    nz: int
    N: int
    regions: tuple  # (M.shape, M entries) per region
    gain_bound: bool

    @classmethod
    def of(cls, data, hinf, scheduled, regions, gain_bound) -> _Structure:
        A, B1, B2, C, _, _ = data[0]
        return cls(
            hinf=hinf,
            scheduled=scheduled,
            n=A.shape[0],
            m=B2.shape[1],
            nw=B1.shape[1],
            nz=C.shape[0],
            N=len(data),
            regions=tuple((r.M.shape, tuple(r.M.ravel().tolist())) for r in regions),
            gain_bound=gain_bound is not None,
        )

    @property
    def nZ(self) -> int:
        return self.N if self.scheduled else 1

    @property
    def lmi_size(self) -> int:
        """Size of the largest LMI of a vertex or pair."""
        size = self.n + self.nw + self.nz if self.hinf else self.n
        return max([size] + [shape[0] * self.n for shape, _ in self.regions])

    @property
    def entries(self) -> int:
        """Number of LMI matrix entries, the measure of its compiled size."""
        size = self.n + self.nw + self.nz if self.hinf else self.n
        per_pair = size**2 + sum((shape[0] * self.n) ** 2 for shape, _ in self.regions)
        return len(_pairs(self.N, self.scheduled)) * per_pair + self.n**2


def _stack(blocks, axis):
    """``np.vstack``/``np.hstack`` or their cvxpy versions."""
    if all(isinstance(b, np.ndarray) for b in blocks):
        return np.concatenate(blocks, axis=axis)
    return cp.vstack(blocks) if axis == 0 else cp.hstack(blocks)


def _pair(v, name, j, k):
    """Data parameter ``name`` ("P", "O" or "Q") of LMI ``(j, k)``."""
    return getattr(v, f"{name}_{j}_{k}")


def _pair_variables(v, j, k, scheduled):
    """``X = [W; Z_k; Z_j]`` (``[W; Z_j]`` at a vertex) of LMI ``(j, k)``."""
    if not scheduled:
        return _stack([v.W, v.Z0], 0)
    if j == k:
        return _stack([v.W, getattr(v, f"Z{j}")], 0)
    return _stack([v.W, getattr(v, f"Z{k}"), getattr(v, f"Z{j}")], 0)


def _build(s: _Structure) -> _Compiled:
    """The LMI problem of a structure, data as parameters (module doc).

    The LMI of a vertex or of a pair ``(j, k)`` of vertices is written with
    one product of a data parameter and the stacked variables
    ``X = [W; Z_k; Z_j]``:

    * ``q = A_jk W + B2_j Z_k + B2_k Z_j = Q_jk X`` with
      ``Q_jk = [A_j + A_k, B2_j, B2_k]`` (``[A_j, B2_j]`` at a vertex), and
      ``R = [C_j + C_k, D2_j, D2_k] X`` likewise;
    * the H-infinity LMI, its blocks ordered ``(x, z, w)`` (a symmetric
      permutation of (24)-(25): the same eigenvalues), is the symmetric
      part of the lower block triangle
      ``[[2 q, 0, 0], [2 R, -c g I, 0], [2 B1', 2 D1', -c I]]`` (``c`` is 1
      at a vertex, 2 for a pair): ``[[P_jk X; 0], g E, 0] + O_jk`` with
      ``P_jk = [2 Q_jk; 2 [C_j + C_k, D2_j, D2_k]]`` and the w rows in
      ``O_jk`` (filled in by `_load`). With the w rows last, ``P_jk`` has
      no rows of zeros, which cvxpy would keep as explicit zeros of the
      conic problem (about 20 % of Clarabel's time per iteration, n = 12).

    Written block by block the same LMIs take about twice as long for cvxpy
    to compile. Parameters get their values from `_load`, before every use.
    """
    n, m, nw, nz_, N = s.n, s.m, s.nw, s.nz, s.N
    lmi = LMIProblem()
    lmi.variable("W", (n, n), symmetric=True)
    for k in range(s.nZ):
        lmi.variable(f"Z{k}", (m, n))
    if s.hinf:
        lmi.variable("g", (1, 1))
        lmi.parameter("g_max", (1, 1), nonneg=True)
    lmi.variable("t", (1, 1))
    lmi.variable("kappa", (1, 1))
    lmi.parameter("w_max", nonneg=True)
    for r, (shape, _) in enumerate(s.regions):
        lmi.parameter(f"region{r}_L", shape)

    lmi.add("W > 0", lambda v: [[-v.W]])

    size = n + nz_ + nw if s.hinf else n
    # E: where g enters the H-infinity LMI (its (z, z) block).
    E = np.zeros((size, nz_))
    E[n : n + nz_] = -np.eye(nz_)
    below = np.zeros((nw, n))  # the w rows of the first block column: data
    right = np.zeros((size, nw))  # the last block column: data
    for j, k in _pairs(N, s.scheduled):
        label = f"vertex {j}" if j == k else f"pair ({j}, {k})"
        twice = 1.0 if j == k else 2.0
        width = n + (m if j == k or not s.scheduled else 2 * m)
        lmi.parameter(f"P_{j}_{k}", (n + nz_ if s.hinf else n, width))
        if s.regions:
            lmi.parameter(f"Q_{j}_{k}", (n, width))

        def PX(v, j=j, k=k):
            # [2 q; 2 R] (H-infinity), or 2 q.
            return _pair(v, "P", j, k) @ _pair_variables(v, j, k, s.scheduled)

        if s.hinf:
            lmi.parameter(f"O_{j}_{k}", (size, size))

            def blocks(v, PX=PX, j=j, k=k, twice=twice):
                first = _stack([PX(v), below], 0)
                lower = _stack([first, twice * v.g[0, 0] * E, right], 1)
                return [[lower + _pair(v, "O", j, k)]]

            lmi.add(f"H-infinity {label}", blocks)
        else:
            # 2 q stands for q + q' (only the symmetric part counts).
            lmi.add(f"Lyapunov {label}", lambda v, PX=PX: [[PX(v)]])
            # With W <= I, sym(A_cl W) <= -t I guarantees a decay rate t / 2:
            # maximising t picks a well-damped point, not one on the boundary.
            lmi.add(
                f"decay {label}",
                lambda v, PX=PX, twice=twice: [[PX(v) + twice * v.t[0, 0] * np.eye(n)]],
                strict=False,
                stages=("stabilize",),
                normalization=True,
            )

        for r, (shape, entries) in enumerate(s.regions):
            M = np.array(entries).reshape(shape)

            def region_blocks(v, j=j, k=k, r=r, M=M, twice=twice):
                L = getattr(v, f"region{r}_L")
                q = _pair(v, "Q", j, k) @ _pair_variables(v, j, k, s.scheduled)
                return [[_region_block(L, M, v.W, q, twice)]]

            lmi.add(f"region {r} {label}", region_blocks)

    # Stage constraints (non-strict; they shape the point, not the proof).
    back = ("center", "gain")
    if s.hinf:
        lmi.add("g <= g_max", lambda v: [[v.g - v.g_max]], strict=False, stages=back)
    lmi.add(
        "W <= w_max I",
        lambda v: [[v.W - v.w_max * np.eye(n)]],
        strict=False,
        stages=("center",) if s.hinf else ("center", "stabilize"),
        normalization=True,
    )
    lmi.add(
        "W >= t I",
        lambda v: [[v.t[0, 0] * np.eye(n) - v.W]],
        strict=False,
        stages=("center", "stabilize"),
        normalization=True,
    )
    # The gain bound (see _gain_tangent) reads the state and input scalings
    # as constants: T W~ G0^-1 with the parameter G0^-1 is DPP, T as a
    # parameter would not be (a parameter on each side of a variable).
    # `_load` rebuilds the "gain" stage when they change; being powers of
    # two from a balancing they rarely do, and a weight sweep never does.
    scales = {"T": np.eye(n), "Su": np.eye(m)}
    lmi.parameter("gain_Ginv", (n, n))
    lmi.parameter("gain_Ginv_K", (n, n))
    lmi.parameter("kappa_max", nonneg=True)
    lmi.parameter("z_max", nonneg=True)
    for k in range(s.nZ):
        # The stabilization LMIs are homogeneous in (W, Z): W <= I together
        # with ||Z|| <= 1 fixes the scale and balances decay against gain;
        # larger z_max admit the smaller decays of badly scaled problems.
        lmi.add(
            f"||Z{k}||^2 <= z_max",
            lambda v, k=k: [[-v.z_max * np.eye(n)], [getattr(v, f"Z{k}"), -np.eye(m)]],
            strict=False,
            stages=("stabilize",),
            normalization=True,
        )
        # Normalised ||K_k||^2 <= kappa in original units (see _gain_tangent).
        lmi.add(
            f"||K{k}||^2 <= kappa",
            lambda v, k=k: [
                [
                    -(
                        scales["T"] @ v.W @ v.gain_Ginv
                        + v.gain_Ginv.T @ v.W @ scales["T"]
                        - np.eye(n)
                    )
                ],
                [
                    scales["Su"] @ getattr(v, f"Z{k}") @ v.gain_Ginv_K,
                    -v.kappa[0, 0] * np.eye(m),
                ],
            ],  # fmt: skip
            strict=False,
            stages=("gain",),
        )
    if s.gain_bound:
        lmi.add(
            "kappa <= kappa_max",
            lambda v: [[v.kappa - v.kappa_max * np.eye(1)]],
            strict=False,
            stages=("gain",),
        )
    return _Compiled(lmi, scales)


@dataclass
class _Compiled:
    """A cached problem: the LMIs and the constants its gain stage reads."""

    lmi: LMIProblem
    scales: dict


def _load(compiled, s: _Structure, data, scaling, regions, margin) -> None:
    """Set every parameter of a (possibly reused) problem for this call.

    All of them, stage bounds included, so that nothing of a previous call
    can leak into this one. See `_build` for the pair data.
    """
    lmi = compiled.lmi
    scales = {"T": np.diag(scaling.T), "Su": np.diag(scaling.Su)}
    if any(not np.array_equal(compiled.scales[k], v) for k, v in scales.items()):
        compiled.scales.update(scales)
        lmi.invalidate("gain")
    n, nw = s.n, s.nw
    for j, k in _pairs(s.N, s.scheduled):
        Aj, B1j, B2j, Cj, D1j, D2j = data[j]
        if j == k:
            twice, A, B1, C, D1 = 1.0, Aj, B1j, Cj, D1j
            B2, D2 = [B2j], [D2j]
        else:
            Ak, B1k, B2k, Ck, D1k, D2k = data[k]
            twice, A, B1, C, D1 = 2.0, Aj + Ak, B1j + B1k, Cj + Ck, D1j + D1k
            B2, D2 = [B2j, B2k], [D2j, D2k]
        Q = np.hstack([A, *B2])
        if s.regions:
            lmi.set_parameter(f"Q_{j}_{k}", Q)
        if not s.hinf:
            lmi.set_parameter(f"P_{j}_{k}", 2 * Q)
            continue
        R = np.hstack([C, *D2])
        lmi.set_parameter(f"P_{j}_{k}", np.vstack([2 * Q, 2 * R]))
        # The w rows: [2 B1', 2 D1', -c I] (blocks ordered x, z, w).
        nxz = n + s.nz
        offset = np.zeros((nxz + nw, nxz + nw))
        offset[nxz:, :n] = 2 * B1.T
        offset[nxz:, n:nxz] = 2 * D1.T
        offset[nxz:, nxz:] = -twice * np.eye(nw)
        lmi.set_parameter(f"O_{j}_{k}", offset)
    for r, region in enumerate(regions):
        lmi.set_parameter(f"region{r}_L", region.L)
    lmi.margin = margin
    if s.hinf:
        lmi.set_parameter("g_max", 1.0)
    lmi.set_parameter("w_max", 1.0)
    lmi.set_parameter("gain_Ginv", np.eye(s.n))
    lmi.set_parameter("gain_Ginv_K", np.eye(s.n))
    lmi.set_parameter("kappa_max", 1.0)
    lmi.set_parameter("z_max", 1.0)


def _validated_options(
    regions, backoff, gamma, gain_bound, margin, solvers, time_limit
):
    """Check the keyword options of the four functions at their boundary."""
    if isinstance(regions, LMIRegion):
        regions = (regions,)
    try:
        regions = tuple(regions)
    except TypeError:
        raise TypeError(
            f"regions: expected an LMIRegion or a sequence of them, got {regions!r}"
        ) from None
    for region in regions:
        if not isinstance(region, LMIRegion):
            raise TypeError(f"regions: expected LMIRegion objects, got {region!r}")
    backoff = real_number(backoff, "backoff", allow_none=True, minimum=0.0)
    # gamma^2 and gain_bound^2 must stay finite in float64.
    gamma = real_number(gamma, "gamma", allow_none=True, positive=True, below=1e150)
    gain_bound = real_number(gain_bound, "gain_bound", allow_none=True, positive=True)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    time_limit = real_number(time_limit, "time_limit", allow_none=True, positive=True)
    return (
        regions,
        backoff,
        gamma,
        gain_bound,
        margin,
        solver_chain(solvers),
        time_limit,
    )


def _guard_size(structure, time_limit=None) -> None:
    """Warn about, or refuse, a problem too large for this machine or time.

    cvxpy compiles each LMI in Python: measured here about 0.03-0.07 s per
    LMI of a vertex pair and 1e-2 s per thousand matrix entries, all stages
    together, so a scheduled design on 200 vertices (20,100 LMIs) takes
    about a quarter of an hour before any solver runs.
    """
    entries = structure.entries
    npairs = len(_pairs(structure.N, structure.scheduled))
    estimate = entries * _BYTES_PER_ENTRY
    seconds = _COMPILE_SECONDS_PER_LMI * npairs + _COMPILE_SECONDS_PER_ENTRY * entries
    text = (
        f"{npairs} LMIs of size up to {structure.lmi_size}, about {entries:,} "
        f"matrix entries, estimated {estimate / 2**30:.2g} GiB and "
        f"{seconds:.3g} s to compile"
    )
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        memory = None
    if memory is not None and estimate > 0.5 * memory:
        raise ValueError(
            f"sys: the problem is too large for this machine ({text}, more than "
            f"half of its {memory / 2**30:.3g} GiB); use fewer vertices or a "
            "common gain"
        )
    if structure in synthesis_cache:
        return  # compiled already: only the solver's time is left
    if time_limit is not None and seconds > time_limit:
        raise CertificationError(
            f"time_limit: no design tried, the problem would not compile within "
            f"{time_limit:g} s ({text})"
        )
    if seconds > _WARN_COMPILE_SECONDS:
        warnings.warn(
            f"large LMI problem: {text}; time_limit= bounds the whole call",
            ProblemSizeWarning,
            stacklevel=4,
        )


def _synthesize(
    sys, w, u, z, method, scheduled, gamma, regions, backoff, gain_bound, margin,
    solvers, time_limit=None, hinf=False,
):  # fmt: skip
    start = time.perf_counter()
    iw, iu, iz = _resolve_channels(sys, w, u, z, hinf)
    regions, backoff, gamma, gain_bound, margin, chain, time_limit = _validated_options(
        regions, backoff, gamma, gain_bound, margin, solvers, time_limit
    )
    suspects = check_stabilizability(sys, iu)
    deadline = None if time_limit is None else start + time_limit
    original = _vertex_channels(sys, iw, iu, iz)
    _guard_size(
        _Structure.of(original, hinf, scheduled, regions, gain_bound), time_limit
    )

    record: list[str] = []
    attempts: list[SolveAttempt] = []
    compiling = verifying = 0.0
    built = time.perf_counter()
    # The ladder: each solver in turn (the slow ones last), then the
    # prescalings, then the margins; the stages have rungs of their own.
    solver_rungs = [[entry] for entry in (chain or default_solvers())]
    if not solver_rungs:
        raise RuntimeError("no SDP solver installed: install clarabel or scs")
    scalings = list(_scalings(original))
    # The slower solvers after the first get the first prescaling and the
    # nominal margin only (SCS to 1e-9 takes seconds where Clarabel takes
    # milliseconds, and rarely certifies what Clarabel could not).
    rungs = [
        (solver_rungs[0], scaling, f) for scaling in scalings for f in _MARGIN_FACTORS
    ]
    rungs += [(one, scalings[0], _MARGIN_FACTORS[0]) for one in solver_rungs[1:]]
    for one_solver, (scaling_name, scaling), factor in rungs:
        rung = f"{one_solver[0][0]}, {scaling_name} scaling, margin {margin * factor:g}"
        if deadline is not None and time.perf_counter() > deadline:
            record.append(f"{rung}: not tried (time_limit {time_limit:g} s)")
            continue
        job = _Job(
            original, scaling, regions, scheduled, hinf, gamma, backoff,
            gain_bound, margin * factor, one_solver, deadline,
        )  # fmt: skip
        try:
            found = job.run(attempts)
        except InfeasibleError as exc:
            raise InfeasibleError(f"{method}: {exc}", attempts, exc.farkas) from None
        compiling += job.compiling
        verifying += job.verifying
        record.extend(f"{rung}: {note}" for note in job.notes)
        if found is None:
            continue
        point, gamma_opt = found
        solved = time.perf_counter()
        labels = sys.physical_inputs
        return StateFeedbackDesign(
            system=sys,
            method=method,
            gains=point.gains,
            P=point.P,
            gamma=point.gamma,
            gamma_opt=gamma_opt,
            w=tuple(labels[i] for i in iw),
            u=tuple(labels[i] for i in iu),
            z=tuple(sys.output_labels[i] for i in iz),
            certificate=point.certificate,
            attempts=tuple(attempts),
            timing={
                "build": built - start,
                "compile": compiling,
                "solve": solved - built - compiling - verifying,
                "verify": verifying,
            },
            backoff=backoff,
            regions=regions,
            ladder=tuple(record),
        )
    hint = "".join(f"; weakly controllable: {m}" for m in suspects)
    raise CertificationError(
        f"{method}: no certified solution found after {len(rungs)} rungs "
        f"(solvers {[one[0][0] for one in solver_rungs]}, prescalings "
        f"{[name for name, _ in scalings]}, margins "
        f"{[margin * f for f in _MARGIN_FACTORS]}); what failed: "
        + _summary(record)
        + hint,
        attempts,
    )


def _summary(record) -> str:
    """The ladder's notes without repeats (rung prefix dropped), counted."""
    counts: dict[str, int] = {}
    for note in record:
        reason = note.split(": ", 1)[-1]
        counts[reason] = counts.get(reason, 0) + 1
    return "; ".join(
        f"{reason} (x{count})" if count > 1 else reason
        for reason, count in counts.items()
    )


def _scalings(original):
    """Prescalings tried in turn: balanced, time scaling alone, none.

    The last keeps the model's units: a time scaling by the fastest mode
    leaves a mode 1e15 times slower no margin the solvers can see.
    """
    balanced = _Scaling.of(original)
    yield "balanced", balanced
    plain = _Scaling.of(original, balance=False)
    if not np.array_equal(plain.T, balanced.T):
        yield "unbalanced", plain
    A, _, B2, _, _, _ = original[0]
    none = _Scaling(np.ones(A.shape[0]), np.ones(B2.shape[1]), 1.0, 1.0, 1.0)
    if not (
        np.array_equal(none.T, plain.T)
        and np.array_equal(none.Su, plain.Su)
        and (none.sw, none.sz, none.a) == (plain.sw, plain.sz, plain.a)
    ):
        yield "none", none


@dataclass(frozen=True)
class _Point:
    """A fully verified point, in the model's units."""

    solution: object  # the LMISolution, in the scaled units of its job
    gains: tuple
    certificate: Certificate
    gamma: float | None
    P: np.ndarray


class _Job:
    """One rung of the ladder: a scaling and a margin, all stages.

    `run` returns ``(point, gamma_opt)`` for the best certified `_Point` of
    this rung, or None (`notes` says why); an
    `InfeasibleError` escapes only with a proof that needs no normalisation.
    """

    def __init__(
        self, original, scaling, regions, scheduled, hinf, gamma, backoff,
        gain_bound, margin, chain, deadline,
    ):  # fmt: skip
        self.original = original
        self.scaling = scaling
        self.data = [scaling.apply(v) for v in original]
        self.regions = tuple(r.time_scaled(scaling.a) for r in regions)
        self.scheduled = scheduled
        self.hinf = hinf
        self.gamma = gamma
        self.backoff = backoff
        self.gain_bound = gain_bound
        self.margin = margin
        self.chain = chain
        self.deadline = deadline
        self.structure = _Structure.of(self.data, hinf, scheduled, regions, gain_bound)
        self.notes: list[str] = []
        self.compiling = self.verifying = 0.0

    def run(self, attempts):
        s = self.structure
        with synthesis_cache.checkout(s, _build) as (compiled, _):
            _load(compiled, s, self.data, self.scaling, self.regions, self.margin)
            self.compiled = compiled
            self.lmi = compiled.lmi
            self.attempts = attempts
            if s.hinf:
                return self._hinf()
            return self._stabilize()

    # -- one solve -----------------------------------------------------
    def _solve(self, stage, objective, certify=True, proof=False):
        """Solve a stage; None if it gave no certified point.

        A verified infeasibility proof that needs no normalisation is
        re-raised when `proof` is set (the stage poses the user's problem
        itself, with its variables bounded by the data: a given gamma);
        otherwise it only ends this branch, and the note says what it
        proved.
        """
        lmi = self.lmi
        first = self.chain[0][0] if self.chain else None
        self.compiling += lmi.compile(stage, objective, first)
        try:
            sol = lmi.solve(
                objective, stage=stage, solvers=self.chain, certify=certify,
                deadline=self.deadline,
            )  # fmt: skip
        except InfeasibleError as exc:
            self.attempts.extend(exc.attempts)
            if proof and not exc.farkas.normalized:
                raise
            self.notes.append(f"{stage}: {exc.farkas}")
            return None
        except CertificationError as exc:
            self.attempts.extend(exc.attempts)
            self.notes.append(f"{stage}: {exc}")
            return None
        self.attempts.extend(sol.attempts)
        return sol

    def _accept(self, sol, label, bounded=False):
        """Full verification of a point: a `_Point`, or None.

        `bounded` also asks for the gain bound (met only after the gain
        stage, in general).
        """
        if sol is None or not sol.certified:
            return None
        scaling = self.scaling
        gains = tuple(
            scaling.unscale_K(-getattr(sol, f"Z{k}") @ np.linalg.inv(sol.W))
            for k in range(self.structure.nZ)
        )
        if bounded and self.gain_bound is not None:
            worst = max(np.linalg.norm(K, 2) for K in gains)
            if worst > self.gain_bound:
                self.notes.append(
                    f"{label}: gain norm {worst:.4g} above gain_bound "
                    f"{self.gain_bound:g}"
                )
                return None
        certified = (
            float(np.sqrt(scaling.unscale_g(float(sol.g[0, 0])))) if self.hinf else None
        )
        if self.hinf and self.gamma is not None:
            if not certified < self.gamma:
                self.notes.append(
                    f"{label}: certified gamma {certified:.8g} not below the "
                    f"required {self.gamma:.8g}"
                )
                return None
        started = time.perf_counter()
        # Inverted in scaled units, where W~ is well conditioned, then
        # scaled back exactly (powers of two).
        P = scaling.unscale_P(np.linalg.inv(sol.W))
        certificate = _verify(
            self.original, self.data, sol, gains, self.lmi.margin, self.scheduled,
            P, certified,
        )  # fmt: skip
        self.verifying += time.perf_counter() - started
        if not certificate.verified:
            self.notes.append(
                f"{label}: closed-loop verification failed ({certificate})"
            )
            return None
        return _Point(sol, gains, certificate, certified, P)

    # -- stage sequences -------------------------------------------------
    def _stabilize(self):
        lmi = self.lmi
        lmi.set_parameter("w_max", 1.0)
        best = None
        for z_max in _STABILIZE_Z_MAX:
            lmi.set_parameter("z_max", z_max)
            sol = self._solve("stabilize", lambda v: -v.t[0, 0], proof=True)
            best = self._accept(sol, f"stabilize (z_max {z_max:g})")
            if best is not None:
                break
        if best is None:
            return None
        if self.gain_bound is None:
            return best, None
        return self._minimise_gain(best, None)

    def _normalise_gamma(self, gamma) -> bool:
        """Rescale z so that ``gamma^2`` is about 1 in scaled units.

        A ``-g I`` block of 1e3 beside data of order one costs the solvers
        three digits (measured: Clarabel's "optimal" points then miss the
        H-infinity LMI by 1e-4). The scaling of z is exact (a power of two)
        and leaves ``W`` and ``Z`` unchanged; it is only ever made larger.
        Returns whether it changed.
        """
        sz = _pow2(gamma * self.scaling.sw)
        if sz <= self.scaling.sz:
            # Only shrink z: a tiny gamma would blow its rows up instead.
            return False
        self.scaling = dataclasses.replace(self.scaling, sz=sz)
        self.data = [self.scaling.apply(v) for v in self.original]
        _load(
            self.compiled, self.structure, self.data, self.scaling, self.regions,
            self.margin,
        )  # fmt: skip
        return True

    def _hinf(self):
        lmi = self.lmi
        if self.gamma is not None:
            # A required gamma, posed slightly below so it is met strictly.
            self._normalise_gamma(self.gamma)
            to_scaled = (self.scaling.sw / self.scaling.sz) ** 2
            best = None
            for slack in _GAMMA_SLACK:
                lmi.set_parameter("g_max", self.gamma**2 * to_scaled * (1 - slack))
                for w_max in _FIXED_GAMMA_W_MAX:
                    lmi.set_parameter("w_max", w_max)
                    sol = self._solve("center", lambda v: -v.t[0, 0], proof=True)
                    best = self._accept(sol, f"gamma given (w_max {w_max:g})")
                    if best is not None:
                        break
                if best is not None:
                    break
            if best is None:
                return None
            if self.backoff is None and self.gain_bound is None:
                return best, None
            return self._minimise_gain(best, None)

        # Not a proof stage: gamma is free, so a certificate that excludes a
        # ball of (W, Z, gamma^2) leaves designs with a huge gamma possible.
        raw = self._solve("optimal", lambda v: v.g[0, 0], certify=False)
        if raw is None:
            return None
        # gamma* from the nominal-margin point, even when the raw point only
        # certified with a larger margin (and so a larger gamma).
        g_opt = float((raw.nominal or raw).g[0, 0])
        if not (np.isfinite(g_opt) and g_opt > 0):
            self.notes.append(
                f"optimal: the solver's gamma^2 = {g_opt:g} is not positive"
            )
            return None
        if abs(np.log2(g_opt)) > 2:
            # The stages after this one are posed with gamma^2 about 1. The
            # raw point stays as it is: W and Z do not depend on z's scale.
            old_sz = self.scaling.sz
            self._normalise_gamma(float(np.sqrt(self.scaling.unscale_g(g_opt))))
            rescale = (old_sz / self.scaling.sz) ** 2
            g_opt *= rescale
            raw.values["g"] = raw.values["g"] * rescale
        gamma_opt = float(np.sqrt(self.scaling.unscale_g(g_opt)))
        raw_design = self._accept(raw, "raw optimum")
        if not self.backoff:
            if raw_design is not None:
                if self.gain_bound is None:
                    return raw_design, gamma_opt
                return self._minimise_gain(raw_design, gamma_opt)
            self.notes.append("raw optimum: not certified; backing off")
            factors = (1.001, 1.01, 1.05, 1.2)
        else:
            b = self.backoff
            factors = (1 + b, 1 + b / 2, 1 + b / 8, 1 + 2 * b)
        w_star = max(float(np.linalg.eigvalsh(raw.W)[-1]), 1e-12)
        best = None
        for factor in factors:
            lmi.set_parameter("g_max", g_opt * factor**2)
            for w_max in (w_star, 1e3 * w_star):
                lmi.set_parameter("w_max", w_max)
                sol = self._solve("center", lambda v: -v.t[0, 0])
                best = self._accept(sol, f"back-off x{factor:g} (w_max {w_max:.3g})")
                if best is not None:
                    break
            if best is not None:
                break
        if best is None:
            if raw_design is None:
                return None
            self.notes.append("back-off: no certified point; the raw optimum is kept")
            best = raw_design
            lmi.set_parameter("g_max", g_opt * (1 + 1e-9))
        if not self.backoff and self.gain_bound is None:
            return best, gamma_opt
        return self._minimise_gain(best, gamma_opt)

    def _minimise_gain(self, best, gamma_opt):
        """Convex-concave gain iterations from a certified point.

        Returns the design tuple with `gamma_opt`, or None if a gain bound
        is not met by any certified point.
        """
        s = self.structure
        for _ in range(_GAIN_ITERATIONS):
            sol = best.solution
            Z = [getattr(sol, f"Z{k}") for k in range(s.nZ)]
            _gain_tangent(self.lmi, self.scaling, sol.W, Z, self.gain_bound)
            candidate = self._accept(
                self._solve("gain", lambda v: v.kappa[0, 0]), "gain stage"
            )
            if candidate is None:
                break  # the previous point is certified: keep it
            best = candidate
            # kappa is relative to the previous point's squared gain.
            if float(candidate.solution.kappa[0, 0]) > 1 - _GAIN_RTOL:
                break
        if self._accept(best.solution, "final point", bounded=True) is None:
            return None
        return best, gamma_opt


def _gain_tangent(lmi, scaling, W, Z, gain_bound):
    """Linearise the gain bound at the scaled point ``(W, Z)``.

    ``K = Su Z~ W~^-1 T^-1``, so ``||K||^2 <= kappa0 kappa`` iff
    ``(Su Z~)'(Su Z~) <= kappa0 kappa (T W~)'(T W~)``. The right side is
    bounded below by its tangent at ``G0 = T W~0``,
    ``G0' T W~ + W~ T G0 - G0' G0``, linear in ``W~`` and exact at ``W~0``;
    by a Schur complement the bound is then an LMI, sufficient everywhere
    and tight at ``W~0``. The congruence with ``G0^-1`` makes it well
    conditioned (the identity at ``W~0``) and ``kappa0``, the squared gain at
    ``(W, Z)``, makes ``kappa`` of order one. Re-linearising at each new
    point (a convex-concave iteration) lowers the gain monotonically.

    Returns
    -------
    float
        ``kappa0``.
    """
    Ginv = np.linalg.inv(scaling.T[:, None] * W)
    Winv = np.linalg.inv(W)
    kappa0 = max(
        float(np.linalg.norm(scaling.unscale_K(Zk @ Winv), 2)) ** 2 for Zk in Z
    )
    lmi.set_parameter("gain_Ginv", Ginv)
    lmi.set_parameter("gain_Ginv_K", Ginv / np.sqrt(kappa0))
    if gain_bound is not None:
        # A bound far above the current gain is inactive: cap it in float64.
        ratio = min(gain_bound / np.sqrt(kappa0), 1e100)
        lmi.set_parameter("kappa_max", ratio**2)
    return kappa0


def _verify(original, data, sol, gains, margin, scheduled, P, gamma) -> Certificate:
    """Independent float64 checks of the returned point (see module doc)."""
    N = len(original)
    rng = np.random.default_rng(12345)
    deltas = list(np.eye(N))
    if N > 1:
        deltas += list(rng.dirichlet(np.ones(N), size=_VERIFY_SAMPLES))
        deltas += [0.5 * (np.eye(N)[j] + np.eye(N)[k]) for j, k in _pairs(N, True)[N:]]
    deltas = np.array(deltas)
    W = sol.W
    Winv = np.linalg.inv(W)
    Kstack = np.stack(gains)
    Ktilde = np.stack([-getattr(sol, f"Z{k}") @ Winv for k in range(len(gains))])

    def at(stack):
        # Frozen matrices at every point at once: shape (points, rows, cols).
        return np.einsum("pj,jab->pab", deltas, np.stack(stack))

    K = at(Kstack) if scheduled else Kstack[0]
    A = at([v[0] for v in original])
    B = at([v[2] for v in original])
    max_real = np.linalg.eigvals(A - B @ K).real.max()
    Kt = at(Ktilde) if scheduled else Ktilde[0]
    At = at([v[0] for v in data])
    Bt = at([v[2] for v in data])
    Acl_W = (At - Bt @ Kt) @ W
    lyap = np.linalg.eigvalsh(Acl_W + np.swapaxes(Acl_W, 1, 2))[:, -1]
    Acl = A - B @ K
    PA = P @ Acl
    if gamma is None:
        M = PA + np.swapaxes(PA, 1, 2)
    else:
        # The bounded-real inequality with the returned P and gamma, in the
        # model's units: what a user can check with the design alone.
        B1 = at([v[1] for v in original])
        Ccl = at([v[3] for v in original]) - at([v[5] for v in original]) @ K
        D1 = at([v[4] for v in original])
        npts, nw, nz = len(deltas), B1.shape[2], Ccl.shape[1]
        M = np.block([
            [PA + np.swapaxes(PA, 1, 2), P @ B1, np.swapaxes(Ccl, 1, 2)],
            [np.swapaxes(P @ B1, 1, 2), np.broadcast_to(-np.eye(nw), (npts, nw, nw)),
             np.swapaxes(D1, 1, 2)],
            [Ccl, D1, np.broadcast_to(-gamma**2 * np.eye(nz), (npts, nz, nz))],
        ])  # fmt: skip
    return Certificate(
        lmi_checks=sol.checks,
        margin=margin,
        max_closed_loop_real=float(max_real),
        max_lyapunov_eig=float(lyap.max() / np.linalg.norm(W, 2)),
        npoints=len(deltas),
        max_original_eig=_normalized_max_eig(M),
    )


def _normalized_max_eig(M) -> float:
    """Largest ``lambda_max(D M D)`` over a stack, ``D = |diag M|^-1/2``.

    The Jacobi normalisation makes the test scale-free; a nonnegative
    diagonal entry (no strict inequality possible) gives ``inf``.
    """
    diag = np.diagonal(M, axis1=1, axis2=2)
    if not np.all(diag < 0):
        return float("inf")
    d = 1.0 / np.sqrt(-diag)
    return float(np.linalg.eigvalsh(M * d[:, :, None] * d[:, None, :])[:, -1].max())
