"""The paper's LMIs built straight into Clarabel's conic form (not a test module).

An independent reference for ``ctrl_lpv``'s Theorem 2 / Lemma 2 (H-infinity
state feedback, minimum ``gamma``) and Theorem 1 / Lemma 1 (quadratic
stabilization): the LMIs are assembled with numpy and scipy.sparse into

    minimise q'x  subject to  b - A x in K,

``K`` a product of Clarabel's ``PSDTriangleConeT`` cones, and solved once by
Clarabel (``chordal_decomposition_enable=False``, as the library runs it).
No code of ``ctrl_lpv`` is used. Shared by ``tests/test_direct_reference.py``
(the library's optimum against this one) and
``benchmarks/bench_synthesis.py`` (the cost of one solve).

The problem posed is the library's first solve (its ``optimal`` stage for
the H-infinity functions, ``stabilize`` for the stabilizations; see
``ctrl_lpv/synthesis/assembly.py``), so that both are the same conic
problem:

* data prescaled by powers of two (state balancing ``x = T x~``, time
  ``t~ = a t``, inputs ``u = Su u~``, ``w = sw w~``, ``z = sz z~``), exact in
  floating point; the LMIs in the scaled data are congruent to the model's;
* strict LMIs posed as ``F <= -margin I`` in the scaled units;
* the H-infinity LMI of a vertex ``j`` (``c = 1``) or pair ``j < k``
  (``c = 2``, the sums of the two vertices' data), blocks ordered
  ``(x, z, w)``, with ``g = gamma^2`` (paper (24)-(25), ``u = -K x``)::

      [ He(A W + B2 Z)   (C W + D2 Z)'   B1  ]
      [ C W + D2 Z       -c g I          D1  ]  <  0
      [ B1'              D1'             -c I]

  where at a pair ``A W + B2 Z`` stands for ``(A_j + A_k) W + B2_j Z_k +
  B2_k Z_j`` and ``C W + D2 Z`` for ``(C_j + C_k) W + D2_j Z_k + D2_k Z_j``;
* the stabilization stage: maximise ``t`` with ``He(A W + B2 Z) < 0`` and
  ``He(A W + B2 Z) + c t I <= 0`` per vertex/pair, ``t I <= W <= I``,
  ``||Z_k||^2 <= z_max``.

Checked once against the library at 41492b1 (cvxpy's Clarabel data of its
``optimal`` and ``stabilize`` stages, random polytopes, both gains): the
same ``A``, ``b`` and ``q`` up to the order of the variables, except that
cvxpy also stores explicit zeros of ``A``.

Clarabel's PSD cone (its documentation, ``examples/python/example_sdp.py``,
checked by `check_convention`): the upper triangle of the symmetric matrix
stacked column by column, ``(0,0), (0,1), (1,1), (0,2), ...``, off-diagonal
entries times ``sqrt(2)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import clarabel
import numpy as np
import scipy.sparse as sp
from scipy.linalg import matrix_balance

SQRT2 = float(np.sqrt(2.0))


# ----------------------------------------------------------------------
# svec: Clarabel's triangle of a symmetric matrix
# ----------------------------------------------------------------------
def svec_position(i, j):
    """Row of entry ``(i, j)`` (either order) in the triangle vector."""
    lo, hi = np.minimum(i, j), np.maximum(i, j)
    return hi * (hi + 1) // 2 + lo


def svec(M):
    """The triangle vector of symmetric ``M`` (or of a stack ``(..., d, d)``)."""
    d = M.shape[-1]
    rows, cols = np.triu_indices(d)
    out = np.empty(M.shape[:-2] + (d * (d + 1) // 2,))
    out[..., svec_position(rows, cols)] = M[..., rows, cols] * np.where(
        rows == cols, 1.0, SQRT2
    )
    return out


def check_convention() -> None:
    """Solve ``min t`` with ``[[t, 1, 0], [1, t, 3], [0, 3, t]] >= 0``.

    The optimum is ``sqrt(10)``; another order of the triangle, or no
    ``sqrt(2)``, gives another one.
    """
    M0 = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 3.0], [0.0, 3.0, 0.0]])
    A = sp.csc_array(-svec(np.eye(3))[:, None])
    sol = _solve(A, svec(M0), np.array([1.0]), [clarabel.PSDTriangleConeT(3)])
    if abs(sol.x[0] - np.sqrt(10.0)) > 1e-6:
        raise AssertionError(f"Clarabel's PSD triangle convention: t = {sol.x[0]}")


# ----------------------------------------------------------------------
# Prescaling (powers of two: exact)
# ----------------------------------------------------------------------
def pow2(x: float) -> float:
    return float(2.0 ** np.round(np.log2(x))) if x > 0 else 1.0


def _norm(M) -> float:
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


@dataclass(frozen=True)
class Scales:
    """``x = T x~`` (T diagonal), ``t~ = a t``, ``u = Su u~``, ``w = sw w~``,
    ``z = sz z~``."""

    T: np.ndarray
    Su: np.ndarray
    sw: float
    sz: float
    a: float

    @classmethod
    def of(cls, vertices) -> Scales:
        """State balancing of ``sum |A_j|``, ``||A~|| ~ 1`` (time), columns of
        ``B2~`` and ``B1~`` of norm about ``a``, ``[C~, D1~, D2~]`` of norm
        about 1."""
        absA = sum(np.abs(v[0]) for v in vertices)
        _, (t, _) = matrix_balance(absA, permute=False, separate=True)
        T = np.array([pow2(x) for x in t])
        a = pow2(max(np.linalg.norm(v[0] * T / T[:, None], 2) for v in vertices))
        cols = np.max([np.linalg.norm(v[2] / T[:, None], axis=0) for v in vertices], 0)
        Su = np.array([pow2(a / c) if c > 0 else 1.0 for c in cols])
        b1 = max(_norm(v[1] / T[:, None]) for v in vertices)
        sw = pow2(a / b1) if b1 > 0 else 1.0
        rows = max(_norm(np.hstack([v[3] * T, v[4] * sw, v[5] * Su])) for v in vertices)
        return cls(T, Su, sw, pow2(rows) if rows > 0 else 1.0, a)

    def apply(self, v):
        A, B1, B2, C, D1, D2 = v
        Ti = 1.0 / self.T[:, None]
        return (
            Ti * A * self.T / self.a,
            Ti * B1 * self.sw / self.a,
            Ti * B2 * self.Su / self.a,
            C * self.T / self.sz,
            D1 * self.sw / self.sz,
            D2 * self.Su / self.sz,
        )

    def unscale(self, Wt, Zt):
        """Model-unit ``W = (a / sw^2) T W~ T`` and ``Z = (a / sw^2) Su Z~ T``.

        From the bounded-real inequality in scaled time and signals
        multiplied through by ``sw^2 / a``; then ``K = -Z W^-1 = Su K~ T^-1``.
        """
        f = self.a / self.sw**2
        W = f * self.T[:, None] * Wt * self.T
        return W, [f * self.Su[:, None] * Z * self.T for Z in Zt]


def channels(sys_data, w, u, z):
    """Vertex data ``(A, B1, B2, C, D1, D2)`` from ``(A, B, C, D)`` tuples."""
    return [
        (A, B[:, w], B[:, u], C[z], D[np.ix_(z, w)], D[np.ix_(z, u)])
        for A, B, C, D in sys_data
    ]


# ----------------------------------------------------------------------
# Assembly
# ----------------------------------------------------------------------
def lmi_list(N, scheduled):
    """``(j, k)``: the vertices, then (scheduled) every pair ``j < k``."""
    pairs = [(j, j) for j in range(N)]
    if scheduled:
        pairs += [(j, k) for j in range(N) for k in range(j + 1, N)]
    return pairs


def _pattern(n, m, nz, slots):
    """Where each variable enters ``He(Q X)`` and ``R X`` of one LMI.

    ``X = [W; Z_slot0; ...]`` and ``G = [Q; R]`` (``n + nz`` rows, ``n +
    slots m`` columns). A variable puts a 1 at ``(p, q)`` of ``X`` (two
    places for an off-diagonal entry of ``W``), so ``Q X`` gets column ``p``
    of ``Q`` in its column ``q``: entry ``(i, q)`` of ``He`` gets ``G[i, p]``
    (twice on the diagonal), entry ``(n + r, q)`` gets ``G[n + r, p]``.
    Returns ``(svec row, local variable, flat index into G, factor)``; the
    local variables are the free entries of ``W`` (svec order), then entry
    ``(r, c)`` of each ``Z`` slot at ``r + m c``.
    """
    width, nw_free = n + slots * m, n * (n + 1) // 2
    places = []  # (local variable, p, q)
    for i, j in zip(*np.triu_indices(n)):
        places += [(svec_position(i, j), i, j)] + (
            [(svec_position(i, j), j, i)] if i != j else []
        )
    for s in range(slots):
        places += [
            (nw_free + s * m * n + r + m * c, n + s * m + r, c)
            for c in range(n)
            for r in range(m)
        ]
    rows, cols, src, fac = [], [], [], []
    for v, p, q in places:
        rows += [svec_position(i, q) for i in range(n)]
        rows += [svec_position(q, n + r) for r in range(nz)]
        cols += [v] * (n + nz)
        src += [i * width + p for i in range(n + nz)]
        fac += [2.0 if i == q else SQRT2 for i in range(n)] + [SQRT2] * nz
    return tuple(np.array(x) for x in (rows, cols, src, fac))


def _lmi_groups(data, scheduled, nz):
    """The vertex LMIs, then the pair LMIs: per group the entries of every
    LMI and its ``(B1, D1, c)``, stacked.

    ``G = [[A, B2], [C, D2]]`` at vertex ``j``, ``[[A_j + A_k, B2_j, B2_k],
    [C_j + C_k, D2_j, D2_k]]`` at pair ``j < k`` (``X = [W; Z_k; Z_j]``);
    a common gain uses ``Z_0`` everywhere. Yields ``(rows, cols, vals, B1,
    D1, c)``: rows local to the LMI's cone (shared), columns and values
    ``(P, entries)``.
    """
    n, m = data[0][2].shape
    nw_free, nmZ = n * (n + 1) // 2, m * n
    stack = {i: np.array([v[i] for v in data]) for i in range(6)}
    pairs = lmi_list(len(data), scheduled)
    for slots in (1, 2):
        group = [p for p in pairs if (p[0] == p[1]) == (slots == 1)]
        if not group:
            continue
        j, k = np.array(group).T
        both = [j, k] if slots == 2 else [j]

        def summed(i, both=both):  # the vertex's data, or the pair's sum
            return sum(stack[i][x] for x in both)

        blocks = [[summed(0)] + [stack[2][x] for x in both]]
        if nz:
            blocks.append([summed(3)] + [stack[5][x] for x in both])
        G = np.concatenate([np.concatenate(row, axis=2) for row in blocks], axis=1)
        rows, local, src, fac = _pattern(n, m, nz, slots)
        vals = G.reshape(len(j), -1)[:, src] * fac
        # Global column of each local variable: W's are shared; slot s of
        # LMI (j, k) is Z_k (s = 0) or Z_j (s = 1).
        zs = np.stack(both[::-1], 1) if scheduled else np.zeros((len(j), 1), int)
        colmap = np.tile(np.arange(nw_free + slots * nmZ), (len(j), 1))
        for s in range(slots):
            colmap[:, nw_free + s * nmZ : nw_free + (s + 1) * nmZ] = (
                nw_free + zs[:, [s]] * nmZ + np.arange(nmZ)
            )
        yield rows, colmap[:, local], vals, summed(1), summed(4), float(slots)


class _Builder:
    """COO triplets of ``A``, the vector ``b`` and the cones, in order."""

    def __init__(self, nvar):
        self.nvar, self.m = nvar, 0
        self.rows, self.cols, self.vals, self.cones, self.b = [], [], [], [], []

    def reserve(self, d, count):
        """Start rows of `count` PSD cones of side `d`, next in order."""
        size = d * (d + 1) // 2
        starts = self.m + size * np.arange(count)
        self.cones += [clarabel.PSDTriangleConeT(d)] * count
        self.m += size * count
        return starts

    def put(self, starts, rows, cols, vals, b=None):
        """Entries ``svec(F_v)`` of ``A`` (rows local to each cone) and
        ``b``, for the cones at `starts`: ``F(x) = F0 + sum x_v F_v <= 0``
        is ``b - A x = -svec(F(x))`` with ``b = -svec(F0)``."""
        starts = np.asarray(starts)
        rows = np.asarray(rows)
        shape = (len(starts), rows.shape[-1])
        rows, cols, vals = (np.broadcast_to(x, shape) for x in (rows, cols, vals))
        keep = vals.ravel() != 0.0  # what the data leaves out is not stored
        self.rows.append((starts[:, None] + rows).ravel()[keep])
        self.cols.append(cols.ravel()[keep])
        self.vals.append(vals.ravel()[keep])
        if b is not None:
            b = np.broadcast_to(b, (len(starts), np.shape(b)[-1]))
            self.b.append((starts[:, None] + np.arange(b.shape[1]), b))

    def matrices(self):
        A = sp.csc_array(
            (
                np.concatenate(self.vals),
                (np.concatenate(self.rows), np.concatenate(self.cols)),
            ),
            shape=(self.m, self.nvar),
        )
        A.sum_duplicates()
        b = np.zeros(self.m)
        for index, values in self.b:
            b[index] = values
        return A, b


def _w_entries(n):
    """Rows (= columns) of the free entries of ``W`` and ``svec(W)``'s scale."""
    a, b = np.triu_indices(n)
    return svec_position(a, b), np.where(a == b, 1.0, SQRT2)


