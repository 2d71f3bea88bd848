"""The certificate of an output-feedback design, on the closed loop itself.

The LMI checks of the solver's point (`ctrl_lpv.lmi.LMIProblem`) prove the
transformed inequalities; what runs is the controller rebuilt from them, so
the certificate is recomputed from the returned controller matrices alone:
``P`` from ``(X, Y, M, N)``, then at every vertex the closed loop's
bounded-real inequality with the certified ``gamma`` and ``P > 0``, each by
the library's rounding-aware `ctrl_lpv.certificate.negative_definite`.
Because the plant's ``B2, C2, D12, D21`` do not depend on the parameter and
the controller is interpolated with the plant's convex coordinates, the
closed loop is affine in them: the vertex inequalities with one ``P`` hold
on the whole polytope and for any parameter trajectory. Frozen H-infinity
norms from `control.linfnorm` at the verification points cross-check the
bound.
"""

from __future__ import annotations

import control as ct
import numpy as np
from scipy.linalg import matrix_balance

from ..certificate import Certificate, Check, negative_definite
from ..lmi import LMIProblem
from ..synthesis.frozen import verification_points
from .reconstruct import closed_loop

__all__ = ["closed_loop_certificate", "closed_loop_analysis"]


def closed_loop_certificate(plant, controllers, P, gamma) -> Certificate:
    """Float64 checks that the vertex controllers meet ``||T_zw|| < gamma``."""
    checks = [negative_definite(-P, what="P > 0", where="closed loop", group="LMI")]
    for j, K in enumerate(controllers):
        Acl, Bcl, Ccl, Dcl = closed_loop(plant, plant.data(_unit(plant, j)), K)
        F, F_abs = _bounded_real(Acl, Bcl, Ccl, Dcl, P, gamma, plant.continuous)
        checks.append(negative_definite(
            F, absolute=F_abs, what="bounded real (closed loop)",
            where=f"vertex {j}", group="LMI",
        ))  # fmt: skip
    checks.extend(_frozen_norms(plant, controllers, gamma))
    statement = (
        f"||T_zw||_inf < {gamma:.6g} for every parameter trajectory in the "
        "polytope, with one quadratic Lyapunov function of the closed loop"
    )
    return Certificate(tuple(checks), statement=statement)


def closed_loop_analysis(plant, controllers, margin, chain):
    """``(P, gamma)``: the closed loop's own least quadratic L2 bound.

    Used when ``P`` rebuilt from the design's ``(X, Y)`` is too ill-
    conditioned for its float64 check: the bounded-real LMIs of the closed
    loop in a fresh ``P`` (size ``2 n``), minimising ``gamma``.
    """
    loops = [closed_loop(plant, plant.data(_unit(plant, j)), K)
             for j, K in enumerate(controllers)]  # fmt: skip
    loops, t = _balanced(loops)
    n = loops[0][0].shape[0]
    scale = max(np.linalg.norm(np.block([[A, B], [C, D]]), 2) for A, B, C, D in loops)
    lmi = LMIProblem(margin=margin * max(scale, 1.0))
    lmi.variable("P", (n, n), symmetric=True)
    lmi.variable("g", (1, 1), symmetric=True)
    lmi.add("P > 0", lambda v: [[-v.P]])
    for j, loop in enumerate(loops):
        lmi.add(
            f"bounded real vertex {j}",
            lambda v, loop=loop: [[_bounded_real(*loop, v.P, v.g[0, 0],
                                                 plant.continuous)[0]]],
        )  # fmt: skip
    sol = lmi.solve(lambda v: v.g[0, 0], solvers=chain)
    return _unbalanced(sol.P, t), float(sol.g[0, 0])


def _balanced(loops):
    """The loops in balanced state coordinates ``x = T x~``, and ``diag T``.

    A quadratic bound is invariant under a common change of state
    coordinates, and the reconstruction scales the controller's states by
    orders of magnitude: balancing first keeps the solvers accurate.
    """
    _, (t, _) = matrix_balance(sum(np.abs(L[0]) for L in loops), permute=False,
                               separate=True)  # fmt: skip
    return [(A * (t[None, :] / t[:, None]), B / t[:, None], C * t[None, :], D)
            for A, B, C, D in loops], t  # fmt: skip


def _unbalanced(P, t):
    """``P`` of the original coordinates: ``T^-T P~ T^-1``."""
    return P / t[:, None] / t[None, :]


def _bounded_real(Acl, Bcl, Ccl, Dcl, P, gamma, continuous):
    nw, nz = Bcl.shape[1], Ccl.shape[0]
    a = [np.abs(M) for M in (Acl, Bcl, Ccl, Dcl, P)]
    if continuous:

        def brl(A, B, C, D, P, g):
            return np.block([
                [A.T @ P + P @ A, P @ B, C.T],
                [B.T @ P, -g * np.eye(nw), D.T],
                [C, D, -g * np.eye(nz)],
            ])  # fmt: skip

    else:

        def brl(A, B, C, D, P, g):
            n = A.shape[0]
            return -np.block([
                [P, np.zeros((n, nz)), P @ A, P @ B],
                [np.zeros((nz, n)), g * np.eye(nz), C, D],
                [A.T @ P, C.T, P, np.zeros((n, nw))],
                [B.T @ P, D.T, np.zeros((nw, n)), g * np.eye(nw)],
            ])  # fmt: skip

    return brl(Acl, Bcl, Ccl, Dcl, P, gamma), np.abs(brl(*a, gamma))


def _frozen_norms(plant, controllers, gamma):
    """Cross-checks: the frozen closed loops' norms from python-control."""
    worst, where = -np.inf, ""
    for label, weights in _points(plant):
        K = tuple(np.tensordot(weights, np.array(M), axes=1)
                  for M in zip(*controllers))  # fmt: skip
        Acl, Bcl, Ccl, Dcl = closed_loop(plant, plant.data(weights), K)
        dt = plant.system.dt if not plant.continuous else 0
        norm = float(ct.linfnorm(ct.ss(Acl, Bcl, Ccl, Dcl, dt))[0])
        if not norm <= worst:
            worst, where = norm, label
    return [Check(
        "frozen H-infinity norm (control.linfnorm)", worst, gamma, strict=True,
        cross_check=True, where=where, group="frozen",
    )]  # fmt: skip


def _points(plant):
    for delta, p in verification_points(plant.system):
        point = delta if p is None else p
        yield f"p = {np.round(point, 6).tolist()}", delta


def _unit(plant, j):
    e = np.zeros(plant.nvertices)
    e[j] = 1.0
    return e
