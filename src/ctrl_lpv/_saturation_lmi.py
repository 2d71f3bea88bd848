"""The hand-built saturation LMI pipeline, kept for the gate of issue 20 only.

The public `ctrl_lpv.saturation` runs on the one engine; this copy of its
old body (prescaling, line search, back-off, verifier) is compared with it
in tests/test_saturation_engine.py and deleted after that commit.

State feedback under actuator saturation with a certified region.

Plant (polytopic, ``delta(t)`` anywhere in the simplex, possibly varying):

.. math::

    \\dot x = A(\\delta) x + B(\\delta) \\operatorname{sat}_{u_0}(u)
    + E(\\delta) w, \\qquad u = -K x, \\qquad |w_i| \\le w_{max,i},

with ``sat_u0(u)_i = sign(u_i) min(|u_i|, u0_i)`` and the dead zone
``psi(u) = u - sat(u)``. The generalized sector condition (Tarbouriech,
Garcia, Gomes da Silva and Queinnec, 2011, chapters 1 and 3; Gomes da
Silva and Tarbouriech, IEEE TAC 50(1), 2005): if ``|((K - G) x)_i| <= u0_i`` then
``psi' T (psi + G x) <= 0`` for every diagonal ``T > 0`` (our sign
convention ``u = -K x``; the book writes ``u = K x`` and ``-G``). With
``W = P^-1``, ``Y = K W``, ``Z = G W`` and ``S = T^-1`` diagonal, the LMIs

.. math::

    \\begin{bmatrix}
    A_j W - B_j Y + (\\cdot)' + (2\\sigma + \\lambda) W & -B_j S - Z' & E_j D \\\\
    \\cdot & -2 S & 0 \\\\ \\cdot & \\cdot & -\\operatorname{diag}(\\mu)
    \\end{bmatrix} \\prec 0, \\quad
    \\begin{bmatrix} W & (Y_i - Z_i)' \\\\ \\cdot & u_{0,i}^2 \\end{bmatrix}
    \\succ 0, \\quad \\textstyle\\sum_i \\mu_i < \\lambda

(``D = diag(w_max)``; without ``w`` the last row and column, ``lambda`` and
``mu`` are dropped) prove that on ``E = {x : x' P x <= 1}`` every trajectory
obeys ``dV/dt <= -(2 sigma + lambda) (V - rho)``, ``rho = sum(mu) / (2 sigma
+ lambda) < 1``: ``E`` is invariant for every admissible ``w`` and
``delta(t)``, trajectories end in ``{V <= rho}``, and with ``w = 0`` ``E``
lies in the region of attraction with ``V`` decaying at least as
``exp(-2 sigma t)``.

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

`SaturatedDesign` has ``.gains`` (``u = -K x``), ``.P``, ``.ellipsoid``
(``{x'Px <= 1}``), ``.ultimate`` (``{x'Px <= rho}``), ``.beta`` (``beta *
shape`` lies in the ellipsoid), ``.G``, ``.certificate`` and
``.controller()`` (a `ctrl_lpv.state_feedback` I/O system; the saturation
itself belongs to the plant) and ``.closed_loop_vertices()``.

Numerical policy: the data are prescaled (states by the shape or the
points, inputs by ``u_max``, disturbances by ``w_max``, time by the data
norm; powers of two except the input levels), strict LMIs get a margin in
those units, and the returned point is re-verified in float64 in the
original units from the final ``K, G, P, T`` (every vertex or vertex pair
after Jacobi normalisation against a rounding bound, every inclusion
ratio). A point that misses is retried with the states rescaled from its
``W``; a failing point is never returned: `CertificationError`;
`InfeasibleError` only for a vertex that is not stabilizable (PBH) or when
every solver reports infeasibility.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from ._checks import (
    as_matrix,
    per_input,
    positive_levels,
    real_number,
    signal_indices,
)
from .budget import DEFAULT_TIME_LIMIT, time_budget
from .exceptions import CertificationError, InfeasibleError, SynthesisError
from .lmi import LMIProblem, default_solvers, solver_chain
from .lmi.blocks import diagonal, quadratic_rows, total
from .reachability import (
    Ellipsoid,
    EllipsoidCertificate,
    EllipsoidCheck,
    _line_search,
    _positive_check,
    _pow2,
    _strict_check,
)
from .saturation import SaturatedDesign
from .systems import PolytopicStateSpace

__all__ = ["_old_saturated_state_feedback", "_old_saturation_region"]

# Bound W~ <= _W_CAP I in scaled units: keeps a region that could be
# unbounded (a stable plant) finite; `SaturatedDesign.capped` reports it.
_W_CAP = 1e3
# Line search grid of lambda (scaled units) when w is given.
_LAMBDA_GRID = np.geomspace(1e-3, 4.0, 9)
# Back-off decay search (scaled units): first trial, limit, bisections.
_DECAY_START = 1e-3
_DECAY_MAX = 4.0
_DECAY_BISECTIONS = 6
# State rescalings tried after a point misses its certificate.
_RESCALES = 2


# ----------------------------------------------------------------------
# Argument handling and prescaling
# ----------------------------------------------------------------------
def _positive_vector(value, size, name):
    """Positive levels, one per input (a single level for all)."""
    levels = positive_levels(np.ravel(np.asarray(value, dtype=object)), name)
    return per_input(levels, size, name, "inputs")


def _region_target(shape, points, n):
    if shape is not None and points is not None:
        raise ValueError("shape, points: give one of them, not both")
    if points is not None:
        V = as_matrix(points, "points")
        if V.shape[1] != n:
            if V.shape[0] == n:
                V = V.T
            else:
                raise ValueError(f"points: expected rows of {n} entries, got {V.shape}")
        if np.any(np.all(V == 0, axis=1)):
            raise ValueError("points: a point is zero")
        return None, V
    R = np.eye(n) if shape is None else as_matrix(shape, "shape", (n, n))
    R = 0.5 * (R + R.T)
    if np.linalg.eigvalsh(R)[0] <= 0:
        raise ValueError("shape: must be a symmetric positive definite matrix")
    return R, None


@dataclass(frozen=True)
class _Scaled:
    T: np.ndarray  # x = T x~
    U: np.ndarray  # u = U u~ (U = u_max)
    a: float  # tau = a t
    A: list
    B: list
    E: list
    R: np.ndarray | None
    V: np.ndarray | None
    C: np.ndarray | None = None  # output rows (scaled) for objective "output"
    beta_min: float | None = None  # region kept with the output objective


def _prescale(As, Bs, Es, u_max, w_max, R, V, T=None, C=None, beta_min=None):
    n = As[0].shape[0]
    if T is not None:
        T = np.asarray(T, float)
    elif R is not None:
        T = np.array([_pow2(1.0 / np.sqrt(R[i, i])) for i in range(n)])
    else:
        T = np.array([_pow2(np.abs(V[:, i]).max()) for i in range(n)])
    At = [A * T / T[:, None] for A in As]
    Bt = [B * u_max / T[:, None] for B in Bs]
    a = _pow2(max(np.linalg.norm(np.hstack([A, B]), 2) for A, B in zip(At, Bt)))
    Et = [E * w_max / T[:, None] / a for E in Es] if Es else []
    Rt = None if R is None else T[:, None] * R * T
    Vt = None if V is None else V / T
    Ct = None if C is None else C * T
    return _Scaled(
        T, u_max, a, [A / a for A in At], [B / a for B in Bt], Et, Rt, Vt, Ct, beta_min
    )


def _output_rows(sys, output):
    """Rows ``C`` of the outputs to keep small: names/indices or a matrix."""
    labels = tuple(sys.output_labels)
    names = isinstance(output, (str, int, np.integer)) or (
        isinstance(output, (list, tuple))
        and all(isinstance(o, (str, int, np.integer)) for o in output)
    )
    if names:
        iy = signal_indices(output, labels, "output")
        Cs = [d[2][iy] for d in sys.vertex_data()]
        if any(not np.allclose(C, Cs[0]) for C in Cs[1:]):
            raise ValueError("output: the rows differ between vertices; pass a matrix")
        return Cs[0]
    return as_matrix(output, "output")


def _pairs(N, scheduled):
    if not scheduled:
        return [(j, 0) for j in range(N)]
    return [(j, j) for j in range(N)] + list(itertools.combinations(range(N), 2))


# ----------------------------------------------------------------------
# LMI problem
# ----------------------------------------------------------------------
def _build(s: _Scaled, nK, K_fixed, has_w, margin):
    """The LMI problem in scaled units; ``K_fixed`` scaled gains or None."""
    n, m = s.A[0].shape[0], s.B[0].shape[1]
    nw = s.E[0].shape[1] if has_w else 0
    N = len(s.A)
    scheduled = nK > 1
    lmi = LMIProblem(margin=margin)
    lmi.variable("W", (n, n), symmetric=True)
    lmi.variable("s", (m,))
    for k in range(nK):
        if K_fixed is None:
            lmi.variable(f"Y{k}", (m, n))
        lmi.variable(f"Z{k}", (m, n))
    lmi.variable("g", (1, 1))
    lmi.parameter("c", (), value=0.0, nonneg=True)  # 2 sigma + lambda (scaled)
    if has_w:
        lmi.variable("mu", (nw,))
        lmi.parameter("lam", (), value=0.1, nonneg=True)
    lmi.parameter("gmax", (), value=1.0, nonneg=True)  # back-off stage bound
    lmi.variable("kappa", (1, 1))

    def Y(v, k):
        return (K_fixed[k] @ v.W) if K_fixed is not None else getattr(v, f"Y{k}")

    def Z(v, k):
        return getattr(v, f"Z{k}")

    def sector(v, j, k):
        A, B = s.A[j], s.B[j]
        S = diagonal(v.s)
        d = A @ v.W - B @ Y(v, k)
        rows = [[d + d.T + v.c * v.W], [-(S @ B.T) - Z(v, k), -2 * S]]
        if has_w:
            rows.append([s.E[j].T, np.zeros((nw, m)), -diagonal(v.mu)])
        return rows

    lmi.add("W > 0", lambda v: [[-v.W]])
    lmi.add("S > 0", lambda v: [[-diagonal(v.s)]])
    lmi.add("W <= cap", lambda v: [[v.W - _W_CAP * np.eye(n)]], strict=False)
    for j, k in _pairs(N, scheduled):
        if j == k or not scheduled:

            def blocks(v, j=j, k=k):
                return sector(v, j, k)

            name = f"sector vertex {j}" if not scheduled else f"sector pair {j},{j}"
        else:

            def blocks(v, j=j, k=k):
                M1, M2 = sector(v, j, k), sector(v, k, j)
                return [
                    [
                        M1[r][c] + M2[r][c] if not _is_zero(M1[r][c]) else 0
                        for c in range(r + 1)
                    ]
                    for r in range(len(M1))
                ]

            name = f"sector pair {j},{k}"
        lmi.add(name, blocks)
    for k in range(nK):
        for i in range(m):

            def incl(v, k=k, i=i):
                r = Y(v, k)[i : i + 1, :] - Z(v, k)[i : i + 1, :]
                return [[-v.W], [-r, -np.eye(1)]]

            lmi.add(f"inclusion gain {k} input {i}", incl)
    if has_w:
        lmi.add("sum(mu) < lambda", lambda v: [[total(v.mu) - v.lam * np.eye(1)]])
    # Objective g: the region (beta^2 = 1 / g) or the size along outputs.
    if s.C is not None:
        rows = s.C[np.einsum("ij,ij->i", s.C, s.C) > 0]
        weight = 1.0 / np.einsum("ij,ij->i", rows, rows)
        lmi.add(
            "output size <= g",
            lambda v: [
                [
                    diagonal(weight) @ quadratic_rows(rows, v.W)
                    - v.g[0, 0] * np.eye(len(weight))
                ]
            ],
            strict=False,
        )
    if s.C is None or s.beta_min is not None:
        # beta^2 = 1 / g, or the fixed requirement 1 / beta_min^2.
        if s.C is None:

            def gval(v):
                return v.g[0, 0]
        else:
            gfix = 1.0 / s.beta_min**2

            def gval(v):
                return gfix

        if s.R is not None:
            Rt = s.R
            lmi.add(
                "g * shape contains",
                lambda v: [[-gval(v) * Rt], [-np.eye(n), -v.W]],
                strict=False,
            )
        else:
            for q, vq in enumerate(s.V):
                lmi.add(
                    f"point {q} inside",
                    lambda v, vq=vq: [
                        [-gval(v) * np.eye(1)],
                        [-vq.reshape(n, 1), -v.W],
                    ],
                    strict=False,
                )
    lmi.add(
        "g <= gmax",
        lambda v: [[v.g - v.gmax * np.eye(1)]],
        strict=False,
        stages=["backoff"],
    )
    if K_fixed is None:
        for k in range(nK):
            lmi.add(
                f"|Y{k}| <= kappa",
                lambda v, k=k: [[-v.kappa[0, 0] * np.eye(n)], [Y(v, k), -np.eye(m)]],
                strict=False,
                stages=["backoff"],
            )
    return lmi


def _is_zero(x):
    return isinstance(x, (int, float)) and x == 0


# ----------------------------------------------------------------------
# Public functions
# ----------------------------------------------------------------------
@time_budget
def _old_saturated_state_feedback(
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
    module docstring), then backs off.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Continuous-time plant; all states are measured. A discrete-time
        plant is refused (`ValueError`): the certificate's LMIs are
        continuous-time ones.
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
        Required rate ``sigma >= 0``: ``V`` decays at least as ``exp(-2
        sigma t)`` inside the region (``w = 0``).
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
        the largest feasible decay ``sigma_max``, then minimise the gain
        (``||Y_k|| = ||K_k W||``) at the decay halfway between the requested
        one and ``sigma_max`` (`SaturatedDesign.decay` is that certified
        rate). None for the raw optimum at the requested decay.
    margin : float, optional
        Margin of the strict LMIs in the prescaled units, in ``(0, 1)``;
        default 1e-6.
    solvers : str or sequence, optional
        A cvxpy solver name (e.g. ``"CLARABEL"``, ``"SCS"``), or names or
        ``(name, options)`` pairs tried in turn. Default: Clarabel, then
        SCS, then CVXOPT and
        MOSEK if installed. With `w`, the line search over the
        S-procedure rate ``lambda`` uses the first solver only (the whole
        list if it finds nothing); so does the back-off stage.
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
        For bad arguments, and for a discrete-time `sys` (the discrete-time
        certificate is not implemented).

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
    from .stabilizability import check_stabilizability

    prob = _setup(
        sys, u, u_max, shape, points, output, beta_min, decay, w, w_max, margin
    )
    check_stabilizability(sys, prob["iu"])
    nK = sys.nvertices if gains == "scheduled" and sys.nvertices > 1 else 1
    return _run(prob, nK, None, backoff, solvers)


@time_budget
def _old_saturation_region(
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
    contractive ellipsoid of the saturated polytopic closed loop is found.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Continuous-time plant (a discrete-time one is refused, as by
        `saturated_state_feedback`).
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
        Required rate ``sigma >= 0`` (default 0): ``V = x' P x`` decays at
        least as ``exp(-2 sigma t)`` inside the region for ``w = 0``.
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
        A cvxpy solver name (e.g. ``"CLARABEL"``, ``"SCS"``), or names or
        ``(name, options)`` pairs tried in turn. Default: Clarabel, then
        SCS, then CVXOPT and
        MOSEK if installed. With `w`, the line search over the
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
        With ``designed=False``.

    Raises
    ------
    InfeasibleError
        If the solvers report the LMIs infeasible (e.g. a vertex of the
        linear closed loop is not stable).
    CertificationError
        No returned point passed the float64 checks.
    ValueError, TypeError
        For bad arguments, and for a discrete-time `sys` (the discrete-time
        certificate is not implemented).
    """
    prob = _setup(
        sys, u, u_max, shape, points, output, beta_min, decay, w, w_max, margin
    )
    n, m = sys.nstates, len(prob["iu"])
    Ks = [gain] if np.ndim(gain) == 2 or np.ndim(gain) < 2 else list(gain)
    Ks = [as_matrix(K, f"gain[{k}]", (m, n)) for k, K in enumerate(Ks)]
    if len(Ks) not in (1, sys.nvertices):
        raise ValueError(
            f"gain: expected one gain or {sys.nvertices} vertex gains, got {len(Ks)}"
        )
    # Near the origin the loop is linear: a vertex whose linear closed loop
    # is not Hurwitz has no region of attraction to certify (a proof).
    for j, (A, B) in enumerate(zip(prob["As"], prob["Bs"])):
        K = Ks[j if len(Ks) > 1 else 0]
        worst = float(np.linalg.eigvals(A - B @ K).real.max())
        if worst >= 0:
            raise InfeasibleError(
                f"gain: the linear closed loop at vertex {j} is not asymptotically "
                f"stable (eigenvalue with real part {worst:.6g}), so the saturated "
                "loop has no region of attraction there"
            )
    return _run(prob, len(Ks), Ks, None, solvers)


