"""The paper's LMIs as one parametrised cvxpy problem per structure."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from ..lmi import LMIProblem
from ..regions import region_block
from .problem import gain_tangent_blocks


def vertex_pairs(N, scheduled):
    """Index pairs (j, k): vertices, then (if scheduled) every pair j < k."""
    pairs = [(j, j) for j in range(N)]
    if scheduled:
        pairs += list(itertools.combinations(range(N), 2))
    return pairs


@dataclass(frozen=True)
class Structure:
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
    def of(cls, data, hinf, scheduled, regions, gain_bound) -> Structure:
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
        return len(vertex_pairs(self.N, self.scheduled)) * per_pair + self.n**2


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


def build(s: Structure) -> Compiled:
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
      ``O_jk`` (filled in by `load`). With the w rows last, ``P_jk`` has
      no rows of zeros, which cvxpy would keep as explicit zeros of the
      conic problem (about 20 % of Clarabel's time per iteration, n = 12).

    Written block by block the same LMIs take about twice as long for cvxpy
    to compile. Parameters get their values from `load`, before every use.
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
    for j, k in vertex_pairs(N, s.scheduled):
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
                return [[region_block(L, M, v.W, q, twice)]]

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
    # `load` rebuilds the "gain" stage when they change; being powers of
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
            lambda v, k=k: gain_tangent_blocks(
                v.W,
                getattr(v, f"Z{k}"),
                v.gain_Ginv,
                np.eye(n),
                v.gain_Ginv_K,
                v.kappa[0, 0],
                scales["T"],
                scales["Su"],
            ),  # fmt: skip
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
    return Compiled(lmi, scales)


@dataclass
class Compiled:
    """A cached problem: the LMIs and the constants its gain stage reads."""

    lmi: LMIProblem
    scales: dict


def load(compiled, s: Structure, data, scaling, regions, margin) -> None:
    """Set every parameter of a (possibly reused) problem for this call.

    All of them, stage bounds included, so that nothing of a previous call
    can leak into this one. See `build` for the pair data.
    """
    lmi = compiled.lmi
    scales = {"T": scaling.matrix, "Su": np.diag(scaling.Su)}
    if any(not np.array_equal(compiled.scales[k], v) for k, v in scales.items()):
        compiled.scales.update(scales)
        lmi.invalidate("gain")
    n, nw = s.n, s.nw
    for j, k in vertex_pairs(s.N, s.scheduled):
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
