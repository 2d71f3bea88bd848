"""Float64 re-check of a state-feedback design from its data alone.

When a design is read back from a file (`ctrl_lpv.load`, the two-mass gain
files) nothing of the solver is left: only the plant, the gains, the
Lyapunov matrix and the claimed bounds. At the points of
`~ctrl_lpv.synthesis.frozen.verification_points` (vertices, seeded samples,
centre) and at every vertex of the rate box, the frozen closed loop is
built in the model's units (a `~ctrl_lpv.synthesis.frozen.FrozenLoop`) and
checked with the specs' own residuals: the statements
`~ctrl_lpv.synthesis.frozen.verify_frozen` checks after a solve, with the
rounding level, but as proofs: nothing else is left to prove them, so a
value must lie below 0 by its rounding, not only within it. A mode within
rounding of the stability boundary (an uncontrollable eigenvalue at 0) is
not taken for a stable one. The result is a
`~ctrl_lpv.synthesis.results.DesignCertificate` without LMI checks.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._checks import signal_indices
from ..certificate import Check, negative_definite_stack, rounding_bound
from .frozen import FrozenLoop, _where, verification_points
from .parametric import lyapunov_structure, step_terms
from .results import (
    CLOSED_LOOP,
    EIGENVALUES,
    LYAPUNOV,
    ORIGINAL_UNITS_TOL,
    DesignCertificate,
    residual_check,
)
from .spec import lyapunov_residual


@dataclass(frozen=True)
class Recheck:
    """What `recheck` found.

    Attributes
    ----------
    certificate : `ctrl_lpv.synthesis.results.DesignCertificate`
        The recomputed certificate (``margin`` 0: no solver margin is
        involved; no LMI checks).
    failures : tuple of (str, str)
        ``(what, message)`` for every statement that failed: ``what`` is
        ``"gains"`` (closed loop not stable), ``"P"`` (a Lyapunov or bound
        inequality) or ``"regions"``; empty when the certificate holds.
    """

    certificate: DesignCertificate
    failures: tuple[tuple[str, str], ...]

    @property
    def verified(self) -> bool:
        """Whether every statement holds."""
        return self.certificate.verified and not self.failures


def recheck(design, performance=()) -> Recheck:
    """Re-check a `StateFeedbackDesign`'s certificate in float64.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        The design: its ``system``, ``u``, gains (`gain_at`), ``P`` (None:
        closed-loop eigenvalues only, never verified), ``lyapunov``,
        ``rate_bounds`` and ``regions`` are used, its ``certificate`` is
        not.
    performance : sequence of (spec, (iw, iz), value)
        `ctrl_lpv.Hinf` or `ctrl_lpv.H2` specs with their resolved input
        and output indices and the claimed bound.

    Returns
    -------
    `Recheck`
    """
    sys = design.system
    continuous = not sys.isdtime(strict=True)
    data = sys.vertex_data()
    iu = signal_indices(list(design.u), sys.physical_inputs, "u")
    failures: list[tuple[str, str]] = []
    lyap, Wd, checks = _lyapunov_data(design, sys, failures)
    points = verification_points(sys)
    worst = {"eig": (-np.inf, None, 0.0), "lyap": (-np.inf, None)}
    spec_worst = {i: (-np.inf, None) for i in range(len(performance))}
    region_worst = {i: (-np.inf, None) for i in range(len(design.regions))}
    npoints = 0
    for delta, p in points:
        where = _where(sys, delta, p)
        A, B, C, D = (np.tensordot(delta, np.stack(M), axes=1) for M in zip(*data))
        B2 = B[:, iu]
        K = design.gain_at(delta)
        Acl = A - B2 @ K
        eig = np.linalg.eigvals(Acl)
        stab = eig.real.max() if continuous else np.abs(eig).max() - 1.0
        # An eigenvalue within rounding of the boundary is not a proof of
        # stability (an uncontrollable mode at 0 computes as -3e-15).
        rounding = rounding_bound(len(eig), np.linalg.norm(Acl, 2))
        worst["eig"] = max(worst["eig"], (float(stab), where, rounding),
                           key=lambda item: item[0] + item[2])  # fmt: skip
        if Wd is None:
            npoints += 1
            continue
        P, W = _lyapunov_here(design, lyap, Wd, delta)
        for rate in lyap.rates:
            npoints += 1
            P_moved, W_moved = _moved(
                sys, lyap, Wd, delta, p, rate, P, W, continuous, design.primal
            )
            loop = FrozenLoop(A, B2, K, Acl, eig, P, P_moved, W, W_moved)
            value = lyapunov_residual(loop, continuous)
            worst["lyap"] = max(worst["lyap"], (value, where), key=_first)
            for i, (spec, (iw, iz), bound) in enumerate(performance):
                channel = replace(
                    loop,
                    Bw=B[:, iw],
                    Cz=C[iz] - D[np.ix_(iz, iu)] @ K,
                    Dzw=D[np.ix_(iz, iw)],
                    bound=bound,
                )
                value = spec.residual(channel, continuous)
                spec_worst[i] = max(spec_worst[i], (value, where), key=_first)
            for i, region in enumerate(design.regions):
                value = region.residual(loop, continuous)
                region_worst[i] = max(region_worst[i], (value, where), key=_first)
    eig_value, eig_where, eig_rounding = worst["eig"]
    units = "real part" if continuous else "modulus - 1"
    checks.append(Check(EIGENVALUES, eig_value, 0.0, True, eig_rounding,
                        units=units, where=eig_where, group=CLOSED_LOOP))  # fmt: skip
    if not checks[-1].passed:
        what = "real part" if continuous else "modulus minus 1"
        failures.append(
            ("gains", f"the closed loop is not stable at {eig_where} (largest "
                      f"eigenvalue {what} {eig_value:.4g}, rounding level "
                      f"{eig_rounding:.2g})")
        )  # fmt: skip
    if Wd is None:  # no (usable) P: nothing proves stability
        checks.append(Check(LYAPUNOV, np.inf, 0.0, True, where="no P",
                            group=CLOSED_LOOP))  # fmt: skip
    else:
        lyap_value, lyap_where = worst["lyap"]
        checks.append(residual_check(LYAPUNOV, lyap_value, lyap_where,
                                     cross_check=False))  # fmt: skip
        if not checks[-1].passed:
            failures.append(
                ("P", f"the Lyapunov inequality of P fails at {lyap_where} "
                      f"(largest normalised eigenvalue {lyap_value:.3g}, rounding "
                      f"level {ORIGINAL_UNITS_TOL:g})")
            )  # fmt: skip
    for i, (spec, _, bound) in enumerate(performance):
        value, where = spec_worst[i]
        name = spec.inequality
        checks.append(residual_check(f"{spec} <= {bound:.6g}", value, where,
                                     cross_check=False))  # fmt: skip
        if Wd is not None and not checks[-1].passed:
            failures.append(
                ("P", f"the {name} inequality of P and gamma = {bound:.6g} fails at "
                      f"{where} (largest normalised eigenvalue {value:.3g}, rounding "
                      f"level {ORIGINAL_UNITS_TOL:g})")
            )  # fmt: skip
    for i, region in enumerate(design.regions):
        value, where = region_worst[i]
        checks.append(residual_check(str(region), value, where, cross_check=False))
        if Wd is not None and not checks[-1].passed:
            failures.append(
                ("regions", f"the pole region {region} fails at {where} ({value:.3g})")
            )
    certificate = DesignCertificate(tuple(checks), _statement(design), 0.0, npoints)
    return Recheck(certificate, tuple(failures))


def _statement(design) -> str:
    if design.P is None:
        return ("the closed-loop eigenvalues at the vertices and sampled points "
                "only (no Lyapunov matrix): not a certificate")  # fmt: skip
    return (
        "recomputed from the design's data alone (gains, P, claimed bounds) in "
        "the model's units, at the vertices, sampled points and rate-box vertices"
    )


def _first(item):
    return item[0]


def _sym_inv(M):
    inv = np.linalg.inv(M)
    return 0.5 * (inv + inv.T)


def _lyapunov_data(design, sys, failures):
    """The Lyapunov structure, ``W_i`` per distinct index, and ``P > 0``."""
    if design.P is None:
        return None, None, []
    lyap = lyapunov_structure(
        sys,
        design.lyapunov,
        design.rate_bounds if design.lyapunov == "affine" else None,
    )
    Ps = [design.P] if design.lyapunov == "constant" else list(design.P)
    labels = ["P"] if len(Ps) == 1 else [f"P[{j}]" for j in range(len(Ps))]
    positive = negative_definite_stack(
        -np.stack(Ps), what="P > 0", where=labels, group=CLOSED_LOOP
    )
    checks = [positive]
    if not positive.passed:
        failures.append(("P", "is not positive definite"))
        return lyap, None, checks
    Wd = {}
    for j, P in enumerate(Ps):
        index = lyap.index[j]
        if index in Wd and not np.array_equal(P, Ps[lyap.index.index(index)]):
            failures.append(
                ("P", f"vertices {lyap.index.index(index)} and {j} share one "
                      "Lyapunov matrix (their parameter rates are unbounded) but "
                      "differ")
            )  # fmt: skip
            return lyap, None, checks
        # A primal design's P(p) is multi-affine: its vertex matrices are
        # kept as they are (`_lyapunov_here` and `_moved` read them so).
        Wd.setdefault(index, P if design.primal else _sym_inv(P))
    return lyap, Wd, checks


def _lyapunov_here(design, lyap, Wd, delta):
    if lyap.constant:
        return design.P, Wd[0]
    M = sum(d * Wd[lyap.index[j]] for j, d in enumerate(delta))
    return (M, _sym_inv(M)) if design.primal else (_sym_inv(M), M)


def _moved(sys, lyap, Wd, delta, p, rate, P, W, continuous, primal=False):
    """``(P_moved, W_moved)``: derivatives (continuous) or next-sample values.

    `Wd` holds the vertex values of ``W`` (of ``P`` when `primal`, in
    continuous time only).
    """
    if lyap.constant:
        return (np.zeros_like(P), np.zeros_like(W)) if continuous else (P, W)
    if continuous:
        dM = np.zeros_like(W)
        for j, d in enumerate(delta):
            for w, f in step_terms(lyap, j, rate, True):
                dM = dM + d * f * Wd[w]
        # d(M^-1)/dt = -M^-1 (dM/dt) M^-1.
        return (dM, -W @ dM @ W) if primal else (-P @ dM @ P, dM)
    domain = sys.domain
    nxt = domain._weights(np.clip(p + rate, domain.lower, domain.upper))
    W_next = sum(d * Wd[lyap.index[j]] for j, d in enumerate(nxt))
    return _sym_inv(W_next), W_next
