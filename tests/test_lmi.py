import numpy as np
import pytest

from ctrl_lpv import CertificationError, InfeasibleError
from ctrl_lpv.lmi import LMIProblem, assemble


def test_assemble_symmetric_completion():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(2, 2))
    A = A + A.T
    B = rng.normal(size=(3, 2))
    C = np.eye(3)
    M = assemble([[A], [B, C]])
    np.testing.assert_array_equal(M, np.block([[A, B.T], [B, C]]))
    Z = assemble([[A], [0, C]])
    np.testing.assert_array_equal(Z[:2, 2:], np.zeros((2, 3)))


def lyapunov_problem(A, margin=1e-6):
    n = A.shape[0]
    lmi = LMIProblem(margin=margin)
    lmi.variable("P", (n, n), symmetric=True)
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add("Lyapunov", lambda v: [[A.T @ v.P + v.P @ A]])
    lmi.add("P <= I", lambda v: [[v.P - np.eye(n)]], strict=False, normalization=True)
    return lmi


def test_lyapunov_solution_is_certified_independently():
    A = np.array([[-1.0, 5.0], [0.0, -2.0]])
    sol = lyapunov_problem(A).solve()
    P = sol.P
    assert np.linalg.eigvalsh(P)[0] > 0
    assert np.linalg.eigvalsh(A.T @ P + P @ A)[-1] < -0.5e-6
    assert sol.attempts[-1].certified
    assert all(check.passed for check in sol.checks)


def test_unstable_matrix_has_no_certificate():
    # Homogeneous LMIs: the dual certificate bounds the relative margin of
    # any solution (near rounding) but proves no infeasibility on its own.
    A = np.array([[0.1, 1.0], [0.0, -1.0]])
    with pytest.raises(CertificationError) as info:
        lyapunov_problem(A).solve()
    proof = info.value.farkas
    assert proof is not None and not proof.normalized
    assert proof.relative_margin < 1e-9


def test_inhomogeneous_infeasibility_is_proven():
    # P > 0 with trace(P) <= -1: infeasible even with margin 0.
    lmi = LMIProblem()
    lmi.variable("P", (2, 2), symmetric=True)
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add("trace", lambda v: [[np.eye(1) + v.P[0:1, 0:1] + v.P[1:2, 1:2]]])
    with pytest.raises(InfeasibleError) as info:
        lmi.solve()
    assert info.value.farkas.proves_infeasible


def test_certificate_that_needs_the_normalisation_says_so():
    # P > 0 alone is feasible (P = I); only the normalisation tr P <= -1
    # makes the stage infeasible, so the proof must be marked normalised.
    # (A projection that let the normalisation's dual back in while calling
    # the variant normalisation-free claimed "refutes the LMIs".)
    lmi = LMIProblem()
    lmi.variable("P", (2, 2), symmetric=True)
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add(
        "tr P <= -1",
        lambda v: [[np.eye(1) + v.P[0:1, 0:1] + v.P[1:2, 1:2]]],
        strict=False,
        normalization=True,
    )
    assert np.linalg.eigvalsh(-np.eye(2))[-1] < 0  # P = I solves "P > 0"
    with pytest.raises(InfeasibleError) as info:
        lmi.solve()
    proof = info.value.farkas
    assert proof.proves_infeasible and proof.normalized
    assert "normalisation" in str(info.value)


def test_farkas_map_columns_follow_the_parameters():
    # The columns of the affine map are reused between judgements only
    # while the parameters an LMI reads are unchanged: after a parameter
    # change the certificate must refute the new data, not the old.
    lmi = LMIProblem()
    lmi.variable("P", (1, 1), symmetric=True)
    lmi.parameter("a", (1, 1), value=np.array([[1.0]]))
    lmi.add("P > 0", lambda v: [[-v.P]])
    # 1 + a P <= 0 with P > 0: infeasible for a >= 0 (a = 1: P <= -1).
    lmi.add("affine", lambda v: [[np.eye(1) + v.a @ v.P]])
    duals = [np.eye(1), np.eye(1)]  # 1 + (a - 1) P: zero slope at a = 1
    first = lmi.farkas(duals)
    assert first.proves_infeasible
    lmi.set_parameter("a", [[-1.0]])  # now P = 2 solves both
    second = lmi.farkas(duals)
    assert second is None or not second.proves_infeasible


