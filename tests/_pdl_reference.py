r"""Independent references for parameter-dependent Lyapunov (PDL) bounds.

Not a test module. Written from the papers with numpy, scipy, control and
cvxpy only; no synthesis or analysis code of ``ctrl_lpv`` is used (the test
module only uses ``ctrl_lpv`` to build the system under test).

Systems are affine on a box, ``M(p) = M0 + sum_i p_i M_i`` for
``M = (A, B, C, D)`` and ``lo_i <= p_i <= hi_i``, with rate bounds
``|dp_i/dt| <= nu_i`` (``nu_i = 0``: time-invariant; ``nu_i = inf``: arbitrarily
fast, then ``P`` does not depend on ``p_i``).

Parts
-----
* Brute force (`frozen_worst_abscissa`, `frozen_worst_hinf`,
  `frozen_worst_sf_hinf`): the worst case over frozen parameters on a dense
  grid (largest real part of the eigenvalues; H-infinity norm by
  ``control.linfnorm``; the optimal state-feedback H-infinity level by Riccati
  bisection). Frozen parameters are admissible trajectories for every rate
  bound, so these lower-bound every valid robust bound.
* Multi-convexity analysis (Gahinet, Apkarian and Chilali, "Affine
  parameter-dependent Lyapunov functions and real parametric uncertainty",
  IEEE TAC 41(3), 1996): ``P(p)`` multi-affine in the parameters with finite
  rate bound (vertex matrices ``P_v``, multilinear interpolation), the
  Lyapunov / bounded-real matrix ``L(p, dp)`` is affine in ``dp`` and of degree
  two in each ``p_i``; with ``F(p) = L(p) + sum_i (p_i - c_i)^2 Lambda_i``,
  ``Lambda_i >= 0`` and ``d^2 F / dp_i^2 >= 0`` (checked at the vertices, the
  second derivative being multi-affine in the other parameters), ``F`` is
  convex along every axis, so ``F < 0`` at the vertices of the (p, dp) box
  implies ``L <= F < 0`` on the whole box. `pdl_stability_lmi` (feasibility),
  `pdl_l2_gain` (minimum gamma), `max_box_scale` (the largest scaling of the
  box around its centre that is certified, by bisection, as ``pdlstab``'s
  option 1 does).
* Scheduled state feedback with a PDL function (`pdl_sf_hinf`): the dual
  form with ``X(p)`` and ``Y(p) = K(p) X(p)`` multi-affine (``u = -K(p) x``,
  ``K(p) = Y(p) X(p)^{-1}``), ``-dX/dt`` in the Lyapunov block, the same
  multi-convexity relaxation.
* Robust common gain with a PDL function (`pdl_sf_hinf_common`): dilated
  (slack-variable) LMIs with constant slack ``V`` and ``K = Y V^{-1}``, exact
  congruence to the dual bounded-real matrix (`dilation_identity_residual`),
  multi-affine in ``p`` so vertices suffice; a grid search on the scalar
  ``alpha``.
* Constant ``P`` (quadratic) bounds are the same programs with every rate bound
  infinite (`quadratic_*` helpers). For an affine dependence the constant-P
  program is exact (the vertex LMIs are necessary and sufficient), so its
  optimum lower-bounds every constant-P bound.

Every returned bound passed a float64 check of its LMIs (`_solve`); a minimum
gamma is re-certified at a fixed gamma within 1e-4 of the optimum
(`_two_stage`).

Examples and sources
--------------------
Published tables of these standard examples (Geromel and Colaneri 2006;
Mozelli and Palhares 2011; Oliveira and Peres 2007; Ramos and Peres 2002) could
not be read in the stored corpora (only their first pages are stored), so no
published number is used: the truths are computed here (frozen brute force)
or analytic (the quadratic limit ``1 + 2 sqrt 2`` of `oscillator` by the
Shorten-Narendra criterion, the frozen peaks ``1/sqrt(1.75)`` and
``1/(0.2 sqrt(0.99))``). The multi-convexity conditions follow Gahinet,
Apkarian and Chilali (1996) as implemented in MATLAB's ``pdlstab`` (vertex
LMIs over the parameter and rate boxes, ``Lambda_i`` terms on the squared
parameters); here the squares are centred on the box (``(p_i - c_i)^2``).
Run ``python tests/_pdl_reference.py`` for the table (about a minute).
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import control as ct
import cvxpy as cp
import numpy as np

INF = float("inf")


# ======================================================================
# Affine systems on a box
# ======================================================================
@dataclass(frozen=True)
class AffineBox:
    """``M(p) = M0 + sum_i p_i M_i`` over ``lo <= p <= hi``.

    ``base`` and each entry of ``terms`` are ``(A, B, C, D)`` arrays (all of
    the same shapes; ``B``/``C``/``D`` may be empty).
    """

    names: tuple
    lo: np.ndarray
    hi: np.ndarray
    base: tuple
    terms: tuple

    @classmethod
    def make(cls, base, terms, bounds):
        names = tuple(bounds)
        base = tuple(np.atleast_2d(np.asarray(m, float)) for m in base)
        full = []
        for name in names:
            t = terms[name]
            full.append(
                tuple(
                    np.zeros_like(b)
                    if np.isscalar(m) and m == 0
                    else np.asarray(m, float)
                    for m, b in zip(t, base)
                )
            )
        lo = np.array([bounds[k][0] for k in names], float)
        hi = np.array([bounds[k][1] for k in names], float)
        return cls(names, lo, hi, base, tuple(full))

    @property
    def k(self):
        return len(self.names)

    @property
    def n(self):
        return self.base[0].shape[0]

    def at(self, p):
        """``(A, B, C, D)`` at the parameter value `p`."""
        p = np.asarray(p, float)
        return tuple(
            self.base[m] + sum(p[i] * self.terms[i][m] for i in range(self.k))
            for m in range(4)
        )

    def scaled(self, theta):
        """The same system on the box scaled by `theta` around its centre."""
        c, h = (self.lo + self.hi) / 2, (self.hi - self.lo) / 2
        return AffineBox(
            self.names, c - theta * h, c + theta * h, self.base, self.terms
        )

    def vertices(self):
        """Box corners, rows, in ``itertools.product`` order (first name slowest)."""
        return np.array(list(itertools.product(*zip(self.lo, self.hi))), float)

    def grid(self, count):
        """Tensor grid with `count` points per parameter (corners included)."""
        axes = [np.linspace(a, b, count) for a, b in zip(self.lo, self.hi)]
        return np.array(list(itertools.product(*axes)), float)

    def closed_loop(self, K, iw, iu, iz):
        """``(A - B_u K, B_w, C_z - D_zu K, D_zw)`` as an `AffineBox` (constant K)."""
        K = np.atleast_2d(np.asarray(K, float))

        def cl(m):
            A, B, C, D = m
            return (
                A - B[:, iu] @ K,
                B[:, iw],
                C[iz] - D[np.ix_(iz, iu)] @ K,
                D[np.ix_(iz, iw)],
            )

        base = cl(self.base)
        # terms are linear in p: the base's K-term is in base only
        terms = []
        for t in self.terms:
            A, B, C, D = t
            terms.append(
                (
                    A - B[:, iu] @ K,
                    B[:, iw],
                    C[iz] - D[np.ix_(iz, iu)] @ K,
                    D[np.ix_(iz, iw)],
                )
            )
        return AffineBox(self.names, self.lo, self.hi, base, tuple(terms))


# ======================================================================
# Brute force over frozen parameters
# ======================================================================
def frozen_worst_abscissa(sys: AffineBox, count=201):
    """``max_p max Re eig A(p)`` on a grid; returns ``(value, p)``."""
    best, arg = -INF, None
    for p in sys.grid(count):
        a = np.linalg.eigvals(sys.at(p)[0]).real.max()
        if a > best:
            best, arg = a, p
    return float(best), arg


def frozen_worst_hinf(sys: AffineBox, count=101):
    """``max_p ||C(p)(sI - A(p))^{-1}B(p) + D(p)||_inf`` on a grid (linfnorm)."""
    best, arg = -INF, None
    for p in sys.grid(count):
        A, B, C, D = sys.at(p)
        if np.linalg.eigvals(A).real.max() >= 0:
            return INF, p
        g = float(ct.linfnorm(ct.ss(A, B, C, D))[0])
        if g > best:
            best, arg = g, p
    return best, arg


def frozen_worst_sf_hinf(sys: AffineBox, iw, iu, iz, count=41):
    """``max_p`` of the optimal frozen state-feedback H-infinity level.

    Riccati bisection of ``tests/_independent.hinf_riccati``: any gain, scheduled
    or not, with any Lyapunov function, has a bound at least this.
    """
    from _independent import hinf_riccati

    best, arg = -INF, None
    for p in sys.grid(count):
        A, B, C, D = sys.at(p)
        g = hinf_riccati(A, B[:, iw], B[:, iu], C[iz], D[np.ix_(iz, iu)])[0]
        if g > best:
            best, arg = g, p
    return float(best), arg


# ======================================================================
# Multi-affine matrix functions on a box
# ======================================================================
class _MultiAffine:
    """``X(p) = sum_v w_v(p) X_v`` over the corners of the parameters `dep`.

    `dep` are the indices of the parameters X depends on (those with a finite
    rate bound); the corners are ``itertools.product`` of their bounds.
    """

    def __init__(self, shape, sys: AffineBox, dep, symmetric, name):
        self.sys, self.dep = sys, tuple(dep)
        corners = list(itertools.product((0, 1), repeat=len(self.dep)))
        self.vars = {
            c: cp.Variable(shape, symmetric=symmetric, name=f"{name}{c}")
            for c in corners
        }

    def _corner(self, p):
        """Corner key of a box vertex `p` (`p` must be a vertex)."""
        key = []
        for i in self.dep:
            lo, hi = self.sys.lo[i], self.sys.hi[i]
            key.append(0 if abs(p[i] - lo) <= abs(p[i] - hi) else 1)
        return tuple(key)

    def at_vertex(self, p):
        return self.vars[self._corner(p)]

    def d_at_vertex(self, i, p):
        """``dX/dp_i`` at a vertex `p` (zero when X does not depend on p_i)."""
        if i not in self.dep:
            return None
        pos = self.dep.index(i)
        key = list(self._corner(p))
        key[pos] = 1
        up = self.vars[tuple(key)]
        key[pos] = 0
        down = self.vars[tuple(key)]
        return (up - down) / (self.sys.hi[i] - self.sys.lo[i])

    def value(self, p):
        """Numeric X at any `p` in the box (after solving)."""
        p = np.asarray(p, float)
        out = 0.0
        for c, var in self.vars.items():
            w = 1.0
            for pos, i in enumerate(self.dep):
                t = (p[i] - self.sys.lo[i]) / (self.sys.hi[i] - self.sys.lo[i])
                w *= t if c[pos] else 1 - t
            out = out + w * var.value
        return out

    def d_value(self, i, p):
        if i not in self.dep:
            return 0.0
        p = np.asarray(p, float)
        out = 0.0
        pos_i = self.dep.index(i)
        for c, var in self.vars.items():
            w = (1.0 if c[pos_i] else -1.0) / (self.sys.hi[i] - self.sys.lo[i])
            for pos, j in enumerate(self.dep):
                if j == i:
                    continue
                t = (p[j] - self.sys.lo[j]) / (self.sys.hi[j] - self.sys.lo[j])
                w *= t if c[pos] else 1 - t
            out = out + w * var.value
        return out


def _rates(sys: AffineBox, rate_bounds):
    """Rate bounds as an array (None: all infinite = constant P)."""
    if rate_bounds is None:
        return np.full(sys.k, INF)
    if isinstance(rate_bounds, dict):
        return np.array([float(rate_bounds.get(n, INF)) for n in sys.names])
    nu = np.broadcast_to(np.asarray(rate_bounds, float), (sys.k,)).copy()
    if np.any(nu < 0):
        raise ValueError("rate_bounds: must be nonnegative")
    return nu


def _rate_vertices(nu, dep):
    """Vertices of the rate box of the parameters in `dep` (zeros elsewhere)."""
    k = len(nu)
    choices = [
        ((-nu[i], nu[i]) if (i in dep and nu[i] > 0) else (0.0,)) for i in range(k)
    ]
    return [np.array(r) for r in itertools.product(*choices)]


def _sym(M):
    return (M + M.T) / 2


def _solve(prob, strict):
    """Solve with Clarabel (then SCS); the status, after a float64 check.

    `strict` are the constraints written ``-eps I - blk >> 0``: they must hold
    with ``blk`` negative definite in float64. Every other PSD constraint may
    be violated by at most ``1e-9`` times its data scale. A point failing the
    check is reported as ``"unverified"`` (treated as infeasible).
    """
    status = "not solved"
    for solver in ("CLARABEL", "SCS"):  # SCS only when Clarabel fails outright
        try:
            with warnings.catch_warnings():
                warnings.simplefilter(
                    "ignore", UserWarning
                )  # inaccurate: checked below
                if solver == "SCS":
                    prob.solve(solver=solver, eps=1e-8, max_iters=20000)
                else:
                    prob.solve(solver=solver)
        except cp.SolverError:
            continue
        status = prob.status
        break
    if status not in ("optimal", "optimal_inaccurate"):
        return status
    strict_ids = {id(c): eps for c, eps in strict}
    for c in prob.constraints:
        if not isinstance(c, cp.constraints.PSD):
            continue
        M = _sym(np.asarray(c.args[0].value, float))
        low = np.linalg.eigvalsh(M).min()
        if id(c) in strict_ids:
            if low < -0.5 * strict_ids[id(c)]:  # blk <= -(eps/2) I
                return "unverified"
        elif low < -1e-9 * max(1.0, np.abs(M).max()):
            return "unverified"
    return "optimal"


# ======================================================================
# Analysis: stability and L2 gain with P(p) multi-affine
# ======================================================================
@dataclass
class PDLResult:
    feasible: bool
    gamma: float | None
    P: object  # _MultiAffine or None
    status: str
    rate_bounds: np.ndarray

    def lyapunov(self, p):
        return self.P.value(p)


def _analysis_problem(sys: AffineBox, rate_bounds, gain: bool, margin=1e-7, gamma=None):
    """Build the multi-convexity LMIs of the Lyapunov or bounded-real matrix.

    Stability: ``L = A'P + PA + sum dp_i dP/dp_i``.
    L2 gain: ``[[L, PB, C'], [B'P, -g I, D'], [C, D, -g I]]`` (``||.|| < g``).
    """
    nu = _rates(sys, rate_bounds)
    dep = [i for i in range(sys.k) if np.isfinite(nu[i])]
    n = sys.n
    nw = sys.base[1].shape[1] if gain else 0
    nz = sys.base[2].shape[0] if gain else 0
    N = n + nw + nz
    P = _MultiAffine((n, n), sys, dep, True, "P")
    g = (cp.Variable(name="gamma") if gamma is None else gamma) if gain else None
    lam = {i: cp.Variable((N, N), symmetric=True, name=f"Lam{i}") for i in dep}
    scale = max(
        1.0, max(np.linalg.norm(m, 2) for m in sys.at((sys.lo + sys.hi) / 2)[:1])
    )
    eps = margin * scale
    h2 = ((sys.hi - sys.lo) / 2) ** 2
    cons, strict = [], []
    for v in sys.vertices():
        Pv = P.at_vertex(v)
        cons.append(Pv >> eps * np.eye(n))
        strict.append((cons[-1], eps))
        A, B, C, D = sys.at(v)
        # multi-convexity: (1/2) d^2/dp_i^2 of the block + Lambda_i >= 0
        for i in dep:
            Ai, Bi = sys.terms[i][0], sys.terms[i][1]
            dPi = P.d_at_vertex(i, v)
            M11 = Ai.T @ dPi + dPi @ Ai
            if gain:
                M = cp.bmat(
                    [
                        [M11, dPi @ Bi, np.zeros((n, nz))],
                        [(dPi @ Bi).T, np.zeros((nw, nw)), np.zeros((nw, nz))],
                        [np.zeros((nz, n)), np.zeros((nz, nw)), np.zeros((nz, nz))],
                    ]
                )
            else:
                M = M11
            cons.append(_sym(M) + lam[i] >> 0)
        for r in _rate_vertices(nu, dep):
            L11 = A.T @ Pv + Pv @ A
            for i in dep:
                if r[i] != 0:
                    L11 = L11 + r[i] * P.d_at_vertex(i, v)
            if gain:
                blk = cp.bmat(
                    [
                        [L11, Pv @ B, C.T],
                        [(Pv @ B).T, -g * np.eye(nw), D.T],
                        [C, D, -g * np.eye(nz)],
                    ]
                )
            else:
                blk = L11
            for i in dep:
                blk = blk + h2[i] * lam[i]
            cons.append(_sym(blk) << -eps * np.eye(N))
            strict.append((cons[-1], eps))
    for i in dep:
        cons.append(lam[i] >> 0)
    return P, g, cons, strict, nu


def pdl_stability_lmi(sys: AffineBox, rate_bounds=None, margin=1e-7) -> PDLResult:
    """Feasibility of the multi-convexity stability LMIs (None: constant P).

    Normalised with ``P(v) <= I`` at the vertices so the program is bounded.
    """
    P, _, cons, strict, nu = _analysis_problem(sys, rate_bounds, False, margin)
    for v in sys.vertices():
        cons.append(P.at_vertex(v) << np.eye(sys.n))
    prob = cp.Problem(cp.Minimize(0), cons)
    status = _solve(prob, strict)
    ok = status == "optimal"
    return PDLResult(ok, None, P if ok else None, status, nu)


def _two_stage(build, rel=(1e-4, 1e-3, 1e-2, 1e-1)):
    """Minimise gamma, then certify a slightly larger fixed gamma.

    ``build(gamma)`` returns ``(problem_vars, cons, strict)`` with gamma a
    variable (``gamma=None``) or the given number. The minimum is found with
    gamma free; the reported bound is the smallest ``gamma* (1 + r)`` whose
    fixed-gamma feasibility problem passes the float64 check of `_solve`
    (a minimiser sits on the boundary, where rounding breaks strictness).
    """
    vars_, cons, _ = build(None)
    g = vars_[1]
    prob = cp.Problem(cp.Minimize(g), cons)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the bound is re-certified below
        try:
            prob.solve(solver="CLARABEL")
        except cp.SolverError:
            prob.solve(solver="SCS", eps=1e-8, max_iters=50000)
    if prob.status not in ("optimal", "optimal_inaccurate"):
        return None, INF, prob.status
    gstar = float(g.value)
    for r in rel:
        gam = gstar * (1 + r)
        vars_, cons, strict = build(gam)
        status = _solve(cp.Problem(cp.Minimize(0), cons), strict)
        if status == "optimal":
            return vars_, gam, status
    return None, INF, "unverified"


def pdl_l2_gain(sys: AffineBox, rate_bounds=None, margin=1e-7) -> PDLResult:
    """Smallest certified L2-gain bound of the multi-convexity BRL LMIs.

    ``rate_bounds=None``: constant P (quadratic). The bound is certified by a
    fixed-gamma solve within 1e-4 (relative) of the optimum, see `_two_stage`.
    """
    nu = _rates(sys, rate_bounds)

    def build(gam):
        P, g, cons, strict, _ = _analysis_problem(sys, rate_bounds, True, margin, gam)
        return (P, g), cons, strict

    vars_, gam, status = _two_stage(build)
    ok = vars_ is not None
    return PDLResult(ok, gam, vars_[0] if ok else None, status, nu)


def quadratic_l2_gain(sys: AffineBox, margin=1e-7) -> PDLResult:
    """Constant-P (quadratic) L2-gain bound: `pdl_l2_gain` with every rate infinite."""
    return pdl_l2_gain(sys, None, margin)


def max_feasible(family, rate_bounds=None, lo=0.0, hi=64.0, rtol=1e-3):
    """Largest ``x`` in ``[lo, hi]`` (bisection) with ``family(x)`` certified stable.

    ``family(x)`` returns an `AffineBox` whose box grows with ``x`` (so the
    certified set is an interval). Returns ``hi`` when ``family(hi)`` is
    certified and ``lo`` when nothing above it is.
    """
    if pdl_stability_lmi(family(hi), rate_bounds).feasible:
        return hi
    while hi - lo > rtol * max(hi, 1e-3):
        mid = (lo + hi) / 2
        if pdl_stability_lmi(family(mid), rate_bounds).feasible:
            lo = mid
        else:
            hi = mid
    return lo


def verify_lyapunov(sys: AffineBox, res: PDLResult, count=41, gain=False):
    """Float64 check of a solution on a dense grid of ``(p, dp)``.

    Returns the largest eigenvalue of ``L(p, dp)`` (or the BRL matrix with
    ``gamma``) and the smallest eigenvalue of ``P(p)``: a sanity check of the
    relaxation's claim (negative / positive), not a proof.
    """
    nu = res.rate_bounds
    dep = [i for i in range(sys.k) if np.isfinite(nu[i])]
    worst_L, worst_P = -INF, INF
    for p in sys.grid(count):
        A, B, C, D = sys.at(p)
        Pp = res.P.value(p)
        worst_P = min(worst_P, np.linalg.eigvalsh(Pp).min())
        for r in _rate_vertices(nu, dep):
            L = A.T @ Pp + Pp @ A + sum(r[i] * res.P.d_value(i, p) for i in dep)
            if gain:
                g = res.gamma
                nw, nz = B.shape[1], C.shape[0]
                L = np.block(
                    [
                        [L, Pp @ B, C.T],
                        [B.T @ Pp, -g * np.eye(nw), D.T],
                        [C, D, -g * np.eye(nz)],
                    ]
                )
            worst_L = max(worst_L, np.linalg.eigvalsh(_sym(L)).max())
    return worst_L, worst_P


# ======================================================================
# Synthesis: scheduled state feedback with X(p) multi-affine
# ======================================================================
@dataclass
class SFResult:
    feasible: bool
    gamma: float
    X: object
    Y: object
    status: str
    rate_bounds: np.ndarray

    def gain(self, p):
        """``K(p) = Y(p) X(p)^{-1}`` (``u = -K(p) x``)."""
        X = self.X.value(p)
        Y = self.Y.value(p)
        return np.linalg.solve(X.T, np.asarray(Y).T).T


def pdl_sf_hinf(
    sys: AffineBox, iw, iu, iz, rate_bounds=None, scheduled=True, margin=1e-7
) -> SFResult:
    """Minimum gamma of scheduled state feedback with ``V = x' X(p)^{-1} x``.

    Dual bounded-real matrix with ``Acl = A - B_u K``, ``Y = K X``::

        [[A X + X A' - B_u Y - Y' B_u' - dX/dt, B_w, X C_z' - Y' D_zu'],
         [B_w', -g I, D_zw'],
         [C_z X - D_zu Y, D_zw, -g I]]  < 0

    ``X`` multi-affine in the parameters with a finite rate bound (constant
    in the others); ``Y`` multi-affine in every parameter (``scheduled=True``)
    or constant (``scheduled=False``: a robust common gain, which needs a
    constant X here, i.e. every rate infinite). Same multi-convexity
    relaxation as the analysis.
    """
    nu = _rates(sys, rate_bounds)
    dep = [i for i in range(sys.k) if np.isfinite(nu[i])]
    ydep = list(range(sys.k)) if scheduled else []
    if not scheduled and dep:
        raise ValueError(
            "scheduled: a common gain needs every rate bound infinite here"
        )
    n = sys.n
    nw, nu_, nz = len(iw), len(iu), len(iz)
    N = n + nw + nz
    h2 = ((sys.hi - sys.lo) / 2) ** 2
    scale = max(1.0, np.linalg.norm(sys.at((sys.lo + sys.hi) / 2)[0], 2))
    eps = margin * scale

    def parts(m):
        A, B, C, D = m
        return A, B[:, iw], B[:, iu], C[iz], D[np.ix_(iz, iw)], D[np.ix_(iz, iu)]

    def build(gam):
        X = _MultiAffine((n, n), sys, dep, True, "X")
        Y = _MultiAffine((nu_, n), sys, ydep, False, "Y")
        g = cp.Variable(name="gamma") if gam is None else gam
        cvx = sorted(set(dep) | set(ydep))  # parameters with a multi-convexity term
        lam = {i: cp.Variable((N, N), symmetric=True, name=f"Lam{i}") for i in cvx}
        cons, strict = [], []
        for v in sys.vertices():
            Xv, Yv = X.at_vertex(v), Y.at_vertex(v)
            cons.append(Xv >> eps * np.eye(n))
            strict.append((cons[-1], eps))
            A, B1, B2, C1, D11, D12 = parts(sys.at(v))
            for i in cvx:
                Ai, _, B2i, C1i, _, D12i = parts(sys.terms[i])
                dX, dY = X.d_at_vertex(i, v), Y.d_at_vertex(i, v)
                dX = np.zeros((n, n)) if dX is None else dX
                dY = np.zeros((nu_, n)) if dY is None else dY
                M11 = Ai @ dX + dX @ Ai.T - B2i @ dY - dY.T @ B2i.T
                M31 = C1i @ dX - D12i @ dY
                M = cp.bmat(
                    [
                        [M11, np.zeros((n, nw)), M31.T],
                        [np.zeros((nw, n)), np.zeros((nw, nw)), np.zeros((nw, nz))],
                        [M31, np.zeros((nz, nw)), np.zeros((nz, nz))],
                    ]
                )
                cons.append(_sym(M) + lam[i] >> 0)
            for r in _rate_vertices(nu, dep):
                L11 = A @ Xv + Xv @ A.T - B2 @ Yv - Yv.T @ B2.T
                for i in dep:
                    if r[i] != 0:
                        L11 = L11 - r[i] * X.d_at_vertex(i, v)
                C = C1 @ Xv - D12 @ Yv
                blk = cp.bmat(
                    [
                        [L11, B1, C.T],
                        [B1.T, -g * np.eye(nw), D11.T],
                        [C, D11, -g * np.eye(nz)],
                    ]
                )
                for i in cvx:
                    blk = blk + h2[i] * lam[i]
                cons.append(_sym(blk) << -eps * np.eye(N))
                strict.append((cons[-1], eps))
        for i in cvx:
            cons.append(lam[i] >> 0)
        return (X, g, Y), cons, strict

    vars_, gam, status = _two_stage(build)
    ok = vars_ is not None
    if not ok:
        return SFResult(False, INF, None, None, status, nu)
    return SFResult(True, gam, vars_[0], vars_[2], status, nu)


def pdl_sf_hinf_common(
    sys: AffineBox, iw, iu, iz, rate_bounds=None, alphas=None, margin=1e-7
) -> SFResult:
    r"""Robust common gain with a PDL function, by slack-variable (dilated) LMIs.

    With ``X(p) > 0`` multi-affine (in the parameters with a finite rate
    bound), constant ``V``, ``Y`` and a scalar ``alpha > 0``::

        M = [[alpha He(A V - B_u Y) - dX/dt, X - alpha V' + A V - B_u Y, B_w, alpha W'],
             [*,                              -He(V),                    0,   W'      ],
             [B_w',                           0,                  -g I,  D_zw'   ],
             [alpha W,                        W,                     D_zw, -g I   ]] < 0

    with ``W = C_z V - D_zu Y``. With ``T = diag([I, A_cl], I, I)`` (blocks
    x, slack; w; z), ``T M T'`` is exactly the dual bounded-real matrix of
    ``(A - B_u K, B_w, C_z - D_zu K, D_zw)`` with ``K = Y V^{-1}`` and Lyapunov
    matrix ``X(p)^{-1}`` (``-dX/dt`` included), so ``M < 0`` certifies the
    common gain ``u = -K x`` (the dilation of Apkarian, Tuan and Bernussou
    2001 / Pipeleers et al. 2009, derived here; the identity is checked by
    `dilation_identity_residual`). ``M`` is multi-affine in ``p`` and affine in
    ``dp``: the vertices of the (p, dp) box suffice, no relaxation. ``alpha``
    is searched over `alphas` (default a log grid); the best is returned.
    """
    nu = _rates(sys, rate_bounds)
    dep = [i for i in range(sys.k) if np.isfinite(nu[i])]
    n = sys.n
    nw, m, nz = len(iw), len(iu), len(iz)
    scale = max(1.0, np.linalg.norm(sys.at((sys.lo + sys.hi) / 2)[0], 2))
    eps = margin * scale
    # small alpha: ill-conditioned programs (slow, unverified); the optimum
    # on the examples here is at alpha ||A|| ~ 1 to 10
    alphas = np.logspace(-0.5, 1.5, 5) / scale if alphas is None else alphas

    def parts(mats):
        A, B, C, D = mats
        return A, B[:, iw], B[:, iu], C[iz], D[np.ix_(iz, iw)], D[np.ix_(iz, iu)]

    best = SFResult(False, INF, None, None, "not solved", nu)
    for alpha in alphas:

        def build(gam, alpha=alpha):
            X = _MultiAffine((n, n), sys, dep, True, "X")
            V = cp.Variable((n, n), name="V")
            Y = cp.Variable((m, n), name="Y")
            g = cp.Variable(name="gamma") if gam is None else gam
            cons, strict = [], []
            Z = np.zeros
            for v in sys.vertices():
                Xv = X.at_vertex(v)
                cons.append(Xv >> eps * np.eye(n))
                strict.append((cons[-1], eps))
                A, B1, B2, C1, D11, D12 = parts(sys.at(v))
                AV = A @ V - B2 @ Y
                W = C1 @ V - D12 @ Y
                for r in _rate_vertices(nu, dep):
                    dX = sum(
                        (r[i] * X.d_at_vertex(i, v) for i in dep if r[i] != 0),
                        Z((n, n)),
                    )
                    M12 = Xv - alpha * V.T + AV
                    blk = cp.bmat(
                        [
                            [alpha * (AV + AV.T) - dX, M12, B1, alpha * W.T],
                            [M12.T, -(V + V.T), Z((n, nw)), W.T],
                            [B1.T, Z((nw, n)), -g * np.eye(nw), D11.T],
                            [alpha * W, W, D11, -g * np.eye(nz)],
                        ]
                    )
                    cons.append(_sym(blk) << -eps * np.eye(2 * n + nw + nz))
                    strict.append((cons[-1], eps))
            return (X, g, (V, Y)), cons, strict

        vars_, gam, status = _two_stage(build, rel=(1e-4, 1e-2))
        if vars_ is not None and gam < best.gamma:
            X, _, (V, Y) = vars_
            res = SFResult(True, gam, X, None, status, nu)
            res.K = np.linalg.solve(V.value.T, Y.value.T).T  # K = Y V^{-1}
            res.alpha = float(alpha)
            best = res
    return best


def dilation_identity_residual(seed=0, n=3, nw=2, nz=2, m=1):
    """``||T M T' - BRL||`` for random data (the identity behind the dilation)."""
    rng = np.random.default_rng(seed)
    A, B1, B2 = (
        rng.normal(size=(n, n)),
        rng.normal(size=(n, nw)),
        rng.normal(size=(n, m)),
    )
    C1, D11, D12 = (
        rng.normal(size=(nz, n)),
        rng.normal(size=(nz, nw)),
        rng.normal(size=(nz, m)),
    )
    V, Y = rng.normal(size=(n, n)), rng.normal(size=(m, n))
    X = rng.normal(size=(n, n))
    X = X @ X.T
    dX = rng.normal(size=(n, n))
    dX = dX + dX.T
    alpha, g = 0.7, 1.3
    K = np.linalg.solve(V.T, Y.T).T
    Acl, Ccl = A - B2 @ K, C1 - D12 @ K
    AV, W = A @ V - B2 @ Y, C1 @ V - D12 @ Y
    M12 = X - alpha * V.T + AV
    M = np.block(
        [
            [alpha * (AV + AV.T) - dX, M12, B1, alpha * W.T],
            [M12.T, -(V + V.T), np.zeros((n, nw)), W.T],
            [B1.T, np.zeros((nw, n)), -g * np.eye(nw), D11.T],
            [alpha * W, W, D11, -g * np.eye(nz)],
        ]
    )
    T = np.block(
        [
            [np.eye(n), Acl, np.zeros((n, nw)), np.zeros((n, nz))],
            [np.zeros((nw, 2 * n)), np.eye(nw), np.zeros((nw, nz))],
            [np.zeros((nz, n)), Ccl, np.zeros((nz, nw)), np.eye(nz)],
        ]
    )
    brl = np.block(
        [
            [Acl @ X + X @ Acl.T - dX, B1, X @ Ccl.T],
            [B1.T, -g * np.eye(nw), D11.T],
            [Ccl @ X, D11, -g * np.eye(nz)],
        ]
    )
    return float(np.abs(T @ M @ T.T - brl).max())


# ======================================================================
# Examples
# ======================================================================
def oscillator(kmax=10.0, c=1.0):
    r"""``x'' + c x' + (2 + p) x = 0``, ``p in [0, kmax]`` (stability).

    ``A(p) = [[0, 1], [-2, -c]] + p [[0, 0], [-1, 0]]``: Hurwitz for every
    frozen ``p > -2``, so the frozen (time-invariant) stability range is
    unbounded. The family with ``A2 = [[0, 1], [-2 - k, -1]]`` is the standard
    LTV test system of the rate-bounded PDL literature (e.g. Geromel and
    Colaneri 2006, Mozelli and Palhares 2011).
    """
    return AffineBox.make(
        (
            [[0.0, 1.0], [-2.0, -c]],
            np.zeros((2, 0)),
            np.zeros((0, 2)),
            np.zeros((0, 0)),
        ),
        {"p": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)},
        {"p": (0.0, kmax)},
    )


def mass_spring(kbounds=(1.0, 4.0), c=0.5, weight=0.1):
    """Mass-spring-damper, stiffness ``k`` in `kbounds` (the suite's fixture).

    States ``[x, v]``, inputs ``[w, u]`` (forces), outputs ``[x, weight*u]``.
    """
    return AffineBox.make(
        (
            [[0.0, 1.0], [0.0, -c]],
            [[0.0, 0.0], [1.0, 1.0]],
            [[1.0, 0.0], [0.0, 0.0]],
            [[0.0, 0.0], [0.0, weight]],
        ),
        {"k": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)},
        {"k": kbounds},
    )


def two_param(kb=(1.0, 9.0), cb=(0.2, 1.0)):
    """Mass-spring-damper with stiffness ``k`` and damping ``c`` both uncertain.

    States ``[x, v]``, input ``w`` (force), output ``x``; two parameters, so
    ``P(k, c)`` has a cross term ``k c`` (multi-affine, four vertex matrices).
    """
    return AffineBox.make(
        ([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]]),
        {
            "k": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0),
            "c": ([[0.0, 0.0], [0.0, -1.0]], 0, 0, 0),
        },
        {"k": kb, "c": cb},
    )


