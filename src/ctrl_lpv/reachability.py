"""Invariant ellipsoids and ultimate bounds for peak-bounded inputs.

For a polytopic system ``dx/dt = A(delta) x + E(delta) w`` (or its
discrete-time counterpart ``x[k+1] = A(delta) x[k] + E(delta) w[k]``) with
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
w_max_k``.

It is an analysis of the one engine (`ctrl_lpv.synthesize`'s): the spec
`ctrl_lpv.synthesis.ultimate.OutputPeaks` (`Peak`'s invariance LMIs, in
``W = P^-1``, with the size of the ellipsoid along each output row) on
the loop without control inputs, its decay found by the engine's decay
search, the prescalings, margins and solvers of its ladder, and the
engine's certificate (LMIs as posed, frozen loops in the model's units).

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

`InfeasibleError` when a vertex is not Hurwitz (then no ``P`` exists);
otherwise `CertificationError` (the engine's refusal).
"""

from __future__ import annotations

import math
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

# The certificate of a loaded saturated design (`ctrl_lpv._sector_checks`).
from ._invariant_checks import (  # noqa: F401
    EllipsoidCertificate,
    EllipsoidCheck,
    _pow2,
)
from .budget import DEFAULT_TIME_LIMIT, time_budget
from .certificate import Certificate
from .exceptions import CertificationError, InfeasibleError
from .lmi import SolveAttempt, solver_chain

__all__ = [
    "Ellipsoid",
    "EllipsoidCheck",
    "EllipsoidCertificate",
    "UltimateBound",
    "ultimate_bound",
]

# Decays searched (a geometric grid below twice the slowest vertex's decay
# rate, refined by the engine's search).
_DECAYS = 9


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
        The S-procedure rate ``lambda``, 1/s: ``V(t) - rho <= (V(0) - rho)
        exp(-decay t)`` with ``V = x' P x`` (in discrete time at the
        sampling instants, ``decay = -ln(1 - lambda) / dt`` for the
        contraction ``lambda`` per sample).
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
    certificate : `ctrl_lpv.synthesis.results.DesignCertificate`
        The engine's float64 checks (a `ctrl_lpv.Certificate` of named
        checks: the LMIs as posed, and the frozen loops in the model's
        units, among them the invariance inequality with `P`, `decay` and
        `mu`); ``print`` shows them as a table.
    search : tuple of (float, float)
        ``(lambda, objective)`` of the certified point (the objective the
        largest weighted output bound); the engine's decay search is in
        `ladder`.
    attempts : tuple of `ctrl_lpv.lmi.SolveAttempt`
        Every solver attempt.
    ladder : tuple of str
        What the engine tried before the point certified (see
        `ctrl_lpv.StateFeedbackDesign.ladder`).
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
    certificate: Certificate
    search: tuple = ()
    attempts: tuple[SolveAttempt, ...] = field(default_factory=tuple)
    ladder: tuple[str, ...] = ()

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
# Data and refusals
# ----------------------------------------------------------------------
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


def _decay_margin_or_raise(As) -> float:
    """The smallest decay rate ``min_j -max Re eig(A_j)``, which must be > 0.

    Past `_hurwitz_or_raise` it can still be ``<= 0`` for an eigenvalue
    within rounding of the imaginary axis: no rate can be certified then.
    """
    rates = [-np.linalg.eigvals(A).real.max() for A in As]
    j = int(np.argmin(rates))
    if not rates[j] > 0:
        raise CertificationError(
            f"ultimate_bound: vertex {j} has an eigenvalue with real part "
            f"{-rates[j]:.3g} 1/s, on the imaginary axis up to rounding, so no "
            "decay rate (and no ultimate bound) can be certified"
        )
    return float(rates[j])


def _schur_margin_or_raise(As) -> float:
    """``1 - max_j rho(A_j)^2`` (discrete time), which must be > 0.

    It bounds the contraction per sample of any ``V = x' P x`` common to
    the vertices: ``A' P A <= (1 - lambda) P`` needs ``lambda <= 1 -
    rho(A_j)^2``. `InfeasibleError` for a spectral radius above rounding
    (no such ``P``), `CertificationError` on the unit circle up to rounding.
    """
    radii = [np.abs(np.linalg.eigvals(A)).max() for A in As]
    j = int(np.argmax(radii))
    if radii[j] >= 1.0 + 1e-9:
        raise InfeasibleError(
            f"sys: vertex {j} is not Schur (spectral radius {radii[j]:.6g} > 1): "
            "no quadratic Lyapunov function decreases there, so no invariant "
            "attractive ellipsoid exists"
        )
    margin = 1.0 - radii[j] ** 2
    if not margin > 0:
        raise CertificationError(
            f"ultimate_bound: vertex {j} has spectral radius {radii[j]:.12g}, on "
            "the unit circle up to rounding, so no contraction (and no ultimate "
            "bound) can be certified"
        )
    return float(margin)


def _resolve_data(sys, w, output):
    """Vertex ``A_j``, ``E_j``, output ``C_j``, ``Dw_j``, the output names and
    the sample time (0 in continuous time)."""
    from .systems import PolytopicStateSpace

    if isinstance(sys, StateSpace):
        dt = 0.0 if sys.isctime() else sys.dt
        if dt is True or dt is None:
            raise ValueError(
                f"sys: discrete-time system without a numeric sample time (dt = "
                f"{sys.dt!r}); give dt in seconds, the decay is a rate in 1/s"
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
        return As, Es, Cs, Ds, names, float(dt)
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
        0.0,
    )


