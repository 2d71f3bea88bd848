r"""Sampling a polytopic system, with a bound on the error between vertices.

Zero-order hold of a frozen system ``(A, B)`` gives

.. math::

    \begin{bmatrix} \Phi & \Gamma \\ 0 & I \end{bmatrix}
    = e^{T M}, \qquad
    M = \begin{bmatrix} A & B \\ 0 & 0 \end{bmatrix},

which is not affine in ``(A, B)``: the vertexwise ZOH model
``sum_j delta_j (Phi_j, Gamma_j)`` is exact at the vertices only. This
module bounds its error over the whole domain,

.. math::

    e_\Phi = \sup_p \bigl\|\Phi(p) - \textstyle\sum_j \delta_j(p)\,\Phi_j\bigr\|_2,
    \qquad
    e_\Gamma = \sup_p \bigl\|\Gamma(p) - \textstyle\sum_j \delta_j(p)\,
    \Gamma_j\bigr\|_2,

where ``Phi(p)``, ``Gamma(p)`` are the exact ZOH of the frozen system
``A(p) = sum_j delta_j(p) A_j`` (the system the class holds). ``C`` and
``D`` are unchanged by sampling, so the polytopic model is exact for them.

**Derivation.** Write ``F(p) = expm(T M(p))`` with ``M(p) = sum_j delta_j(p)
M_j``. The argument runs in any norm ``||X||_S = ||S X S^-1||_2`` (``S``
invertible), with ``mu_S(X) = lambda_max((Y + Y') / 2)``, ``Y = S X
S^-1``, its logarithmic norm, so that ``||expm(t X)||_S <= exp(t
mu_S(X))`` for ``t >= 0``; ``mu_S`` is convex, so ``mu_S(M(p)) <= mu* =
max_j mu_S(M_j)``. At the end ``||X||_2 <= kappa ||X||_S``, ``kappa =
||S|| ||S^-1||``.

1. *Second derivative along a direction.* If ``M(s) = M + s E``, the
   Dyson expansion gives ``F''(s) = 2 T^2 \int_{\tau_1 + \tau_2 + \tau_3 = 1}
   e^{\tau_1 T M(s)} E e^{\tau_2 T M(s)} E e^{\tau_3 T M(s)} d\sigma`` over
   the 2-simplex (area 1/2), hence ``||F''(s)||_S <= T^2 ||E||_S^2 exp(T
   mu*)``.
2. *Box* (`ParameterBox`, ``delta`` multilinear in ``p``): along coordinate
   ``i`` (others fixed) ``M(p)`` is affine with slope ``E_i = D_i / w_i``,
   where ``w_i`` is the width and ``D_i(p)`` a convex combination of the
   differences ``M_j' - M_j`` over the box edges along ``i``; so ``||D_i||_S
   <= d_i = max over those edges of ||M_j' - M_j||_S``. The vertexwise model
   is the multilinear interpolant ``I_1 ... I_k F`` (``I_i`` the linear
   interpolation in ``p_i``). Telescoping, ``F - I_1...I_k F = sum_i I_1
   ... I_{i-1} (F - I_i F)``; each ``I_i`` is a convex combination, so it
   does not increase the sup norm, and the Peano-kernel form of the
   one-dimensional interpolation error (valid for matrix-valued functions)
   gives ``||F - I_i F|| <= w_i^2 / 8 sup ||d^2 F / dp_i^2||``. Hence

   .. math::

       e \le \kappa \frac{T^2}{8}\, e^{T \mu^*} \sum_i d_i^2 .

3. *Any polytope* (`Simplex`, `Polytope`, or a box): at ``x = sum_j
   lambda_j v_j`` (vertices ``v_j`` in the convex coordinates), Taylor's
   formula with integral remainder at ``x`` and ``sum_j lambda_j (v_j - x)
   = 0`` give ``sum_j lambda_j F(v_j) - F(x) = sum_j lambda_j R_j``, with
   ``||R_j||_S <= 1/2 T^2 ||M_j - M(x)||_S^2 exp(T mu*)`` by step 1, and
   ``||M_j - M(x)||_S <= max_l ||M_j - M_l||_S``. Hence

   .. math::

       e \le \kappa \frac{T^2}{2}\, e^{T \mu^*} \max_{j, l} \|M_j - M_l\|_S^2 .

4. *Box, sampled*. Cut the box into
   ``c^k`` equal cells (``c + 1`` points per coordinate, at most about 1000
   points in all) and let ``G = F - I F`` be the error. On a cell,
   the multilinear interpolation ``J`` from the cell's corners reproduces
   the multilinear ``I F``, so ``G - J G = F - J F``, which is step 2 on
   the cell: its edges are ``1/c`` of the box's and its ``mu*`` no larger,
   so ``||F - J F|| <= e_2 / c^2`` with ``e_2`` the box bound of step 2;
   and ``||J G|| <= max`` of ``||G||`` at the corners (a convex
   combination). Hence ``e <= max_grid ||G|| + e_2 / c^2``, with ``G`` at the
   grid points from `scipy.linalg.expm` and a rounding allowance of
   ``100 eps (||F(p)|| + ||I F(p)||)`` added at each point.

5. *Simplex, sampled* (`Simplex`, ``N = d + 1`` vertices). The same with
   the lattice ``a / c`` of convex coordinates (``a >= 0`` integer, ``sum
   a = c``, at most about 1000 points): the simplex is the union of the
   cells of its Freudenthal triangulation, whose vertices are lattice
   points and whose edges are sums of at most ``r = ceil(d / 2)`` vectors
   ``(v_j - v_l) / c``, so each cell's vertex-pair changes are at most ``r
   / c`` of the simplex's, and ``e <= max_grid ||G|| + (r / c)^2 e_3`` with
   ``e_3`` the bound of step 3. A `Polytope` has no grid (steps 2 and 3
   only).

Step 1 with ``S = I`` (the 2-norm) is tight only for well-scaled data: on a
quarter car (states in m and m/s, tyre stiffness over unsprung mass 4750
s^-2) ``mu_2`` is about 2400 s^-1, so ``exp(T mu*)`` alone is 120 at
``T = 2 ms``. The norms tried are the 2-norm, ``S' S = P`` with ``P`` the
Lyapunov matrix of the mean ``M`` shifted past its spectral abscissa (and
the sum of the vertices' own), and a diagonal balance; the smallest bound
is kept. Measured (``benchmarks/study_discretization_bound.py``, periods
0.5 to 10 ms): the 2-norm bound was 108 to 1.3e11 times the error on the
quarter car and 1.5e5 to 5e29 times on the two-mass drive; in the scaled
norms, 6 to 90 (``Phi``) and 12 to 1.9e4 (``Gamma``) times; with the grid
of steps 4 and 5, 1.00 to 1.16 times with one or two parameters and 1.1 to
2.9 times with three (9 cells per axis), the loosest at the shortest
period. The grid coarsens with the number of parameters (4 cells per axis
for 4 parameters, 2 for 6, none from 7 on) and the remainder grows with ``exp(T
mu*)``, so the bound is loose for many parameters, for long periods
(``T`` times the spectral radius above about 1), and on a `Polytope`
(the quarter car's box as a `Polytope`, 0.5, 2 and 10 ms: 36 to 49 times for
``Phi``, 45 to 600 for ``Gamma``).

For ``e_Phi`` the same argument runs with ``A`` in place of ``M`` (``Phi =
expm(T A)``). For ``e_Gamma`` the bound with ``M`` (it bounds the whole
block row ``[Phi, Gamma]``) is ``O(T^2)``, while ``Gamma`` only changes at
``O(T^3)`` when ``B`` is constant; a second bound is taken from
``S Gamma(p) = \int_0^T S expm(s A(p)) S^-1 ds S B(p)`` (and ``||Gamma||_2
<= ||S^-1|| ||S Gamma||_2``): along a direction with slopes ``(E_A, E_B)``
(``B`` affine along it, so no ``B''`` term), ``||S Gamma''|| <=
||E_A||_S^2 b I_2 + 2 ||E_A||_S ||S E_B|| I_1`` with ``b = max_j ||S
B_j||``, ``I_k = \int_0^T s^k exp(s mu_A*) ds``, from ``||d^2/ds^2
expm(s A)||_S <= s^2 ||E_A||_S^2 exp(s mu_A*)`` and ``||d/ds expm(s
A)||_S <= s ||E_A||_S exp(s mu_A*)``. Steps 2 and 3 then give ``sum_i
(a_i^2 b I_2 + 2 a_i b_i I_1) / 8`` on a box (``a_i, b_i`` the largest
edge changes of ``A`` and ``S B`` along ``i``) and ``(a^2 b I_2 + 2 a b'
I_1) / 2`` on any polytope (``a, b'`` the largest vertex-pair changes).
The smallest of the valid bounds is reported, plus ``100 eps`` times the
largest vertex norm for the rounding of the vertices' own ``expm``.

**Long periods.** ``exp(T mu*)`` overflows for a long period; the bound is
then ``inf`` (never NaN: a zero factor makes a term zero, not ``0 *
inf``), with a `UserWarning` saying the period is too long for a
meaningful bound, as it does whenever a bound is not below the largest
norm of the sampled vertex matrices. A vertex whose own ZOH overflows
(unstable, long period) is refused with a `ValueError` naming ``Ts``.

The forward-Euler model ``(I + T A_j, T B_j)`` is affine in the vertex
data, so it is exactly polytopic (both errors 0).
"""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .polytope import ParameterBox, Simplex