def _table():  # pragma: no cover - run by hand: python tests/_pdl_reference.py
    """Print the reference numbers quoted in tests/test_pdl.py."""
    import time

    t0 = time.time()
    print(
        "== oscillator x'' + x' + (2 + p) x = 0: largest certified kmax, p in [0, kmax]"
    )
    print("  frozen: Hurwitz for every p > -2 (kmax unbounded)")
    print("  quadratic: kmax =", max_feasible(oscillator, None, hi=100.0, rtol=1e-4))
    for nu in (0.0, 1.0, 3.0, 5.0, 10.0, 30.0, 100.0, 1000.0):
        print(f"  PDL nu={nu:<6} kmax =", max_feasible(oscillator, {"p": nu}, hi=100.0))
    print("== mass-spring k in [1, 4], c = 0.5, u = -[1, 0.5] x, w -> x")
    cl = mass_spring().closed_loop(np.array([[1.0, 0.5]]), [0], [1], [0])
    print("  brute force", frozen_worst_hinf(cl, 201)[0])
    print("  quadratic  ", pdl_l2_gain(cl, None).gamma)
    for nu in (0.0, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0, 1e4):
        print(f"  PDL nu={nu:<6}", pdl_l2_gain(cl, {"k": nu}).gamma)
    print("== two parameters k in [1, 9], c in [0.2, 1], w -> x")
    tp = two_param()
    print("  brute force", frozen_worst_hinf(tp, 61)[0])
    print("  quadratic  ", pdl_l2_gain(tp, None).gamma)
    for nu in ((0.0, 0.0), (0.1, 0.1), (0.0, 1.0), (0.0, INF)):
        print(f"  PDL nu={nu}", pdl_l2_gain(tp, {"k": nu[0], "c": nu[1]}).gamma)
    print("== two-mass, spring k in [0.2, 5], u on mass 1, w on mass 2, z = [x2, u]")
    tm = AffineBox.make(
        (
            [[0, 1, 0, 0], [0, -0.05, 0, 0.05], [0, 0, 0, 1], [0, 0.05, 0, -0.05]],
            [[0, 0], [0, 1], [0, 0], [1, 0]],
            [[0, 0, 1, 0], [0, 0, 0, 0]],
            [[0, 0], [0, 1]],
        ),
        {"k": ([[0, 0, 0, 0], [-1, 0, 1, 0], [0, 0, 0, 0], [1, 0, -1, 0]], 0, 0, 0)},
        {"k": (0.2, 5.0)},
    )
    iw, iu, iz = [0], [1], [0, 1]
    print("  max frozen optimum", frozen_worst_sf_hinf(tm, iw, iu, iz, 41)[0])
    print("  common gain, constant X", pdl_sf_hinf(tm, iw, iu, iz, None, False).gamma)
    print("  scheduled, constant X", pdl_sf_hinf(tm, iw, iu, iz, None).gamma)
    for nu in (0.0, 0.1, 0.3, 1.0, 3.0, 10.0, 100.0):
        print(
            f"  scheduled PDL nu={nu:<6}", pdl_sf_hinf(tm, iw, iu, iz, {"k": nu}).gamma
        )
    print(f"[{time.time() - t0:.0f} s]")


if __name__ == "__main__":  # pragma: no cover
    _table()