@dataclass
class Conic:
    """A built problem: ``min q'x``, ``b - A x`` in `cones`."""

    A: sp.csc_array
    b: np.ndarray
    q: np.ndarray
    cones: list
    n: int
    m: int
    nZ: int
    scales: Scales


def _start(data, scheduled):
    """Scaled data, sizes, the builder and ``W~ >= margin I``'s columns."""
    scales = Scales.of(data)
    data = [scales.apply(v) for v in data]
    n, m = data[0][2].shape
    nZ = len(data) if scheduled else 1
    col = n * (n + 1) // 2 + nZ * m * n  # the last variable: g or t
    return scales, data, n, m, nZ, col, _Builder(col + 1)


def build_hinf(data, scheduled, margin=1e-6) -> Conic:
    """Theorem 2 (`scheduled`) or Lemma 2: minimise ``g = gamma~^2``.

    Variables ``[W~ (free entries), Z~_0, ..., g]``; cones ``W~ >= margin
    I``, then one per vertex and pair (`lmi_list`).
    """
    scales, data, n, m, nZ, g_col, builder = _start(data, scheduled)
    nw, nz = data[0][1].shape[1], data[0][3].shape[0]
    pos, scale = _w_entries(n)
    builder.put(builder.reserve(n, 1), pos, pos, -scale, -margin * svec(np.eye(n)))
    d = n + nz + nw
    g_rows = svec_position(n + np.arange(nz), n + np.arange(nz))
    for rows, cols, vals, B1, D1, c in _lmi_groups(data, scheduled, nz):
        P = len(cols)
        F0 = np.zeros((P, d, d))  # the data blocks, (x, z, w) ordered
        F0[:, :n, n + nz :] = B1
        F0[:, n : n + nz, n + nz :] = D1
        F0 = F0 + F0.transpose(0, 2, 1)
        F0[:, n + nz :, n + nz :] = -c * np.eye(nw)
        starts = builder.reserve(d, P)
        builder.put(starts, rows, cols, vals, svec(-F0 - margin * np.eye(d)))
        builder.put(starts, g_rows, g_col, np.full((P, nz), -c))
    A, b = builder.matrices()
    q = np.zeros(g_col + 1)
    q[g_col] = 1.0
    return Conic(A, b, q, builder.cones, n, m, nZ, scales)