def _setup(sys, u, u_max, shape, points, output, beta_min, decay, w, w_max, margin):
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}; wrap an "
            "LTI system as PolytopicStateSpace([sys])"
        )
    _continuous_or_raise(sys)
    inputs = sys.physical_inputs
    if u is None:
        raise ValueError("u: name the saturated control input(s)")
    iu = signal_indices(u, inputs, "u")
    if not iu:
        raise ValueError("u: at least one control input is required")
    iw = signal_indices(w, inputs, "w") if w is not None else []
    if set(iw) & set(iu):
        raise ValueError("w, u: an input cannot be both a disturbance and a control")
    umax = _positive_vector(u_max, len(iu), "u_max")
    if iw:
        if w_max is None:
            raise ValueError("w_max: required with w")
        wmax = _positive_vector(w_max, len(iw), "w_max")
    else:
        if w_max is not None:
            raise ValueError("w_max: given without w")
        wmax = np.zeros(0)
    decay = real_number(decay, "decay", minimum=0.0)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    beta_min = real_number(beta_min, "beta_min", allow_none=True, positive=True)
    n = sys.nstates
    R, V = _region_target(shape, points, n)
    data = sys.vertex_data()
    As = [d[0] for d in data]
    Bs = [d[1][:, iu] for d in data]
    Es = [d[1][:, iw] for d in data] if iw else []
    C = None
    if beta_min is not None:
        if output is None:
            raise ValueError("beta_min: only with output (the region is maximised)")
    if output is not None and not iw:
        raise ValueError(
            "output: minimising the size needs a disturbance w (without one the "
            "invariant ellipsoid shrinks to the origin)"
        )
    if output is not None:
        C = _output_rows(sys, output)
        if C.shape[1] != n or not np.any(C != 0):
            raise ValueError(f"output: expected nonzero rows of {n} entries")
    scaled = _prescale(As, Bs, Es, umax, wmax, R, V, C=C, beta_min=beta_min)
    return dict(
        sys=sys, iu=iu, iw=iw, umax=umax, wmax=wmax, decay=decay, R=R, V=V,
        As=As, Bs=Bs, Es=Es, scaled=scaled, margin=margin, C=C,
    )  # fmt: skip


