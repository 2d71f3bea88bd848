"""LMIs of output feedback: after the change of variables, and closed loop.

Scherer, Gahinet and Chilali (1997), "Multiobjective output-feedback control
via LMI optimization", IEEE TAC 42(7); Gahinet and Apkarian (1994) for the
LTI problem; Apkarian, Gahinet and Becker (1995), "Self-scheduled H-infinity
control of linear parameter-varying systems", Automatica 31(9), for the
polytope: one pair ``(X, Y)`` for every vertex and one set of controller
variables per vertex.

With the closed-loop Lyapunov matrix ``P`` partitioned so that ``P Pi1 =
Pi2``, ``Pi1 = [[X, I], [M', 0]]``, ``Pi2 = [[I, Y], [0, N']]`` and ``M N'
= I - X Y``, the congruence by ``Pi1`` turns each closed-loop inequality
into one affine in ``X, Y`` and

    Ah = N Ak M' + N Bk C2 X + Y B2 Ck M' + Y (A + B2 Dk C2) X,
    Bh = N Bk + Y B2 Dk,   Ch = Ck M' + Dk C2 X,   Dh = Dk,

and ``Xb = [[X, I], [I, Y]] = Pi1' P Pi1 > 0`` is ``P > 0``. The closed-loop
forms (``*_loop``) are the same inequalities before the congruence, checked
in float64 on the rebuilt controller (evaluated on absolute values, the
same forms of the absolute values bound their rounding. Block
lists follow the lower block triangle convention of `ctrl_lpv.lmi.assemble`.

With ``decay > 0`` the Lyapunov part is tightened by ``decay Xb``: the
closed loop's inequality then holds with ``-decay P`` in its state block (a
contraction by ``1 - decay`` in discrete time), a margin relative to ``P``
that survives the reconstruction whatever the scale of ``X`` and ``Y``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "lyapunov_pair",
    "transformed_loop",
    "bounded_real",
    "h2_gramian",
    "h2_output",
    "bounded_real_loop",
    "h2_gramian_loop",
    "h2_output_loop",
]


def lyapunov_pair(v):
    """``-Xb``: negative definite iff the closed-loop ``P > 0``."""
    n = v.X.shape[0]
    return [[-v.X], [-np.eye(n), -v.Y]]


def transformed_loop(plant, j, X, Y, Ah, Bh, Ch, Dh):
    """``Pi1' P Acl Pi1``, ``Pi1' P Bcl``, ``Ccl Pi1`` and ``Dcl`` at vertex `j`.

    Affine in the variables; also evaluated in float64 on a solution.
    """
    A, B1, C1, D11 = plant.A[j], plant.B1[j], plant.C1[j], plant.D11[j]
    B2, C2, D12, D21 = plant.B2, plant.C2, plant.D12, plant.D21
    AA = [[A @ X + B2 @ Ch, A + B2 @ Dh @ C2], [Ah, Y @ A + Bh @ C2]]
    BB = [B1 + B2 @ Dh @ D21, Y @ B1 + Bh @ D21]
    CC = [C1 @ X + D12 @ Ch, C1 + D12 @ Dh @ C2]
    DD = D11 + D12 @ Dh @ D21
    return AA, BB, CC, DD


def bounded_real(plant, j, v, hats, level, decay):
    """``||T_zw||_inf < level`` at vertex `j`, transformed: ``F < 0``.

    Continuous time ``[[He(AA) + decay Xb, BB, CC'], [BB', -g I, DD'], [CC,
    DD, -g I]]``; discrete time ``-[[Xb, 0, AA, BB], [0, g I, CC, DD], [AA',
    CC', (1 - decay) Xb, 0], [BB', DD', 0, g I]]``.
    """
    AA, (b1, b2), (c1, c2), d = transformed_loop(plant, j, v.X, v.Y, *hats)
    (a11, a12), (a21, a22) = AA
    n, nw, nz = plant.n, b1.shape[1], c1.shape[0]
    In, Iw, Iz = np.eye(n), np.eye(nw), np.eye(nz)
    if plant.continuous:
        return [
            [2 * a11 + decay * v.X],
            [a21 + a12.T + decay * In, 2 * a22 + decay * v.Y],
            [b1.T, b2.T, -level * Iw],
            [c1, c2, d, -level * Iz],
        ]
    keep = 1.0 - decay
    return [
        [-v.X],
        [-In, -v.Y],
        [0, 0, -level * Iz],
        [-a11.T, -a21.T, -c1.T, -keep * v.X],
        [-a12.T, -a22.T, -c2.T, -keep * In, -keep * v.Y],
        [-b1.T, -b2.T, -d.T, 0, 0, -level * Iw],
    ]


def h2_gramian(plant, j, v, hats, decay):
    """The Gramian part of the H2 bound at vertex `j`, transformed: ``F < 0``.

    ``P^-1`` bounds the controllability Gramian: continuous time ``[[He(AA)
    + decay Xb, BB], [BB', -I]] < 0``; discrete time ``[[Xb, AA, BB], [AA',
    (1 - decay) Xb, 0], [BB', 0, I]] > 0``.
    """
    AA, (b1, b2), _, _ = transformed_loop(plant, j, v.X, v.Y, *hats)
    (a11, a12), (a21, a22) = AA
    n, nw = plant.n, b1.shape[1]
    In, Iw = np.eye(n), np.eye(nw)
    if plant.continuous:
        return [
            [2 * a11 + decay * v.X],
            [a21 + a12.T + decay * In, 2 * a22 + decay * v.Y],
            [b1.T, b2.T, -Iw],
        ]
    keep = 1.0 - decay
    return [
        [-v.X],
        [-In, -v.Y],
        [-a11.T, -a21.T, -keep * v.X],
        [-a12.T, -a22.T, -keep * In, -keep * v.Y],
        [-b1.T, -b2.T, 0, 0, -Iw],
    ]


def h2_output(plant, j, v, hats, Q):
    """``[[Xb, CC'], [CC, Q]] > 0`` at vertex `j` (``trace Q`` bounds H2^2)."""
    _, _, (c1, c2), _ = transformed_loop(plant, j, v.X, v.Y, *hats)
    n = plant.n
    return [[-v.X], [-np.eye(n), -v.Y], [-c1, -c2, -Q]]


def bounded_real_loop(A, B, C, D, P, g, continuous):
    """The closed loop's bounded-real inequality ``F < 0``."""
    nw, nz = B.shape[1], C.shape[0]
    if continuous:
        return np.block([
            [A.T @ P + P @ A, P @ B, C.T],
            [B.T @ P, -g * np.eye(nw), D.T],
            [C, D, -g * np.eye(nz)],
        ])  # fmt: skip
    n = A.shape[0]
    return -np.block([
        [P, np.zeros((n, nz)), P @ A, P @ B],
        [np.zeros((nz, n)), g * np.eye(nz), C, D],
        [A.T @ P, C.T, P, np.zeros((n, nw))],
        [B.T @ P, D.T, np.zeros((nw, n)), g * np.eye(nw)],
    ])  # fmt: skip


def h2_gramian_loop(A, B, P, continuous):
    """``[[He(P A), P B], [B' P, -I]] < 0`` (discrete time ``-[[P, P A,
    P B], [A' P, P, 0], [B' P, 0, I]] < 0``)."""
    nw = B.shape[1]
    if continuous:
        return np.block([[A.T @ P + P @ A, P @ B], [B.T @ P, -np.eye(nw)]])
    n = A.shape[0]
    return -np.block([
        [P, P @ A, P @ B],
        [A.T @ P, P, np.zeros((n, nw))],
        [B.T @ P, np.zeros((nw, n)), np.eye(nw)],
    ])  # fmt: skip


def h2_output_loop(C, P, Q):
    """``-[[P, C'], [C, Q]] < 0``."""
    return -np.block([[P, C.T], [C, Q]])