__all__ = ["DiscretizationBound", "sampled_vertex_data"]

# Sampled refinement on a box or a simplex: at most this many exact ZOHs
# (one stacked expm, milliseconds for small systems).
_GRID_POINTS = 1025
# Rounding allowance per grid point, relative to the norms of the matrices
# compared (scipy's expm is accurate to a small multiple of eps there).
_ROUNDING = 100.0 * np.finfo(float).eps
# Shifts of the Lyapunov scalings, relative to the spectral radius.
_SHIFTS = (1e-3, 1e-2, 1e-1, 1.0)
# Vertex Lyapunov matrices are summed into a candidate up to this many vertices.
_LYAPUNOV_VERTICES = 64
# Exact largest vertex-pair difference up to this many vertices.
_PAIRWISE_VERTICES = 128


@dataclass(frozen=True)
class DiscretizationBound:
    """Bound on the error of a vertexwise discretization between vertices.

    Attributes
    ----------
    Ts : float
        Sampling period.
    method : str
        ``"zoh"`` or ``"euler"``.
    phi : float
        Upper bound on ``sup_p ||Phi(p) - sum_j delta_j(p) Phi_j||_2``, where
        ``Phi(p)`` is the discretization (by `method`) of the frozen
        continuous-time system at ``p``. ``inf`` (with a warning) when the
        sampling period is too long for a finite bound.
    gamma : float
        The same for the input matrix ``Gamma``.
    exact : bool
        True when the polytopic model equals the frozen discretization at
        every point (a single vertex, vertices with equal ``A, B``, or
        ``method="euler"``).
    """

    Ts: float
    method: str
    phi: float
    gamma: float
    exact: bool


