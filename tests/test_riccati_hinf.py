"""LTI H-infinity state feedback against the Riccati equation (issue 11).

Reference: Zhou, Doyle and Glover, Robust and Optimal Control, state-feedback
H-infinity control: for ``z = C1 x + D12 u`` with ``D12' D12 = I`` and
``D12' C1 = 0`` (a general full-column-rank ``D12`` by the standard
loop-shifting), ``gamma`` is achievable iff
``A'X + XA + X (B1 B1'/gamma^2 - B2 B2') X + C1'C1 = 0`` has a stabilizing
solution ``X >= 0``. The optimum is found by bisection on gamma
(``tests/_independent.py``), and checked first against a closed form (the
scalar plant) and against python-control's ``linfnorm``.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _independent import (
    Case,
    check_design,
    hinf_riccati,
    hinf_riccati_at,
    random_lti_hinf,
)

SEED = 1111
NPROBLEMS = 40


def _problem(i):
    return random_lti_hinf(np.random.default_rng([SEED, i]))


def _system(A, B1, B2, C1, D12):
    nw, m, nz = B1.shape[1], B2.shape[1], C1.shape[0]
    sys = ct.ss(
        A,
        np.hstack([B1, B2]),
        C1,
        np.hstack([np.zeros((nz, nw)), D12]),
        inputs=[f"w{i}" for i in range(nw)] + [f"u{i}" for i in range(m)],
        outputs=[f"z{i}" for i in range(nz)],
    )
    return lpv.PolytopicStateSpace([sys])


def _call(problem, **kwargs):
    A, B1, B2, C1, D12 = problem
    nw, m, nz = B1.shape[1], B2.shape[1], C1.shape[0]
    return lpv.hinf_state_feedback(
        _system(*problem),
        w=[f"w{i}" for i in range(nw)],
        u=[f"u{i}" for i in range(m)],
        z=[f"z{i}" for i in range(nz)],
        **kwargs,
    )


def _case(problem):
    A, B1, B2, C1, D12 = problem
    D11 = np.zeros((C1.shape[0], B1.shape[1]))
    return Case(0, 0, "hinf_state_feedback", [(A, B1, B2, C1, D11, D12)])


def _closed_loop_norm(problem, K):
    A, B1, B2, C1, D12 = problem
    return ct.linfnorm(ct.ss(A - B2 @ K, B1, C1 - D12 @ K, 0))[0]


# ----------------------------------------------------------------------
# The reference itself
# ----------------------------------------------------------------------
@pytest.mark.parametrize(
    "a, b1, b2, c",
    [
        (-1.0, 1.0, 1.0, 1.0),
        (-2.0, 0.5, 3.0, 2.0),
        (1.0, 1.0, 2.0, 1.0),
        (0.5, 2.0, 0.5, 3.0),
    ],
)
def test_reference_scalar_closed_form(a, b1, b2, c):
    # x' = a x + b1 w + b2 u, z = [c x; u]: the Riccati equation is
    # q X^2 + 2 a X + c^2 = 0, q = b1^2/gamma^2 - b2^2, with a stabilizing
    # root iff a^2 > q c^2 (a < 0) or q < 0 (a >= 0): the infimum is
    # b1 / sqrt(b2^2 + a^2/c^2) for a < 0 and b1 / b2 for a >= 0.
    expected = b1 / np.sqrt(b2**2 + a**2 / c**2) if a < 0 else b1 / b2
    A, B1, B2 = np.array([[a]]), np.array([[b1]]), np.array([[b2]])
    C1, D12 = np.array([[c], [0.0]]), np.array([[0.0], [1.0]])
    gamma, _, _ = hinf_riccati(A, B1, B2, C1, D12)
    assert gamma == pytest.approx(expected, rel=1e-5)


@pytest.mark.parametrize("i", range(6))
def test_reference_agrees_with_linfnorm(i):
    problem = _problem(i)
    gamma, _, _ = hinf_riccati(*problem)
    # above the optimum the Riccati gain achieves the bound (python-control)
    X, K = hinf_riccati_at(*problem, 1.05 * gamma)
    assert np.all(np.linalg.eigvals(problem[0] - problem[2] @ K).real < 0)
    assert _closed_loop_norm(problem, K) < 1.05 * gamma
    # below it there is no stabilizing solution
    assert hinf_riccati_at(*problem, 0.98 * gamma) is None


# ----------------------------------------------------------------------
# The library against the reference
# ----------------------------------------------------------------------
@pytest.mark.parametrize("i", range(NPROBLEMS))
def test_default_options_certify(i):
    problem = _problem(i)
    gamma_ric, _, _ = hinf_riccati(*problem)
    design = _call(problem)  # every problem here is feasible
    assert design.gamma >= gamma_ric * (1 - 1e-6)
    K = design.gains[0]
    assert design.gamma >= _closed_loop_norm(problem, K) * (1 - 1e-9)
    result = check_design(_case(problem), design.gains, design.P, design.gamma)
    assert result.ok, str(result)


@pytest.mark.parametrize("i", range(NPROBLEMS))
def test_raw_optimum_matches_riccati(i):
    problem = _problem(i)
    gamma_ric, _, _ = hinf_riccati(*problem)
    design = _call(problem, backoff=None)
    assert design.gamma_opt == pytest.approx(gamma_ric, rel=1e-3)
    assert design.gamma >= _closed_loop_norm(problem, design.gains[0]) * (1 - 1e-9)
    result = check_design(_case(problem), design.gains, design.P, design.gamma)
    assert result.ok, str(result)
