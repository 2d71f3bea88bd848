"""Invariant ellipsoids and ultimate bounds for peak-bounded inputs.

For a polytopic system ``dx/dt = A(delta) x + E(delta) w`` with
``|w_i(t)| <= w_max_i`` and any (time-varying) ``delta(t)`` in the simplex,
`ultimate_bound` finds a common ``P > 0``, a rate ``lambda > 0`` and
multipliers ``mu_i >= 0`` with (S-procedure with decay)

.. math::

    \\begin{bmatrix} A_j' P + P A_j + \\lambda P & P E_j D \\\\
    D E_j' P & -\\operatorname{diag}(\\mu) \\end{bmatrix} \\prec 0
    \\quad (j = 1..N), \\qquad D = \\operatorname{diag}(w_{max}),

so that ``V = x' P x`` obeys ``dV/dt <= -lambda V + sum_i mu_i`` along every
trajectory. With ``rho = sum(mu) / lambda`` the ellipsoid
``{x : x' P x <= rho}`` is invariant and attractive:
``V(t) - rho <= (V(0) - rho) exp(-lambda t)``, and every output
``y = C x + D_w w`` ends up within ``sqrt(rho c_i' P^-1 c_i) + sum_k |D_ik|
w_max_k``. The LMIs are posed in ``W = P^-1`` (congruence), the size along
the chosen outputs is minimised (linear in ``W``) and ``lambda`` is found by
a line search (the LMIs are bilinear in ``lambda`` and ``W``).

Public names
------------
``Ellipsoid``, ``EllipsoidCheck``, ``EllipsoidCertificate``,
``UltimateBound``, ``ultimate_bound``::

    ultimate_bound(sys, w=None, w_max=1.0, *, output=None, weights=None,
                   decay=None, margin=1e-6, solvers=None) -> UltimateBound

``sys`` is a `PolytopicStateSpace` or `control.StateSpace` (``w`` selects
the peak-bounded inputs, ``output`` the outputs to bound, default all), or
a pair ``(A_list, E_list)`` of vertex matrices (``output`` then a matrix
``C`` whose rows are bounded, default the states).

Numerical policy (see the design notes): the data are prescaled by powers of
two (states by the square root of the largest reachability Gramian
diagonal over the vertices, time by ``max ||A_j||``), strict LMIs get a
margin in those units, and the returned result is re-verified in float64 in
the original units (each vertex matrix after Jacobi normalisation, against a
bound on its rounding error); a point that fails is never returned.
`InfeasibleError` only when a vertex is not Hurwitz (then no ``P``
exists); otherwise `CertificationError`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg as sla
from control import StateSpace

from ._checks import (
    as_matrix,
    per_input,
    positive_levels,
    real_number,
    signal_indices,
)
from .budget import DEFAULT_TIME_LIMIT, time_budget
from .certificate import Certificate, Check, negative_definite
from .exceptions import CertificationError, InfeasibleError, SynthesisError
from .lmi import LMIProblem, SolveAttempt, default_solvers, solver_chain
from .lmi.blocks import diagonal, quadratic_rows, total

__all__ = [
    "Ellipsoid",
    "EllipsoidCheck",
    "EllipsoidCertificate",
    "UltimateBound",
    "ultimate_bound",
]

# Line search: coarse grid points, then golden-section iterations.
_GRID = 9
_GOLDEN_ITERS = 8


# ----------------------------------------------------------------------
# Results
# ----------------------------------------------------------------------
@dataclass(frozen=True)
class Ellipsoid:
    """The ellipsoid ``{x : x' P x <= level}``.

    Attributes
    ----------
    P : ndarray
        Positive definite ``n x n`` matrix.
    level : float
        Level of the set (1 unless stated).
    """

    P: np.ndarray
    level: float = 1.0

    @property
    def shape_matrix(self) -> np.ndarray:
        """``level * P^-1``: the set is ``{x : x' (level P^-1)^-1 x <= 1}``."""
        return self.level * np.linalg.inv(self.P)

    def value(self, x) -> np.ndarray:
        """``x' P x / level`` (at most 1 inside), over the columns of `x`."""
        x = np.asarray(x, float)
        return np.einsum("i...,ij,j...->...", x, self.P, x) / self.level

    def contains(self, x, rtol: float = 0.0) -> np.ndarray:
        """Whether ``x' P x <= level (1 + rtol)`` (vectorised over columns)."""
        return self.value(x) <= 1.0 + rtol

    def support(self, c) -> np.ndarray:
        """``max |c' x|`` over the set, ``sqrt(level c' P^-1 c)``, per row of `c`."""
        C = np.atleast_2d(np.asarray(c, float))
        W = self.shape_matrix
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", C, W, C), 0.0))

    def semi_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """Semi-axis lengths (ascending) and directions (columns)."""
        lam, vec = np.linalg.eigh(self.P / self.level)
        return 1.0 / np.sqrt(lam[::-1]), vec[:, ::-1]

    def inside(self, other: Ellipsoid, rtol: float = 0.0) -> bool:
        """Whether this set lies in `other` (``P_o / l_o <= P / l``).

        Chains certificates: a trajectory that reaches a set inside the
        invariant set of another certificate is covered from then on by it.
        """
        M = self.P / self.level - other.P / other.level
        scale = np.linalg.norm(self.P / self.level, 2)
        return bool(np.linalg.eigvalsh(0.5 * (M + M.T))[0] >= -rtol * scale)

    def scaled(self, factor: float) -> Ellipsoid:
        """The set ``factor * E`` (level times ``factor**2``)."""
        factor = real_number(factor, "factor", positive=True)
        return Ellipsoid(self.P, self.level * factor**2)


#: One float64 check in original units: ``EllipsoidCheck(name, value,
#: bound)`` passes when ``value <= bound`` (see `ctrl_lpv.certificate.Check`).
EllipsoidCheck = Check


class EllipsoidCertificate(Certificate):
    """All float64 checks of an invariant-ellipsoid result, with numpy.

    A `ctrl_lpv.Certificate` (see `ctrl_lpv.certificate`): the checks in
    original units the statement rests on, and (group ``"LMI"``) the LMIs
    as posed (scaled units) at the returned point.

    Parameters
    ----------
    checks : sequence of `ctrl_lpv.certificate.Check`
        The checks in original units.
    lmi_checks : sequence of `ctrl_lpv.lmi.LMICheck` or `Check`, optional
        The LMIs as posed, at the returned point.
    statement : str, optional
        What the checks prove, in words.

    Attributes
    ----------
    checks : tuple of `ctrl_lpv.certificate.Check`
        Every check (those in original units first).
    lmi_checks : tuple of `ctrl_lpv.certificate.Check`
        The group ``"LMI"``.
    statement : str
    """

    def __init__(self, checks=(), lmi_checks=(), statement=""):
        lmi = tuple(c if isinstance(c, Check) else Check.from_lmi_check(c)
                    for c in lmi_checks)  # fmt: skip
        super().__init__(tuple(checks) + lmi, statement)

    @property
    def lmi_checks(self) -> tuple[Check, ...]:
        return self.group("LMI")


@dataclass(frozen=True)
class UltimateBound:
    """Certified invariant ellipsoid for peak-bounded inputs.

    Attributes
    ----------
    ellipsoid : `Ellipsoid`
        ``{x : x' P x <= rho}``: invariant, and approached at rate `decay`.
    P : ndarray
        Lyapunov matrix (original units).
    rho : float
        Level ``sum(mu) / decay`` (at most about 1).
    decay : float
        The S-procedure rate ``lambda``: ``V(t) - rho <= (V(0) - rho)
        exp(-decay t)`` with ``V = x' P x``.
    mu : ndarray
        Multipliers of the input bounds (original time units).
    w_max : ndarray
        Peak bounds ``|w_i| <= w_max_i``.
    outputs : tuple of str
        Names of the bounded outputs.
    C : ndarray
        Rows of the bounded outputs on the state.
    Dw : ndarray
        Direct feedthrough of the inputs to those outputs.
    bounds : ndarray
        Ultimate bound on each output: ``support(C) + |Dw| w_max``.
    certificate : `EllipsoidCertificate`
        The float64 checks.
    search : tuple of (float, float)
        The line search: ``(lambda, objective)`` pairs tried (``inf`` where
        no certified point was found).
    attempts : tuple of `ctrl_lpv.lmi.SolveAttempt`
        Solver attempts of the final solve.
    """

    ellipsoid: Ellipsoid
    P: np.ndarray
    rho: float
    decay: float
    mu: np.ndarray
    w_max: np.ndarray
    outputs: tuple[str, ...]
    C: np.ndarray
    Dw: np.ndarray
    bounds: np.ndarray
    certificate: EllipsoidCertificate
    search: tuple = ()
    attempts: tuple[SolveAttempt, ...] = field(default_factory=tuple)

    def bound(self, output) -> float:
        """Ultimate bound of one output, by name or index."""
        i = signal_indices(output, self.outputs, "output")[0]
        return float(self.bounds[i])

    def level_bound(self, V0: float, t) -> np.ndarray:
        """Certified bound ``rho + (V0 - rho) exp(-decay t)`` on ``x' P x``."""
        t = np.asarray(t, float)
        return self.rho + (float(V0) - self.rho) * np.exp(-self.decay * t)

    def __str__(self) -> str:
        rows = ", ".join(f"|{o}| <= {b:.4g}" for o, b in zip(self.outputs, self.bounds))
        return (
            f"UltimateBound: {rows} (ellipsoid x'Px <= {self.rho:.4g}, "
            f"decay {self.decay:.4g}/s)\n  certificate: {self.certificate.summary}"
        )


# ----------------------------------------------------------------------
# Shared helpers (also used by ctrl_lpv.saturation)
# ----------------------------------------------------------------------
def _pow2(x: float) -> float:
    """Nearest power of two (exact scaling in floating point)."""
    return float(2.0 ** np.round(np.log2(x))) if x > 0 and np.isfinite(x) else 1.0


def _strict_check(name: str, M: np.ndarray, M_abs: np.ndarray) -> Check:
    """``M < 0`` in original units (`ctrl_lpv.certificate.negative_definite`:
    Jacobi-normalised; ``M_abs``, the same expression in absolute values,
    bounds the rounding of forming ``M``)."""
    return negative_definite(M, absolute=M_abs, what=name)


def _positive_check(name: str, P: np.ndarray) -> Check:
    """``P > 0`` (``-P < 0``, see `_strict_check`)."""
    return negative_definite(-P, what=name)


def _hurwitz_or_raise(As, what: str = "vertex") -> None:
    """`InfeasibleError` if some ``A_j`` is provably not Hurwitz.

    Proofs: a zero row or column of ``A_j`` (a state with no dynamics, e.g.
    an integrator: the eigenvalue 0 exactly), or an eigenvalue with real
    part above rounding (``1e-9 ||A_j||``).
    """
    for j, A in enumerate(As):
        rows = np.flatnonzero(~A.any(axis=1))
        cols = np.flatnonzero(~A.any(axis=0))
        if rows.size or cols.size:
            if rows.size:
                why = (
                    f"row {rows[0]} of A is zero (dx[{rows[0]}]/dt does not depend "
                    "on the state: a pure integrator)"
                )
            else:
                why = (
                    f"column {cols[0]} of A is zero (x[{cols[0]}] acts on no state "
                    "derivative, not even its own)"
                )
            raise InfeasibleError(
                f"{what} {j}: {why}, so A has the eigenvalue 0 exactly: that mode "
                "does not decay and no attractive invariant ellipsoid exists "
                "(close a loop around it first)"
            )
        scale = max(1.0, np.linalg.norm(A, 2))
        lam = np.linalg.eigvals(A)
        worst = lam[np.argmax(lam.real)]
        if worst.real >= 1e-9 * scale:
            raise InfeasibleError(
                f"{what} {j} is not Hurwitz (eigenvalue {worst:.6g}): no quadratic "
                "Lyapunov function decreases there, so no invariant attractive "
                "ellipsoid exists"
            )


def _decay_margin_or_raise(At, a: float) -> float:
    """The smallest decay rate ``min_j -max Re eig(A~_j)``, which must be > 0.

    On the prescaled ``A~_j = A_j / a`` (up to a diagonal similarity). Past
    `_hurwitz_or_raise` it can still be ``<= 0`` for an eigenvalue within
    rounding of the imaginary axis: no rate can be certified then.
    """
    rates = [-np.linalg.eigvals(A).real.max() for A in At]
    j = int(np.argmin(rates))
    if not rates[j] > 0:
        raise CertificationError(
            f"ultimate_bound: vertex {j} has an eigenvalue with real part "
            f"{-rates[j] * a:.3g} 1/s, on the imaginary axis up to rounding, so no "
            "decay rate (and no ultimate bound) can be certified"
        )
    return float(rates[j])


def _resolve_data(sys, w, output):
    """Vertex ``A_j``, ``E_j``, output ``C_j``, ``Dw_j`` and the output names."""
    from .systems import PolytopicStateSpace

    if isinstance(sys, StateSpace):
        if not sys.isctime():
            raise ValueError(
                f"sys: discrete-time system (dt = {sys.dt!r}); ultimate_bound "
                "certifies continuous-time systems only (dx/dt = A x + E w), the "
                "discrete-time bound is not implemented: bound the continuous-time "
                "model, or use synthesize with a Peak objective, which has a "
                "discrete-time form"
            )
        if isinstance(sys, PolytopicStateSpace):
            data = sys.vertex_data()
            inputs = sys.physical_inputs
        else:
            data = ((sys.A, sys.B, sys.C, sys.D),)
            inputs = tuple(sys.input_labels)
        iw = list(range(len(inputs))) if w is None else signal_indices(w, inputs, "w")
        if not iw:
            raise ValueError("w: at least one bounded input is required")
        labels = tuple(sys.output_labels)
        iy = list(range(len(labels))) if output is None else None
        if output is not None:
            if isinstance(output, (str, int, np.integer)) or (
                isinstance(output, Sequence)
                and all(isinstance(o, (str, int, np.integer)) for o in output)
            ):
                iy = signal_indices(output, labels, "output")
        As = [np.asarray(d[0], float) for d in data]
        Es = [np.asarray(d[1], float)[:, iw] for d in data]
        if iy is not None:
            Cs = [np.asarray(d[2], float)[iy] for d in data]
            Ds = [np.asarray(d[3], float)[np.ix_(iy, iw)] for d in data]
            names = tuple(labels[i] for i in iy)
        else:
            C = as_matrix(output, "output")
            Cs = [C] * len(As)
            Ds = [np.zeros((C.shape[0], len(iw)))] * len(As)
            names = tuple(f"y[{i}]" for i in range(C.shape[0]))
        return As, Es, Cs, Ds, names
    if not (isinstance(sys, (tuple, list)) and len(sys) == 2):
        raise TypeError(
            "sys: expected a PolytopicStateSpace, a control.StateSpace or a pair "
            f"(A_list, E_list), got {type(sys).__name__}"
        )
    if w is not None:
        raise ValueError("w: only for a system with named inputs")
    A_in, E_in = sys
    A_in, E_in = _as_list(A_in), _as_list(E_in)
    As = [as_matrix(A, f"sys[0][{j}]") for j, A in enumerate(A_in)]
    if not As:
        raise ValueError("sys: the vertex list is empty")
    n = As[0].shape[0]
    for j, A in enumerate(As):
        if A.shape != (n, n):
            raise ValueError(f"sys[0][{j}]: expected shape {(n, n)}, got {A.shape}")
    Es = [as_matrix(E, f"sys[1][{j}]") for j, E in enumerate(E_in)]
    if len(Es) == 1 and len(As) > 1:
        Es = Es * len(As)
    if len(Es) != len(As):
        raise ValueError(f"sys: {len(As)} A matrices but {len(Es)} E matrices")
    for j, E in enumerate(Es):
        if E.shape[0] != n or E.shape[1] != Es[0].shape[1]:
            raise ValueError(f"sys[1][{j}]: expected {n} rows, got shape {E.shape}")
    C = np.eye(n) if output is None else as_matrix(output, "output")
    if C.shape[1] != n:
        raise ValueError(f"output: expected {n} columns, got shape {C.shape}")
    names = (
        tuple(f"x[{i}]" for i in range(n))
        if output is None
        else tuple(f"y[{i}]" for i in range(C.shape[0]))
    )
    return (
        As,
        Es,
        [C] * len(As),
        [np.zeros((C.shape[0], Es[0].shape[1]))] * len(As),
        names,
    )


def _line_search(f, grid):
    """Minimise ``f(x) -> (value, payload)`` over a grid, then golden section.

    The golden-section refinement works on ``log x`` in the bracket of the
    best grid point. Returns ``(x, value, payload, [(x, value), ...])``;
    ``payload`` is None when every value is infinite.
    """
    grid = np.asarray(grid, float)
    search, best = [], (np.inf, None, None)
    values = []
    for x in grid:
        val, payload = f(x)
        values.append(val)
        search.append((float(x), val))
        if val < best[0]:
            best = (val, payload, float(x))
    if best[1] is None:
        return float(grid[0]), np.inf, None, search
    k = int(np.argmin(values))
    lo = np.log(grid[max(k - 1, 0)])
    hi = np.log(grid[min(k + 1, len(grid) - 1)])
    g = (np.sqrt(5) - 1) / 2

    def at(y):
        val, payload = f(np.exp(y))
        search.append((float(np.exp(y)), val))
        return val, payload

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    (f1, s1), (f2, s2) = at(x1), at(x2)
    for y, fy, sy in ((x1, f1, s1), (x2, f2, s2)):
        if fy < best[0]:
            best = (fy, sy, float(np.exp(y)))
    for _ in range(_GOLDEN_ITERS):
        if f1 <= f2:
            hi, x2, f2, s2 = x2, x1, f1, s1
            x1 = hi - g * (hi - lo)
            f1, s1 = at(x1)
            y, fy, sy = x1, f1, s1
        else:
            lo, x1, f1, s1 = x1, x2, f2, s2
            x2 = lo + g * (hi - lo)
            f2, s2 = at(x2)
            y, fy, sy = x2, f2, s2
        if fy < best[0]:
            best = (fy, sy, float(np.exp(y)))
    return best[2], best[0], best[1], search


def _as_list(M):
    """A single matrix (nested lists or array) as a one-element list."""
    try:
        if np.ndim(M) <= 2:
            return [M]
    except ValueError:  # ragged: a list of matrices of different shapes
        pass
    return list(M)


def _gramian_scaling(As, Es) -> np.ndarray:
    """Power-of-two state scaling from the reachability Gramians' diagonals."""
    diag = np.zeros(As[0].shape[0])
    for A, E in zip(As, Es):
        try:
            with warnings.catch_warnings():
                # Only a scaling heuristic: an inaccurate Gramian is harmless.
                warnings.simplefilter("ignore", RuntimeWarning)
                X = sla.solve_continuous_lyapunov(A, -E @ E.T)
        except (np.linalg.LinAlgError, ValueError):
            continue
        if not np.all(np.isfinite(X)):
            continue
        diag = np.maximum(diag, np.abs(np.diag(X)))
    s = np.sqrt(diag)
    floor = 1e-6 * s.max() if s.max() > 0 else 1.0
    return np.array([_pow2(max(v, floor)) for v in s])


# ----------------------------------------------------------------------
# Ultimate bound
# ----------------------------------------------------------------------
@time_budget
def ultimate_bound(
    sys,
    w=None,
    w_max=1.0,
    *,
    output=None,
    weights=None,
    decay: float | None = None,
    margin: float = 1e-6,
    solvers=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> UltimateBound:
    """Ultimate bound for inputs with ``|w_i(t)| <= w_max_i``.

    Parameters
    ----------
    sys : `PolytopicStateSpace`, `control.StateSpace` or (A_list, E_list)
        The (closed-loop) system ``dx/dt = A(delta) x + E(delta) w``; with
        vertex lists, ``E_list`` may hold a single matrix for all vertices.
        ``delta(t)`` may vary arbitrarily in time (a common ``P``).
    w : str, int or list, optional
        The peak-bounded inputs (default all inputs). Other inputs are
        taken as zero. The bound holds pointwise in time, so ``w`` may be
        any signal within it, also a function of the state (a bounded
        nonlinearity).
    w_max : float or array_like, optional
        Peak bounds ``|w_i(t)| <= w_max_i`` (one per input, or a scalar).
    output : str, int, list or array_like, optional
        Outputs to bound: names or indices of ``sys``'s outputs (default
        all), or a matrix ``C`` of rows on the state (default the states
        for vertex lists).
    weights : array_like, optional
        Positive weights ``omega_i``: minimises ``max_i omega_i c_i' W
        c_i / ||c_i||^2`` (default all 1: the largest bound relative to
        each row's norm).
    decay : float, optional
        Fix the rate ``lambda`` (1/s) instead of the line search.
    margin : float, optional
        Margin of the strict LMIs in the prescaled units.
    solvers : str or sequence, optional
        A cvxpy solver name (e.g. ``"CLARABEL"``, ``"SCS"``), or names or
        ``(name, options)`` pairs tried in turn. Default: Clarabel, then
        SCS, then CVXOPT and
        MOSEK if installed. The line search over ``lambda`` uses the first
        solver only (the whole list if it finds nothing); a fixed `decay`
        uses the whole list.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `UltimateBound`

    Raises
    ------
    InfeasibleError
        If a vertex is not Hurwitz (no such ellipsoid exists), e.g. a zero
        row or column of ``A`` (a state without dynamics: the eigenvalue 0).
    CertificationError
        If no certified point was found for any rate tried, or a vertex has
        an eigenvalue on the imaginary axis up to rounding.
    ValueError, TypeError
        For bad arguments (naming them), and a discrete-time `sys` (the
        discrete-time bound is not implemented).

    Examples
    --------
    ``dx/dt = -2 x + w`` with ``|w| <= 1``: ``|x|`` ends up below ``1/2``.

    >>> res = ultimate_bound(([[-2.0]], [[1.0]]))
    >>> round(float(res.bounds[0]), 3)
    0.5
    """
    data = _prepare(sys, w, w_max, output, weights, decay, margin)
    return _ultimate_bound_engine(*data, solvers)


def _prepare(sys, w, w_max, output, weights, decay, margin):
    """The checked arguments of `ultimate_bound`: ``(As, Es, C, Dw, names,
    wmax, omega, decay, margin)``; refuses a vertex that is not Hurwitz."""
    As, Es, Cs, Ds, names = _resolve_data(sys, w, output)
    nw = Es[0].shape[1]
    wmax = per_input(positive_levels(np.ravel(w_max), "w_max"), nw, "w_max", "inputs")
    for j in range(1, len(Cs)):
        if not (np.allclose(Cs[j], Cs[0]) and np.allclose(Ds[j], Ds[0])):
            raise ValueError(
                "output: the output matrices differ between vertices; bound a "
                "state combination (pass a matrix C) instead"
            )
    C, Dw = Cs[0], Ds[0]
    ny = C.shape[0]
    if weights is None:
        omega = np.ones(ny)
    else:
        omega = per_input(positive_levels(weights, "weights"), ny, "weights", "outputs")
    decay = real_number(decay, "decay", allow_none=True, positive=True)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    _hurwitz_or_raise(As, "sys: vertex")
    return As, Es, C, Dw, names, wmax, omega, decay, margin


def _ultimate_bound_lmi(As, Es, C, Dw, names, wmax, omega, decay, margin, solvers):
    """The hand-built LMI problem of `ultimate_bound` (its own prescaling,
    line search and checks)."""
    n, nw = As[0].shape[0], Es[0].shape[1]

    # Prescaling: x = T x~, w = D w^ (|w^_i| <= 1), tau = a t.
    Ed = [E * wmax for E in Es]
    T = _gramian_scaling(As, Ed)
    At = [A * T / T[:, None] for A in As]
    a = _pow2(max(np.linalg.norm(A, 2) for A in At))
    At = [A / a for A in At]
    Et = [E / T[:, None] / a for E in Ed]
    Ct = C * T
    row = np.einsum("ij,ij->i", Ct, Ct)
    keep = row > 0
    sigma = _decay_margin_or_raise(At, a)

    lmi = LMIProblem(margin=margin)
    lmi.variable("W", (n, n), symmetric=True)
    lmi.variable("mu", (nw,))
    lmi.variable("t", (1, 1))
    lmi.parameter("lam", (), value=sigma, nonneg=True)
    lmi.add("W > 0", lambda v: [[-v.W]])
    for j, (A, E) in enumerate(zip(At, Et)):
        lmi.add(
            f"decay vertex {j}",
            lambda v, A=A, E=E: [
                [2 * (A @ v.W) + v.lam * v.W],
                [E.T, -diagonal(v.mu)],
            ],
        )
    lmi.add(
        "sum(mu) <= lambda",
        lambda v: [[total(v.mu) - v.lam * np.eye(1)]],
        strict=False,
    )
    if np.any(keep):
        scale = omega[keep] / row[keep]
        Ck = Ct[keep]
        lmi.add(
            "output size <= t",
            lambda v: [
                [
                    diagonal(scale) @ quadratic_rows(Ck, v.W)
                    - v.t[0, 0] * np.eye(len(scale))
                ]
            ],
            strict=False,
        )

        def objective(v):
            return v.t[0, 0]
    else:

        def objective(v):
            return np.trace(v.W)

    chain = solver_chain(solvers) or default_solvers()

    def solve_at(lam, use=chain[:1]):
        lmi.set_parameter("lam", lam)
        try:
            sol = lmi.solve(objective, solvers=use)
        except SynthesisError:
            return np.inf, None
        return float(sol.objective), sol

    if decay is not None:
        lam, value, sol = decay / a, *solve_at(decay / a, chain)
        search = [(decay, value)]
    else:
        grid = np.geomspace(2e-3 * sigma, 1.96 * sigma, _GRID)
        lam, value, sol, search = _line_search(solve_at, grid)
        if sol is None and len(chain) > 1:
            # The search used the first solver only: try the whole chain.
            lam, value, sol, search = _line_search(lambda x: solve_at(x, chain), grid)
        search = [(x * a, f) for x, f in search]
    if sol is None:
        raise CertificationError(
            "ultimate_bound: no certified invariant ellipsoid for any rate tried "
            f"(lambda in [{search[0][0]:.3g}, {search[-1][0]:.3g}] 1/s)"
        )
    lam = float(lam)
    lmi.set_parameter("lam", lam)
    lmi_checks = lmi.check(sol.values)

    # Back to original units and independent float64 checks.
    W = T[:, None] * sol.W * T
    W = 0.5 * (W + W.T)
    P = np.linalg.inv(W)
    P = 0.5 * (P + P.T)
    lam_o = lam * a
    mu = np.asarray(sol.mu, float).reshape(-1) * a
    mu = np.maximum(mu, 0.0)
    checks = [_positive_check("P > 0", P)]
    aP = np.abs(P)
    for j, (A, E) in enumerate(zip(As, Ed)):
        M = np.block([[A.T @ P + P @ A + lam_o * P, P @ E], [E.T @ P, -np.diag(mu)]])
        aA, aPE = np.abs(A), aP @ np.abs(E)
        M_abs = np.block(
            [[aA.T @ aP + aP @ aA + lam_o * aP, aPE], [aPE.T, np.diag(mu)]]
        )
        checks.append(_strict_check(f"decay vertex {j}", M, M_abs))
    rho = float(mu.sum() / lam_o)
    checks.append(EllipsoidCheck("rho = sum(mu)/lambda", rho, 1.0 + 1e-6))
    certificate = EllipsoidCertificate(
        tuple(checks),
        lmi_checks,
        statement=(
            "for every delta(t) in the polytope and every input with "
            "|w_i(t)| <= w_max_i: d(x'Px)/dt <= -lambda (x'Px - rho)"
        ),
    )
    if not certificate.verified:
        raise CertificationError(
            "ultimate_bound: the returned point failed its float64 checks "
            f"({certificate.summary})",
            sol.attempts,
        )
    ell = Ellipsoid(P, rho)
    bounds = ell.support(C) + np.abs(Dw) @ wmax
    return UltimateBound(
        ellipsoid=ell,
        P=P,
        rho=rho,
        decay=lam_o,
        mu=mu,
        w_max=wmax,
        outputs=names,
        C=C,
        Dw=Dw,
        bounds=bounds,
        certificate=certificate,
        search=tuple(search),
        attempts=tuple(sol.attempts),
    )


def _ultimate_bound_engine(As, Es, C, Dw, names, wmax, omega, decay, margin,
                           solvers):  # fmt: skip
    """`ultimate_bound` on the one engine: an `OutputPeaks` analysis.

    The closed loop ``(A_j, E_j, C_w)`` with the output rows ``C_w``
    weighted (``sqrt(omega_i) / ||c_i T||``, ``T`` the reachability-Gramian
    state scaling, so that the bounds are compared in the states' natural
    units), the decays searched from ``2e-3`` to ``1.96`` times the slowest
    vertex's decay rate (``lambda`` below twice it), or the given one.
    """
    from .synthesis.general import run_analysis
    from .synthesis.parametric import lyapunov_structure
    from .synthesis.ultimate import OutputPeaks
    from .systems import PolytopicStateSpace

    n, nw = As[0].shape[0], Es[0].shape[1]
    sigma = _decay_margin_or_raise(As, 1.0)
    T = _gramian_scaling(As, [E * wmax for E in Es])
    row = np.einsum("ij,ij->i", C * T, C * T)
    keep = row > 0
    if np.any(keep):
        Cw = C[keep] * np.sqrt(omega[keep] / row[keep])[:, None]
    else:
        Cw = np.eye(n)  # no output to bound: any certified ellipsoid
    if decay is not None:
        lambdas = (decay,)
    else:
        lambdas = tuple(np.geomspace(2e-3 * sigma, 1.96 * sigma, _GRID))
    zero = np.zeros((Cw.shape[0], nw))
    loop = PolytopicStateSpace([(A, E, Cw, zero) for A, E in zip(As, Es)])
    spec = OutputPeaks(w_max=tuple(wmax), lambdas=lambdas)
    design = run_analysis(
        loop, spec, lyapunov_structure(loop, "constant", None), margin,
        solver_chain(solvers), "ultimate_bound",
    )  # fmt: skip
    values = design.values[spec]
    P, lam, mu, rho = design.P, values["decay"], values["mu"], values["level"]
    ell = Ellipsoid(P, rho)
    certificate = replace(
        design.certificate,
        statement=(
            "for every delta(t) in the polytope and every input with "
            "|w_i(t)| <= w_max_i: d(x'Px)/dt <= -lambda (x'Px - rho); "
            + design.certificate.statement
        ),
    )
    return UltimateBound(
        ellipsoid=ell,
        P=P,
        rho=rho,
        decay=lam,
        mu=mu,
        w_max=wmax,
        outputs=names,
        C=C,
        Dw=Dw,
        bounds=ell.support(C) + np.abs(Dw) @ wmax,
        certificate=certificate,
        search=((lam, float(design.gamma)),),
        attempts=design.attempts,
    )
