"""The certificate of an observer, computed on the estimation-error system.

The engine certifies the dual state-feedback loop
(`ctrl_lpv.estimation.duality`); this module does not rely on it. With the
returned gains ``L_j`` and the Lyapunov matrix ``P`` of the error (the
inverse of the dual design's ``P``, i.e. the engine's own variable ``W``),
it recomputes in float64, at every vertex of the error system ``e' = A_e e
+ B_e w``, ``z_e = C_z e`` (``A_e = A - L C_y``, ``B_e = B_w - L D_yw``):

* ``P > 0`` and the Lyapunov inequality ``A_e' P + P A_e < 0`` (discrete
  time ``[[P, A_e' P], [P A_e, P]] > 0``);
* H-infinity: the bounded-real inequality
  ``[[A_e' P + P A_e, P B_e, C_z'], [B_e' P, -g^2 I, 0], [C_z, 0, -I]] < 0``
  (discrete time ``[[P, P A_e, P B_e, 0], [A_e' P, P, 0, C_z'],
  [B_e' P, 0, g^2 I, 0], [0, C_z, 0, I]] > 0``);
* H2: the observability Gramian bound ``[[A_e' P + P A_e, C_z'], [C_z,
  -I]] < 0`` (discrete time ``[[P, A_e' P, C_z'], [P A_e, P, 0], [C_z, 0,
  I]] > 0``) and ``trace(B_e' P B_e) < g^2``;
* each pole region ``kron(L, P) + kron(M, A_e' P) + kron(M', P A_e) < 0``
  (Chilali and Gahinet's LMI for ``A_e'``, whose eigenvalues are those of
  ``A_e``).

Each is affine in the vertex data (the trace convex) when the error data
are affine in the convex coordinates: one ``L``, or one ``L_j`` per vertex
with ``C_y`` and ``D_yw`` constant. So the vertex checks hold on the whole
polytope, with one ``P`` for arbitrarily fast parameter variation. These
are the engine's inequalities for the dual read back through the
transpose, in the model's units (the engine proves its own in prescaled
units); ``P`` rather than its inverse keeps them well conditioned at a
raw optimum, where the dual's ``P`` grows without bound in some
direction. The frozen error systems at the vertices and sampled interior
points cross-check: their eigenvalues, their H-infinity norms
(`control.linfnorm`) and H2 norms (Gramians) at most the certified bound.
"""

from __future__ import annotations

import control as ct
import numpy as np
from scipy.linalg import solve_continuous_lyapunov, solve_discrete_lyapunov

from ..certificate import Certificate, Check, negative_definite_stack, rounding_bound
from ..regions import LMIRegion

LMI, FROZEN = "error LMI", "frozen error system"
STATEMENT = (
    "the estimation-error system e' = (A - L C_y) e + (B_w - L D_yw) w, "
    "z_e = C_z e satisfies, with one Lyapunov matrix P, the Lyapunov, "
    "bounded-real or H2 Gramian and pole-region inequalities at every vertex "
    "(affine in the vertex data: hence on the whole polytope, for any "
    "parameter variation); frozen error systems at sampled points cross-check"
)
AFFINE_STATEMENT = (
    "the estimation-error system with the returned gain, analysed on its own "
    "with a Lyapunov matrix P(p) multi-affine in the box parameters for the "
    "given rate bounds (the engine's LMIs, checked in float64); frozen error "
    "systems at sampled points cross-check"
)
# Relative rounding allowed for a frozen norm against the certified bound
# (`control.linfnorm`'s bisection, the Gramian solve).
NORM_RTOL = 1e-6


def interpolated_gain(L, delta) -> np.ndarray:
    """``L(delta) = sum_j delta_j L_j`` (the one gain when common)."""
    if len(L) == 1:
        return L[0]
    return np.tensordot(delta, np.stack(L), axes=1)


def sample_points(N: int, extra: int = 8, seed: int = 0) -> np.ndarray:
    """Convex coordinates: the vertices, the centroid and `extra` seeded
    random points (Dirichlet) of the simplex of the vertices."""
    rows = [np.eye(N), np.full((1, N), 1.0 / N)]
    if N > 1:
        rows.append(np.random.default_rng(seed).dirichlet(np.ones(N), extra))
    return np.vstack(rows)


