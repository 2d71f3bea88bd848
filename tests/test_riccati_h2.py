"""LTI H2 state feedback against the Riccati equations (issue 19).

Reference: for ``z = C1 x + D12 u`` with ``D12'D12`` invertible, the H2
optimum over stabilizing state feedback is ``sqrt(trace(B1' X B1))`` with
``X`` the stabilizing solution of the LQR equation with weights ``C1'C1``,
``D12'D12`` and cross term ``C1'D12`` (Zhou, Doyle and Glover, ch. 14), and
the H2 norm of a closed loop is ``sqrt(trace(C L C'))`` with ``L`` its
controllability Gramian. Both are computed here with scipy.

The plants are the hard family of the issue: six states, one input, four
unstable modes (3.23, 1.98 +- 0.89j, 0.53) in random coordinates, and an
effort weight from 1e-2 to 10. Before this test the raw optimum of such
plants was reported 95 % below the Riccati optimum, and ``backoff=None``
designs were up to 3.5 times above it.
"""

import control as ct
import numpy as np
import pytest
import scipy.linalg as sl

import ctrl_lpv as lpv

SEED = 1919
NPROBLEMS = 12


def _problem(i):
    rng = np.random.default_rng([SEED, i])
    J = np.zeros((6, 6))
    J[0, 0], J[3, 3] = 3.23, 0.53
    J[1:3, 1:3] = [[1.98, 0.89], [-0.89, 1.98]]
    J[4, 4], J[5, 5] = -rng.uniform(0.1, 5), rng.uniform(-3, 3)
    V = rng.normal(size=(6, 6))
    A = V @ J @ np.linalg.inv(V)
    B2 = rng.normal(size=(6, 1))
    B1 = rng.normal(size=(6, int(rng.integers(1, 3))))
    nz = int(rng.integers(1, 4))
    C1 = np.vstack([rng.normal(size=(nz, 6)), np.zeros((1, 6))])
    D12 = np.zeros((nz + 1, 1))
    D12[-1, 0] = 10 ** rng.uniform(-2, 1)
    return A, B1, B2, C1, D12


def _riccati_optimum(A, B1, B2, C1, D12):
    X = sl.solve_continuous_are(A, B2, C1.T @ C1, D12.T @ D12, s=C1.T @ D12)
    return float(np.sqrt(np.trace(B1.T @ X @ B1)))


def _h2_norm(A, B, C):
    L = sl.solve_continuous_lyapunov(A, -B @ B.T)
    return float(np.sqrt(np.trace(C @ L @ C.T)))


def _design(problem, **kwargs):
    A, B1, B2, C1, D12 = problem
    nw = B1.shape[1]
    w = [f"w{i}" for i in range(nw)]
    D = np.hstack([np.zeros((C1.shape[0], nw)), D12])
    sys = ct.ss(A, np.hstack([B1, B2]), C1, D, inputs=[*w, "u"])
    return lpv.h2_state_feedback(lpv.PolytopicStateSpace([sys]), w=w, u="u", **kwargs)


def test_h2_raw_optimum_matches_riccati():
    refused = []
    for i in range(NPROBLEMS):
        problem = _problem(i)
        A, B1, B2, C1, D12 = problem
        optimum = _riccati_optimum(*problem)
        try:
            design = _design(problem, backoff=None)
        except lpv.CertificationError as exc:
            # Says why not: no point that certifies in the model's units.
            assert "no certified solution found" in str(exc)
            refused.append(i)
            continue
        K = design.gains[0]
        true = _h2_norm(A - B2 @ K, B1, C1 - D12 @ K)
        # The certified bound holds, and is the optimum within solver accuracy.
        assert true <= design.gamma * (1 + 1e-9), i
        assert design.gamma <= optimum * (1 + 2e-3), i
        # The reported optimum is never below the infimum, nor above gamma.
        assert optimum * (1 - 1e-6) <= design.gamma_opt <= design.gamma, i
    # Measured: problem 5 (its optimal W has a direction the float64 check
    # in the model's units cannot resolve) is refused, the rest certify.
    assert len(refused) <= 1, refused


@pytest.mark.parametrize("i", range(4))
def test_h2_backoff_design_relative_to_riccati(i):
    problem = _problem(i)
    optimum = _riccati_optimum(*problem)
    design = _design(problem)
    # gamma_opt is an estimate from above, taken from points that meet the
    # LMIs: with a back-off the ladder stops at the first rung that
    # certifies, so it may be the optimum certified at a larger margin
    # (measured with Clarabel 0.11.1: 3.1e-3 above on problem 3; the raw
    # optimum, test above, is 2e-5 above).
    assert optimum * (1 - 1e-6) <= design.gamma_opt <= optimum * (1 + 5e-3)
    assert design.gamma <= 1.2 * design.gamma_opt * (1 + 1e-9)


def _discrete_problem(i):
    rng = np.random.default_rng([SEED, 100 + i])
    A = rng.normal(size=(5, 5))
    A = 1.3 * A / np.abs(np.linalg.eigvals(A)).max()  # spectral radius 1.3
    B2, B1 = rng.normal(size=(5, 1)), rng.normal(size=(5, 2))
    C1 = np.vstack([rng.normal(size=(2, 5)), np.zeros((1, 5))])
    D12 = np.array([[0.0], [0.0], [10 ** rng.uniform(-1, 0.5)]])
    return A, B1, B2, C1, D12


@pytest.mark.parametrize("i", range(6))
def test_discrete_h2_raw_optimum_matches_riccati(i):
    # Discrete time: the optimum is sqrt(trace(B1' X B1)) with X the
    # stabilizing solution of the discrete LQR equation, and a loop's H2
    # norm sqrt(trace(C L C')) with L its discrete Gramian.
    A, B1, B2, C1, D12 = _discrete_problem(i)
    X = sl.solve_discrete_are(A, B2, C1.T @ C1, D12.T @ D12, s=C1.T @ D12)
    optimum = float(np.sqrt(np.trace(B1.T @ X @ B1)))
    D = np.hstack([np.zeros((3, 2)), D12])
    sys = ct.ss(A, np.hstack([B1, B2]), C1, D, inputs=["w0", "w1", "u"], dt=0.1)
    design = lpv.h2_state_feedback(
        lpv.PolytopicStateSpace([sys]), w=["w0", "w1"], u="u", backoff=None
    )
    K = design.gains[0]
    L = sl.solve_discrete_lyapunov(A - B2 @ K, B1 @ B1.T)
    Cc = C1 - D12 @ K
    assert np.sqrt(np.trace(Cc @ L @ Cc.T)) <= design.gamma * (1 + 1e-9)
    assert design.gamma <= optimum * (1 + 1e-4)
    assert optimum * (1 - 1e-6) <= design.gamma_opt <= design.gamma