@dataclass(frozen=True)
class _Norm:
    """The norm ``||X||_S = ||S X S^-1||_2`` in which a bound is derived."""

    S: np.ndarray
    S_inv: np.ndarray

    @property
    def kappa(self) -> float:
        """``||S|| ||S^-1||``: ``||X||_2 <= kappa ||X||_S``."""
        return float(np.linalg.norm(self.S, 2) * np.linalg.norm(self.S_inv, 2))

    def similar(self, X: np.ndarray) -> np.ndarray:
        return self.S @ X @ self.S_inv


def _norms(mats) -> list[_Norm]:
    """Candidate norms: 2-norm, Lyapunov norms, diagonal balance.

    Any invertible ``S`` gives a valid bound; these make the logarithmic
    norms of the vertices small: ``S' S`` the Lyapunov matrix of the mean
    shifted past its spectral abscissa (``mu_S(mean)`` then lies just above
    the abscissa), or the sum of the vertices' own (a common Lyapunov
    function of many polytopes), or a diagonal balance. The smallest
    bound wins.
    """
    size = mats[0].shape[0]
    out = [_Norm(np.eye(size), np.eye(size))]
    mean = sum(mats) / len(mats)
    eigs = [np.linalg.eigvals(M) for M in [mean, *mats]]
    radius = max(float(np.abs(e).max()) for e in eigs)
    if not np.isfinite(radius) or radius == 0.0:
        return out
    for shift in _SHIFTS:
        groups = [[mean]] + ([mats] if len(mats) <= _LYAPUNOV_VERTICES else [])
        for group in groups:
            try:
                S = _factor(sum(_lyapunov(M, shift * radius) for M in group))
            except (np.linalg.LinAlgError, ValueError):
                continue  # no candidate from this group: the others remain
            if S is not None:
                out.append(_Norm(S, np.linalg.inv(S)))
    _, (scale, _) = scipy.linalg.matrix_balance(mean, permute=False, separate=True)
    out.append(_Norm(np.diag(1.0 / scale), np.diag(scale)))
    return [c for c in out if np.all(np.isfinite(c.S_inv))]