def error_certificate(err, L, P, *, continuous, kind=None, gamma=None,
                      regions=(), labels=None) -> Certificate:  # fmt: skip
    """Float64 certificate of the error system (module docstring).

    Parameters
    ----------
    err : `ctrl_lpv.estimation.duality.ErrorData`
        The error system's vertex data.
    L : tuple of ndarray
        One gain, or one per vertex.
    P : ndarray
        The error's Lyapunov matrix, ``V(e) = e' P e``.
    continuous : bool
        Timebase.
    kind : {None, "Hinf", "H2"}
        The objective's type; None for stability alone.
    gamma : float, optional
        The certified bound of the objective.
    regions : sequence of `LMIRegion`
        Pole regions.
    labels : sequence of str, optional
        Vertex labels for the `where` of each check.

    Returns
    -------
    `ctrl_lpv.Certificate`
    """
    N = err.A.shape[0]
    labels = list(labels) if labels is not None else [f"vertex {j}" for j in range(N)]
    P = 0.5 * (P + P.T)
    n = P.shape[0]
    eye = np.eye(N)
    loops = [err.at(eye[j], interpolated_gain(L, eye[j])) for j in range(N)]
    checks = [negative_definite_stack(-P[None], what="P > 0", where=["P"], group=LMI)]
    lyap = []
    for A, _, _ in loops:
        if continuous:
            lyap.append(A.T @ P + P @ A)
        else:
            lyap.append(-np.block([[P, A.T @ P], [P @ A, P]]))
    checks.append(_stack(lyap, "Lyapunov inequality", labels))
    if kind == "Hinf":
        blocks = [_bounded_real(*loop, P, gamma, continuous) for loop in loops]
        checks.append(_stack(blocks, "bounded-real inequality", labels))
    elif kind == "H2":
        blocks = [_h2_gramian(A, Cz, P, continuous) for A, _, Cz in loops]
        checks.append(_stack(blocks, "H2 Gramian inequality", labels))
        traces = [float(np.trace(B.T @ P @ B)) for _, B, _ in loops]
        bounds = [float(np.trace(abs(B).T @ abs(P) @ abs(B))) for _, B, _ in loops]
        worst = int(np.argmax(traces))
        checks.append(Check(
            "trace(B_e' P B_e) < gamma^2", traces[worst], gamma**2, True,
            rounding_bound(n, max(bounds)), False, "model", labels[worst], LMI,
        ))  # fmt: skip
    for region in regions:
        blocks = [_region(region, A, P) for A, _, _ in loops]
        checks.append(_stack(blocks, f"pole region {region}", labels))
    checks.extend(frozen_checks(err, L, continuous, kind, gamma, regions))
    return Certificate(tuple(checks), STATEMENT)


def _stack(matrices, what, labels) -> Check:
    return negative_definite_stack(np.stack(matrices), what=what, where=labels,
                                   group=LMI)  # fmt: skip


def _bounded_real(A, B, Cz, P, gamma, continuous):
    n, nw, nz = A.shape[0], B.shape[1], Cz.shape[0]
    g2 = gamma**2
    if continuous:
        return np.block([
            [A.T @ P + P @ A, P @ B, Cz.T],
            [B.T @ P, -g2 * np.eye(nw), np.zeros((nw, nz))],
            [Cz, np.zeros((nz, nw)), -np.eye(nz)],
        ])  # fmt: skip
    return -np.block([
        [P, P @ A, P @ B, np.zeros((n, nz))],
        [A.T @ P, P, np.zeros((n, nw)), Cz.T],
        [B.T @ P, np.zeros((nw, n)), g2 * np.eye(nw), np.zeros((nw, nz))],
        [np.zeros((nz, n)), Cz, np.zeros((nz, nw)), np.eye(nz)],
    ])  # fmt: skip


def _h2_gramian(A, Cz, P, continuous):
    n, nz = A.shape[0], Cz.shape[0]
    if continuous:
        return np.block([[A.T @ P + P @ A, Cz.T], [Cz, -np.eye(nz)]])
    return -np.block([
        [P, A.T @ P, Cz.T],
        [P @ A, P, np.zeros((n, nz))],
        [Cz, np.zeros((nz, n)), np.eye(nz)],
    ])  # fmt: skip


def _region(region: LMIRegion, A, P):
    PA = P @ A
    return np.kron(region.L, P) + np.kron(region.M, PA.T) + np.kron(region.M.T, PA)


def frozen_checks(err, L, continuous, kind, gamma, regions):
    """Eigenvalues and norms of the frozen error systems at sampled points."""
    N = err.A.shape[0]
    points = sample_points(N)
    spectra, norms, outside = [], [], []
    for delta in points:
        A, B, Cz = err.at(delta, interpolated_gain(L, delta))
        lam = np.linalg.eigvals(A)
        spectra.append(float(lam.real.max() if continuous else np.abs(lam).max() - 1))
        for region in regions:
            outside.append(0.0 if region.contains(lam).all() else 1.0)
        if kind is None or spectra[-1] >= 0:
            continue
        if kind == "Hinf":
            dt = 0 if continuous else True
            norms.append(float(ct.linfnorm(ct.ss(A, B, Cz, 0, dt=dt))[0]))
        else:
            norms.append(_h2_norm(A, B, Cz, continuous))
    where = f"{len(points)} points"
    checks = [Check(
        "frozen error eigenvalues (max Re)" if continuous
        else "frozen error eigenvalues (max |z| - 1)",
        max(spectra), 0.0, True, 0.0, True, "model", where, FROZEN,
    )]  # fmt: skip
    if regions:
        checks.append(Check("frozen eigenvalues outside a pole region", max(outside),
                            0.5, True, 0.0, True, "count", where, FROZEN))  # fmt: skip
    if kind is not None:
        value = max(norms) if len(norms) == len(points) else np.inf
        what = f"frozen {kind} norm <= gamma"
        rounding = NORM_RTOL * gamma
        checks.append(
            Check(what, value, gamma, False, rounding, True, "model", where, FROZEN)
        )
    return checks


def _h2_norm(A, B, C, continuous) -> float:
    """H2 norm of a stable strictly proper system from its Gramian."""
    if continuous:
        W = solve_continuous_lyapunov(A, -B @ B.T)
    else:
        # The bilinear method: the direct (Kronecker) solve loses accuracy
        # with eigenvalues near the unit circle (slow sampled modes).
        W = solve_discrete_lyapunov(A, B @ B.T, method="bilinear")
    return float(np.sqrt(max(np.trace(C @ W @ C.T), 0.0)))
