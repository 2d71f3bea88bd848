"""Independent checks of ctrl_lpv's designs and refusals (not a test module).

Written from the textbook statements with numpy, scipy and cvxpy only: no
code of ``ctrl_lpv`` is used to decide whether a design or a refusal is
right (``ctrl_lpv`` is only called to build the system, the regions it is
asked for, and the design under test). Shared by ``tests/test_trust_fuzz.py``,
``tests/test_riccati_hinf.py`` and ``benchmarks/fuzz_trust.py``.

Parts
-----
* `generate_case`: a seeded generator of polytopic state-feedback problems
  (badly scaled and ill-conditioned coordinates, near-uncontrollable,
  marginal and lightly damped vertices, duplicate vertices, ``D != 0``, pole
  regions, gain bounds, required gammas), with the ground truth the
  construction gives (an exactly uncontrollable unstable mode; a required
  gamma below a frozen vertex's Riccati optimum).
* `check_design`: float64 verification of a returned design from its gains
  and ``P`` alone: the Lyapunov (Theorem 1: vertex and pair) inequalities and
  the bounded-real-lemma LMIs with a rounding-error bound after a diagonal
  congruence (scale invariant), Hurwitz and pole-region membership of the
  frozen closed loops at vertices and sampled points, ``gamma`` against the
  frozen H-infinity norms (``control.linfnorm`` and a frequency-grid lower
  bound), the gain bound and a required gamma.
* `probe_case`: an independent search for a design (plain cvxpy LMIs with
  Clarabel and SCS in several scalings and margins, LQR and Riccati gains),
  every candidate checked by `check_design`.
* `classify_refusal`: true (proved) / false (a verified design exists) /
  unresolved, and whether the message's claim is true.
* `hinf_riccati`: the H-infinity state-feedback optimum by bisection on the
  Riccati equation (Zhou, Doyle and Glover, Robust and Optimal Control,
  state feedback H-infinity control, with the standard loop-shifting of a
  general full-column-rank ``D12``).
"""

from __future__ import annotations

import re
import time
import warnings
from dataclasses import dataclass, field

import control as ct
import cvxpy as cp
import numpy as np
from scipy import linalg as sla

UNIT = 2.0**-53  # unit roundoff of float64

FUNCTIONS = (
    "quadratic_stabilization",
    "gain_scheduled_stabilization",
    "hinf_state_feedback",
    "gain_scheduled_hinf",
)
HINF = {"hinf_state_feedback", "gain_scheduled_hinf"}
SCHEDULED = {"gain_scheduled_stabilization", "gain_scheduled_hinf"}


# ======================================================================
# Regions, described here (membership and LMI data written here too)
# ======================================================================
@dataclass(frozen=True)
class Region:
    """A pole region: ``("halfplane", a)``, ``("disk", r, c)``, ``("sector", th)``."""

    kind: str
    params: tuple

    def contains(self, s, rtol=1e-9) -> bool:
        """All eigenvalues `s` inside (with a relative tolerance `rtol`)."""
        s = np.atleast_1d(np.asarray(s, complex))
        scale = np.maximum(np.abs(s), 1e-300)
        if self.kind == "halfplane":
            (a,) = self.params
            return bool(np.all(s.real < -a + rtol * np.maximum(scale, abs(a))))
        if self.kind == "disk":
            r, c = self.params
            return bool(np.all(np.abs(s - c) < r * (1 + rtol)))
        (th,) = self.params
        # |arg(-s)| < th  <=>  -Re s > 0 and |Im s| < tan(th) (-Re s)
        return bool(
            np.all(
                (-s.real > -rtol * scale)
                & (np.abs(s.imag) * np.cos(th) < -s.real * np.sin(th) + rtol * scale)
            )
        )

    def LM(self, time_scale=1.0):
        """Chilali-Gahinet data for the region of ``s / time_scale``."""
        if self.kind == "halfplane":
            (a,) = self.params
            return np.array([[2.0 * a / time_scale]]), np.array([[1.0]])
        if self.kind == "disk":
            r, c = self.params
            r, c = r / time_scale, c / time_scale
            return np.array([[-r, -c], [-c, -r]]), np.array([[0.0, 1.0], [0.0, 0.0]])
        (th,) = self.params
        sn, cs = np.sin(th), np.cos(th)
        return np.zeros((2, 2)), np.array([[sn, cs], [-cs, sn]])

    def to_lpv(self, lpv):
        """The same region as a ``ctrl_lpv.LMIRegion``."""
        if self.kind == "halfplane":
            return lpv.halfplane(self.params[0])
        if self.kind == "disk":
            return lpv.disk(self.params[0], self.params[1])
        return lpv.sector(self.params[0])

    def __str__(self):
        return f"{self.kind}{tuple(float(f'{p:.4g}') for p in self.params)}"


# ======================================================================
# Problems
# ======================================================================
@dataclass
class Case:
    """One generated problem and the ground truth its construction gives."""

    seed: int
    index: int
    function: str
    vertices: list  # (A, B1, B2, C, D1, D2) per vertex
    regions: list = field(default_factory=list)
    gain_bound: float | None = None
    gamma: float | None = None  # required gamma (H-infinity only)
    backoff: object = "default"  # "default" = do not pass the keyword
    tags: list = field(default_factory=list)
    # Ground truth: vertices with an exactly uncontrollable mode Re >= 0.
    unstabilizable: set = field(default_factory=set)
    # Vertices that are stabilizable by construction (weak but nonzero B).
    stabilizable_by_construction: bool = False
    gamma_lower: float | None = None  # max over vertices of the Riccati optimum
    nice: tuple | None = None  # (T, nice vertices): x_nice = T x (T None: x = x_nice)
    channel_style: str = "names"  # how u, w, z are passed
    small: bool = False

    @property
    def N(self):
        return len(self.vertices)

    @property
    def n(self):
        return self.vertices[0][0].shape[0]

    @property
    def m(self):
        return self.vertices[0][2].shape[1]

    @property
    def nw(self):
        return self.vertices[0][1].shape[1]

    @property
    def nz(self):
        return self.vertices[0][3].shape[0]

    @property
    def hinf(self):
        return self.function in HINF

    @property
    def scheduled(self):
        return self.function in SCHEDULED

    def label(self):
        return f"{self.seed}:{self.index}" + (" (small)" if self.small else "")

    def describe(self) -> str:
        extra = []
        if self.regions:
            extra.append("regions " + ", ".join(map(str, self.regions)))
        if self.gain_bound is not None:
            extra.append(f"gain_bound {self.gain_bound:.3g}")
        if self.gamma is not None:
            extra.append(f"gamma {self.gamma:.4g} (frozen lb {self.gamma_lower:.4g})")
        if self.backoff != "default":
            extra.append(f"backoff {self.backoff}")
        if self.unstabilizable:
            extra.append(f"unstabilizable vertices {sorted(self.unstabilizable)}")
        return (
            f"case {self.label()}: {self.function} N={self.N} n={self.n} "
            f"m={self.m}"
            + (f" nw={self.nw} nz={self.nz}" if self.hinf else "")
            + f" [{', '.join(self.tags)}]"
            + ("; " + "; ".join(extra) if extra else "")
        )

    # ------------------------------------------------------------------
    def system(self, lpv):
        """The problem as a ``ctrl_lpv.PolytopicStateSpace``."""
        verts = []
        for A, B1, B2, C, D1, D2 in self.vertices:
            verts.append((A, np.hstack([B1, B2]), C, np.hstack([D1, D2])))
        inputs = [f"w{i}" for i in range(self.nw)] + [f"u{i}" for i in range(self.m)]
        outputs = [f"z{i}" for i in range(self.nz)]
        states = [f"x{i}" for i in range(self.n)]
        return lpv.PolytopicStateSpace(
            verts, inputs=inputs, outputs=outputs, states=states, name="fuzz"
        )

    def kwargs(self, lpv):
        """Keyword arguments of the library call."""
        if self.channel_style == "names":
            u = [f"u{i}" for i in range(self.m)]
            w = [f"w{i}" for i in range(self.nw)]
            z = [f"z{i}" for i in range(self.nz)]
        else:
            u = list(range(self.nw, self.nw + self.m))
            w = list(range(self.nw))
            z = list(range(self.nz))
        kw = {"u": u}
        if self.hinf:
            kw.update(w=w, z=z)
            if self.gamma is not None:
                kw["gamma"] = self.gamma
            if self.backoff != "default":
                kw["backoff"] = self.backoff
        if self.regions:
            kw["regions"] = [r.to_lpv(lpv) for r in self.regions]
        if self.gain_bound is not None:
            kw["gain_bound"] = self.gain_bound
        return kw

    def call(self, lpv):
        """Run the library function on this problem."""
        return getattr(lpv, self.function)(self.system(lpv), **self.kwargs(lpv))


