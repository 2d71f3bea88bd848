"""Checks of a point on frozen closed loops, in the model's units.

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
from .terms import names

_VERIFY_SAMPLES = 64


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


class Here:
    """A frozen point as a spec's `loop_fields` reads it.

    Attributes: ``frame`` (the rung's prescaling), ``W_scaled`` (``W`` here
    in prescaled units), ``nw`` (the spec's channel width); `mix` (the
    channel's data here, model units), `var` (the spec's own values) and
    `gain_like` (a spec's gain-like variable here, prescaled).
    """

    def __init__(self, problem, frame, values, delta, W_scaled, q):
        self.frame = frame
        self.W_scaled = W_scaled
        self._problem, self._values, self._delta, self._q = problem, values, delta, q
        i = problem.channels[q]
        self._channel = None if i is None else problem.plant.channels[i]
        self.nw = 0 if self._channel is None else self._channel.nw

    def mix(self, key):
        return np.tensordot(self._delta, getattr(self._channel, key), axes=1)

    def var(self, name):
        return self._values[names.local(self._q, name)]

    def gain_like(self, name):
        count = self._problem.ngains
        items = [self.var(f"{name}{k}") for k in range(count)]
        if self._problem.scheduled:
            return np.tensordot(self._delta, np.stack(items), axes=1)
        return items[0]


def _moved_all(problem, lyap, Ws, deltas, points, rate):
    """``dW/dt`` (continuous) or ``W`` at the next sample at every point,
    prescaled units (`rate` prescaled, a point's ``p`` the model's
    parameter)."""
    N = deltas.shape[1]
    if problem.continuous:
        # The weight of each W_w at a vertex, then at every point one
        # product: dW/dt = sum_w (sum_j delta_j f_jw) W_w.
        S = np.zeros((N, len(Ws)))
        for j in range(N):
            for w, f in step_terms(lyap, j, rate, True):
                S[j, w] += f
        return np.tensordot(deltas @ S, np.asarray(Ws), axes=1)
    nxt = deltas
    if not lyap.constant and points[0][1] is not None:
        domain = problem.plant.system.domain
        nxt = np.array([domain._weights(np.clip(p + rate, domain.lower, domain.upper))
                        for _, p in points])  # fmt: skip
    return np.tensordot(nxt, np.stack([Ws[lyap.index[j]] for j in range(N)]), axes=1)


def _dual_lyapunov_all(Acl, W, W_moved, continuous) -> np.ndarray:
    """``lambda_max(A W + W A' - dW/dt)`` (``A W A' - W+``) over ``||W||``
    at every point (stacks).

    In the prescaled units, where ``W`` is the solver's: the margin of the
    LMIs shows here, where the primal form with an ill-conditioned ``P``
    (`lyapunov_residual`) may round it away.
    """
    AW = Acl @ W
    if continuous:
        M = AW + np.swapaxes(AW, 1, 2) - W_moved
    else:
        M = AW @ np.swapaxes(Acl, 1, 2) - W_moved
    M = 0.5 * (M + np.swapaxes(M, 1, 2))
    return np.linalg.eigvalsh(M)[:, -1] / np.linalg.norm(W, 2, axis=(1, 2))


def _unscale_P(sc, Pt):
    """`~ctrl_lpv.synthesis.scaling.Scaling.unscale_P` of a stack."""
    if sc.T.ndim == 1:
        P = Pt / (sc.w_factor * sc.T[:, None] * sc.T)
    else:
        Ti = np.linalg.inv(sc.T)
        P = Ti.T @ Pt @ Ti / sc.w_factor
    return 0.5 * (P + np.swapaxes(P, -1, -2))


def verify_frozen(problem, shape, frame, values, gains, bounds, margin, checks,
                  final=True):  # fmt: skip
    """Frozen closed loops in the model's units at vertices and samples.

    Parameters
    ----------
    problem : `~ctrl_lpv.synthesis.problem.Problem`
    shape : `~ctrl_lpv.synthesis.terms.Shape`
        Its structure in the rung's frame (the prescaled rates).
    frame : `~ctrl_lpv.synthesis.scaling.Frame`
    values : dict
        The point's variables and the searched parameters (prescaled).
    gains : tuple of ndarray
        The gains in the model's units.
    bounds : tuple of float
        The certified bound of each channel spec.
    margin : float
        The margin the LMIs were posed with.
    checks : tuple of `ctrl_lpv.certificate.Check`
        The point's LMI checks.
    final : bool, optional
        Whether to check a spec's gain bound too (the last stage's point).

    Returns
    -------
    `DesignCertificate`, dict
        The certificate, and the largest value each spec reports over the
        points (`~ctrl_lpv.synthesis.spec.Spec.reported`).
    """
    sc, lyap = frame.scaling, problem.lyap
    Ti = np.linalg.inv(sc.matrix)
    plant = problem.plant
    # Worst (value, where, rounding) of each cross-check, by name.
    worst = {}

    def record(what, value, where, rounding=0.0):
        if what not in worst or value - rounding > worst[what][0] - worst[what][2]:
            worst[what] = (float(value), where, rounding)

    Ws = [values[f"W{e}"] for e in range(lyap.count)]
    Zs = [values[f"Z{k}"] for k in range(problem.nZ)]
    reported = {}
    npoints = 0
    # The loops of every point at once (one product per datum, stacked
    # eigenvalues and norms); the specs' residuals point by point below.
    points = verification_points(plant.system)
    deltas = np.array([delta for delta, _ in points])

    def mix_all(items):
        return np.tensordot(deltas, np.asarray(items), axes=1)

    A_all, B2_all = mix_all(plant.A), mix_all(plant.B2)
    W_all = mix_all([Ws[lyap.index[j]] for j in range(deltas.shape[1])])
    n = A_all.shape[1]
    if problem.fixed is not None:
        K_all = mix_all(gains) if problem.scheduled else np.broadcast_to(
            gains[0], (len(points), *gains[0].shape))  # fmt: skip
    elif not Zs:
        K_all = np.zeros((len(points), 0, n))
    elif problem.scheduled and not lyap.constant:
        Y_all = -mix_all(Zs) @ np.linalg.inv(W_all)
        K_all = np.array([sc.unscale_K(Y) for Y in Y_all])
    elif problem.scheduled:
        K_all = mix_all(gains)
    else:
        K_all = np.broadcast_to(gains[0], (len(points), *gains[0].shape))
    Acl_all = A_all - B2_all @ K_all
    eig_all = np.linalg.eigvals(Acl_all)
    # ROUNDING n eps ||Acl|| marks the level below which the sign of a
    # (non-normal) matrix's eigenvalue means nothing.
    eig_value = (eig_all.real.max(axis=1) if problem.continuous
                 else np.abs(eig_all).max(axis=1) - 1)  # fmt: skip
    eig_rounding = rounding_bound(n, 1.0) * np.linalg.norm(Acl_all, 2, axis=(1, 2))
    labels = [str(spec) for spec in problem.specs]
    # Each channel's (Bw, Cz - Dzu K, Dzw) at every point.
    channels = {i: (mix_all(c.Bw), mix_all(c.Cz) - mix_all(c.Dzu) @ K_all,
                    mix_all(c.Dzw))
                for i, c in enumerate(plant.channels)}  # fmt: skip
    # What does not depend on the specs, stacked over the points: P and W
    # in the model's units, and per rate the moved W and P and the dual
    # Lyapunov residual.
    P_all = _unscale_P(sc, np.linalg.inv(W_all))
    W_model_all = sc.w_factor * (sc.matrix @ W_all @ sc.matrix.T)
    Acl_scaled_all = Ti @ Acl_all @ sc.matrix / sc.a
    moved = []
    for rate in shape.lyap.rates:
        W_moved_scaled = _moved_all(problem, shape.lyap, Ws, deltas, points, rate)
        W_moved = sc.w_factor * (sc.matrix @ W_moved_scaled @ sc.matrix.T)
        if problem.continuous:
            # d(W^-1)/dt = -W^-1 (dW/dt) W^-1.
            P_moved = -P_all @ W_moved @ P_all
        else:
            P_moved = _sym_inv(W_moved) if not lyap.constant else P_all
        dual = _dual_lyapunov_all(Acl_scaled_all, W_all, W_moved_scaled,
                                  problem.continuous)  # fmt: skip
        moved.append((W_moved, P_moved, dual))
    # The loops each spec judges, in order, its residuals asked for at once
    # (`~ctrl_lpv.synthesis.spec.Spec.residuals`); the records made after,
    # in the order of the points.
    judged = {q: [] for q in range(len(problem.specs))}
    order = []
    for index, (delta, p) in enumerate(points):
        where = _Where(plant.system, delta, p)

        A, B2, W_here, K = A_all[index], B2_all[index], W_all[index], K_all[index]
        Acl, eig = Acl_all[index], eig_all[index]
        order.append((EIGENVALUES, eig_value[index], where, eig_rounding[index]))
        fields = {}
        for q, spec in enumerate(problem.specs):
            here = Here(problem, frame, values, delta, W_here, q)
            fields |= spec.loop_fields(here)
        P, W = P_all[index], W_model_all[index]
        for W_moved, P_moved, dual in moved:
            npoints += 1
            loop = FrozenLoop(A, B2, K, Acl, eig, P, P_moved[index], W,
                              W_moved[index], **fields)  # fmt: skip
            for q, (spec, i) in enumerate(zip(problem.specs, problem.channels)):
                if spec.gain_limit is not None and not final:
                    continue
                channel = loop
                if i is not None:
                    Bw, Cz, Dzw = (data[index] for data in channels[i])
                    channel = replace(loop, Bw=Bw, Cz=Cz, Dzw=Dzw, bound=bounds[i])
                order.append((q, len(judged[q]), where, 0.0))
                judged[q].append(channel)
            order.append((LYAPUNOV, dual[index], where, 0.0))
        for q, spec in enumerate(problem.specs):
            value = spec.reported(P)
            if value is not None:
                reported[q] = max(reported.get(q, value), value)
    residuals = {q: problem.specs[q].residuals(loops, problem.continuous)
                 for q, loops in judged.items() if loops}  # fmt: skip
    for what, value, where, rounding in order:
        if isinstance(what, int):
            what, value = labels[what], residuals[what][value]
        record(what, value, where, rounding)
    eig_value, eig_where, eig_rounding = worst.pop(EIGENVALUES)
    units = "real part" if problem.continuous else "modulus - 1"
    checks = (
        *(Check.from_lmi_check(c) for c in checks),
        Check(EIGENVALUES, eig_value, 0.0, True, eig_rounding, True, units,
              str(eig_where), CLOSED_LOOP),
        *(residual_check(what, value, str(where), cross_check=True)
          for what, (value, where, _) in worst.items()),
    )  # fmt: skip
    return DesignCertificate(checks, DESIGN_STATEMENT, margin, npoints), reported


class _Where:
    """The label of a verification point: its parameter values (box) or
    convex coordinates; written only for the points a check reports."""

    def __init__(self, sys, delta, p):
        self._sys, self._delta, self._p = sys, delta, p

    def __str__(self) -> str:
        if self._p is not None:
            names = self._sys.domain.names
            return ", ".join(f"{n} = {v:.6g}" for n, v in zip(names, self._p))
        return "delta = [" + ", ".join(f"{d:.4g}" for d in self._delta) + "]"


def _where(sys, delta, p) -> str:
    """The label of a verification point (`_Where`, written)."""
    return str(_Where(sys, delta, p))


def _sym_inv(W):
    """``W^-1``, symmetrised (see `ctrl_lpv.synthesis.scaling.Scaling.unscale_P`),
    of a matrix or a stack."""
    P = np.linalg.inv(W)
    return 0.5 * (P + np.swapaxes(P, -1, -2))
