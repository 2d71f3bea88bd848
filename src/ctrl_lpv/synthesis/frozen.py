"""Checks of a point of the general engine on frozen closed loops, in model units.

At the vertices, random parameter points and the centre, and at every
vertex of the rate box: closed-loop eigenvalues (Hurwitz or Schur), and
each spec's statements written with the returned Lyapunov matrix and gains
in the model's units (``spec.residual`` of a `FrozenLoop`). These are
recomputed from the model's data, independently of the relaxation whose
coefficients `ctrl_lpv.lmi.LMIProblem` checks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..certificate import Check, rounding_bound
from .parametric import step_terms
from .results import (
    CLOSED_LOOP,
    DESIGN_STATEMENT,
    EIGENVALUES,
    LYAPUNOV,
    DesignCertificate,
    residual_check,
)
from .specs import Stability

_VERIFY_SAMPLES = 64


def _points(job):
    """Convex coordinates (and box points) of the verification points."""
    return verification_points(job.sys)


def verification_points(sys):
    """``(delta, p)`` pairs: the vertices, seeded samples and the centre.

    ``p`` is the box point (None on a simplex or polytope domain, whose
    points are given by their convex coordinates ``delta``).
    """
    N = sys.nvertices
    rng = np.random.default_rng(12345)
    domain = sys.domain
    if hasattr(domain, "lower") and N > 1:
        points = list(domain.points)
        points += list(
            rng.uniform(
                domain.lower, domain.upper, size=(_VERIFY_SAMPLES, domain.nparams)
            )
        )
        points.append(0.5 * (domain.lower + domain.upper))
        return [(domain._weights(np.asarray(p, float)), np.asarray(p, float))
                for p in points]  # fmt: skip
    deltas = list(np.eye(N))
    if N > 1:
        deltas += list(rng.dirichlet(np.ones(N), size=_VERIFY_SAMPLES))
    return [(d, None) for d in deltas]


def _moved(job, Ws, delta, p, rate):
    """``dW/dt`` (continuous) or ``W`` at the next sample, model units."""
    lyap, sc = job.lyap, job.scaling
    N = len(delta)
    if job.continuous:
        dW = np.zeros_like(Ws[0])
        for j in range(N):
            for w, f in step_terms(lyap, j, rate, True):
                dW = dW + delta[j] * f * Ws[w]
        return sc.unscale_W(dW)
    nxt = delta
    if p is not None and not lyap.constant:
        domain = job.sys.domain
        nxt = domain._weights(np.clip(p + rate, domain.lower, domain.upper))
    return sc.unscale_W(
        np.tensordot(nxt, np.stack([Ws[lyap.index[j]] for j in range(N)]), axes=1)
    )


@dataclass(frozen=True)
class FrozenLoop:
    """A frozen closed loop in the model's units, as the specs' residuals
    read it.

    ``Acl = A - B2 K``; ``P`` and ``W = P^-1`` the Lyapunov matrix at this
    point, ``P_moved`` and ``W_moved`` their derivatives along the rate
    (continuous time) or their values at the next sample (discrete time).
    A performance spec's channel: ``Bw``, ``Cz`` (closed loop, ``Cz - Dzu
    K``), ``Dzw`` and its certified ``bound``; a `Saturation` spec's
    auxiliary gain ``G`` and sector multiplier ``T``. With a `Peak` spec:
    its disturbance input ``Bd``, decay ``lam`` and weights ``mu_w = mu /
    w_max^2`` (model units), which a `Saturation` sector also reads.
    """

    A: np.ndarray
    B2: np.ndarray
    K: np.ndarray
    Acl: np.ndarray
    eig: np.ndarray
    P: np.ndarray
    P_moved: np.ndarray
    W: np.ndarray
    W_moved: np.ndarray
    Bw: np.ndarray | None = None
    Cz: np.ndarray | None = None
    Dzw: np.ndarray | None = None
    bound: float | None = None
    G: np.ndarray | None = None
    T: np.ndarray | None = None
    Bd: np.ndarray | None = None
    lam: float | None = None
    mu_w: np.ndarray | None = None


def verify_frozen(job, sol, gains, values, Ws, Zs):
    """Frozen closed loops in the model's units at vertices and samples.

    Returns the `DesignCertificate` and, with a `Saturation` spec, the
    largest ``x0' P x0`` over its points (None without one).
    """
    sc, lyap = job.scaling, job.lyap
    # Worst (value, where) of each cross-check, by name.
    worst = {}

    def record(what, value, where, rounding=0.0):
        if what not in worst or value - rounding > worst[what][0] - worst[what][2]:
            worst[what] = (float(value), where, rounding)

    saturation = job.saturation
    if saturation is not None:
        Zgs, T_sector = saturation.unscale(sol, sc, len(Zs))
    level = None
    peak = job.peak
    if peak is not None:
        ip = job.index[peak]
        nw = job.original[0][(ip, "Bw")].shape[1]
        # mu = a mu~, lambda = a lambda~ (a = 1 in discrete time).
        disturbance = {
            "lam": job.lam * sc.a,
            "mu_w": sc.a * np.asarray(sol.mu, float).ravel() * peak.weights(nw),
        }
    npoints = 0
    for delta, p in _points(job):
        where = _where(job.sys, delta, p)

        def mix(items, delta=delta):
            return np.tensordot(delta, np.stack(items), axes=1)

        A = mix([v["A"] for v in job.original])
        B2 = mix([v["B2"] for v in job.original])
        W_here = mix([Ws[lyap.index[j]] for j in range(len(delta))])
        if not Zs:
            K = np.zeros((0, A.shape[0]))
        elif job.scheduled and not lyap.constant:
            K = sc.unscale_K(-mix(Zs) @ np.linalg.inv(W_here))
        elif job.scheduled:
            K = mix(gains)
        else:
            K = gains[0]
        Acl = A - B2 @ K
        eig = np.linalg.eigvals(Acl)
        # ROUNDING n eps ||Acl|| marks the level below which the sign of a
        # (non-normal) matrix's eigenvalue means nothing.
        record(EIGENVALUES, eig.real.max() if job.continuous
               else np.abs(eig).max() - 1, where,
               rounding_bound(len(Acl), np.linalg.norm(Acl, 2)))  # fmt: skip
        sector = {}
        if peak is not None:
            Bd = mix([v[(ip, "Bw")] for v in job.original])
            sector = {"Bd": Bd, **disturbance}
        if saturation is not None:
            Zg = mix(Zgs) if job.scheduled else Zgs[0]
            sector |= {"G": sc.unscale_K(Zg @ np.linalg.inv(W_here)), "T": T_sector}
        P = sc.unscale_P(np.linalg.inv(W_here))
        W = sc.unscale_W(W_here)
        for rate in lyap.rates:
            W_moved = _moved(job, Ws, delta, p, rate)
            if job.continuous:
                # d(W^-1)/dt = -W^-1 (dW/dt) W^-1.
                P_moved = -P @ W_moved @ P
            else:
                P_moved = _sym_inv(W_moved) if not lyap.constant else P
            npoints += 1
            loop = FrozenLoop(A, B2, K, Acl, eig, P, P_moved, W, W_moved, **sector)
            for i, (spec, bound) in enumerate(zip(job.specs, values)):
                channel = loop
                if not isinstance(spec, Stability):
                    Bw, Cz, Dzu, Dzw = (
                        mix([v[(i, key)] for v in job.original])
                        for key in ("Bw", "Cz", "Dzu", "Dzw")
                    )
                    channel = replace(
                        loop, Bw=Bw, Cz=Cz - Dzu @ K, Dzw=Dzw, bound=bound
                    )
                record(str(spec), spec.residual(channel, job.continuous), where)
            record(LYAPUNOV, Stability().residual(loop, job.continuous), where)
            for spec in job.constraints:
                record(str(spec), spec.residual(loop, job.continuous), where)
        if saturation is not None and saturation.points:
            level = max(level or 0.0, saturation.level(P))
    eig_value, eig_where, eig_rounding = worst.pop(EIGENVALUES)
    units = "real part" if job.continuous else "modulus - 1"
    checks = (
        *(Check.from_lmi_check(c) for c in sol.checks),
        Check(EIGENVALUES, eig_value, 0.0, True, eig_rounding, True, units,
              eig_where, CLOSED_LOOP),
        *(residual_check(what, value, where, cross_check=True)
          for what, (value, where, _) in worst.items()),
    )  # fmt: skip
    certificate = DesignCertificate(checks, DESIGN_STATEMENT, job.lmi.margin, npoints)
    return certificate, level


def _where(sys, delta, p) -> str:
    """The label of a verification point: its parameter values (box) or
    convex coordinates."""
    if p is not None:
        return ", ".join(f"{n} = {v:.6g}" for n, v in zip(sys.domain.names, p))
    return "delta = [" + ", ".join(f"{d:.4g}" for d in delta) + "]"


def _sym_inv(W):
    """``W^-1``, symmetrised (see `ctrl_lpv.synthesis.scaling.Scaling.unscale_P`)."""
    P = np.linalg.inv(W)
    return 0.5 * (P + P.T)