def _orth(rng, n):
    q, r = np.linalg.qr(rng.standard_normal((n, n)))
    return q * np.sign(np.diag(r))


def _loguniform(rng, lo, hi):
    return float(10.0 ** rng.uniform(lo, hi))


def _eigen_block(rng, n, family):
    """Real block-diagonal matrix with eigenvalues of the given family."""
    blocks = []
    left = n
    while left > 0:
        pair = left >= 2 and rng.random() < 0.5
        if family == "light" and left >= 2:
            pair = True
        if pair:
            if family == "light":
                zeta = _loguniform(rng, -4, -2)
                w = _loguniform(rng, 0, 2)
                sig, om = -zeta * w, w * np.sqrt(1 - zeta**2)
            elif family == "marginal" and rng.random() < 0.6:
                sig, om = 0.0, rng.uniform(0.3, 3)
            else:
                sig, om = rng.uniform(-2, 1), rng.uniform(0.2, 3)
            blocks.append(np.array([[sig, om], [-om, sig]]))
            left -= 2
        else:
            if family == "marginal" and rng.random() < 0.5:
                lam = 0.0
            else:
                lam = rng.uniform(-2, 1)
            blocks.append(np.array([[lam]]))
            left -= 1
    return sla.block_diag(*blocks)


FAMILIES = ("random", "random", "marginal", "light")


