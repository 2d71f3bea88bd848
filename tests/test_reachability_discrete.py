"""`ultimate_bound` in discrete time, held to independent facts.

For ``x+ = a x + w`` with ``|w| <= 1`` the reachable set is exactly
``|x| <= 1 / (1 - |a|)`` (the geometric series of ``w_k = sign``), so a
certified bound can be neither below it (a trajectory reaches it) nor far
above it (the ellipsoid of a scalar system is the interval itself). For a
polytope, simulated trajectories under switching vertices and extreme or
random inputs stay inside the bound, and the certificate's own decrease
``V(x+) <= (1 - lambda) V(x) + sum_i mu_i (w_i / w_max_i)^2`` is recomputed
with numpy along them.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import InfeasibleError


@pytest.mark.parametrize("a", [0.5, -0.8, 0.95])
def test_scalar_bound_is_the_reachable_set(a):
    res = lpv.ultimate_bound(ct.ss([[a]], [[1.0]], [[1.0]], [[0.0]], dt=0.1))
    exact = 1.0 / (1.0 - abs(a))
    assert res.certificate.verified
    # The summary speaks of the discrete-time spectrum: |z| - 1 of the loop.
    assert f"max |z| - 1 = {abs(a) - 1:.4g}" in res.certificate.summary
    assert exact <= res.bounds[0] <= exact * (1 + 1e-3)
    # The worst input sequence, w_k = sign(a)^(N - 1 - k), reaches the bound.
    x, N = 0.0, 400
    for k in range(N):
        x = a * x + np.sign(a) ** (N - 1 - k)
    assert abs(x) <= res.bounds[0]
    assert abs(x) >= 0.99 * exact


def _polytope(dt=1e-3):
    A0 = np.array([[0.9, 0.2], [-0.1, 0.7]])
    A1 = np.array([[0.8, -0.1], [0.15, 0.85]])
    E = np.array([[1.0, 0.0], [0.5, 0.3]])
    verts = [ct.ss(A, E, np.eye(2), np.zeros((2, 2)), dt=dt) for A in (A0, A1)]
    return lpv.PolytopicStateSpace(verts, inputs=["w1", "w2"], outputs=["y1", "y2"])


def test_polytope_bound_holds_along_switching_trajectories():
    sys = _polytope()
    w_max = np.array([1.0, 2.0])
    res = lpv.ultimate_bound(sys, w_max=w_max)
    assert res.certificate.verified
    lam = -np.expm1(-res.decay * sys.dt)  # contraction per sample
    P, mu = res.P, np.asarray(res.mu, float)
    As = [v.A for v in sys.vertices]
    E = sys.vertices[0].B
    rng = np.random.default_rng(7)
    worst = np.zeros(2)
    for trial in range(20):
        x = np.zeros(2) if trial % 2 else rng.normal(size=2) * 30
        V0 = x @ P @ x
        for k in range(1500):
            d = rng.uniform()
            A = d * As[0] + (1 - d) * As[1]
            extreme = trial < 10
            w = np.sign(rng.normal(size=2)) if extreme else rng.uniform(-1, 1, 2)
            w = w_max * w
            xn = A @ x + E @ w
            # The certificate's decrease, recomputed.
            bound = (1 - lam) * (x @ P @ x) + mu @ (w / w_max) ** 2
            assert xn @ P @ xn <= bound * (1 + 1e-9) + 1e-12
            x = xn
            V = x @ P @ x
            level = res.rho + (V0 - res.rho) * np.exp(-res.decay * (k + 1) * sys.dt)
            assert V <= max(level, res.rho) * (1 + 1e-9)
            if k > 1000 or V0 <= res.rho:
                worst = np.maximum(worst, np.abs(x))
    assert np.all(worst <= res.bounds)
    # Not vacuous: the simulated peaks use a fair share of the bound.
    assert np.all(worst >= 0.2 * res.bounds)


def test_discrete_refusals_name_the_problem():
    unstable = ct.ss([[1.05]], [[1.0]], [[1.0]], [[0.0]], dt=0.1)
    with pytest.raises(InfeasibleError, match="not Schur"):
        lpv.ultimate_bound(unstable)
    with pytest.raises(ValueError, match="sample time"):
        lpv.ultimate_bound(ct.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], dt=True))