def _lyapunov(M: np.ndarray, shift: float) -> np.ndarray:
    """``P`` with ``X' P + P X = -I``, ``X = M - (abscissa + shift) I``, unit norm."""
    abscissa = float(np.linalg.eigvals(M).real.max())
    X = M - (abscissa + shift) * np.eye(M.shape[0])  # Hurwitz
    P = scipy.linalg.solve_continuous_lyapunov(X.T, -np.eye(M.shape[0]))
    return P / np.linalg.norm(P, 2)


def _factor(P: np.ndarray) -> np.ndarray | None:
    """``S`` with ``S' S = P``, or None if ``P`` is not numerically definite."""
    try:
        S = np.linalg.cholesky((P + P.T) / 2.0).T
    except np.linalg.LinAlgError:
        return None
    return S if np.linalg.cond(S) < 1e8 else None


def _mu(X: np.ndarray) -> float:
    """Logarithmic 2-norm ``lambda_max((X + X') / 2)``."""
    return float(np.linalg.eigvalsh((X + X.T) / 2.0).max())


def _product(*factors: float) -> float:
    """Product that is 0 when a factor is 0 (not NaN against an overflow)."""
    if any(f == 0.0 for f in factors):
        return 0.0
    with np.errstate(over="ignore"):
        return float(np.prod(factors))


def _exp(x: float) -> float:
    with np.errstate(over="ignore"):
        return float(np.exp(x))  # inf past 709, never an exception


def _norm2(stack: np.ndarray) -> np.ndarray:
    """Spectral norms of stacked matrices (one batched SVD)."""
    return np.linalg.norm(stack, 2, axis=(-2, -1))


def _pairwise(mats) -> float:
    """``max_{j,l} ||M_j - M_l||_2`` (0 for one vertex).

    Past `_PAIRWISE_VERTICES` vertices, the upper bound ``2 max_j ||M_j -
    mean||`` instead (linear, not quadratic, in the number of vertices).
    """
    stack = np.stack(mats)
    if len(mats) > _PAIRWISE_VERTICES:
        return 2.0 * float(_norm2(stack - stack.mean(axis=0)).max())
    j, k = np.triu_indices(len(mats), 1)
    return float(_norm2(stack[j] - stack[k]).max(initial=0.0))


def _edges(mats, domain) -> list[float]:
    """Per box coordinate ``i``: ``max ||M_j' - M_j||_2`` over its edges."""
    stack = np.stack(mats)
    k = domain.nparams
    out = []
    for i in range(k):
        lower = np.flatnonzero(~domain._bits[:, i])
        step = 1 << (k - 1 - i)  # the first parameter varies slowest
        out.append(float(_norm2(stack[lower ^ step] - stack[lower]).max()))
    return out


def _moments(T: float, mu: float) -> tuple[float, float]:
    """``I_1, I_2`` with ``I_k = int_0^T s^k exp(mu s) ds`` (inf on overflow)."""
    x = mu * T
    if abs(x) <= 1.0:  # series, no cancellation
        i1 = i2 = 0.0
        term = 1.0  # x^k / k!
        for k in range(40):
            i1 += term / (k + 2)
            i2 += term / (k + 3)
            term *= x / (k + 1)
        return T**2 * i1, T**3 * i2
    with np.errstate(over="ignore", invalid="ignore"):
        e = np.exp(x)
        return (
            float((e * (x - 1.0) + 1.0) / mu**2),
            float((e * (x * x - 2.0 * x + 2.0) - 2.0) / mu**3),
        )


def _expm_bound(mats, domain, T: float, norm: _Norm) -> tuple[float, float]:
    """Bounds on the interpolation error of ``expm(T M(p))`` (steps 1 to 3).

    Returns the bound valid on any polytope and the box bound (``inf`` off
    a box), both in the 2-norm, derived in the norm `norm`.
    """
    similar = [norm.similar(M) for M in mats]
    grow = _product(norm.kappa, T * T, _exp(T * max(_mu(M) for M in similar)))
    pair = _product(grow, _pairwise(similar) ** 2 / 2.0)
    if not isinstance(domain, ParameterBox):
        return pair, np.inf
    return pair, _product(grow, sum(d * d for d in _edges(similar, domain)) / 8.0)