def build_stabilization(data, scheduled, margin=1e-6, z_max=1.0) -> Conic:
    """Theorem 1 (`scheduled`) or Lemma 1: maximise the decay ``t``.

    Variables ``[W~, Z~_0, ..., t]``; cones ``W~ >= margin I``, per
    vertex/pair ``He < -margin I`` then ``He + c t I <= 0``, then
    ``W~ <= I``, ``W~ >= t I`` and ``||Z~_k||^2 <= z_max``.
    """
    scales, data, n, m, nZ, t_col, builder = _start(data, scheduled)
    pos, scale = _w_entries(n)
    eye = svec(np.eye(n))
    diag = svec_position(np.arange(n), np.arange(n))
    builder.put(builder.reserve(n, 1), pos, pos, -scale, -margin * eye)
    for rows, cols, vals, _, _, c in _lmi_groups(data, scheduled, 0):
        starts = builder.reserve(n, 2 * len(cols))
        builder.put(starts[0::2], rows, cols, vals, -margin * eye)
        builder.put(starts[1::2], rows, cols, vals)
        builder.put(starts[1::2], diag, t_col, c)
    builder.put(builder.reserve(n, 1), pos, pos, scale, eye)  # W <= I
    start = builder.reserve(n, 1)  # W >= t I
    builder.put(start, pos, pos, -scale)
    builder.put(start, diag, t_col, 1.0)
    # [[z_max I, -Z'], [-Z, I]] >= 0: Z's entry (r, c) sits at (n + r, c).
    r, c = np.divmod(np.arange(m * n), m)[::-1]
    starts = builder.reserve(n + m, nZ)
    bound = svec(np.diag(np.r_[np.full(n, z_max), np.ones(m)]))
    cols = t_col - nZ * m * n + np.arange(nZ)[:, None] * m * n + r + m * c
    builder.put(starts, svec_position(c, n + r), cols, SQRT2, bound)
    A, b = builder.matrices()
    q = np.zeros(t_col + 1)
    q[t_col] = -1.0
    return Conic(A, b, q, builder.cones, n, m, nZ, scales)


