"""Independent float64 verification of a returned point."""

from __future__ import annotations

import numpy as np

from ..certificate import Check, negative_definite_stack, rounding_bound
from .assembly import vertex_pairs
from .results import (
    CLOSED_LOOP,
    DESIGN_STATEMENT,
    EIGENVALUES,
    LYAPUNOV,
    DesignCertificate,
)

# Number of random interior points at which closed loops are verified.
_VERIFY_SAMPLES = 64


def verify(original, data, sol, gains, margin, scheduled, P, gamma):
    """Independent float64 checks of the returned point (see module doc)."""
    N = len(original)
    rng = np.random.default_rng(12345)
    deltas = list(np.eye(N))
    if N > 1:
        deltas += list(rng.dirichlet(np.ones(N), size=_VERIFY_SAMPLES))
        deltas += [
            0.5 * (np.eye(N)[j] + np.eye(N)[k]) for j, k in vertex_pairs(N, True)[N:]
        ]
    deltas = np.array(deltas)
    where = [f"vertex {j}" for j in range(N)] + [
        "delta = [" + ", ".join(f"{d:.3g}" for d in delta) + "]" for delta in deltas[N:]
    ]
    W = sol.W
    Winv = np.linalg.inv(W)
    Kstack = np.stack(gains)
    Ktilde = np.stack([-getattr(sol, f"Z{k}") @ Winv for k in range(len(gains))])

    def at(stack):
        # Frozen matrices at every point at once: shape (points, rows, cols).
        return np.einsum("pj,jab->pab", deltas, np.stack(stack))

    K = at(Kstack) if scheduled else Kstack[0]
    A = at([v[0] for v in original])
    B = at([v[2] for v in original])
    Acl = A - B @ K
    real = np.linalg.eigvals(Acl).real.max(axis=1)
    i = int(np.argmax(real))
    Kt = at(Ktilde) if scheduled else Ktilde[0]
    At = at([v[0] for v in data])
    Bt = at([v[2] for v in data])
    Acl_W = (At - Bt @ Kt) @ W
    PA = P @ Acl
    if gamma is None:
        M = PA + np.swapaxes(PA, 1, 2)
    else:
        # The bounded-real inequality with the returned P and gamma, in the
        # model's units: what a user can check with the design alone.
        B1 = at([v[1] for v in original])
        Ccl = at([v[3] for v in original]) - at([v[5] for v in original]) @ K
        D1 = at([v[4] for v in original])
        npts, nw, nz = len(deltas), B1.shape[2], Ccl.shape[1]
        M = np.block([
            [PA + np.swapaxes(PA, 1, 2), P @ B1, np.swapaxes(Ccl, 1, 2)],
            [np.swapaxes(P @ B1, 1, 2), np.broadcast_to(-np.eye(nw), (npts, nw, nw)),
             np.swapaxes(D1, 1, 2)],
            [Ccl, D1, np.broadcast_to(-gamma**2 * np.eye(nz), (npts, nz, nz))],
        ])  # fmt: skip
    cross = {"cross_check": True, "where": where, "group": CLOSED_LOOP}
    checks = (
        *(Check.from_lmi_check(c) for c in sol.checks),
        # Cross-checks of what the LMIs prove (the eigenvalues of a
        # non-normal matrix have no rounding bound: ROUNDING n eps ||A||
        # only marks the level below which their sign means nothing).
        Check(EIGENVALUES, real[i], 0.0, True, rounding_bound(len(Acl[i]),
              np.linalg.norm(Acl[i], 2)), True, "real part", where[i], CLOSED_LOOP),
        negative_definite_stack(Acl_W + np.swapaxes(Acl_W, 1, 2), what=LYAPUNOV,
                                **cross),
        negative_definite_stack(M, what="Lyapunov inequality (P)" if gamma is None
                                else f"bounded-real inequality (P, gamma {gamma:.6g})",
                                **cross),
    )  # fmt: skip
    return DesignCertificate(checks, DESIGN_STATEMENT, margin, len(deltas))