def _continuous_or_raise(sys):
    """Refuse a discrete-time plant: the LMIs here are continuous-time ones.

    Certifying a sampled plant with them would be a wrong certificate (a
    contractive ellipsoid of ``dx/dt = A x + B sat(u)`` says nothing about
    ``x+ = A x + B sat(u)``).
    """
    if sys.isdtime(strict=True):
        raise ValueError(
            f"sys: discrete-time plant (dt = {sys.dt!r}); the saturation "
            "certificate (region of attraction under saturation) is implemented "
            "for continuous time only, the discrete-time one is not. Design on "
            "the continuous-time model (saturated_state_feedback, or synthesize "
            "with a Saturation constraint) and sample the controller afterwards "
            "(check the sampled loop by simulation), or use synthesize on the "
            "discrete-time plant for a linear design without the saturation region"
        )


class _Rescale(Exception):
    """A scaled problem gave no certified point; carries the estimate's W~."""

    def __init__(self, message, W, attempts, infeasible=False):
        super().__init__(message)
        self.W = W
        self.attempts = attempts
        self.infeasible = infeasible


def _run(prob, nK, Ks, backoff, solvers):
    """Solve, re-scaling the states from the last estimate when it fails.

    A point that misses its certificate usually has a badly conditioned
    ``W~`` (a region much longer along some states than the prescaling
    guessed); the next try scales the states by ``sqrt(diag(W~))`` (powers
    of two), so that the margin is relative to the region's own size.
    """
    s = prob["scaled"]
    messages, attempts, infeasible = [], [], []
    for _ in range(_RESCALES + 1):
        K_fixed = None if Ks is None else [(K / s.U[:, None]) * s.T for K in Ks]
        try:
            return _solve_scaled(prob, s, nK, K_fixed, backoff, solvers)
        except _Rescale as exc:
            messages.append(str(exc))
            attempts.extend(exc.attempts)
            infeasible.append(exc.infeasible)
            if exc.W is None:
                break
            d = np.sqrt(np.clip(np.diag(exc.W), 1e-12, None))
            if np.all((d > 0.5) & (d < 2.0)):
                break  # already scaled to the estimate: rescaling won't help
            T = s.T * np.array([_pow2(x) for x in d])
            s = _prescale(
                prob["As"], prob["Bs"], prob["Es"], s.U, prob["wmax"],
                prob["R"], prob["V"], T=T, C=prob["C"], beta_min=s.beta_min,
            )  # fmt: skip
    tried = "; then with states rescaled: ".join(messages)
    if all(infeasible):
        raise InfeasibleError(
            f"saturation: the LMIs are infeasible [{tried}]", attempts
        )
    raise CertificationError(f"saturation: no certified solution [{tried}]", attempts)


