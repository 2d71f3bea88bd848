"""The direct conic backend on random problems, against independent facts.

Random polytopes stabilizable by construction (the recipe of
``benchmarks/bench_synthesis.random_polytope``); every returned bound is
checked on frozen closed loops built here with numpy from the vertex data
and the returned gains (``u = -K x``): python-control's H-infinity norms
(`control.linfnorm`) and H2 norms (a Lyapunov equation, `control.lyap`,
and the controllability Gramian, `control.gram`) below the certified
bound, closed-loop eigenvalues inside the requested region, and the
per-vertex Riccati optimum below a minimal gamma. Nothing is compared with
another run of the library (the old-vs-new comparison is
``benchmarks/compare_backends.py``).
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _independent import hinf_riccati

ROUND = 1e-7  # relative slack for norms computed in float64 here


def polytope(seed, n, N, m=1, dt=None):
    """Vertices ``(A, B, C, D)`` (inputs ``[w0, u...]``, outputs ``[z0,
    u...]``) and the system; ``A_j - B_j K0 = skew - c_j I`` by construction."""
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(m, n))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q @ np.diag(rng.uniform(0.5, 2.0, size=n))
    Ti = np.linalg.inv(T)
    vertices = []
    for _ in range(N):
        B = rng.normal(size=(n, m))
        S = rng.normal(size=(n, n))
        A = B @ K0 + (S - S.T) - rng.uniform(0.1, 1.0) * np.eye(n)
        Cz = np.vstack([rng.normal(size=(1, n)) @ Ti, np.zeros((m, n))])
        Dz = np.zeros((1 + m, 1 + m))
        Dz[1:, 1:] = np.eye(m)
        Bf = T @ np.hstack([rng.normal(size=(n, 1)), B])
        vertices.append((T @ A @ Ti, Bf, Cz, Dz))
    u = [f"u{i}" for i in range(m)]
    z = ["z0"] + [f"z{i + 1}" for i in range(m)]
    sys = lpv.pss(vertices, inputs=["w0"] + u, outputs=z)
    if dt is not None:
        sys = sys.sample(dt)
        vertices = sys.vertex_data()
    return vertices, sys, u, z


def frozen_loops(vertices, gains, count=12, seed=0):
    """``(A - Bu K, Bw, C - Du K)`` at the vertices and random convex points
    (a scheduled gain is ``K(delta) = sum_j delta_j K_j``)."""
    N = len(vertices)
    rng = np.random.default_rng(seed)
    deltas = list(np.eye(N)) + list(rng.dirichlet(np.ones(N), size=count))
    for delta in deltas:
        A, B, C, D = (sum(d * v[i] for d, v in zip(delta, vertices)) for i in range(4))
        K = gains[0] if len(gains) == 1 else sum(d * Kj for d, Kj in zip(delta, gains))
        yield A - B[:, 1:] @ K, B[:, :1], C - D[:, 1:] @ K


def h2_norm(A, B, C):
    """``sqrt(tr(C X C'))`` with ``A X + X A' + B B' = 0`` (control.lyap)."""
    X = ct.lyap(A, B @ B.T)
    return float(np.sqrt(np.trace(C @ X @ C.T)))


@pytest.mark.parametrize("seed, n, N", [(1, 3, 3), (2, 4, 2)])
def test_common_hinf_gain_bounds_every_frozen_loop(seed, n, N):
    vertices, sys, u, z = polytope(seed, n, N)
    design = lpv.hinf_state_feedback(sys, "w0", u, z, backoff=None)
    assert design.certificate.verified
    for Acl, Bw, Ccl in frozen_loops(vertices, design.gains):
        assert np.linalg.eigvals(Acl).real.max() < 0
        norm = ct.linfnorm(ct.ss(Acl, Bw, Ccl, 0))[0]
        assert norm <= design.gamma * (1 + ROUND)
    # a common gain cannot beat the best gain of any single vertex
    best = max(
        hinf_riccati(A, B[:, :1], B[:, 1:], C, D[:, 1:])[0] for A, B, C, D in vertices
    )
    assert design.gamma >= best * (1 - 1e-5)


def test_scheduled_hinf_gains_bound_every_frozen_loop():
    vertices, sys, u, z = polytope(3, 3, 3)
    design = lpv.gain_scheduled_hinf(sys, "w0", u, z, backoff=None)
    assert len(design.gains) == 3
    for Acl, Bw, Ccl in frozen_loops(vertices, design.gains):
        assert np.linalg.eigvals(Acl).real.max() < 0
        assert ct.linfnorm(ct.ss(Acl, Bw, Ccl, 0))[0] <= design.gamma * (1 + ROUND)


def test_h2_design_and_h2_bound_are_above_the_frozen_h2_norms():
    vertices, sys, u, z = polytope(4, 3, 3)
    design = lpv.h2_state_feedback(sys, "w0", u, z)
    norms = []
    for Acl, Bw, Ccl in frozen_loops(vertices, design.gains):
        norms.append(h2_norm(Acl, Bw, Ccl))
        # the same norm from the controllability Gramian
        Wc = ct.gram(ct.ss(Acl, Bw, Ccl, 0), "c")
        assert norms[-1] == pytest.approx(np.sqrt(np.trace(Ccl @ Wc @ Ccl.T)))
    assert max(norms) <= design.gamma * (1 + ROUND)
    # analysis of the same gain: a bound at least the frozen norms
    bound = lpv.h2_bound(sys, design.gains[0], "w0", u, z)
    assert max(norms) <= bound.gamma * (1 + ROUND)


def test_l2_gain_bound_of_a_given_gain_is_above_the_frozen_norms():
    vertices, sys, u, z = polytope(5, 4, 3)
    K = lpv.quadratic_stabilization(sys, u).gains[0]
    result = lpv.l2_gain_bound(sys, K, "w0", u, z)
    norms = [
        ct.linfnorm(ct.ss(Acl, Bw, Ccl, 0))[0]
        for Acl, Bw, Ccl in frozen_loops(vertices, [K])
    ]
    assert max(norms) <= result.gamma * (1 + ROUND)


def test_pole_regions_and_gain_bound_hold_on_frozen_loops():
    vertices, sys, u, z = polytope(6, 3, 3)
    decay, radius = 0.3, 40.0
    design = lpv.synthesize(
        sys,
        u,
        objective=lpv.Hinf("w0", z),
        constraints=[lpv.halfplane(decay), lpv.disk(radius), lpv.GainBound(50.0)],
    )
    assert np.linalg.norm(design.gains[0], 2) <= 50.0
    for Acl, Bw, Ccl in frozen_loops(vertices, design.gains):
        poles = np.linalg.eigvals(Acl)
        assert poles.real.max() < -decay
        assert np.abs(poles).max() < radius
        assert ct.linfnorm(ct.ss(Acl, Bw, Ccl, 0))[0] <= design.gamma * (1 + ROUND)


def test_discrete_time_hinf_design_is_schur_with_its_bound():
    dt = 0.05
    vertices, sys, u, z = polytope(7, 3, 2, dt=dt)
    design = lpv.hinf_state_feedback(sys, "w0", u, z, backoff=None)
    for Acl, Bw, Ccl in frozen_loops(vertices, design.gains):
        assert np.abs(np.linalg.eigvals(Acl)).max() < 1
        norm = ct.linfnorm(ct.ss(Acl, Bw, Ccl, 0, dt))[0]
        assert norm <= design.gamma * (1 + ROUND)


def test_quadratic_stability_lyapunov_matrix_holds_at_every_vertex():
    vertices, sys, u, _ = polytope(8, 4, 4)
    K = lpv.gain_scheduled_stabilization(sys, u).gains
    loops = [(A - B[:, 1:] @ Kj, B, C, D) for (A, B, C, D), Kj in zip(vertices, K)]
    result = lpv.quadratic_stability(lpv.pss(loops))
    P = result.P
    assert np.linalg.eigvalsh(P)[0] > 0
    for A, *_ in loops:
        assert np.linalg.eigvalsh(A.T @ P + P @ A)[-1] < 0
