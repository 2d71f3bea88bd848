"""Controller matrices from the LMI variables, by a stable factorization.

``M N' = I - X Y`` is factored by the SVD ``I - X Y = U S V'``, ``M = U
S^1/2``, ``N = V S^1/2``: both factors have the same condition number,
``sqrt(cond(I - X Y))`` (the smallest possible for the product), and their
inverses are explicit (``S^-1/2 U'``), so no triangular solve can amplify
the rounding of a nearly singular ``I - X Y`` into one factor. The
conditioning of ``I - X Y`` itself is the design's business: the back-off
stage keeps ``[[X, I], [I, Y]]`` away from singular (`ctrl_lpv.output_feedback.stages`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["factor", "controller_matrices", "closed_loop_lyapunov", "closed_loop"]


def factor(X, Y):
    """``(M, N, M^-1, N^-1)`` with ``M N' = I - X Y``."""
    U, s, Vt = np.linalg.svd(np.eye(X.shape[0]) - X @ Y)
    if s[-1] <= 0 or not np.isfinite(s).all():
        raise np.linalg.LinAlgError("I - X Y is singular")
    root = np.sqrt(s)
    return U * root, Vt.T * root, (U / root).T, (Vt.T / root).T


def controller_matrices(plant, j, X, Y, hats, factors):
    """``(Ak, Bk, Ck, Dk)`` of vertex `j`: ``u = Ck xk + Dk y``."""
    Ah, Bh, Ch, Dh = hats
    M, N, Mi, Ni = factors
    B2, C2 = plant.B2, plant.C2
    Dk = Dh
    Ck = (Ch - Dk @ C2 @ X) @ Mi.T
    Bk = Ni @ (Bh - Y @ B2 @ Dk)
    inner = Ah - N @ Bk @ C2 @ X - Y @ B2 @ Ck @ M.T
    inner = inner - Y @ (plant.A[j] + B2 @ Dk @ C2) @ X
    Ak = Ni @ inner @ Mi.T
    return Ak, Bk, Ck, Dk


def closed_loop_lyapunov(X, Y, factors):
    """``P`` with ``P Pi1 = Pi2`` (module `ctrl_lpv.output_feedback.lmis`)."""
    M, N, Mi, _ = factors
    P = np.block([[Y, N], [N.T, -N.T @ X @ Mi.T]])
    return (P + P.T) / 2


def closed_loop(plant, data, K):
    """Closed-loop ``(Acl, Bcl, Ccl, Dcl)`` from w to z.

    `data` is ``(A, B1, C1, D11)`` of the plant and `K` ``(Ak, Bk, Ck, Dk)``
    of the controller, at the same vertex or point.
    """
    Ak, Bk, Ck, Dk = K
    A, B1, C1, D11 = data
    B2, C2, D12, D21 = plant.B2, plant.C2, plant.D12, plant.D21
    Acl = np.block([[A + B2 @ Dk @ C2, B2 @ Ck], [Bk @ C2, Ak]])
    Bcl = np.vstack([B1 + B2 @ Dk @ D21, Bk @ D21])
    Ccl = np.hstack([C1 + D12 @ Dk @ C2, D12 @ Ck])
    Dcl = D11 + D12 @ Dk @ D21
    return Acl, Bcl, Ccl, Dcl
