"""Optimal H-infinity output-feedback gamma by the DGKF Riccati conditions.

Doyle, Glover, Khargonekar and Francis (1989), "State-space solutions to
standard H2 and H-infinity control problems", IEEE TAC 34(8), Theorem 3:
for a plant normalised so that ``D11 = 0``, ``D22 = 0``, ``D12' [C1 D12] =
[0 I]`` and ``[B1; D21] D21' = [0; I]``, a controller with ``||T_zw|| <
gamma`` exists iff the two Hamiltonians

    H_X = [[A, B1 B1'/gamma^2 - B2 B2'], [-C1' C1, -A']],
    H_Y = [[A', C1' C1/gamma^2 - C2' C2], [-B1 B1', -A]]

have no imaginary-axis eigenvalues, their stabilizing solutions ``X, Y``
are positive semidefinite, and ``rho(X Y) < gamma^2``. Bisection on these
conditions gives the optimum independently of any LMI solver (and of
python-control's `hinfsyn`, whose returned gamma is not always achieved by
its controller).
"""

import numpy as np
from scipy.linalg import schur


def _stabilizing(H):
    """Stabilizing solution of the Riccati equation of Hamiltonian `H`."""
    n = H.shape[0] // 2
    eig = np.linalg.eigvals(H)
    if np.min(np.abs(eig.real)) < 1e-9 * max(1.0, np.abs(eig).max()):
        return None
    T, Z, sdim = schur(H, output="real", sort="lhp")
    if sdim != n:
        return None
    U1, U2 = Z[:n, :n], Z[n:, :n]
    if np.linalg.cond(U1) > 1e12:
        return None
    X = U2 @ np.linalg.inv(U1)
    return (X + X.T) / 2


def _feasible(A, B1, B2, C1, C2, gamma):
    g2 = gamma**2
    X = _stabilizing(np.block([[A, B1 @ B1.T / g2 - B2 @ B2.T], [-C1.T @ C1, -A.T]]))
    Y = _stabilizing(np.block([[A.T, C1.T @ C1 / g2 - C2.T @ C2], [-B1 @ B1.T, -A]]))
    if X is None or Y is None:
        return False
    tol = 1e-10 * max(1.0, np.abs(X).max(), np.abs(Y).max())
    if np.linalg.eigvalsh(X).min() < -tol or np.linalg.eigvalsh(Y).min() < -tol:
        return False
    return np.abs(np.linalg.eigvals(X @ Y)).max() < g2


def optimal_gamma(A, B1, B2, C1, C2, rtol=1e-9):
    """The optimal gamma of a normalised plant, by bisection."""
    hi = 1.0
    while not _feasible(A, B1, B2, C1, C2, hi):
        hi *= 2.0
        if hi > 1e8:
            raise ValueError("no stabilizing controller below gamma = 1e8")
    lo = hi / 2.0
    while _feasible(A, B1, B2, C1, C2, lo) and lo > 1e-8:
        hi, lo = lo, lo / 2.0
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if _feasible(A, B1, B2, C1, C2, mid):
            hi = mid
        else:
            lo = mid
    return hi
