"""The float64 checks of a saved `SaturatedDesign`, recomputed on load.

`ctrl_lpv.load` re-checks a saturated design from its file alone: the
generalized sector inequality of `~ctrl_lpv.synthesis.constraints.Saturation`
at every vertex (a common gain) or vertex pair (vertex gains: ``M_jj`` and
``M_jk + M_kj``, the relaxation the engine poses), with the saved ``P``, the
gains ``K``, the auxiliary gains ``G``, the multiplier ``T`` and (with
disturbances) the multipliers ``mu``, in the model's units; the inclusions
of ``{x'Px <= 1}`` in the sector regions; ``mu >= 0`` and the level
``rho <= 1``. Continuous time in the primal form (``P``), discrete time in
the dual Schur form (``W = P^-1``, ``S = T^-1``), as the engine poses it.
"""

from __future__ import annotations

import itertools

import numpy as np

from ._invariant_checks import EllipsoidCheck, _positive_check, _strict_check

__all__ = ["sector_checks", "sector_statement"]


def sector_statement(has_w: bool, continuous: bool = True) -> str:
    """What the checks of `sector_checks` prove, in words."""
    change = (
        "d(x'Px)/dt <= -(2 sigma + lambda)(x'Px - rho)"
        if continuous
        else "V(x+) - V(x) <= -(1 - exp(-2 sigma dt) + lambda)(V(x) - rho)"
    )
    return (
        "for every delta(t) in the polytope"
        + (" and every |w_i(t)| <= w_max_i" if has_w else "")
        + ": on {x'Px <= 1} the saturated closed loop satisfies "
        + change
    )


def _pairs(N, scheduled):
    if not scheduled:
        return [(j, 0) for j in range(N)]
    return [(j, j) for j in range(N)] + list(itertools.combinations(range(N), 2))


def sector_checks(As, Bs, Es, wmax, U, P, W, Ks, Gs, Tm, mu, sigma, lam, dt=0.0):
    """The float64 checks of a saturated design in original units.

    `dt` the sampling period (0 for continuous time; ``sigma`` is in 1/s
    either way). Returns the checks and the ultimate level ``rho =
    sum(mu) / (2 sigma + lam)`` (continuous) or ``sum(mu) / (1 - exp(-2
    sigma dt) + lam)`` (discrete).
    """
    continuous = not dt
    has_w = len(Es) > 0
    m, nw, n = len(U), len(wmax), P.shape[0]
    rate = 2 * sigma if continuous else 1 - np.exp(-2 * sigma * dt)
    checks = [
        _positive_check("P > 0", P),
        EllipsoidCheck("T > 0", -float(np.min(np.diag(Tm))), 0.0),
    ]
    S = np.diag(1.0 / np.diag(Tm))

    def primal(j, k, ab=False):
        # ab=True: the same expression in absolute values (rounding bound).
        f = np.abs if ab else (lambda X: X)
        sg = 1.0 if ab else -1.0
        Pj, Bj, Kk, Gk = f(P), f(Bs[j]), f(Ks[k]), f(Gs[k])
        Acl = (f(As[j]) + Bj @ Kk) if ab else (As[j] - Bs[j] @ Ks[k])
        off = sg * (Pj @ Bj) + sg * (Gk.T @ Tm)
        top = [Acl.T @ Pj + Pj @ Acl + (rate + lam) * Pj, off]
        mid = [off.T, 2 * sg * Tm]
        if not has_w:
            return np.block([top, mid])
        PE = Pj @ f(Es[j] * wmax)
        return np.block([top + [PE], mid + [np.zeros((m, nw))],
                         [PE.T, np.zeros((nw, m)), sg * np.diag(mu)]])  # fmt: skip

    def dual(j, k, ab=False):
        # [[-(r - lam) W, *, *, *], [-Zg, -2S, *, *], [0, 0, -mu, *],
        #  [A W - B K W, -B S, E D, -W]] with r = exp(-2 sigma dt).
        f = np.abs if ab else (lambda X: X)
        sg = 1.0 if ab else -1.0
        Wf, Bj = f(W), f(Bs[j])
        AW = (f(As[j]) @ Wf + Bj @ f(Ks[k]) @ Wf) if ab else (
            As[j] @ W - Bs[j] @ Ks[k] @ W)  # fmt: skip
        Zg = f(Gs[k]) @ Wf
        Ed = f(Es[j] * wmax) if has_w else np.zeros((n, 0))
        z = np.zeros
        return np.block([
            [sg * abs(1 - rate - lam) * Wf if ab else -(1 - rate - lam) * W,
             sg * Zg.T, z((n, nw)), AW.T],
            [sg * Zg, 2 * sg * f(S), z((m, nw)), sg * (Bj @ f(S)).T],
            [z((nw, n)), z((nw, m)), sg * np.diag(f(mu)), Ed.T],
            [AW, sg * Bj @ f(S), Ed, sg * Wf],
        ])  # fmt: skip

    block = primal if continuous else dual
    scheduled = len(Ks) > 1
    for j, k in _pairs(len(As), scheduled):
        if not scheduled:
            name, M, Mab = f"sector vertex {j}", block(j, 0), block(j, 0, True)
        elif j == k:
            name, M, Mab = f"sector pair {j},{j}", block(j, j), block(j, j, True)
        else:
            name = f"sector pair {j},{k}"
            M = block(j, k) + block(k, j)
            Mab = block(j, k, True) + block(k, j, True)
        checks.append(_strict_check(name, M, Mab))
    for k in range(len(Ks)):
        D = Ks[k] - Gs[k]
        ratio = np.einsum("ij,jk,ik->i", D, W, D) / U**2
        for i in range(m):
            checks.append(
                EllipsoidCheck(f"inclusion gain {k} input {i}", float(ratio[i]), 1.0)
            )
    rho = 0.0
    if has_w:
        rho = float(mu.sum() / (rate + lam))
        checks.append(EllipsoidCheck("mu >= 0", -float(mu.min()), 0.0))
        checks.append(EllipsoidCheck("rho <= 1", rho, 1.0))
    return checks, rho