# ----------------------------------------------------------------------
# Solve
# ----------------------------------------------------------------------
def _solve(A, b, q, cones):
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.chordal_decomposition_enable = False
    P = sp.csc_array((A.shape[1], A.shape[1]))
    return clarabel.DefaultSolver(P, q, A, b, cones, settings).solve()


@dataclass
class Result:
    """A direct solve, in the model's units (``u = -K x``, ``K = -Z W^-1``)."""

    status: str
    gamma: float | None  # sqrt of the solver's g in model units (H-infinity)
    t: float | None  # the decay variable (stabilization, scaled units)
    W: np.ndarray
    K: list
    iterations: int
    conic: Conic


def solve(conic: Conic, hinf: bool) -> Result:
    """Solve once with Clarabel; the point in the model's units."""
    sol = _solve(conic.A, conic.b, conic.q, conic.cones)
    x = np.asarray(sol.x)
    n, m = conic.n, conic.m
    nw_free = n * (n + 1) // 2
    a, b = np.triu_indices(n)
    Wt = np.zeros((n, n))
    Wt[a, b] = Wt[b, a] = x[svec_position(a, b)]  # the entries themselves
    Zt = [
        x[nw_free + k * m * n : nw_free + (k + 1) * m * n].reshape((m, n), order="F")
        for k in range(conic.nZ)
    ]
    W, Z = conic.scales.unscale(Wt, Zt)
    W = 0.5 * (W + W.T)
    last, s = float(x[-1]), conic.scales
    return Result(
        status=str(sol.status),
        gamma=float(np.sqrt(last) * s.sz / s.sw) if hinf and last > 0 else None,
        t=None if hinf else last,
        W=W,
        K=[-Zk @ np.linalg.inv(W) for Zk in Z],
        iterations=int(sol.iterations),
        conic=conic,
    )