def _as_list(M):
    """A single matrix (nested lists or array) as a one-element list."""
    try:
        if np.ndim(M) <= 2:
            return [M]
    except ValueError:  # ragged: a list of matrices of different shapes
        pass
    return list(M)


def _gramian_scaling(As, Es, continuous=True) -> np.ndarray:
    """Power-of-two state scaling from the reachability Gramians' diagonals."""
    diag = np.zeros(As[0].shape[0])
    for A, E in zip(As, Es):
        try:
            with warnings.catch_warnings():
                # Only a scaling heuristic: an inaccurate Gramian is harmless.
                warnings.simplefilter("ignore", RuntimeWarning)
                if continuous:
                    X = sla.solve_continuous_lyapunov(A, -E @ E.T)
                else:
                    X = sla.solve_discrete_lyapunov(A, E @ E.T, method="bilinear")
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
        The (closed-loop) system ``dx/dt = A(delta) x + E(delta) w``, or
        ``x[k+1] = A(delta) x[k] + E(delta) w[k]`` for a discrete-time
        system (``dt > 0``: the invariance inequality ``V(x+) <= (1 -
        lambda) V(x) + sum_i mu_i (w_i / w_max_i)^2`` per sample); with
        vertex lists (continuous time), ``E_list`` may hold a single
        matrix for all vertices.
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
        c_i / ||c_i T||^2`` (default all 1: the largest bound relative to
        each row's norm in the states' natural units, ``T`` the diagonal
        power-of-two scaling by the reachability Gramians' diagonals).
    decay : float, optional
        Fix the rate ``lambda`` (1/s) instead of searching it (the engine's
        decay search over 9 rates up to ``1.96`` times the slowest
        vertex's decay rate, refined around the best; in discrete time 9
        contractions per sample up to ``0.98 (1 - max_j rho(A_j)^2)``).
    margin : float, optional
        Margin of the strict LMIs in the prescaled units (the engine's
        ladder also tries ``1e-3`` of it).
    solvers : str or sequence, optional
        A solver name (e.g. ``"CLARABEL"``, ``"SCS"``), or names or
        ``(name, options)`` pairs tried in turn. Default: Clarabel, then
        SCS, then CVXOPT and MOSEK if installed. The decay search uses the
        first solver only (the whole list once, at the best decay, if it
        finds nothing).
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
        For bad arguments (naming them), and a discrete-time `sys` without
        a numeric sample time.

    Examples
    --------
    ``dx/dt = -2 x + w`` with ``|w| <= 1``: ``|x|`` ends up below ``1/2``.

    >>> res = ultimate_bound(([[-2.0]], [[1.0]]))
    >>> round(float(res.bounds[0]), 3)
    0.5
    """
    from .synthesis.general import run_analysis
    from .synthesis.parametric import lyapunov_structure
    from .synthesis.ultimate import OutputPeaks
    from .systems import PolytopicStateSpace

    As, Es, Cs, Ds, names, dt = _resolve_data(sys, w, output)
    continuous = dt == 0.0
    n, nw = As[0].shape[0], Es[0].shape[1]
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
    chain = solver_chain(solvers)
    if continuous:
        _hurwitz_or_raise(As, "sys: vertex")
        sigma = _decay_margin_or_raise(As)
    else:
        sigma = _schur_margin_or_raise(As)

    # The rows bounded, weighted: the largest bound relative to each row's
    # norm in the states' natural units (the reachability-Gramian scaling).
    T = _gramian_scaling(As, [E * wmax for E in Es], continuous)
    row = np.einsum("ij,ij->i", C * T, C * T)
    keep = row > 0
    if np.any(keep):
        Cw = C[keep] * np.sqrt(omega[keep] / row[keep])[:, None]
    else:
        Cw = np.eye(n)  # no output to bound: any certified ellipsoid
    # Continuous time lambda < 2 sigma (A_j + lambda / 2 I Hurwitz); discrete
    # time the contraction per sample lambda < sigma = 1 - max rho(A_j)^2.
    top = 1.96 * sigma if continuous else 0.98 * sigma
    if decay is None:
        lambdas = tuple(np.geomspace(2e-3 * sigma, top, _DECAYS))
    elif continuous:
        lambdas = (decay,)
    else:
        lambdas = (-math.expm1(-decay * dt),)
        if not lambdas[0] < sigma:
            raise ValueError(
                f"decay: {decay:g}/s is a contraction of {lambdas[0]:.4g} per sample, "
                f"beyond what the slowest vertex allows ({sigma:.4g})"
            )
    zero = np.zeros((Cw.shape[0], nw))
    loop = PolytopicStateSpace(
        [(A, E, Cw, zero) for A, E in zip(As, Es)], **({} if continuous else {"dt": dt})
    )
    spec = OutputPeaks(w_max=tuple(wmax), lambdas=lambdas)
    design = run_analysis(
        loop, spec, lyapunov_structure(loop, "constant", None), margin, chain,
        "ultimate_bound",
    )  # fmt: skip
    values = design.values[spec]
    P, rho = design.P, values["level"]
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
        decay=values["decay"] if continuous else -math.log1p(-values["decay"]) / dt,
        mu=values["mu"],
        w_max=wmax,
        outputs=names,
        C=C,
        Dw=Dw,
        bounds=ell.support(C) + np.abs(Dw) @ wmax,
        certificate=certificate,
        search=((values["decay"], float(design.gamma)),),
        attempts=design.attempts,
        ladder=design.ladder,
    )