def test_check_rejects_a_wrong_point():
    A = np.array([[-1.0, 5.0], [0.0, -2.0]])
    lmi = lyapunov_problem(A)
    checks = lmi.check({"P": np.eye(2)})  # A' + A is indefinite here
    lyap = next(c for c in checks if c.name == "Lyapunov")
    assert not lyap.passed
    assert lyap.max_eig == pytest.approx(np.linalg.eigvalsh(A + A.T)[-1])


def test_parameters_reread_only_the_inequalities_that_read_them():
    # Decay-rate test: A + a I must be Hurwitz; a is a parameter.
    A = np.array([[-1.0, 5.0], [0.0, -2.0]])
    lmi = LMIProblem()
    lmi.variable("P", (2, 2), symmetric=True)
    lmi.parameter("a", value=0.5)
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add("decay", lambda v: [[A.T @ v.P + v.P @ A + 2 * v.a * v.P]])
    lmi.add("P <= I", lambda v: [[v.P - np.eye(2)]], strict=False, normalization=True)
    sol = lmi.solve(stage="decay")
    assert np.linalg.eigvalsh((A + 0.5 * np.eye(2)).T @ sol.P + sol.P @ A)[-1] < 0
    (positive,) = lmi._columns["P > 0"].values()
    (decay,) = lmi._columns["decay"].values()
    lmi.set_parameter("a", 1.5)  # decay 1.5 > 1: infeasible
    with pytest.raises(CertificationError):
        lmi.solve(stage="decay")
    assert list(lmi._columns["P > 0"].values()) == [positive]
    assert len(lmi._columns["decay"]) == 2  # read again for the new value
    assert lmi._params["a"].value == 1.5


def test_no_solver_error_messages():
    lmi = lyapunov_problem(np.array([[0.5]]))
    with pytest.raises(CertificationError) as info:
        lmi.solve(solvers=[("SCS", {"max_iters": 5})])
    assert info.value.attempts and "SCS" in str(info.value)


def test_bad_margin():
    with pytest.raises(ValueError, match="margin"):
        LMIProblem(margin=-1.0)


def test_compile_reads_the_stage_once():
    A = np.array([[-1.0, 5.0], [0.0, -2.0]])
    lmi = lyapunov_problem(A)
    assert lmi.compile() > 0
    assert lmi.compile() == 0.0  # nothing it reads has changed
    sol = lmi.solve()
    np.testing.assert_array_equal(sol.P, sol.P.T)
    assert np.linalg.eigvalsh(A.T @ sol.P + sol.P @ A)[-1] < -0.5e-6
    assert lmi.compile() == 0.0
    lmi.invalidate("default")
    assert lmi.compile() > 0


def test_set_parameter_checks_values():
    lmi = LMIProblem()
    lmi.parameter("a", (2,), nonneg=True)
    lmi.parameter("b", (2, 2))
    lmi.set_parameter("a", [0.0, 1.0])
    lmi.set_parameter("b", 3.0)  # broadcast
    np.testing.assert_array_equal(lmi._params["b"].value, np.full((2, 2), 3.0))
    with pytest.raises(ValueError, match="a: the value must be nonnegative"):
        lmi.set_parameter("a", [-1.0, 1.0])
    with pytest.raises(ValueError, match="b: the value must be finite"):
        lmi.set_parameter("b", np.nan)
    with pytest.raises(ValueError, match=r"b: expected shape \(2, 2\)"):
        lmi.set_parameter("b", np.ones(3))
    with pytest.raises(ValueError, match="name: no parameter 'c'"):
        lmi.set_parameter("c", 1.0)


def test_assemble_is_the_symmetric_part_of_the_block_matrix():
    # Against np.block of the full lower-and-upper block matrix, for plain
    # blocks, zero blocks and a stack broadcast with plain ones.

    rng = np.random.default_rng(3)
    A, B, C = (
        rng.standard_normal((3, 3)),
        rng.standard_normal((2, 3)),
        rng.standard_normal((2, 2)),
    )
    M = np.block([[A, B.T], [B, C]])
    np.testing.assert_array_equal(assemble([[A], [B, C]]), 0.5 * (M + M.T))
    Z = np.block([[A, np.zeros((3, 2))], [np.zeros((2, 3)), C]])
    np.testing.assert_array_equal(assemble([[A], [0, C]]), 0.5 * (Z + Z.T))
    S = rng.standard_normal((4, 2, 3))
    stacked = assemble([[A], [S, C]])
    for k in range(4):
        M = np.block([[A, S[k].T], [S[k], C]])
        np.testing.assert_array_equal(stacked[k], 0.5 * (M + M.T))
    with pytest.raises(ValueError, match=r"block \(1, 0\)"):
        assemble([[A], [B.T, C]])