def _solve_scaled(prob, s, nK, K_fixed, backoff, solvers):
    has_w = bool(prob["iw"])
    lmi = _build(s, nK, K_fixed, has_w, prob["margin"])
    sigma_t = prob["decay"] / s.a
    chain = solver_chain(solvers) or default_solvers()
    estimate = {}

    def objective(v):
        return v.g[0, 0]

    def solve_at(lam, use=chain[:1]):
        lmi.set_parameter("c", 2 * sigma_t + (lam if has_w else 0.0))
        if has_w:
            lmi.set_parameter("lam", lam)
        try:
            sol = lmi.solve(objective, solvers=use, certify=False)
        except SynthesisError as exc:
            estimate.setdefault("message", str(exc))
            estimate.setdefault("attempts", list(exc.attempts))
            certain = isinstance(exc, InfeasibleError)
            estimate["infeasible"] = estimate.get("infeasible", True) and certain
            return np.inf, None
        if not sol.certified:
            estimate["infeasible"] = False
            estimate["W"] = sol.W
            estimate["message"] = _summary(sol.attempts)
            estimate["attempts"] = list(sol.attempts)
            return np.inf, None
        return float(sol.g[0, 0]), sol

    if has_w:
        # The search uses the first solver only; the whole chain if it fails.
        lam, g_opt, sol, _ = _line_search(solve_at, _LAMBDA_GRID)
        if sol is None and len(chain) > 1:
            lam, g_opt, sol, _ = _line_search(
                lambda x: solve_at(x, chain), _LAMBDA_GRID
            )
    else:
        lam = 0.0
        g_opt, sol = solve_at(0.0, chain)
    if sol is None:
        raise _Rescale(
            estimate.get("message", "no point returned"),
            estimate.get("W"),
            estimate.get("attempts", []),
            estimate.get("infeasible", False),
        )
    if s.C is not None:
        beta_opt = None
    else:
        beta_opt = 1.0 / np.sqrt(g_opt) if g_opt > 0 else np.inf
    # The line search leaves the parameters at its last point: set the best.
    lmi.set_parameter("c", 2 * sigma_t + lam)
    if has_w:
        lmi.set_parameter("lam", lam)
    best, sigma_use = sol, sigma_t
    if backoff is not None and K_fixed is None:
        lmi.set_parameter("gmax", g_opt * (1.0 + backoff) ** 2)
        sol, sigma_use = _backoff(lmi, sigma_t, lam, chain)
        if sol is None:
            sol, sigma_use = best, sigma_t  # keep the certified optimum
    try:
        return _finish(prob, s, sol, lam, nK, K_fixed, beta_opt, sigma_use * s.a)
    except CertificationError as exc:
        if sol is best:
            raise _Rescale(str(exc), sol.W, list(sol.attempts)) from None
    try:
        return _finish(prob, s, best, lam, nK, K_fixed, beta_opt, sigma_t * s.a)
    except CertificationError as exc:
        raise _Rescale(str(exc), best.W, list(best.attempts)) from None


