"""State feedback under actuator saturation with a certified region.

Plant (polytopic, ``delta(t)`` anywhere in the polytope, possibly varying;
continuous or discrete time):

.. math::

    \\dot x \\;(x^+) = A(\\delta) x + B(\\delta) \\operatorname{sat}_{u_0}(u)
    + E(\\delta) w, \\qquad u = -K x, \\qquad |w_i| \\le w_{max,i},

with ``sat_u0(u)_i = sign(u_i) min(|u_i|, u0_i)``. The certificate is the
generalized sector condition (Tarbouriech, Garcia, Gomes da Silva and
Queinnec, 2011, chapters 1 and 3; Gomes da Silva and Tarbouriech, IEEE TAC
50(1), 2005) of `ctrl_lpv.synthesis.constraints.Saturation`: on
``E = {x : x' P x <= 1}`` every trajectory obeys ``dV/dt <= -(2 sigma +
lambda) (V - rho)`` (discrete time: ``V(x+) - V(x) <= -(1 - exp(-2 sigma
dt) + lambda) (V(x) - rho)``), ``rho <= 1``: ``E`` is invariant for every
admissible ``w`` and ``delta(t)``, and with ``w = 0`` it lies in the region
of attraction with ``V`` decaying at least as ``exp(-2 sigma t)``.

Both public functions are thin wrappers of the one engine
(`ctrl_lpv.synthesis.general`): the objective is the ellipsoid's size
(`ctrl_lpv.synthesis.region.RegionSize`), the constraint the sector
condition; the prescalings, margins, solvers, certificate and refusals are
the engine's (`ctrl_lpv._saturated` makes the calls).

Public names
------------
``SaturatedDesign``, ``saturated_state_feedback``, ``saturation_region``::

    saturated_state_feedback(sys, u, u_max, *, shape=None, points=None,
        output=None, beta_min=None, decay=0.0, w=None, w_max=None,
        gains="common", backoff=0.1, margin=1e-6, solvers=None)
        -> SaturatedDesign
    saturation_region(sys, gain, u, u_max, *, shape=None, points=None,
        output=None, beta_min=None, decay=0.0, w=None, w_max=None,
        margin=1e-6, solvers=None)
        -> SaturatedDesign            # analysis of a given u = -K x
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from control import StateSpace

from . import _saturated
from ._checks import real_number, signal_indices
from .budget import DEFAULT_TIME_LIMIT, time_budget
from .certificate import Certificate
from .lmi import SolveAttempt, solver_chain
from .reachability import Ellipsoid
from .synthesis import StateFeedbackDesign
from .synthesis.results import frozen_loop
from .systems import PolytopicStateSpace

__all__ = ["SaturatedDesign", "saturated_state_feedback", "saturation_region"]


@dataclass(frozen=True)
class SaturatedDesign:
    """Certified state feedback (or analysis) under input saturation.

    ``controller()`` gives ``u = -K x`` as for `StateFeedbackDesign`; its
    output is not clipped (the saturation is the plant's).

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The plant model.
    u : tuple of str
        Saturated control inputs.
    u_max : ndarray
        Saturation levels ``|sat(u)_i| <= u_max_i``.
    gains : tuple of ndarray
        ``m x n`` gains of ``u = -K x``: one common gain or one per vertex.
    G : tuple of ndarray
        Gains of the generalized sector condition (one per gain).
    P : ndarray
        Lyapunov matrix (original units).
    ellipsoid : `Ellipsoid`
        ``{x : x' P x <= 1}``: invariant for every admissible ``w`` and
        ``delta(t)``, inside the region of attraction for ``w = 0``.
    ultimate : `Ellipsoid` or None
        ``{x : x' P x <= rho}``, where trajectories end up (None without
        ``w``).
    rho : float
        Level of `ultimate` (0 without ``w``).
    beta : float
        Largest factor with ``beta * shape`` inside `ellipsoid` (for
        `points`: every ``beta * v_k`` inside).
    beta_opt : float or None
        The solver's optimum before back-off (an estimate; None when the
        objective was an output size).
    decay : float
        Certified rate ``sigma`` (1/s, also for a sampled plant):
        ``V(t) <= V(0) exp(-2 sigma t)`` for ``w = 0`` inside `ellipsoid`
        (at least the requested one; the back-off raises it).
    lam : float
        S-procedure rate ``lambda`` of the disturbance (0 without ``w``).
    w : tuple of str
        Peak-bounded disturbance inputs.
    w_max : ndarray
        Their bounds.
    certificate : `ctrl_lpv.certificate.Certificate`
        The engine's certificate (the LMIs as posed, and the frozen loops'
        checks in the model's units); for a loaded design the float64
        sector, inclusion and level checks recomputed from the file.
    capped : bool
        Whether the ellipsoid touched the size cap (``W <= 1e4 W_ref``,
        `ctrl_lpv.synthesis.region.RegionSize`: the true certified region
        may then be larger than stated).
    designed : bool
        False for an analysis (`saturation_region`) of a given gain.
    attempts : tuple of `ctrl_lpv.lmi.SolveAttempt`
        Solver attempts of the final solve.
    T : ndarray or None
        Diagonal multiplier of the sector condition (original units).
    mu : ndarray or None
        S-procedure multipliers of the disturbance bounds (empty without
        ``w``).
    shape, points : ndarray or None
        The reference set of `beta`: ``R`` of ``{x'Rx <= 1}``, or the rows
        ``v_k`` (one of them is None).
    ladder : tuple of str
        What the engine's rungs tried (empty for a loaded design).
    """

    system: PolytopicStateSpace
    u: tuple[str, ...]
    u_max: np.ndarray
    gains: tuple[np.ndarray, ...]
    G: tuple[np.ndarray, ...]
    P: np.ndarray
    ellipsoid: Ellipsoid
    ultimate: Ellipsoid | None
    rho: float
    beta: float
    beta_opt: float | None
    decay: float
    lam: float
    w: tuple[str, ...]
    w_max: np.ndarray
    certificate: Certificate
    capped: bool = False
    designed: bool = True
    attempts: tuple[SolveAttempt, ...] = field(default_factory=tuple)
    T: np.ndarray | None = None
    mu: np.ndarray | None = None
    shape: np.ndarray | None = None
    points: np.ndarray | None = None
    ladder: tuple = field(default=(), compare=False)

    @property
    def scheduled(self) -> bool:
        """Whether the design has one gain per vertex."""
        return len(self.gains) > 1

    @property
    def states(self) -> tuple[str, ...]:
        """State labels (the measured signals of the controller)."""
        return tuple(self.system.state_labels)

    def gain(self, p=None) -> np.ndarray:
        """Gain ``K(delta(p))`` (``p`` ignored for a common gain)."""
        if not self.scheduled:
            return self.gains[0].copy()
        if p is None:
            raise ValueError("p: a scheduled design needs the parameter value")
        return np.tensordot(self.system.weights(p), np.stack(self.gains), axes=1)

    # The same controller as for any state-feedback design. Its output is
    # not clipped: the saturation ``sat_u0`` is the plant's (or a saturation
    # block placed before the plant input).
    controller = StateFeedbackDesign.controller

    def closed_loop_vertices(self) -> tuple[np.ndarray, ...]:
        """Linear closed loops ``A_j - B_j K_j`` (or the common ``K``).

        For vertex gains the closed loop is quadratic in ``delta``; the
        matrices ``A_j - B_j K_j`` are its values at the vertices only.
        """
        iu = signal_indices(list(self.u), self.system.physical_inputs, "u")
        out = []
        for j, (A, B, _, _) in enumerate(self.system.vertex_data()):
            K = self.gains[j] if self.scheduled else self.gains[0]
            out.append(A - B[:, iu] @ K)
        return tuple(out)

    def closed_loop(self, p) -> StateSpace:
        """Frozen linear closed loop from `w` to the plant's outputs at `p`.

        ``x' = (A - B_u K) x + B_w w``, ``y = (C - D_u K) x + D_w w``: the
        loop while no input saturates (inside `ellipsoid` the saturated
        loop is certified, not this one).

        Parameters
        ----------
        p : array_like or mapping
            Parameter value (for a simplex domain: the convex coordinates).

        Returns
        -------
        `control.StateSpace`
            Inputs named after `w`, outputs after the plant's outputs,
            states after its states. Without `w` the inputs are the
            control inputs, as an additive ``v`` in ``u = -K x + v``
            (python-control has no system without inputs).
        """
        sys = self.system
        iu = signal_indices(list(self.u), sys.physical_inputs, "u")
        iw = signal_indices(list(self.w), sys.physical_inputs, "w")
        return frozen_loop(sys, p, self.gain(p), iu, iw, [])

    def save(self, path):
        """Write the design and its plant to a JSON file (atomically).

        `ctrl_lpv.load` reads it back and recomputes every float64 check
        of `certificate` against the plant rebuilt from the file (see
        `ctrl_lpv.persistence`).

        Parameters
        ----------
        path : str or path-like
            File to write; its folder must exist.

        Returns
        -------
        `pathlib.Path`
            The file written.
        """
        from .persistence import save

        return save(self, path)

    def support(self, c) -> np.ndarray:
        """``max |c' x|`` over `ellipsoid`, per row of `c`."""
        return self.ellipsoid.support(c)

    def __str__(self) -> str:
        kind = "design" if self.designed else "analysis"
        lines = [
            f"SaturatedDesign ({kind}, "
            f"{'vertex gains' if self.scheduled else 'common gain'}, u = -K x, "
            f"|u| <= {np.array2string(self.u_max, precision=4)})",
            f"  region: x'Px <= 1 contains beta * shape, beta = {self.beta:.5g}"
            + (" (size cap reached)" if self.capped else ""),
            f"  decay sigma = {self.decay:.4g} 1/s",
        ]
        if self.w:
            lines.append(
                f"  w = {list(self.w)} with |w| <= {self.w_max}: invariant, "
                f"ultimate level rho = {self.rho:.4g} (lambda = {self.lam:.4g})"
            )
        with np.printoptions(precision=5, linewidth=100):
            for j, K in enumerate(self.gains):
                label = f"K[{j}]" if self.scheduled else "K"
                lines.append(f"  {label} = {np.array2string(K, prefix='  K = ')}")
        lines.append(f"  certificate: {self.certificate.summary}")
        return "\n".join(lines)


# ----------------------------------------------------------------------
# Public functions
# ----------------------------------------------------------------------
@time_budget
def saturated_state_feedback(
    sys: PolytopicStateSpace,
    u,
    u_max,
    *,
    shape=None,
    points=None,
    output=None,
    beta_min: float | None = None,
    decay: float = 0.0,
    w=None,
    w_max=None,
    gains: str = "common",
    backoff: float | None = 0.1,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> SaturatedDesign:
    """State feedback with a certified region under saturation.

    Maximises ``beta`` such that ``beta * shape`` (the ellipsoid ``{x :
    x' R x <= 1}`` of ``R = shape``, or the points ``beta * v_k``) lies in
    an ellipsoid ``{x' P x <= 1}`` that is contractive for the saturated
    closed loop at every vertex (generalized sector condition; see the
    module docstring), then backs off. A thin wrapper of the engine:
    `ctrl_lpv.synthesis.region.RegionSize` objective,
    `ctrl_lpv.Saturation` constraint.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Continuous- or discrete-time plant (``dt > 0``: the discrete-time
        sector condition); all states are measured.
    u : str, int or list
        Saturated control inputs.
    u_max : float or array_like
        Saturation levels, one per control input.
    shape : array_like, optional
        ``n x n`` positive definite ``R`` of the reference set ``{x' R x <=
        1}`` (default the identity: a ball in the model's units).
    points : array_like, optional
        Instead of `shape`: rows ``v_k`` (directions) that must be inside.
    output : str, int, list or array_like, optional
        Instead of the largest region: the smallest invariant ellipsoid
        along these outputs (names or indices of ``sys``'s outputs, or rows
        ``C`` on the state), minimising ``max_i c_i' P^-1 c_i / ||c_i||^2``.
        Needs `w`: it is the ultimate bound under saturation, certified for
        trajectories that start inside it. `beta` is still reported.
    beta_min : float, optional
        With `output`: keep ``beta_min * shape`` (or the points) inside the
        ellipsoid, so that it is also a region for the initial states.
    decay : float, optional
        Required rate ``sigma >= 0`` (1/s, also for a sampled plant): ``V``
        decays at least as ``exp(-2 sigma t)`` inside the region (``w =
        0``).
    w : str, int or list, optional
        Peak-bounded disturbance inputs (the region is then also invariant
        for every ``|w_i(t)| <= w_max_i``).
    w_max : float or array_like, optional
        Their bounds (required with `w`).
    gains : {"common", "scheduled"}, optional
        One gain for the whole polytope (implementable without knowing the
        parameter), or vertex gains ``K(delta) = sum_j delta_j K_j``.
    backoff : float or None, optional
        Keep ``beta >= beta* / (1 + backoff)`` (with `output`: the size at
        most ``1 + backoff`` times the optimum) and spend the slack: find
        the largest decay ``sigma_max`` whose optimum stays within it, then
        the engine's smallest gain under that bound at the decay halfway
        between the requested one and ``sigma_max``
        (`SaturatedDesign.decay` is that certified rate). None for the raw
        optimum at the requested decay.
    margin : float, optional
        Margin of the strict LMIs in the prescaled units, in ``(0, 1)``;
        default 1e-6.
    solvers : str or sequence, optional
        A solver name (e.g. ``"CLARABEL"``, ``"SCS"``), or names or
        ``(name, options)`` pairs tried in turn, as for `synthesize` (the
        engine's ladder). With `w`, the engine's search of the
        S-procedure rate ``lambda`` uses the first solver only (the whole
        list if it finds nothing).
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `SaturatedDesign`

    Raises
    ------
    InfeasibleError
        A vertex is not stabilizable from `u`, or the solvers report the
        LMIs infeasible.
    CertificationError
        No returned point passed the float64 checks.
    ValueError, TypeError
        For bad arguments.

    Examples
    --------
    >>> import control as ct
    >>> plant = PolytopicStateSpace([ct.ss([[1.0]], [[1.0]], [[1.0]], 0)])
    >>> d = saturated_state_feedback(plant, u=0, u_max=1.0)
    >>> 0.9 < d.beta < 1.0    # true region of attraction: |x| < 1
    True
    """
    if not isinstance(gains, str) or gains not in ("common", "scheduled"):
        raise ValueError(f"gains: expected 'common' or 'scheduled', got {gains!r}")
    backoff = real_number(backoff, "backoff", allow_none=True, minimum=0.0)
    call = _saturated.prepare(
        sys, u, u_max, shape, points, output, beta_min, decay, w, w_max, margin
    )
    scheduled = gains == "scheduled" and sys.nvertices > 1
    return _saturated.design(call, scheduled, backoff, solver_chain(solvers))


@time_budget
def saturation_region(
    sys: PolytopicStateSpace,
    gain,
    u,
    u_max,
    *,
    shape=None,
    points=None,
    output=None,
    beta_min: float | None = None,
    decay: float = 0.0,
    w=None,
    w_max=None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> SaturatedDesign:
    """Certified region of ``u = -K x`` under input saturation.

    The analysis counterpart of `saturated_state_feedback`: the gain is
    given, and the largest ``beta`` with ``beta * shape`` inside a
    contractive ellipsoid of the saturated polytopic closed loop is found
    (the engine with fixed gains: ``Z = -K W``, a constant ``W``).

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Continuous- or discrete-time plant.
    gain : array_like or sequence of array_like
        ``m x n`` gain of ``u = -K x``, or one per vertex (scheduled).
    u : str, int or list
        Saturated control inputs (names or indices of the physical inputs),
        one per row of the gain.
    u_max : float or array_like
        Saturation levels ``u_max_i > 0``, one per control input (a scalar
        for all).
    shape : array_like, optional
        ``n x n`` positive definite ``R`` of the reference set ``{x' R x <=
        1}`` whose largest multiple ``beta * shape`` is certified (default
        the identity: a ball in the model's units).
    points : array_like, optional
        Instead of `shape`: nonzero rows ``v_k`` (one state vector each);
        ``beta`` is then the largest factor with every ``beta * v_k``
        inside the region.
    output : str, int, list or array_like, optional
        Instead of the largest region: the smallest invariant ellipsoid
        along these outputs (names or indices of ``sys``'s outputs, or rows
        ``C`` on the state), minimising ``max_i c_i' P^-1 c_i / ||c_i||^2``:
        the ultimate bound of the saturated loop, certified for
        trajectories that start inside it. Needs `w`.
    beta_min : float, optional
        Only with `output`: keep ``beta_min * shape`` (or the points)
        inside the ellipsoid, so that it is also a region for the initial
        states.
    decay : float, optional
        Required rate ``sigma >= 0`` (1/s, default 0): ``V = x' P x``
        decays at least as ``exp(-2 sigma t)`` inside the region for ``w =
        0``.
    w : str, int or list, optional
        Peak-bounded disturbance inputs (names or indices, disjoint from
        `u`): the region is then also invariant for every
        ``|w_i(t)| <= w_max_i``.
    w_max : float or array_like, optional
        Positive bounds of `w`, one per input (a scalar for all); required
        with `w`, refused without it.
    margin : float, optional
        Margin of the strict LMIs in the prescaled units, in ``(0, 1)``;
        default 1e-6.
    solvers : str or sequence, optional
        A solver name, or names or ``(name, options)`` pairs tried in turn,
        as for `synthesize` (the engine's ladder).
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `SaturatedDesign`
        With ``designed=False``.

    Raises
    ------
    InfeasibleError
        A vertex of the linear closed loop is not asymptotically stable, or
        the engine proves the LMIs infeasible.
    CertificationError
        No returned point passed the float64 checks.
    ValueError, TypeError
        For bad arguments.
    """
    call = _saturated.prepare(
        sys, u, u_max, shape, points, output, beta_min, decay, w, w_max, margin
    )
    fixed = _saturated.given_gains(call, gain)
    return _saturated.analysis(call, fixed, solver_chain(solvers))