def _gamma_bound(As, Bs, domain, T: float, norm: _Norm) -> tuple[float, float]:
    """The same for ``Gamma(p)`` from its integral form."""
    similar = [norm.similar(A) for A in As]
    scaled = [norm.S @ B for B in Bs]  # ||Gamma||_2 <= ||S^-1|| ||S Gamma||_2
    back = float(np.linalg.norm(norm.S_inv, 2))
    i1, i2 = _moments(T, max(_mu(A) for A in similar))
    b = max(np.linalg.norm(B, 2) for B in scaled)

    def second(a: float, db: float) -> float:
        """Bound on ``||Gamma''||`` for slopes of norms ``a`` (A), ``db`` (B)."""
        return _product(a * a * b, i2) + _product(2.0 * a * db, i1)

    pair = _product(back, second(_pairwise(similar), _pairwise(scaled)) / 2.0)
    if not isinstance(domain, ParameterBox):
        return pair, np.inf
    box = sum(
        second(a, db) for a, db in zip(_edges(similar, domain), _edges(scaled, domain))
    )
    return pair, _product(back, box / 8.0)


def _best(bounds) -> tuple[float, float]:
    """Smallest (any-polytope, box) pair over the candidate norms."""
    bounds = list(bounds)
    return min(b[0] for b in bounds), min(b[1] for b in bounds)


def _grid(domain):
    """Grid of convex coordinates, and how much each bound shrinks on a cell.

    Returns ``(weights, shrink_any, shrink_box)`` (``weights`` of shape
    ``(points, N)``, the vertices among the points) or None when the domain
    has no grid here (a `Polytope`) or the grid would be too coarse.
    """
    if isinstance(domain, ParameterBox):
        k = domain.nparams
        cells = int(_GRID_POINTS ** (1.0 / k) + 1e-9) - 1
        if cells < 2:
            return None
        ticks = np.linspace(0.0, 1.0, cells + 1)
        lam = np.array(list(itertools.product(ticks, repeat=k)))[:, None]
        weights = np.prod(np.where(domain._bits[None], lam, 1.0 - lam), axis=2)
        return weights, np.inf, 1.0 / cells**2
    if not isinstance(domain, Simplex) or domain.nvertices < 2:
        return None
    d = domain.nvertices - 1
    cells = 1
    while math.comb(cells + 1 + d, d) <= _GRID_POINTS:
        cells += 1
    if cells < 2:
        return None
    # The lattice a / cells (a >= 0 integer, sum cells), by stars and bars.
    bars = np.array(list(itertools.combinations(range(cells + d), d)))
    edges = np.hstack(
        [np.full((len(bars), 1), -1), bars, np.full((len(bars), 1), cells + d)]
    )
    weights = (np.diff(edges, axis=1) - 1) / cells
    runs = (d + 1) // 2  # step 4: edges of a cell are sums of <= runs vertex pairs
    return weights, (runs / cells) ** 2, np.inf


def _grid_errors(Ms, Fs, n: int, weights: np.ndarray, T: float):
    """Largest errors of ``Phi`` and ``Gamma`` at the grid points `weights`.

    The exact ZOH there is one stacked `scipy.linalg.expm`. Each error
    carries a rounding allowance. ``inf`` if the expm overflows.
    """
    M = np.einsum("gj,jab->gab", weights, np.stack(Ms))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        exact = scipy.linalg.expm(T * M)[:, :n, :]
    if not np.all(np.isfinite(exact)):
        return np.inf, np.inf
    model = np.einsum("gj,jab->gab", weights, np.stack([F[:n, :] for F in Fs]))
    out = []
    for cols in (slice(0, n), slice(n, None)):
        size = [np.linalg.norm(X[:, :, cols], 2, axis=(1, 2)) for X in (exact, model)]
        error = np.linalg.norm(exact[:, :, cols] - model[:, :, cols], 2, axis=(1, 2))
        out.append(float(np.max(error + _ROUNDING * (size[0] + size[1]))))
    return tuple(out)


def _analytic_bounds(Ms, n: int, domain, T: float):
    """``(any, box)`` bound pairs for ``Phi`` and ``Gamma`` (steps 1 to 3)."""
    As = [M[:n, :n] for M in Ms]
    Bs = [M[:n, n:] for M in Ms]
    block = _best(_expm_bound(Ms, domain, T, c) for c in _norms(Ms))  # [Phi, Gamma]
    norms_A = _norms(As)
    phi = _best(_expm_bound(As, domain, T, c) for c in norms_A)
    gamma = _best(_gamma_bound(As, Bs, domain, T, c) for c in norms_A)
    return [(min(b, c) for b, c in zip(own, block)) for own in (phi, gamma)]