def _backoff(lmi, sigma_t, lam, chain):
    """Back-off stage: spend the slack on decay, then on the gain.

    With the objective held within the back-off (``g <= gmax``), find the
    largest decay ``sigma_max`` that stays feasible (doubling, then
    bisection), and minimise the gain at ``sigma_t + (sigma_max -
    sigma_t) / 2``: halfway, so that the gain does not blow up at the edge
    of feasibility, and never below the requested decay (a gain minimised
    at the requested decay alone drifts to the edge of linear stability
    when that decay is 0). Returns ``(solution, sigma)`` in scaled units,
    or ``(None, sigma_t)`` when nothing certified.
    """

    def at(sigma):
        lmi.set_parameter("c", 2 * sigma + lam)
        try:
            return lmi.solve(
                lambda v: v.kappa[0, 0], stage="backoff", solvers=chain[:1]
            )
        except SynthesisError:
            return None

    lo, hi = sigma_t, max(2 * sigma_t, _DECAY_START)
    if at(lo) is None:
        return None, sigma_t
    while hi < _DECAY_MAX and at(hi) is not None:
        lo, hi = hi, 2 * hi
    for _ in range(_DECAY_BISECTIONS):
        mid = 0.5 * (lo + hi)
        if at(mid) is not None:
            lo = mid
        else:
            hi = mid
    sigma_use = sigma_t + 0.5 * (lo - sigma_t)
    sol = at(sigma_use)
    if sol is None:
        sigma_use, sol = sigma_t, at(sigma_t)
    return sol, sigma_use


