"""A spec's residuals over many frozen loops at once (`Spec.residuals`)
against the bounded-real matrix written out loop by loop with
``numpy.block``, and the design certificates they enter."""

import control as ct
import numpy as np
import pytest

from ctrl_lpv.synthesis.frozen import FrozenLoop
from ctrl_lpv.synthesis.spec import Spec, Stability
from ctrl_lpv.synthesis.specs import Hinf


def _max_normalized_eig(M):
    # Independent of the library: D M D with D = |diag M|^-1/2.
    d = np.diag(M)
    if np.any(d >= 0):
        return np.inf
    s = 1.0 / np.sqrt(-d)
    return np.linalg.eigvalsh(M * s[:, None] * s[None, :])[-1]


def _bounded_real(loop, continuous):
    A, Bw, Cz, Dzw, gamma = loop.Acl, loop.Bw, loop.Cz, loop.Dzw, loop.bound
    n, nw, nz = A.shape[0], Bw.shape[1], Cz.shape[0]
    if continuous:
        P, Pm = loop.P, loop.P_moved
        return np.block([
            [A.T @ P + P @ A + Pm, P @ Bw, Cz.T],
            [Bw.T @ P, -np.eye(nw), Dzw.T],
            [Cz, Dzw, -gamma**2 * np.eye(nz)],
        ])  # fmt: skip
    W, Wm = loop.W, loop.W_moved
    return np.block([
        [-Wm, A @ W, Bw, np.zeros((n, nz))],
        [W @ A.T, -W, np.zeros((n, nw)), W @ Cz.T],
        [Bw.T, np.zeros((nw, n)), -np.eye(nw), Dzw.T],
        [np.zeros((nz, n)), Cz @ W, Dzw, -gamma**2 * np.eye(nz)],
    ])  # fmt: skip


def _loops(rng, continuous, count=12):
    """Random stable loops at rate zero (``dP/dt = 0``, ``W+ = W``), every
    other one with a bound below its H-infinity norm (``control.linfnorm``)."""
    n, nw, nz = 4, 2, 3
    out = []
    for k in range(count):
        A = rng.standard_normal((n, n))
        A = A - (np.max(np.linalg.eigvals(A).real) + 1.0) * np.eye(n)
        if not continuous:
            A = A / (1.1 * np.max(np.abs(np.linalg.eigvals(A))))
        Bw, Cz = rng.standard_normal((n, nw)), rng.standard_normal((nz, n))
        Dzw = 0.1 * rng.standard_normal((nz, nw))
        plant = ct.ss(A, Bw, Cz, Dzw, 0 if continuous else True)
        norm = ct.linfnorm(plant)[0]
        bound = norm * (1.5 if k % 2 else 0.7)
        W = np.eye(n) + 0.1 * np.diag(rng.random(n))
        P = np.linalg.inv(W)
        out.append(FrozenLoop(A, np.zeros((n, 1)), np.zeros((1, n)), A,
                              np.linalg.eigvals(A), P, 0 * P, W, W,
                              Bw=Bw, Cz=Cz, Dzw=Dzw, bound=bound))  # fmt: skip
    return out


@pytest.mark.parametrize("continuous", [True, False])
@pytest.mark.parametrize("seed", range(5))
def test_hinf_residuals_match_the_loop_by_loop_matrix(continuous, seed):
    loops = _loops(np.random.default_rng(seed), continuous)
    stacked = Hinf().residuals(loops, continuous)
    expected = [_max_normalized_eig(_bounded_real(lp, continuous)) for lp in loops]
    np.testing.assert_allclose(stacked, expected, rtol=1e-12, atol=1e-14)
    # One loop is the stack of one.
    assert [Hinf().residual(lp, continuous) for lp in loops] == list(stacked)
    # Bounded-real lemma: below the norm no P makes the matrix negative.
    assert np.all(stacked[0::2] > 0)


def test_default_residuals_are_the_residual_of_each_loop():
    loops = _loops(np.random.default_rng(7), True)
    stability = Stability()
    assert Spec.residuals is type(stability).residuals
    expected = [stability.residual(lp, True) for lp in loops]
    assert list(stability.residuals(loops, True)) == expected


def test_a_nonnegative_diagonal_is_infinite_at_that_loop_only():
    loops = _loops(np.random.default_rng(3), True, count=3)
    # -gamma^2 = 0 on the diagonal: no strict inequality at that loop.
    from dataclasses import replace

    loops[1] = replace(loops[1], bound=0.0)
    values = Hinf().residuals(loops, True)
    assert np.isinf(values[1]) and np.all(np.isfinite(values[[0, 2]]))