def hinf(data, scheduled, margin=1e-6) -> Result:
    """Build and solve Theorem 2 / Lemma 2 once."""
    return solve(build_hinf(data, scheduled, margin), hinf=True)


def stabilization(data, scheduled, margin=1e-6) -> Result:
    """Build and solve Theorem 1 / Lemma 1 once (``z_max = 1``)."""
    return solve(build_stabilization(data, scheduled, margin), hinf=False)


# ----------------------------------------------------------------------
# Frozen closed loops
# ----------------------------------------------------------------------
def frozen_loop(data, K, delta):
    """``(A - B2 K, B1, C - D2 K, D1)`` at polytopic coordinates `delta`
    (``K(delta) = sum delta_j K_j`` for scheduled gains, one K otherwise)."""
    delta = np.asarray(delta, float)
    A, B1, B2, C, D1, D2 = (
        sum(d * v[i] for d, v in zip(delta, data)) for i in range(6)
    )
    Kd = sum(d * Kj for d, Kj in zip(delta, K)) if len(K) > 1 else K[0]
    return A - B2 @ Kd, B1, C - D2 @ Kd, D1


def random_vertices(n, N, m=2, seed=0):
    """``(A, B, C, D)`` of `N` vertices, inputs ``[w, u_1..u_m]``, outputs
    ``[C x; u]``: quadratically stabilizable by construction (a common
    ``K0`` makes every ``A - B2 K0`` the sum of a skew-symmetric and a
    negative multiple of I, in coordinates ``T``)."""
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(m, n))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q @ np.diag(rng.uniform(0.5, 2.0, size=n))
    Ti = np.linalg.inv(T)
    vertices = []
    for _ in range(N):
        B = rng.normal(size=(n, m))
        S = rng.normal(size=(n, n))
        A = B @ K0 + (S - S.T) - rng.uniform(0.1, 1.0) * np.eye(n)
        B1 = rng.normal(size=(n, 1))
        C = rng.normal(size=(1, n))
        Cz = np.vstack([C @ Ti, np.zeros((m, n))])
        Dz = np.zeros((1 + m, 1 + m))
        Dz[1:, 1:] = np.eye(m)
        vertices.append((T @ A @ Ti, T @ np.hstack([B1, B]), Cz, Dz))
    return vertices
