"""Float64 re-check of a state-feedback design from its data alone.

When a design is read back from a file (`ctrl_lpv.load`, the two-mass gain
files) nothing of the solver is left: only the plant, the gains, the
Lyapunov matrix and the claimed bounds. At the points of
`~ctrl_lpv.synthesis.frozen.verification_points` (vertices, seeded samples,
centre) and at every vertex of the rate box, the frozen closed loop is
built in the model's units (a `~ctrl_lpv.synthesis.frozen.FrozenLoop`) and
checked with the specs' own residuals: the statements
`~ctrl_lpv.synthesis.frozen.verify_frozen` checks after a solve, with the
same acceptance (``ORIGINAL_UNITS_TOL`` after a Jacobi normalisation, a
rounding level). Stability is asked with a rounding margin: the recorded
``max_closed_loop_real`` and ``max_lyapunov_eig`` include it, so that a
mode within rounding of the boundary (an uncontrollable eigenvalue at 0)
is not taken for a stable one.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._checks import signal_indices
from ..lmi import LMICheck
from .frozen import FrozenLoop, verification_points
from .parametric import lyapunov_structure, step_terms
from .results import ORIGINAL_UNITS_TOL, Certificate
from .spec import lyapunov_residual

# A positive definite P needs lambda_min / lambda_max above rounding.
_PD_TOL = 4 * np.finfo(float).eps
# Rounding level per unit of size and norm: closed-loop eigenvalues must
# be below -_ROUNDING n ||A_cl|| (continuous; below 1 by as much in
# discrete time), the normalised Lyapunov inequality below -_ROUNDING n.
_ROUNDING = 16 * np.finfo(float).eps


@dataclass(frozen=True)
class Recheck:
    """What `recheck` found.

    Attributes
    ----------
    certificate : `ctrl_lpv.Certificate`
        The recomputed certificate (``margin`` 0: no solver margin is
        involved).
    failures : tuple of (str, str)
        ``(what, message)`` for every statement that failed: ``what`` is
        ``"gains"`` (closed loop not stable), ``"P"`` (a Lyapunov or bound
        inequality) or ``"regions"``; empty when the certificate holds.
    """

    certificate: Certificate
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
    worst = {"eig": (-np.inf, None), "lyap": (-np.inf, None)}
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
        stab += _ROUNDING * len(eig) * max(np.linalg.norm(Acl, 2), 1.0)
        worst["eig"] = max(worst["eig"], (float(stab), where), key=_first)
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
            value = lyapunov_residual(loop, continuous) + _ROUNDING * len(P)
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
    eig_value, eig_where = worst["eig"]
    if not eig_value < 0:
        what = "real part" if continuous else "modulus minus 1"
        failures.append(
            ("gains", f"the closed loop is not stable at {eig_where} (largest "
                      f"eigenvalue {what} {eig_value:.4g}, rounding level "
                      "included)")
        )  # fmt: skip
    lyap_value, lyap_where = worst["lyap"]
    if Wd is not None and not lyap_value < 0:
        failures.append(
            ("P", f"the Lyapunov inequality of P fails at {lyap_where} (largest "
                  f"normalised eigenvalue {lyap_value:.3g})")
        )  # fmt: skip
    others = []
    for i, (spec, _, bound) in enumerate(performance):
        value, where = spec_worst[i]
        name = spec.inequality
        checks.append(
            LMICheck(f"{spec} <= {bound:.6g}", value, ORIGINAL_UNITS_TOL, True)
        )
        others.append(value)
        if Wd is not None and not value < ORIGINAL_UNITS_TOL:
            failures.append(
                ("P", f"the {name} inequality of P and gamma = {bound:.6g} fails at "
                      f"{where} (largest normalised eigenvalue {value:.3g}, rounding "
                      f"level {ORIGINAL_UNITS_TOL:g})")
            )  # fmt: skip
    for i, region in enumerate(design.regions):
        value, where = region_worst[i]
        checks.append(LMICheck(str(region), value, ORIGINAL_UNITS_TOL, True))
        others.append(value)
        if Wd is not None and not value < ORIGINAL_UNITS_TOL:
            failures.append(
                ("regions", f"the pole region {region} fails at {where} ({value:.3g})")
            )
    checks.append(LMICheck("Lyapunov inequality", lyap_value, 0.0, True))
    certificate = Certificate(
        lmi_checks=tuple(checks),
        margin=0.0,
        max_closed_loop_real=float(eig_value),
        max_lyapunov_eig=float(lyap_value) if Wd is not None else np.inf,
        npoints=npoints,
        max_original_eig=float(max(others, default=lyap_value)),
    )
    return Recheck(certificate, tuple(failures))


def _first(item):
    return item[0]


def _where(sys, delta, p) -> str:
    if p is not None:
        return ", ".join(f"{n} = {v:.6g}" for n, v in zip(sys.domain.names, p))
    return "delta = [" + ", ".join(f"{d:.4g}" for d in delta) + "]"


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
    ratio = max(
        -np.linalg.eigvalsh(P)[0] / max(np.linalg.eigvalsh(P)[-1], 1e-300) for P in Ps
    )
    checks = [LMICheck("P > 0", float(ratio), -_PD_TOL, True)]
    if not ratio < -_PD_TOL:
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
