"""The objective of `certify`: a certified L2 (or H2) bound of a channel.

Both kinds of closed loops (a schedule on a polytopic plant, on a gridded
one) reduce the channel ``w -> z`` to finitely many closed-loop matrices
``(A_cl, B_w, C_cl, D_zw)`` whose convex hull holds every frozen loop; one
Lyapunov matrix for all of them, from the engine's analysis
(`ctrl_lpv.l2_gain_bound`'s path), bounds the channel for arbitrarily fast
parameters.
"""

from __future__ import annotations

import numpy as np

from .._checks import signal_indices
from ..certificate import Certificate

__all__ = ["checked_objective", "channel", "certified_bound"]


def checked_objective(objective):
    """An `Hinf` or `H2` spec naming its channel, or a clear error."""
    from ..synthesis import H2, Hinf

    if objective is None:
        return None
    if not isinstance(objective, (Hinf, H2)):
        raise TypeError(
            "objective: expected ctrl_lpv.Hinf(w=..., z=...) (an L2-gain bound) "
            f"or ctrl_lpv.H2(w=..., z=...), got {type(objective).__name__}"
        )
    if objective.w is None or objective.z is None:
        raise ValueError("objective: name the channel's signals, w=... and z=...")
    if objective.bound is not None:
        raise ValueError(
            "objective: bound= is not used by certify (it reports the certified "
            "bound); leave it None"
        )
    return objective


def channel(objective, plant, u):
    """``(iw, iz, of)``: the channel's indices and the loop of (point, gain).

    ``of(data, K)`` is ``(A - B_u K, B_w, C_z - D_zu K, D_zw)`` of a plant's
    ``data = (A, B, C, D)`` under ``u = -K x``; also returned: ``D_zu`` of
    `data` (to see whether it varies).
    """
    iw = signal_indices(objective.w, plant.physical_inputs, "objective.w")
    iz = signal_indices(objective.z, plant.output_labels, "objective.z")

    def of(data, K):
        A, B, C, D = data
        return (A - B[:, u] @ K, B[:, iw], C[iz] - D[np.ix_(iz, u)] @ K,
                D[np.ix_(iz, iw)])  # fmt: skip

    def dzu(data):
        return data[3][np.ix_(iz, u)]

    return iw, iz, of, dzu


def certified_bound(loops, objective, dt, margin, w, z, where):
    """``(bound, certificate)`` for the matrices `loops`, one Lyapunov matrix.

    Raises
    ------
    ValueError
        An `H2` objective in continuous time whose loop has a feedthrough
        from `w` to `z` (named).
    SynthesisError
        When the engine certifies no bound.
    """
    from ..analysis import _general_analysis
    from ..synthesis import H2, Hinf
    from ..systems import PolytopicStateSpace

    if isinstance(objective, H2) and not dt:
        for T in loops:
            rows, cols = np.nonzero(np.asarray(T[3]))
            if rows.size:
                i, j = int(rows[0]), int(cols[0])
                raise ValueError(
                    f"objective: the closed loop's feedthrough from {w[j]!r} to "
                    f"{z[i]!r} is {float(T[3][i, j]):.6g} (not zero) {where}, so "
                    f"its continuous-time H2 norm is infinite; leave {z[i]!r} "
                    f"out of z (or {w[j]!r} out of w), or use Hinf"
                )
    unique = {}
    for T in loops:
        unique.setdefault(b"".join(np.asarray(M).tobytes() for M in T), T)
    loop = PolytopicStateSpace(list(unique.values()), dt=dt)
    spec = type(objective)()
    gamma, _, cert = _general_analysis(loop, spec, "constant", None, margin)
    what = "L2 gain" if isinstance(spec, Hinf) else "H2 bound"
    statement = (
        f"{what} from {list(w)} to {list(z)} below {float(gamma):.6g} for "
        f"arbitrarily fast parameters {where} (one Lyapunov matrix for the "
        f"{len(unique)} closed-loop matrices spanning the frozen loops)"
    )
    return float(gamma), Certificate(cert.checks, statement=statement)