def _summary(attempts):
    return "; ".join(
        f"{a.solver}: {a.status}" + (f" ({a.message})" if a.message else "")
        for a in attempts
    )


def _finish(prob, s, sol, lam_t, nK, K_fixed, beta_opt, sigma):
    """Unscale and verify in float64, original units."""
    T, U, a = s.T, s.U, s.a
    Wt = sol.W
    Wti = np.linalg.inv(Wt)
    W = T[:, None] * Wt * T
    W = 0.5 * (W + W.T)
    P = np.linalg.inv(W)
    P = 0.5 * (P + P.T)
    if K_fixed is None:
        Kt = [getattr(sol, f"Y{k}") @ Wti for k in range(nK)]
    else:
        Kt = K_fixed
    Gt = [getattr(sol, f"Z{k}") @ Wti for k in range(nK)]
    Ks = tuple(U[:, None] * K / T for K in Kt)
    Gs = tuple(U[:, None] * G / T for G in Gt)
    Tm = a * np.diag(1.0 / (np.asarray(sol.s, float).reshape(-1) * U**2))
    has_w = bool(prob["iw"])
    lam = lam_t * a
    mu = np.asarray(sol.mu, float).reshape(-1) * a if has_w else np.zeros(0)
    wmax = prob["wmax"]
    checks, rho = sector_checks(
        prob["As"], prob["Bs"], prob["Es"], wmax, U, P, W, Ks, Gs, Tm, mu, sigma, lam
    )
    beta = region_size(P, prob["R"], prob["V"])
    certificate = EllipsoidCertificate(
        tuple(checks), sol.checks, statement=sector_statement(has_w)
    )
    if not certificate.verified:
        raise CertificationError(
            f"saturation: the returned point failed its float64 checks "
            f"({certificate.summary})",
            sol.attempts,
        )
    labels = prob["sys"].physical_inputs
    capped = bool(np.linalg.eigvalsh(Wt)[-1] >= 0.99 * _W_CAP)
    return SaturatedDesign(
        system=prob["sys"],
        u=tuple(labels[i] for i in prob["iu"]),
        u_max=U.copy(),
        gains=Ks,
        G=Gs,
        P=P,
        ellipsoid=Ellipsoid(P, 1.0),
        ultimate=Ellipsoid(P, rho) if has_w else None,
        rho=rho,
        beta=beta,
        beta_opt=beta_opt,
        decay=sigma,
        lam=lam,
        w=tuple(labels[i] for i in prob["iw"]),
        w_max=wmax.copy(),
        certificate=certificate,
        capped=capped,
        designed=K_fixed is None,
        attempts=tuple(sol.attempts),
        T=Tm,
        mu=mu,
        shape=prob["R"],
        points=prob["V"],
    )