def _zoh_bound(Ms, Fs, n: int, domain, T: float) -> list[float]:
    """``[phi, gamma]`` bounds of the vertexwise ZOH (see the module)."""
    pairs = [tuple(p) for p in _analytic_bounds(Ms, n, domain, T)]
    result = [min(p) for p in pairs]
    grid = _grid(domain)
    if grid is not None and 0.0 < max(result) and min(result) < np.inf:
        # Step 4: the error is within the bound of a cell (the domain's
        # bound shrunk) of its interpolation from the cell's corners.
        weights, shrink_any, shrink_box = grid
        sampled = _grid_errors(Ms, Fs, n, weights, T)
        result = [
            min(r, s + min(_product(pair, shrink_any), _product(box, shrink_box)))
            for r, s, (pair, box) in zip(result, sampled, pairs)
        ]
    for i, cols in enumerate((slice(0, n), slice(n, None))):
        if result[i] > 0.0:  # the vertices' own rounding, as in the model
            size = max(np.linalg.norm(F[:n, cols], 2) for F in Fs)
            result[i] += _ROUNDING * size
    return result


def _warn_if_meaningless(Ts: float, phi: float, gamma: float, vertices) -> None:
    """Warn when a bound is inf or not below the sampled matrices' size."""
    loose = [
        f"{name} = {bound:.3g} (largest vertex norm {size:.3g})"
        for name, bound, size in (
            ("phi", phi, max(np.linalg.norm(v[0], 2) for v in vertices)),
            ("gamma", gamma, max(np.linalg.norm(v[1], 2) for v in vertices)),
        )
        if bound > 0.0 and bound >= size
    ]
    inf = not (np.isfinite(phi) and np.isfinite(gamma))
    if loose:
        warnings.warn(
            f"Ts = {Ts:g} is too long for a meaningful bound on the error "
            "between the vertices' zero-order holds: discretization_error "
            f"has {' and '.join(loose)}"
            + ("; inf: the growth factor exp(Ts * mu) overflows" if inf else "")
            + ". Sample faster, or narrow the parameter box.",
            UserWarning,
            stacklevel=4,
        )


def sampled_vertex_data(data, domain, Ts: float, method: str):
    """Vertexwise discretization and its `DiscretizationBound`.

    Parameters
    ----------
    data : sequence of (A, B, C, D)
        Continuous-time vertex matrices, in the domain's vertex order.
    domain : `ParameterBox`, `Polytope` or `Simplex`
        The parameter domain (its type selects the bound; see the module).
    Ts : float
        Sampling period, positive.
    method : {"zoh", "euler"}
        Discretization.

    Returns
    -------
    vertices : list of (Phi_j, Gamma_j, C_j, D_j)
    bound : `DiscretizationBound`

    Raises
    ------
    ValueError
        If the zero-order hold of a vertex overflows (`Ts` too long for an
        unstable vertex).

    Warns
    -----
    UserWarning
        If a bound is ``inf`` (the growth factor overflows) or not below the
        largest norm of the sampled vertex matrices: `Ts` is too long for a
        meaningful bound.
    """
    n = data[0][0].shape[0]
    m = data[0][1].shape[1]
    if method == "euler":
        vertices = [(np.eye(n) + Ts * A, Ts * B, C, D) for A, B, C, D in data]
        return vertices, DiscretizationBound(Ts, method, 0.0, 0.0, True)
    Ms, Fs = [], []
    for j, (A, B, _, _) in enumerate(data):
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            F = scipy.linalg.expm(Ts * M)
        if not np.all(np.isfinite(F)):
            raise ValueError(
                f"Ts: {Ts:g} is too long to sample this system: the zero-order "
                f"hold of vertex {j} overflows (expm(Ts * A) is not finite in "
                "float64)"
            )
        Ms.append(M)
        Fs.append(F)
    vertices = [(F[:n, :n], F[:n, n:], C, D) for F, (_, _, C, D) in zip(Fs, data)]
    phi, gamma = _zoh_bound(Ms, Fs, n, domain, Ts)
    _warn_if_meaningless(Ts, phi, gamma, vertices)
    return vertices, DiscretizationBound(
        float(Ts), method, float(phi), float(gamma), bool(gamma == 0.0 and phi == 0.0)
    )