def generate_case(seed: int, index: int, small: bool = False) -> Case:
    """The problem number `index` of the stream `seed` (reproducible alone).

    `small` caps the sizes (n <= 4, N <= 4, scheduled N <= 3) for the fast
    test subset; the draws are otherwise the same.
    """
    rng = np.random.default_rng([seed, index])
    function = FUNCTIONS[rng.integers(4)]
    hinf = function in HINF
    tags = []
    kind = rng.choice(
        ["generic", "scaled", "illcond", "nearunc", "issue"],
        p=[0.3, 0.2, 0.15, 0.2, 0.15],
    )
    # sizes: mostly small, sometimes up to n = 10, N = 16
    n = int(
        rng.choice(np.arange(1, 11), p=np.array([4, 8, 8, 7, 6, 4, 3, 2, 2, 2]) / 46)
    )
    m = int(rng.choice([1, 2, 3], p=[0.5, 0.3, 0.2]))
    N = int(
        rng.choice(
            [1, 2, 3, 4, 6, 8, 12, 16], p=[0.15, 0.25, 0.15, 0.15, 0.1, 0.1, 0.05, 0.05]
        )
    )
    if function in SCHEDULED and n * N > 60:
        N = max(2, 60 // n)
    if small:
        n, N = min(n, 4), min(N, 3 if function in SCHEDULED else 4)
    nw = int(rng.choice([1, 2])) if hinf else 0
    case = Case(seed, index, function, [], tags=tags, small=small)

    if kind == "issue":
        nice, T = _issue_vertices(rng, N, hinf, nw, tags)
        case.stabilizable_by_construction = True
    else:
        family = FAMILIES[rng.integers(len(FAMILIES))]
        tags.append(family)
        nice = _nice_vertices(rng, n, m, N, nw, hinf, family, tags)
        T = None
        if kind == "nearunc":
            _make_near_uncontrollable(rng, nice, case, tags)
        if rng.random() < 0.12 and len(nice) > 1:
            tags.append("duplicates")
            for j in range(1, len(nice)):
                if rng.random() < 0.5:
                    nice[j] = tuple(x.copy() for x in nice[int(rng.integers(j))])
        n = nice[0][0].shape[0]
        if kind == "scaled":
            T = np.diag(10.0 ** rng.uniform(-4, 4, n))
            tags.append("scaled 1e-4..1e4")
        elif kind == "illcond" and n > 1:
            c = rng.uniform(3, 6)
            T = _orth(rng, n) @ np.diag(np.logspace(0, -c, n)) @ _orth(rng, n)
            tags.append(f"illcond 1e{c:.1f}")
    n = nice[0][0].shape[0]
    m = nice[0][2].shape[1]
    # gamma lower bound on the nice data (state transforms keep the gains)
    wz_gain = 1.0
    case.nice = (T, [tuple(x.copy() for x in v) for v in nice])
    verts = [tuple(x.copy() for x in v) for v in nice]
    if T is not None:
        Ti = np.linalg.inv(T)
        verts = [
            (Ti @ A @ T, Ti @ B1, Ti @ B2, C @ T, D1, D2)
            for A, B1, B2, C, D1, D2 in verts
        ]
    omega = 1.0
    if rng.random() < 0.2:
        omega = _loguniform(rng, -2, 3)
        tags.append(f"time x{omega:.3g}")
        verts = [
            (omega * A, omega * B1, omega * B2, C, D1, D2)
            for A, B1, B2, C, D1, D2 in verts
        ]
    if rng.random() < 0.2:
        su = 10.0 ** rng.uniform(-3, 3, m)
        tags.append("input scaled")
        verts = [(A, B1, B2 * su, C, D1, D2 * su) for A, B1, B2, C, D1, D2 in verts]
    if hinf and rng.random() < 0.15:
        sw, sz = _loguniform(rng, -3, 3), _loguniform(rng, -3, 3)
        wz_gain = sz * sw
        tags.append("w/z scaled")
        verts = [
            (A, B1 * sw, B2, C * sz, D1 * sw * sz, D2 * sz)
            for A, B1, B2, C, D1, D2 in verts
        ]
    case.vertices = verts
    case.channel_style = "names" if rng.random() < 0.7 else "indices"

    # requirements
    if rng.random() < 0.3:
        case.regions = _random_regions(rng, omega)
    if rng.random() < 0.15:
        case.gain_bound = _gain_scale(verts) * _loguniform(rng, 0, 1.5)
        tags.append("gain bound")
    if hinf:
        nice_lb = _gamma_lower(nice)
        if nice_lb is not None:
            case.gamma_lower = nice_lb * wz_gain
            if rng.random() < 0.2:
                case.gamma = case.gamma_lower * _loguniform(rng, -0.15, 1)
                tags.append("gamma given")
        r = rng.random()
        if r < 0.15:
            case.backoff = None
        elif r < 0.25:
            case.backoff = float(rng.uniform(0, 1))
    return case


def _nice_vertices(rng, n, m, N, nw, hinf, family, tags):
    A0 = _eigen_block(rng, n, family)
    if rng.random() < 0.6:
        Q = _orth(rng, n)
        A0 = Q @ A0 @ Q.T
    B0 = rng.standard_normal((n, m))
    B10 = rng.standard_normal((n, max(nw, 0))) * _loguniform(rng, -1, 0.5)
    ncz = int(rng.integers(1, n + 1))
    C0 = rng.standard_normal((ncz, n))
    rho = _loguniform(rng, -1.5, 0.5)
    singular = hinf and rng.random() < 0.15
    if singular:
        tags.append("singular D12")
        D20 = np.zeros((ncz, m))
        C = C0
        D2base = D20
    else:
        C = np.vstack([C0, np.zeros((m, n))])
        D2base = np.vstack([np.zeros((ncz, m)), rho * np.eye(m)])
    nz = C.shape[0]
    D1base = np.zeros((nz, nw))
    if hinf and rng.random() < 0.35:
        tags.append("D11 != 0")
        D1base = 0.3 * rng.standard_normal((nz, nw))
    if rng.random() < 0.2:
        tags.append("D12 cross")
        D2base = D2base + 0.3 * rng.standard_normal((nz, m))
    spread = _loguniform(rng, -1.5, -0.3)
    box = N > 1 and rng.random() < 0.5 and N in (2, 4, 8, 16)
    verts = []
    if box:
        k = int(np.log2(N))
        dA = [rng.standard_normal((n, n)) * spread for _ in range(k)]
        dB = [rng.standard_normal((n, m)) * spread for _ in range(k)]
        for corner in range(N):
            signs = [1.0 if (corner >> i) & 1 else -1.0 for i in range(k)]
            A = A0 + sum(s * d for s, d in zip(signs, dA))
            B = B0 + sum(s * d for s, d in zip(signs, dB))
            verts.append((A, B10.copy(), B, C.copy(), D1base.copy(), D2base.copy()))
        tags.append(f"box 2^{k}")
    else:
        for _ in range(N):
            A = A0 + spread * rng.standard_normal((n, n)) / np.sqrt(n)
            B = B0 * (1 + spread * rng.standard_normal((n, m)))
            Cj, D1j = C.copy(), D1base.copy()
            if rng.random() < 0.2:
                Cj = Cj + spread * rng.standard_normal(Cj.shape)
            verts.append((A, B10.copy(), B, Cj, D1j, D2base.copy()))
    return verts


def _make_near_uncontrollable(rng, verts, case, tags):
    """One (or every) vertex gets a mode the input barely or never reaches."""
    n = verts[0][0].shape[0]
    if n < 2:
        return
    lam = float(rng.choice([0.3, 0.0, -0.3]))
    exact = rng.random() < 0.35
    eps = 0.0 if exact else _loguniform(rng, -6, -2)
    which = range(len(verts)) if rng.random() < 0.3 else [int(rng.integers(len(verts)))]
    for j in which:
        A, B1, B2, C, D1, D2 = (x.copy() for x in verts[j])
        A[-1, :-1] = 0.0
        A[-1, -1] = lam
        B2[-1, :] = eps * rng.standard_normal(B2.shape[1]) if eps else 0.0
        verts[j] = (A, B1, B2, C, D1, D2)
        if eps == 0.0 and lam >= 0:
            case.unstabilizable.add(j)
    tags.append(
        f"{'uncontrollable' if exact else f'weak B {eps:.1e}'} mode {lam:+g} at "
        f"{'all vertices' if len(which) > 1 else f'vertex {which[0]}'}"
    )
    case.stabilizable_by_construction = not case.unstabilizable


def _issue_vertices(rng, N, hinf, nw, tags):
    """The issue's badly scaled stabilizable examples, perturbed."""
    N = min(N, 4)
    variant = int(rng.integers(3))
    verts = []
    for j in range(N):
        f = 1 + 0.1 * j
        if variant == 0:
            c = _loguniform(rng, 4, 9)
            b = _loguniform(rng, -6, -2)
            A = np.array([[1.0 * f, 0.0], [c, -1.0]])
            B = np.array([[b], [0.0]])
            tags.append(
                f"issue A=[[1,0],[{c:.1e},-1]] B=[{b:.1e};0]"
            ) if j == 0 else None
        elif variant == 1:
            a = _loguniform(rng, 6, 9)
            A = np.diag([a * f, -(10.0 ** -rng.uniform(6, 9))])
            B = np.array([[1.0], [10.0 ** -rng.uniform(6, 9)]])
            tags.append(f"issue A=diag({a:.1e}, -tiny) B=[1; tiny]") if j == 0 else None
        else:
            k = _loguniform(rng, 6, 9.5)
            # two-mass like: stiff spring k between two inertias, torque on one
            A = np.array(
                [
                    [0, 1, 0, 0],
                    [-k * f, -0.1, k * f, 0],
                    [0, 0, 0, 1],
                    [k, 0, -k, -0.1],
                ],
                float,
            )
            B = np.array([[0.0], [1.0], [0.0], [0.0]])
            tags.append(f"issue stiff two-mass k={k:.1e}") if j == 0 else None
        n = A.shape[0]
        B1 = np.ones((n, nw)) * 0.5 if hinf else np.zeros((n, 0))
        C = np.vstack([np.eye(n)[:1], np.zeros((1, n))])
        D2 = np.array([[0.0], [1.0]])
        D1 = np.zeros((2, nw))
        verts.append((A, B1, B, C, D1, D2))
    return verts, None


def _random_regions(rng, omega):
    out = []
    for _ in range(int(rng.choice([1, 1, 2]))):
        kind = rng.choice(["halfplane", "disk", "sector"])
        if kind == "halfplane":
            a = 0.0 if rng.random() < 0.3 else omega * _loguniform(rng, -3, -0.5)
            out.append(Region("halfplane", (a,)))
        elif kind == "disk":
            r = omega * _loguniform(rng, 0.7, 2)
            c = 0.0 if rng.random() < 0.7 else -r * rng.uniform(0, 0.5)
            out.append(Region("disk", (r, c)))
        else:
            out.append(Region("sector", (float(rng.uniform(0.35, 1.4)),)))
    return out


def _gain_scale(verts):
    """Rough size of a stabilizing gain: max of ``||pinv(B)|| (||A|| + 1)``."""
    return max(
        np.linalg.norm(np.linalg.pinv(B2), 2) * (np.linalg.norm(A, 2) + 1.0)
        for A, _, B2, *_ in verts
    )


def _gamma_lower(verts):
    """max_j of the frozen Riccati optimum (None if not applicable)."""
    out = 0.0
    for A, B1, B2, C, D1, D2 in verts:
        if np.any(D1) or np.linalg.matrix_rank(D2) < D2.shape[1]:
            return None
        # The Hamiltonian bisection is not trustworthy on data spanning many
        # orders of magnitude (case 2026:9: its optimum 5.9e6 was above the
        # frozen linfnorm 4.8e6 of a design): no lower bound there.
        if np.linalg.cond(A) > 1e8:
            return None
        try:
            g = hinf_riccati(A, B1, B2, C, D2)[0]
        except (RuntimeError, np.linalg.LinAlgError):
            return None
        out = max(out, g)
    return out


# ======================================================================
# Float64 checks of a design
# ======================================================================
def negdef_margin(F, G, inner):
    """Enclosure of ``lambda_max`` of ``F`` after a diagonal congruence.

    ``F`` is a computed symmetric matrix and ``G >= 0`` bounds the absolute
    sizes that entered each entry (so the rounding error of ``F`` is at most
    ``gamma_inner * G`` entrywise). With ``D = diag(-F_ii)^-1/2`` and
    ``lam = lambda_max(D F D)``, returns ``(lam - err, lam + err)`` where
    ``err`` bounds the rounding error of ``F`` and of the eigenvalue
    computation: ``F < 0`` is proved when the upper end is negative, and
    disproved when the lower end is positive.
    """
    F = 0.5 * (F + F.T)
    G = 0.5 * (G + G.T)
    k = inner + 4
    gam = k * UNIT / (1 - k * UNIT)
    d = np.diag(F)
    if not np.all(np.isfinite(F)):
        return float(np.inf), float(np.inf)
    if np.any(d >= 0):
        if np.any(d > gam * np.diag(G)):
            return float(np.inf), float(np.inf)
        return -1e-300, float(np.inf)  # within rounding of zero: undecided
    s = 1.0 / np.sqrt(-d)
    Fh = F * s[:, None] * s[None, :]
    Gh = G * s[:, None] * s[None, :]
    lam = float(np.linalg.eigvalsh(Fh)[-1])
    err = gam * np.linalg.norm(Gh, 2) + 4 * len(F) * UNIT * np.linalg.norm(Fh, 2)
    return lam - float(err), lam + float(err)


def _sym_abs(X):
    return X + X.T


def lyapunov_lmi(P, Acl, absAcl):
    """``Acl' P + P Acl`` and its absolute-size bound."""
    F = Acl.T @ P + P @ Acl
    G = _sym_abs(absAcl.T @ np.abs(P))
    return F, G


def brl_lmi(P, Acl, absAcl, B1, Ccl, absCcl, D1, g, c=1.0):
    """Bounded-real LMI ``[[A'P+PA, PB, C'], [B'P, -c I, D'], [C, D, -c g I]]``.

    (``g = gamma^2``; ``c = 2`` for the pair sums of Theorem 2.)
    """
    nw, nz = B1.shape[1], Ccl.shape[0]
    PB = P @ B1
    F = np.block(
        [
            [Acl.T @ P + P @ Acl, PB, Ccl.T],
            [PB.T, -c * np.eye(nw), D1.T],
            [Ccl, D1, -c * g * np.eye(nz)],
        ]
    )
    aP = np.abs(P)
    aPB = aP @ np.abs(B1)
    G = np.block(
        [
            [_sym_abs(absAcl.T @ aP), aPB, absCcl.T],
            [aPB.T, c * np.eye(nw), np.abs(D1).T],
            [absCcl, np.abs(D1), c * g * np.eye(nz)],
        ]
    )
    return F, G


def region_lmi(P, Acl, absAcl, L, M):
    """``kron(L, P) + kron(M, P Acl) + kron(M', Acl' P)`` (P form, W = P^-1)."""
    PA = P @ Acl
    F = np.kron(L, P) + np.kron(M, PA) + np.kron(M.T, PA.T)
    aPA = np.abs(P) @ absAcl
    G = (
        np.kron(np.abs(L), np.abs(P))
        + np.kron(np.abs(M), aPA)
        + np.kron(np.abs(M).T, aPA.T)
    )
    return F, G


def _gain_at(gains, delta):
    return np.tensordot(delta, np.stack(gains), axes=1)


def sample_deltas(N, count=32, seed=0, pairs=True):
    """Vertices, Dirichlet samples and (optionally) pair midpoints."""
    rng = np.random.default_rng(seed)
    out = [np.eye(N)[j] for j in range(N)]
    if N > 1:
        out += list(rng.dirichlet(np.ones(N) * 0.5, size=count))
        if pairs:
            out += [
                0.5 * (np.eye(N)[j] + np.eye(N)[k])
                for j in range(N)
                for k in range(j + 1, N)
            ][:120]
    return out


def frozen(case_vertices, delta):
    """Frozen ``(A, B1, B2, C, D1, D2)`` at convex coordinates `delta`."""
    return tuple(sum(d * v[i] for d, v in zip(delta, case_vertices)) for i in range(6))


def hinf_norm(A, B, C, D):
    """Frozen H-infinity norm: ``(control.linfnorm, grid lower bound)``."""
    _, (s, _) = sla.matrix_balance(A, permute=False, separate=True)
    s = np.asarray(s, float)
    Ab = A * (1 / s)[:, None] * s[None, :]
    Bb = B * (1 / s)[:, None]
    Cb = C * s[None, :]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = float(ct.linfnorm(ct.ss(Ab, Bb, Cb, D))[0])
    except Exception:  # noqa: BLE001 - the grid bound still applies
        value = float("nan")
    ev = np.linalg.eigvals(Ab)
    scale = max(np.abs(ev).max(initial=0.0), 1e-6)
    omegas = np.concatenate(
        [
            [0.0],
            np.logspace(np.log10(scale) - 4, np.log10(scale) + 3, 200),
            np.abs(ev.imag),
        ]
    )
    lower = float(np.linalg.svd(D, compute_uv=False).max(initial=0.0))
    eye = np.eye(len(A))
    for wv in omegas:
        try:
            G = Cb @ np.linalg.solve(1j * wv * eye - Ab, Bb) + D
        except np.linalg.LinAlgError:
            return value, float("inf")
        lower = max(lower, float(np.linalg.svd(G, compute_uv=False).max(initial=0.0)))
    return value, lower


@dataclass
class CheckResult:
    """Outcome of `check_design`: ``hard`` failures make a design wrong."""

    hard: list = field(default_factory=list)
    soft: list = field(default_factory=list)
    info: dict = field(default_factory=dict)

    @property
    def ok(self):
        return not self.hard

    @property
    def verified(self):
        """Everything proved, rounding included (used for probe designs)."""
        return not self.hard and not self.soft

    def __str__(self):
        parts = ["OK" if self.ok else "FAIL"]
        if self.hard:
            parts.append("hard: " + "; ".join(self.hard[:4]))
        if self.soft:
            parts.append("soft: " + "; ".join(self.soft[:4]))
        return " | ".join(parts)


def _conventions(gamma):
    """Scalings of P tried for the BRL (the library's, Lyapunov, storage)."""
    return (("P", 1.0), ("P/gamma", 1.0 / gamma), ("P/gamma^2", 1.0 / gamma**2))


def check_design(
    case: Case, gains, P, gamma=None, *, samples=32, norms=True
) -> CheckResult:
    """Independent float64 verification of a design (see module doc).

    Parameters
    ----------
    case : Case
        The problem.
    gains : sequence of ndarray
        One common gain or one per vertex, ``u = -K x``.
    P : ndarray
        Lyapunov matrix, ``V = x' P x``.
    gamma : float, optional
        Certified H-infinity bound (H-infinity problems).
    """
    res = CheckResult()
    V = case.vertices
    N, n = case.N, case.n
    gains = [np.asarray(K, float) for K in gains]
    P = np.asarray(P, float)
    if len(gains) not in (1, N):
        res.hard.append(f"{len(gains)} gains for {N} vertices")
        return res
    if any(K.shape != (case.m, n) for K in gains) or P.shape != (n, n):
        res.hard.append("wrong shapes")
        return res
    if not (all(np.all(np.isfinite(K)) for K in gains) and np.all(np.isfinite(P))):
        res.hard.append("non-finite gains or P")
        return res
    sched = len(gains) > 1
    res.info["max_gain"] = max(float(np.linalg.norm(K, 2)) for K in gains)
    # Exact power-of-two diagonal change of coordinates x = D x^ that makes
    # diag(P^) about 1: every LMI below is then computed in coordinates
    # where its rounding error is small, and is exactly congruent to the
    # original one (scaling by powers of two is exact in binary floating
    # point). Eigenvalues and transfer functions do not change.
    dP = np.diag(P)
    if np.all(np.isfinite(dP)) and np.all(dP > 0):
        d = 2.0 ** np.round(-0.5 * np.log2(dP))
        V = [
            (A * d[None, :] / d[:, None], B1 / d[:, None], B2 / d[:, None],
             C * d[None, :], D1, D2)
            for A, B1, B2, C, D1, D2 in V
        ]  # fmt: skip
        gains = [K * d[None, :] for K in gains]
        P = P * d[:, None] * d[None, :]
    if case.gain_bound is not None and res.info["max_gain"] > case.gain_bound * (
        1 + 1e-9
    ):
        res.hard.append(
            f"gain bound {case.gain_bound:.6g} exceeded: "
            f"||K|| = {res.info['max_gain']:.6g}"
        )
    asym = np.abs(P - P.T).max() / max(np.abs(P).max(), 1e-300)
    if asym > 1e-8:
        res.hard.append(f"P not symmetric ({asym:.1e})")
    Ps = 0.5 * (P + P.T)
    lamP = negdef_margin(-Ps, np.abs(Ps), 1)
    if lamP[0] >= 0:
        res.hard.append("P not positive definite")
    elif lamP[1] >= 0:
        res.soft.append("P > 0 not proved beyond rounding")

    def closed(j, k):
        A, B1, B2, C, D1, D2 = V[j]
        K = gains[k] if sched else gains[0]
        Acl = A - B2 @ K
        aA = np.abs(A) + np.abs(B2) @ np.abs(K)
        Ccl = C - D2 @ K
        aC = np.abs(C) + np.abs(D2) @ np.abs(K)
        return Acl, aA, B1, Ccl, aC, D1

    # -- Lyapunov / BRL / region LMIs at vertices and (scheduled) pairs
    pairs = [(j, j) for j in range(N)]
    if sched:
        pairs += [(j, k) for j in range(N) for k in range(j + 1, N)]
    worst = {"lyap": -np.inf, "brl": -np.inf, "region": -np.inf}
    hinf = case.hinf
    conv_used = None
    if hinf:
        if gamma is None or not np.isfinite(gamma) or gamma <= 0:
            res.hard.append(f"H-infinity design without a finite gamma ({gamma})")
            return res
        if case.gamma is not None and gamma > case.gamma:
            res.hard.append(f"required gamma {case.gamma:.10g} not met: {gamma:.10g}")
        for name, c in _conventions(gamma):
            ok_all, worst_b = True, -np.inf
            for j, k in pairs:
                F, G = _pair_brl(closed, j, k, c * Ps, gamma**2)
                lam, bound = negdef_margin(F, G, 2 * n + case.m + case.nw + case.nz)
                worst_b = max(worst_b, bound)
                if lam >= 0:
                    ok_all = False
                    break
            if ok_all:
                conv_used = name
                worst["brl"] = worst_b
                break
        if conv_used is None:
            scale = _brl_scale_search(closed, pairs, Ps, gamma, case)
            if scale is None:
                res.hard.append(
                    "bounded-real LMI fails at some vertex/pair for every scaling of P"
                )
            else:
                res.soft.append(
                    f"bounded-real LMI holds only with {scale:.3g} P "
                    "(no standard convention)"
                )
        elif worst["brl"] >= 0:
            res.soft.append(
                f"BRL ({conv_used}) not proved beyond rounding ({worst['brl']:.2e})"
            )
        res.info["P_convention"] = conv_used
    for j, k in pairs:
        Acl, aA = closed(j, k)[:2]
        if j != k:
            Acl2, aA2 = closed(k, j)[:2]
            Acl, aA = Acl + Acl2, aA + aA2
        F, G = lyapunov_lmi(Ps, Acl, aA)
        lam, bound = negdef_margin(F, G, 2 * n + case.m)
        worst["lyap"] = max(worst["lyap"], bound)
        if lam >= 0:
            res.hard.append(
                "Lyapunov LMI fails at "
                + (f"vertex {j}" if j == k else f"pair {(j, k)}")
                + f" (lambda_max {lam:.3g} after diagonal congruence)"
            )
            break
    else:
        if worst["lyap"] >= 0:
            res.soft.append(
                f"Lyapunov LMI not proved beyond rounding ({worst['lyap']:.2e})"
            )
    for region in case.regions:
        L, M = region.LM()
        for j, k in pairs:
            Acl, aA = closed(j, k)[:2]
            LL = L
            if j != k:
                Acl2, aA2 = closed(k, j)[:2]
                Acl, aA, LL = Acl + Acl2, aA + aA2, 2 * L
            F, G = region_lmi(Ps, Acl, aA, LL, M)
            lam, bound = negdef_margin(F, G, 2 * n + case.m)
            worst["region"] = max(worst["region"], bound)
            if bound >= 0:
                res.soft.append(
                    f"region {region} LMI with this P not proved at {(j, k)}"
                )
                break
    res.info["lyap_bound"] = worst["lyap"]
    res.info["brl_bound"] = worst["brl"]

    # -- frozen closed loops at vertices and samples
    max_re = -np.inf
    max_norm = 0.0
    for delta in sample_deltas(N, samples):
        A, B1, B2, C, D1, D2 = frozen(V, delta)
        K = _gain_at(gains, delta) if sched else gains[0]
        Acl = A - B2 @ K
        ev = np.linalg.eigvals(Acl)
        max_re = max(max_re, float(ev.real.max()))
        if ev.real.max() >= 0:
            res.hard.append(
                f"closed loop not Hurwitz at delta={np.round(delta, 3).tolist()}"
            )
            break
        for region in case.regions:
            if not region.contains(ev):
                res.hard.append(
                    f"eigenvalues outside {region} at "
                    f"delta={np.round(delta, 3).tolist()}"
                )
                break
        if hinf and norms:
            value, lower = hinf_norm(Acl, B1, C - D2 @ K, D1)
            max_norm = max(max_norm, value if np.isfinite(value) else lower)
            if lower > gamma * (1 + 1e-9):
                res.hard.append(
                    f"frozen H-inf norm >= {lower:.8g} (grid) > gamma {gamma:.8g}"
                )
                break
            if np.isfinite(value) and value > gamma * (1 + 1e-7):
                res.hard.append(
                    f"frozen H-inf norm {value:.8g} (linfnorm) > gamma {gamma:.8g}"
                )
                break
    res.info["max_real"] = max_re
    res.info["max_frozen_norm"] = max_norm
    return res


def _brl_scale_search(closed, pairs, P, gamma, case):
    """A scalar c with the BRL true for c P at every vertex/pair, or None."""
    inner = 2 * case.n + case.m + case.nw + case.nz
    for c in np.logspace(-12, 12, 97):
        if all(
            negdef_margin(*_pair_brl(closed, j, k, c * P, gamma**2), inner)[0] < 0
            for j, k in pairs
        ):
            return float(c)
    return None


def _pair_brl(closed, j, k, P, g):
    Acl, aA, B1, Ccl, aC, D1 = closed(j, k)
    if j == k:
        return brl_lmi(P, Acl, aA, B1, Ccl, aC, D1, g, 1.0)
    Acl2, aA2, B12, Ccl2, aC2, D12 = closed(k, j)
    return brl_lmi(
        P, Acl + Acl2, aA + aA2, B1 + B12, Ccl + Ccl2, aC + aC2, D1 + D12, g, 2.0
    )


# ======================================================================
# Stabilizability, scale invariant
# ======================================================================
def mode_controllability(A, B):
    """Scale-invariant controllability cosine of each mode with ``Re >= 0``.

    The cosine is ``max_k |v'b_k| / (|v|'|b_k|)``.

    ``v`` is the left eigenvector; the ratio does not change under diagonal
    state or input scaling. Returns ``[(eigenvalue, cosine), ...]``.
    """
    w, vl = sla.eig(A, left=True, right=False)
    out = []
    for i, lam in enumerate(w):
        if lam.real < -1e-12 * max(1.0, abs(lam)):
            continue
        v = vl[:, i]
        num = np.abs(v.conj() @ B)
        den = np.abs(v) @ np.abs(B)
        cos = float(np.max(num / np.maximum(den, 1e-300), initial=0.0))
        out.append((complex(lam), cos))
    return out


def vertex_unstabilizable(case: Case, j: int, tol=1e-10) -> bool | None:
    """Ground truth (construction) or the scale-invariant test for vertex `j`."""
    if j in case.unstabilizable:
        return True
    if case.stabilizable_by_construction:
        return False
    A, _, B2, *_ = case.vertices[j]
    if case.nice is not None and case.nice[0] is not None:
        A, _, B2, *_ = case.nice[1][j]  # the same modes, well-conditioned coordinates
    modes = mode_controllability(A, B2)
    if any(cos < tol for _, cos in modes):
        return None  # looks uncontrollable: not decided here
    return False


# ======================================================================
# Independent feasibility probe
# ======================================================================
@dataclass
class ProbeResult:
    found: bool
    method: str = ""
    gains: list | None = None
    P: np.ndarray | None = None
    gamma: float | None = None
    tried: list = field(default_factory=list)
    check: CheckResult | None = None
    seconds: float = 0.0


def _scaling(case, mode):
    """Coordinates for the probe: x = T x~, u = Su u~, time a, w/z scales."""
    V = case.vertices
    n = case.n
    if mode == "nice" and case.nice is not None and case.nice[0] is not None:
        T = np.linalg.inv(case.nice[0])  # x = T x_nice
    elif mode in ("balanced", "nice"):
        M = sum(np.abs(v[0]) for v in V) + sum(np.abs(v[2]) @ np.abs(v[2]).T for v in V)
        M = M + sum(np.abs(v[1]) @ np.abs(v[1]).T for v in V) if case.hinf else M
        _, (s, _) = sla.matrix_balance(M + 1e-300, permute=False, separate=True)
        T = np.diag(s)
    else:
        T = np.eye(n)
    Ti = np.linalg.inv(T)
    a = max(np.linalg.norm(Ti @ v[0] @ T, 2) for v in V)
    a = a if a > 0 else 1.0
    if mode == "raw":
        a = 1.0
    cols = np.max([np.linalg.norm(Ti @ v[2], axis=0) for v in V], axis=0)
    Su = (
        np.where(cols > 0, a / np.maximum(cols, 1e-300), 1.0)
        if mode != "raw"
        else np.ones(case.m)
    )
    sw = sz = 1.0
    if case.hinf and mode != "raw":
        nb1 = max(np.linalg.norm(Ti @ v[1], 2) for v in V)
        sw = a / nb1 if nb1 > 0 else 1.0
        nz = max(
            np.linalg.norm(np.hstack([v[3] @ T, v[4] * sw, v[5] * Su]), 2) for v in V
        )
        sz = nz if nz > 0 else 1.0
    data = [
        (
            Ti @ A @ T / a,
            Ti @ B1 * sw / a,
            Ti @ B2 * Su / a,
            C @ T / sz,
            D1 * sw / sz,
            D2 * Su / sz,
        )  # fmt: skip
        for A, B1, B2, C, D1, D2 in V
    ]
    return T, Su, a, sw, sz, data


def _solver_options(solver, time_limit):
    if solver == "SCS":
        return {"eps": 1e-8, "max_iters": 20000, "time_limit_secs": time_limit}
    return {"time_limit": time_limit}


# A probe's single solve never runs longer than this (s): an SCS call
# without a limit sat 8 minutes on one fuzz case (5757:26).
_PROBE_SOLVE_LIMIT = 30.0


def _time_limit(solver):
    key = "time_limit_secs" if solver == "SCS" else "time_limit"
    return {key: _PROBE_SOLVE_LIMIT}


def lmi_design(case, mode="balanced", margin=1e-6, solver="CLARABEL", gamma_factor=1.2,
               time_limit=60.0):  # fmt: skip
    """Plain cvxpy LMI synthesis in the given coordinates; returns candidates.

    Stabilization: maximise the decay ``t`` (``sym(A_cl W) <= -t I``) with
    ``W <= I``, ``||Z|| <= 1``. H-infinity: minimise ``g = gamma^2``, then at
    ``g <= (gamma_factor gamma*)^2`` (or the required gamma) maximise the
    common margin ``s`` of every LMI with ``W <= 10 lambda_max(W*) I``.
    """
    T, Su, a, sw, sz, data = _scaling(case, mode)
    n, m, N = case.n, case.m, case.N
    sched = case.scheduled
    W = cp.Variable((n, n), symmetric=True)
    Z = [cp.Variable((m, n)) for _ in range(N if sched else 1)]
    g = cp.Variable() if case.hinf else None
    t = cp.Variable()
    eye = np.eye(n)
    pairs = [(j, j) for j in range(N)] + (
        [(j, k) for j in range(N) for k in range(j + 1, N)] if sched else []
    )

    def Zk(k):
        return Z[k] if sched else Z[0]

    def both(f, j, k):
        return f(j, k) if j == k else f(j, k) + f(k, j)

    def AclW(j, k):
        return data[j][0] @ W - data[j][2] @ Zk(k)

    def CclW(j, k):
        return data[j][3] @ W - data[j][5] @ Zk(k)

    scaled_regions = [r.LM(a) for r in case.regions]

    def lmis(slack):
        cons = [W >> margin * eye]
        for j, k in pairs:
            c = 1.0 if j == k else 2.0
            X = both(AclW, j, k)
            shift = (margin + slack) if j == k else slack
            if case.hinf:
                B1 = data[j][1] if j == k else data[j][1] + data[k][1]
                D1 = data[j][4] if j == k else data[j][4] + data[k][4]
                Y = both(CclW, j, k)
                F = cp.bmat(
                    [
                        [X + X.T, B1, Y.T],
                        [B1.T, -c * np.eye(case.nw), D1.T],
                        [Y, D1, -c * g * np.eye(case.nz)],
                    ]
                )
            else:
                F = X + X.T
            cons.append(0.5 * (F + F.T) + shift * np.eye(F.shape[0]) << 0)
            for L, M in scaled_regions:
                LL = L if j == k else 2 * L
                R = cp.kron(LL, W) + cp.kron(M, X) + cp.kron(M.T, X.T)
                cons.append(0.5 * (R + R.T) + shift * np.eye(R.shape[0]) << 0)
        return cons

    gamma_req = None if case.gamma is None else case.gamma * sw / sz
    opts = _solver_options(solver, time_limit)
    out = []

    def solve(name, objective, cons):
        prob = cp.Problem(objective, cons)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                prob.solve(solver=solver, **opts)
        except Exception as exc:  # noqa: BLE001 - recorded
            out.append(
                (f"{mode}/{solver}/{name}/m={margin:g}: {type(exc).__name__}", None)
            )
            return None
        if W.value is None or prob.status not in ("optimal", "optimal_inaccurate"):
            out.append((f"{mode}/{solver}/{name}/m={margin:g}: {prob.status}", None))
            return None
        Wv = 0.5 * (W.value + W.value.T)
        try:
            Winv = np.linalg.inv(Wv)
        except np.linalg.LinAlgError:
            return None
        Ti = np.linalg.inv(T)
        gains = [(Su[:, None] * (z.value @ Winv)) @ Ti for z in Z]
        # The BRL of the original data holds with (sw^2 / a) T^-T W~^-1 T^-1.
        P = (sw**2 / a if case.hinf else 1.0) * Ti.T @ Winv @ Ti
        gv = None if g is None else float(g.value)
        gamma = None if gv is None else float(np.sqrt(max(gv, 0))) * sz / sw
        cand = (gains, P, gamma, Wv, [z.value.copy() for z in Z])
        out.append((f"{mode}/{solver}/{name}/m={margin:g}", cand))
        return cand

    if case.hinf:
        base = lmis(0.0)
        if gamma_req is not None:
            base.append(g <= gamma_req**2 * (1 - 1e-6))
        first = solve("min gamma", cp.Minimize(g), base)
        if first is not None:
            gb = (first[2] * sw / sz * gamma_factor) ** 2
            if gamma_req is not None:
                gb = min(gb, gamma_req**2 * (1 - 1e-6))
            wmax = 10 * np.linalg.eigvalsh(first[3])[-1]
            s = cp.Variable()
            solve(
                "max margin",
                cp.Maximize(s),
                lmis(s) + [g <= gb, W << wmax * eye, s <= 1],
            )
    else:
        cons = lmis(t) + [W << eye, t <= 1]
        for z in Z:
            cons.append(cp.bmat([[np.eye(m), z], [z.T, eye]]) >> 0)
        solve("max decay", cp.Maximize(t), cons)
    return out


def _gain_iterate(case, mode, start, solver="CLARABEL", iterations=6, margin=1e-6):
    """Convex-concave minimisation of max ||K_k|| from a start (W~, Z~)."""
    T, Su, a, sw, sz, data = _scaling(case, mode)
    n, m, N = case.n, case.m, case.N
    sched = case.scheduled
    W0 = start[3]
    out = []
    for _ in range(iterations):
        W = cp.Variable((n, n), symmetric=True)
        Z = [cp.Variable((m, n)) for _ in range(N if sched else 1)]
        g = cp.Variable() if case.hinf else None
        mu = cp.Variable()
        G0inv = np.linalg.inv(T @ W0)
        H = T @ W @ G0inv
        cons = [W >> margin * np.eye(n)]
        for k in range(len(Z)):
            S = np.diag(Su) @ Z[k] @ G0inv
            cons.append(cp.bmat([[H + H.T - np.eye(n), S.T], [S, mu * np.eye(m)]]) >> 0)
        pairs = [(j, j) for j in range(N)] + (
            [(j, k) for j in range(N) for k in range(j + 1, N)] if sched else []
        )

        def X(j, k, W=W, Z=Z):
            return data[j][0] @ W - data[j][2] @ (Z[k] if sched else Z[0])

        for j, k in pairs:
            Xs = X(j, k) if j == k else X(j, k) + X(k, j)
            strict = margin if j == k else 0.0
            c = 1.0 if j == k else 2.0
            if case.hinf:
                B1 = data[j][1] if j == k else data[j][1] + data[k][1]
                D1 = data[j][4] if j == k else data[j][4] + data[k][4]

                def Y(jj, kk, W=W, Z=Z):
                    return data[jj][3] @ W - data[jj][5] @ (Z[kk] if sched else Z[0])

                Ys = Y(j, k) if j == k else Y(j, k) + Y(k, j)
                F = cp.bmat(
                    [
                        [Xs + Xs.T, B1, Ys.T],
                        [B1.T, -c * np.eye(case.nw), D1.T],
                        [Ys, D1, -c * g * np.eye(case.nz)],
                    ]
                )
            else:
                F = Xs + Xs.T
            cons.append(0.5 * (F + F.T) << -strict * np.eye(F.shape[0]))
            for L, M in [r.LM(a) for r in case.regions]:
                LL = L if j == k else 2 * L
                R = cp.kron(LL, W) + cp.kron(M, Xs) + cp.kron(M.T, Xs.T)
                cons.append(0.5 * (R + R.T) << -strict * np.eye(R.shape[0]))
        if case.hinf:
            gb = start[2] * sw / sz if start[2] is not None else None
            if case.gamma is not None:
                gb = (
                    case.gamma * sw / sz * (1 - 1e-6)
                    if gb is None
                    else min(gb, case.gamma * sw / sz * (1 - 1e-6))
                )
            cons.append(g <= (gb if gb is not None else 1e12) ** 2 * 1.44)
        prob = cp.Problem(cp.Minimize(mu), cons)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                prob.solve(solver=solver, **_time_limit(solver))
        except Exception:  # noqa: BLE001
            break
        if W.value is None:
            break
        Wv = 0.5 * (W.value + W.value.T)
        Winv = np.linalg.inv(Wv)
        gains = [(Su[:, None] * (z.value @ Winv)) @ np.linalg.inv(T) for z in Z]
        P = (sw**2 / a) * np.linalg.inv(T).T @ Winv @ np.linalg.inv(T)
        gamma = None if g is None else float(np.sqrt(max(float(g.value), 0))) * sz / sw
        out.append((gains, P, gamma))
        W0 = Wv
        if (
            case.gain_bound is not None
            and max(np.linalg.norm(K, 2) for K in gains) <= case.gain_bound
        ):
            break
    return out


def _riccati_candidates(case):
    """LTI: LQR / H-infinity Riccati gains with P from the Riccati solution."""
    out = []
    if case.N != 1 and not all(
        all(np.array_equal(x, y) for x, y in zip(case.vertices[0], v))
        for v in case.vertices
    ):
        return out
    A, B1, B2, C, D1, D2 = case.vertices[0]
    n = case.n
    if case.hinf and not np.any(D1) and np.linalg.matrix_rank(D2) == case.m:
        try:
            gopt, _, _ = hinf_riccati(A, B1, B2, C, D2)
        except (RuntimeError, np.linalg.LinAlgError):
            gopt = None
        if gopt is not None:
            for f in (1.05, 1.2, 1.5, 2.0):
                gam = gopt * f
                if case.gamma is not None:
                    gam = min(gam, case.gamma * (1 - 1e-6))
                sol = hinf_riccati_at(
                    A,
                    B1,
                    B2,
                    C,
                    D2,
                    gam,
                    eps=1e-6 * max(np.linalg.norm(C, 2) ** 2, 1e-12),
                )
                if sol is None:
                    continue
                X, K = sol
                # storage X: BRL with P = X / gamma^2 in the library form
                out.append((f"riccati gamma={f}*opt", ([K], X / gam**2, gam)))
    else:
        try:
            X = sla.solve_continuous_are(A, B2, np.eye(n), np.eye(case.m))
            K = B2.T @ X
            out.append(("lqr", ([K], X, None)))
        except (np.linalg.LinAlgError, ValueError):
            pass
    return out


def _analysis_P(case, gains, solver="CLARABEL"):
    """Given gains, the best P (and gamma) by an analysis LMI, balanced coords."""
    sched = len(gains) > 1
    V = case.vertices
    N, n = case.N, case.n
    Acls = {}
    for j in range(N):
        for k in range(N) if sched else [0]:
            K = gains[k]
            Acls[j, k] = (V[j][0] - V[j][2] @ K, V[j][3] - V[j][5] @ K)
    M = sum(np.abs(Acls[key][0]) for key in Acls)
    _, (s, _) = sla.matrix_balance(M + 1e-300, permute=False, separate=True)
    S = np.diag(s)
    Si = np.diag(1 / s)
    a = max(np.linalg.norm(Si @ Acls[key][0] @ S, 2) for key in Acls) or 1.0
    Q = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    cons = [Q >> np.eye(n), Q << 1e6 * np.eye(n)]
    pairs = [(j, j) for j in range(N)] + (
        [(j, k) for j in range(N) for k in range(j + 1, N)] if sched else []
    )
    for j, k in pairs:
        kk, jj = (k, j) if sched else (0, 0)
        A = Si @ Acls[j, kk if sched else 0][0] @ S / a
        if j != k:
            A = A + Si @ Acls[k, jj][0] @ S / a
        F = A.T @ Q + Q @ A
        cons.append(0.5 * (F + F.T) << -t * np.eye(n))
    prob = cp.Problem(cp.Maximize(t), cons + [t <= 1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prob.solve(solver=solver, **_time_limit(solver))
    except Exception:  # noqa: BLE001
        return None
    if Q.value is None:
        return None
    return Si @ Q.value @ Si


def probe_case(case: Case, budget=120.0, verbose=False) -> ProbeResult:
    """Search independently for a float64-verified design of `case`.

    `budget` is in CPU seconds (checked between candidates).
    """
    start = time.process_time()  # a CPU budget: the same under load
    res = ProbeResult(False)

    def accept(name, gains, P, gamma):
        if gamma is None and case.hinf:
            return False
        chk = check_design(case, gains, P, gamma)
        res.tried.append(f"{name}: {chk}")
        if verbose:
            print(f"    probe {name}: {chk}")
        if chk.verified:
            res.found, res.method, res.gains, res.P, res.gamma, res.check = (
                True, name, gains, P, gamma, chk,
            )  # fmt: skip
            return True
        return False

    def over():
        return time.process_time() - start > budget

    for name, (gains, P, gamma) in _riccati_candidates(case):
        if accept(name, gains, P, gamma):
            break
    nice = case.nice is not None and case.nice[0] is not None
    plans = [
        ("nice", 1e-6, "CLARABEL"), ("balanced", 1e-6, "CLARABEL"),
        ("nice", 1e-8, "CLARABEL"), ("balanced", 1e-8, "CLARABEL"),
        ("nice", 1e-6, "SCS"), ("balanced", 1e-6, "SCS"),
        ("raw", 1e-6, "CLARABEL"), ("balanced", 1e-4, "CLARABEL"),
    ]  # fmt: skip
    plans = [p for p in plans if nice or p[0] != "nice"]
    for mode, margin, solver in plans:
        if res.found or over():
            break
        try:
            designs = lmi_design(case, mode, margin, solver)
        except Exception as exc:  # noqa: BLE001 - a probe bug must not stop a run
            res.tried.append(
                f"{mode}/{solver}: probe error {type(exc).__name__}: {exc}"
            )
            continue
        for name, cand in designs:
            if cand is None:
                res.tried.append(name)
                if verbose:
                    print(f"    probe {name}")
                continue
            gains, P, gamma, Wv, Zv = cand
            if accept(name, gains, P, gamma):
                break
            if case.gain_bound is not None and not over():
                try:
                    iterates = _gain_iterate(case, mode, cand, solver, margin=margin)
                except Exception as exc:  # noqa: BLE001
                    res.tried.append(f"gain iteration: probe error {exc}")
                    iterates = []
                for i, (g2, P2, gm2) in enumerate(iterates):
                    if accept(f"{name}/gain iteration {i}", g2, P2, gm2):
                        break
                if res.found:
                    break
            if not case.hinf and not case.regions and not over():
                P2 = _analysis_P(case, gains)
                if P2 is not None and accept(f"{name}/analysis P", gains, P2, None):
                    break
    res.seconds = time.process_time() - start
    return res


# ======================================================================
# Refusals
# ======================================================================
def message_kind(exc) -> str:
    """What a refusal claims, from the head of its message."""
    msg = str(exc).lower()
    head = msg.split(" [", 1)[0]  # the solver summary (statuses) follows " ["
    if "not stabilizable" in head or "uncontrollable" in head:
        return "not stabilizable"
    if "gain_bound" in head:
        return "gain_bound"
    if "certif" in head or "verification" in head:
        return "not certified"
    if "infeasible" in head:
        return "infeasible"
    return "other"


def proved_infeasible(case: Case) -> str | None:
    """A proof from the construction that no design exists, or None."""
    if case.unstabilizable:
        return (
            f"vertices {sorted(case.unstabilizable)} have an exactly "
            "uncontrollable mode Re >= 0"
        )
    if case.gamma is not None and case.gamma_lower is not None:
        if case.gamma < case.gamma_lower * (1 - 1e-3):
            return (
                f"required gamma {case.gamma:.4g} below a vertex's Riccati optimum "
                f"{case.gamma_lower:.4g}"
            )
    return None


def classify_refusal(case: Case, exc, probe: ProbeResult | None, lpv) -> dict:
    """Class of a refusal and whether its message is true."""
    cls = type(exc).__name__
    kind = message_kind(exc)
    proof = proved_infeasible(case)
    known = isinstance(exc, lpv.SynthesisError)  # InfeasibleError or CertificationError
    out = {"class": cls, "kind": kind, "proof": proof, "message": str(exc)[:400]}
    if not known:
        out["verdict"] = "uncaught exception"
    elif probe is not None and probe.found:
        out["verdict"] = "false refusal"
    elif proof:
        out["verdict"] = "true refusal (proved)"
    else:
        out["verdict"] = "unresolved"
    # truth of the statement
    false_statement = None
    if known and kind == "not stabilizable":
        m = re.search(r"vertex (\d+)", str(exc))
        j = int(m.group(1)) if m else None
        if j is not None and j < case.N:
            truth = vertex_unstabilizable(case, j)
            if truth is False or (probe is not None and probe.found):
                false_statement = f"says vertex {j} not stabilizable; it is"
        elif probe is not None and probe.found:
            false_statement = "says not stabilizable; a verified design exists"
    if known and kind == "infeasible" and probe is not None and probe.found:
        false_statement = "says infeasible; a verified design exists"
    if known and type(exc) is lpv.InfeasibleError and kind not in ("not stabilizable",):
        if probe is not None and probe.found:
            false_statement = false_statement or "InfeasibleError on a feasible problem"
    out["false_statement"] = false_statement
    return out


# ======================================================================
# Running one case
# ======================================================================
class LibraryTimeout(Exception):
    """The library call ran past the time cap (recorded, not a refusal)."""


class _time_cap:
    """SIGALRM-based cap (POSIX, main thread); checked between solver calls."""

    def __init__(self, seconds):
        self.seconds = seconds

    def __enter__(self):
        import signal

        if not self.seconds or not hasattr(signal, "SIGALRM"):
            self.old = None
            return self

        def handler(signum, frame):
            raise LibraryTimeout(f"library call ran past {self.seconds:g} s")

        self.old = signal.signal(signal.SIGALRM, handler)
        signal.setitimer(signal.ITIMER_REAL, self.seconds)
        return self

    def __exit__(self, *exc):
        import signal

        if self.old is not None:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, self.old)
        return False


def run_case(case: Case, lpv, probe_budget=120.0, verbose=False, time_cap=None) -> dict:
    """Call the library on `case`, check what it says, probe refusals."""
    rec = {"case": case.label(), "function": case.function, "N": case.N, "n": case.n,
           "m": case.m, "tags": list(case.tags),
           "describe": case.describe()}  # fmt: skip
    t0 = time.perf_counter()
    design, exc = None, None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with _time_cap(time_cap):
                design = case.call(lpv)
        except LibraryTimeout as e:
            rec.update(
                outcome="timeout", seconds=time.perf_counter() - t0, message=str(e)
            )
            return rec
        except Exception as e:  # noqa: BLE001 - classified below
            exc = e
    rec["seconds"] = time.perf_counter() - t0
    rec["warnings"] = sorted({type(w.message).__name__ for w in caught})
    if design is not None:
        gamma = getattr(design, "gamma", None)
        chk = check_design(case, design.gains, design.P, gamma)
        rec.update(
            outcome="design",
            check_ok=chk.ok,
            check_verified=chk.verified,
            hard=chk.hard,
            soft=chk.soft,
            gamma=gamma,
            gamma_opt=getattr(design, "gamma_opt", None),
            max_gain=chk.info.get("max_gain"),
            P_convention=chk.info.get("P_convention"),
        )
        if proved_infeasible(case):
            rec["design_on_proved_infeasible"] = True
        if verbose:
            print(f"  design: gamma={gamma} gamma_opt={rec['gamma_opt']} check: {chk}")
        return rec
    rec["outcome"] = "refusal"
    rec["exception"] = type(exc).__name__
    probe = probe_case(case, probe_budget, verbose=verbose)
    cls = classify_refusal(case, exc, probe, lpv)
    rec.update(cls)
    rec["probe_found"] = bool(probe and probe.found)
    rec["probe_method"] = probe.method if probe else ""
    rec["probe_seconds"] = probe.seconds if probe else 0.0
    if probe and probe.found and probe.gamma is not None:
        rec["probe_gamma"] = probe.gamma
    if verbose:
        print(f"  refusal {type(exc).__name__}: {str(exc)[:600]}")
        print(f"  verdict: {cls['verdict']}; false statement: {cls['false_statement']}")
        if probe and probe.found:
            print(f"  probe design: {probe.method} gamma={probe.gamma} {probe.check}")
    return rec


# ======================================================================
# H-infinity state feedback by the Riccati equation (ZDG, ch. 16/17)
# ======================================================================
def _loop_shift(A, B1, B2, C1, D12):
    """Standard transformation to ``D12' D12 = I``, ``D12' C1 = 0``."""
    R = D12.T @ D12
    ev, U = np.linalg.eigh(R)
    if ev.min() <= 1e-12 * max(ev.max(), 1e-300):
        raise RuntimeError("D12 must have full column rank")
    Rih = U @ np.diag(ev**-0.5) @ U.T
    F0 = np.linalg.solve(R, D12.T @ C1)  # u = -F0 x + Rih v
    At = A - B2 @ F0
    B2t = B2 @ Rih
    C1t = C1 - D12 @ F0
    return At, B2t, C1t, F0, Rih


def hinf_riccati_at(A, B1, B2, C1, D12, gamma, eps=0.0):
    """Stabilizing ``X >= 0`` of the H-infinity Riccati equation at `gamma`.

    ``A'X + XA + X (B1 B1'/gamma^2 - B2 B2') X + C1'C1 = 0`` (after the
    loop-shifting of a general `D12`), or None when it has none. Returns
    ``(X, K)`` with ``u = -K x`` achieving ``||T_zw|| < gamma``. With
    ``eps > 0`` the equation has ``C1'C1 + eps I``: then ``X`` satisfies the
    bounded-real inequality of the closed loop strictly (storage form,
    ``P = X / gamma^2`` in the form of `brl_lmi`).
    """
    At, B2t, C1t, F0, Rih = _loop_shift(A, B1, B2, C1, D12)
    n = A.shape[0]
    Q = C1t.T @ C1t + eps * np.eye(n)  # eps > 0: a strict storage inequality
    H = np.block([[At, B1 @ B1.T / gamma**2 - B2t @ B2t.T], [-Q, -At.T]])
    ev = np.linalg.eigvals(H)
    hn = max(np.linalg.norm(H, 1), 1e-300)
    if np.any(np.abs(ev.real) < 1e-9 * hn):
        return None
    Tm, U, sdim = sla.schur(H, sort="lhp")
    if sdim != n:
        return None
    U11, U21 = U[:n, :n], U[n:, :n]
    if np.linalg.cond(U11) > 1e12:
        return None
    X = np.linalg.solve(U11.T, U21.T).T
    X = 0.5 * (X + X.T)
    if np.linalg.eigvalsh(X).min() < -1e-9 * max(np.abs(X).max(), 1e-300):
        return None
    K = F0 + Rih @ B2t.T @ X
    return X, K


def hinf_riccati(A, B1, B2, C1, D12, rtol=1e-7):
    """Infimum of the achievable gamma by bisection on `hinf_riccati_at`.

    Returns ``(gamma_opt, X, K)`` for the upper end of the final bracket.
    """
    At, B2t, C1t, _, _ = _loop_shift(A, B1, B2, C1, D12)
    n = A.shape[0]
    try:
        X = sla.solve_continuous_are(
            At, B2t, C1t.T @ C1t + 1e-9 * np.eye(n), np.eye(B2t.shape[1])
        )
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise RuntimeError(f"no stabilizing LQR gain: {exc}") from None
    hi = 1.0
    for _ in range(200):
        if hinf_riccati_at(A, B1, B2, C1, D12, hi) is not None:
            break
        hi *= 2.0
    else:
        raise RuntimeError("no feasible gamma found")
    lo = hi / 2.0
    for _ in range(200):
        if hinf_riccati_at(A, B1, B2, C1, D12, lo) is None:
            break
        hi, lo = lo, lo / 2.0
        if lo < 1e-12:
            return hi, *hinf_riccati_at(A, B1, B2, C1, D12, hi)
    while hi / lo - 1 > rtol:
        mid = np.sqrt(hi * lo)
        if hinf_riccati_at(A, B1, B2, C1, D12, mid) is not None:
            hi = mid
        else:
            lo = mid
    X, K = hinf_riccati_at(A, B1, B2, C1, D12, hi)
    return hi, X, K


def random_lti_hinf(rng, n=None, m=None, nw=None, general_d12=None):
    """A random LTI H-infinity state-feedback problem meeting ZDG's assumptions.

    ``z = [C x; E x + F u]`` with ``F`` square invertible (full column rank
    ``D12``, cross term when `general_d12`), ``D11 = 0``; `(A, B2)`
    stabilizable (random B2); returns ``(A, B1, B2, C1, D12)``.
    """
    n = int(rng.integers(1, 7)) if n is None else n
    m = int(rng.integers(1, 3)) if m is None else m
    nw = int(rng.integers(1, 3)) if nw is None else nw
    general_d12 = rng.random() < 0.5 if general_d12 is None else general_d12
    A = rng.standard_normal((n, n)) * rng.uniform(0.3, 1.5)
    B1 = rng.standard_normal((n, nw))
    B2 = rng.standard_normal((n, m))
    p = int(rng.integers(1, n + 1))
    C = rng.standard_normal((p, n))
    if general_d12:
        E = 0.5 * rng.standard_normal((m, n))
        F = np.diag(10.0 ** rng.uniform(-1, 0.5, m)) @ _orth(rng, m)
    else:
        E = np.zeros((m, n))
        F = 10.0 ** rng.uniform(-1, 0.5) * np.eye(m)
    C1 = np.vstack([C, E])
    D12 = np.vstack([np.zeros((p, m)), F])
    return A, B1, B2, C1, D12
