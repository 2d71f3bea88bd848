"""Bounded-real LMIs of output feedback after the change of variables.

Scherer, Gahinet and Chilali (1997), "Multiobjective output-feedback control
via LMI optimization", IEEE TAC 42(7); Gahinet and Apkarian (1994) for the
LTI problem; Apkarian, Gahinet and Becker (1995), "Self-scheduled H-infinity
control of linear parameter-varying systems", Automatica 31(9), for the
polytope: one pair ``(X, Y)`` for every vertex and one set of controller
variables per vertex.

With the closed-loop Lyapunov matrix ``P`` partitioned so that ``P Pi1 =
Pi2``, ``Pi1 = [[X, I], [M', 0]]``, ``Pi2 = [[I, Y], [0, N']]`` and ``M N'
= I - X Y``, the congruence by ``Pi1`` turns the closed loop's
bounded-real inequality into one affine in ``X, Y`` and

    Ah = N Ak M' + N Bk C2 X + Y B2 Ck M' + Y (A + B2 Dk C2) X,
    Bh = N Bk + Y B2 Dk,   Ch = Ck M' + Dk C2 X,   Dh = Dk,

and ``[[X, I], [I, Y]] > 0`` is ``P > 0``. The blocks here are written
with the lower block triangle convention of `ctrl_lpv.lmi.assemble`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["lyapunov_pair", "bounded_real", "transformed_loop"]


def lyapunov_pair(v):
    """``-[[X, I], [I, Y]]``: negative definite iff the closed-loop ``P > 0``."""
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


def bounded_real(plant, j, v, hats, decay=0.0):
    """The bounded-real inequality ``F < 0`` at vertex `j` (``gamma = v.g``).

    Continuous time: ``[[He(AA), BB, CC'], [BB', -g I, DD'], [CC, DD, -g I]]
    < 0``; discrete time: ``-[[Xb, 0, AA, BB], [0, g I, CC, DD], [AA', CC',
    Xb, 0], [BB', DD', 0, g I]] < 0`` with ``Xb = [[X, I], [I, Y]]``: the
    closed loop's ``||T_zw||_inf < g`` with ``P`` transformed by ``Pi1``.

    With ``decay > 0`` the Lyapunov part is tightened by ``decay Xb``
    (``Xb = Pi1' P Pi1``): the closed loop's inequality then holds with
    ``-decay P`` in its state block, a margin relative to ``P`` that
    survives the reconstruction, whatever the scale of ``X`` and ``Y``.
    """
    n = plant.n
    nw, nz = plant.B1.shape[2], plant.C1.shape[1]
    g = v.g[0, 0]
    AA, (b1, b2), (c1, c2), d = transformed_loop(plant, j, v.X, v.Y, *hats)
    (a11, a12), (a21, a22) = AA
    In, Iw, Iz = np.eye(n), np.eye(nw), np.eye(nz)
    if plant.continuous:
        return [
            [2 * a11 + decay * v.X],
            [a21 + a12.T + decay * In, 2 * a22 + decay * v.Y],
            [b1.T, b2.T, -g * Iw],
            [c1, c2, d, -g * Iz],
        ]
    return [
        [-v.X],
        [-In, -v.Y],
        [0, 0, -g * Iz],
        [-a11.T, -a21.T, -c1.T, -(1 - decay) * v.X],
        [-a12.T, -a22.T, -c2.T, -(1 - decay) * In, -(1 - decay) * v.Y],
        [-b1.T, -b2.T, -d.T, 0, 0, -g * Iw],
    ]