def sector_checks(As, Bs, Es, wmax, U, P, W, Ks, Gs, Tm, mu, sigma, lam):
    """The float64 checks of a saturated design in original units.

    Every vertex (common gain) or vertex pair (vertex gains) of the sector
    inequality with ``P``, the gains ``Ks``, the auxiliary gains ``Gs``,
    the diagonal multiplier ``Tm`` and (with disturbances ``Es``) the
    S-procedure multipliers ``mu``; the inclusions of ``{x'Px <= 1}`` in
    the sector regions; ``mu >= 0`` and ``rho < 1``. Returns the checks and
    the ultimate level ``rho = sum(mu) / (2 sigma + lam)``.
    """
    has_w = len(Es) > 0
    c = 2 * sigma + lam
    m, nw = len(U), len(wmax)
    checks = [
        _positive_check("P > 0", P),
        EllipsoidCheck("T > 0", -float(np.min(np.diag(Tm))), 0.0),
    ]

    def M(j, k, ab=False):
        # ab=True: the same expression in absolute values (rounding bound).
        f = np.abs if ab else (lambda X: X)
        sg = 1.0 if ab else -1.0
        Pj, Bj, Kk, Gk = f(P), f(Bs[j]), f(Ks[k]), f(Gs[k])
        Acl = (f(As[j]) + Bj @ Kk) if ab else (As[j] - Bs[j] @ Ks[k])
        off = sg * (Pj @ Bj) + sg * (Gk.T @ Tm)
        top = [Acl.T @ Pj + Pj @ Acl + c * Pj, off]
        mid = [off.T, 2 * sg * Tm]
        if not has_w:
            return np.block([top, mid])
        PE = Pj @ f(Es[j] * wmax)
        return np.block(
            [
                top + [PE],
                mid + [np.zeros((m, nw))],
                [PE.T, np.zeros((nw, m)), sg * np.diag(mu)],
            ]
        )

    nK = len(Ks)
    scheduled = nK > 1
    for j, k in _pairs(len(As), scheduled):
        if not scheduled:
            checks.append(_strict_check(f"sector vertex {j}", M(j, 0), M(j, 0, True)))
        elif j == k:
            checks.append(_strict_check(f"sector pair {j},{j}", M(j, j), M(j, j, True)))
        else:
            checks.append(
                _strict_check(
                    f"sector pair {j},{k}",
                    M(j, k) + M(k, j),
                    M(j, k, True) + M(k, j, True),
                )
            )
    for k in range(nK):
        D = Ks[k] - Gs[k]
        ratio = np.einsum("ij,jk,ik->i", D, W, D) / U**2
        for i in range(m):
            checks.append(
                EllipsoidCheck(f"inclusion gain {k} input {i}", float(ratio[i]), 1.0)
            )
    rho = 0.0
    if has_w:
        rho = float(mu.sum() / c)
        checks.append(EllipsoidCheck("mu >= 0", -float(mu.min()), 0.0))
        checks.append(EllipsoidCheck("rho = sum(mu)/(2 sigma + lambda)", rho, 1.0))
    return checks, rho


def region_size(P, R, V) -> float:
    """Largest ``beta`` with ``beta * {x'Rx <= 1}`` (or every ``beta v_k``) in
    ``{x'Px <= 1}``."""
    if R is not None:
        return float(1.0 / np.sqrt(eigh(P, R, eigvals_only=True)[-1]))
    return float(1.0 / np.sqrt(np.einsum("ij,jk,ik->i", V, P, V).max()))


def sector_statement(has_w: bool) -> str:
    """What the checks of `sector_checks` prove, in words."""
    return (
        "for every delta(t) in the polytope"
        + (" and every |w_i(t)| <= w_max_i" if has_w else "")
        + ": on {x'Px <= 1} the saturated closed loop satisfies "
        + "d(x'Px)/dt <= -(2 sigma + lambda)(x'Px - rho)"
    )
