"""Certified LPV observers (`ctrl_lpv.observer`) against independent facts.

References: the Kalman filters of python-control (`control.lqe`,
`control.dlqe`), a Hamiltonian bisection written here for the H-infinity
filter, eigenvalues and norms of the frozen error systems from numpy and
`control`, and simulations of the plant with the estimator connected by
name.
"""

import control as ct
import numpy as np
import pytest
import scipy.linalg as sla

import ctrl_lpv as lpv
from ctrl_lpv.estimation.checks import error_certificate
from ctrl_lpv.estimation.duality import ErrorData


def _noisy_plant(seed, n=3, nd=2, ny=1, dt=0):
    """``x' = A x + G d``, ``y = C x + v``: inputs d0.., v0.. (unit noises)."""
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    if dt:
        A *= 1.1 / max(abs(np.linalg.eigvals(A)))  # one mode or more unstable
    G = rng.normal(size=(n, nd))
    C = rng.normal(size=(ny, n))
    B = np.hstack([G, np.zeros((n, ny))])
    D = np.hstack([np.zeros((ny, nd)), np.eye(ny)])
    inputs = [f"d{i}" for i in range(nd)] + [f"v{i}" for i in range(ny)]
    outputs = [f"y{i}" for i in range(ny)]
    sys = ct.ss(A, B, C, D, inputs=inputs, outputs=outputs, dt=dt)
    return lpv.PolytopicStateSpace([sys]), A, G, C, outputs


@pytest.mark.parametrize("seed, ny", [(1, 1), (2, 2), (3, 1)])
def test_h2_continuous_matches_kalman_filter(seed, ny):
    # The steady Kalman filter with unit noise intensities minimises the
    # H2 norm from (d, v) to e = x - x_hat: its square is trace(P).
    plant, A, G, C, y = _noisy_plant(seed, ny=ny)
    L_ref, P, _ = ct.lqe(A, G, C, np.eye(G.shape[1]), np.eye(ny))
    reference = np.sqrt(np.trace(P))
    raw = lpv.observer(plant, y, objective=lpv.H2(), backoff=None)
    assert raw.gamma == pytest.approx(reference, rel=1e-5)
    np.testing.assert_allclose(raw.L[0], L_ref, rtol=1e-3, atol=1e-3 * abs(L_ref).max())
    design = lpv.observer(plant, y, objective=lpv.H2())
    assert design.gamma >= reference
    assert ct.system_norm(design.closed_loop(), p=2) <= design.gamma


@pytest.mark.parametrize("seed", [4, 5])
def test_h2_discrete_matches_kalman_predictor(seed):
    # dlqe solves the DARE of the filter (`dare(A', C', G G', R)`): P is
    # the a-priori error covariance and L = A P C' (C P C' + R)^-1 the gain
    # of the predictor x_hat[k+1] = A x_hat + L (y - C x_hat); trace(P) is
    # the squared H2 norm of the optimal predictor's error system.
    plant, A, G, C, y = _noisy_plant(seed, dt=0.1)
    L_ref, P, _ = ct.dlqe(A, G, C, np.eye(G.shape[1]), np.eye(1))
    reference = np.sqrt(np.trace(P))
    raw = lpv.observer(plant, y, objective=lpv.H2(), backoff=None)
    assert raw.gamma == pytest.approx(reference, rel=1e-5)
    np.testing.assert_allclose(raw.L[0], L_ref, rtol=1e-3, atol=1e-3)
    error = raw.closed_loop()
    assert max(abs(np.linalg.eigvals(error.A))) < 1


def _hinf_filter_reference(A, G, C, lo=1e-3, hi=1e4, rtol=1e-9):
    """Smallest gamma of an observer gain for ``(d, v) -> x - x_hat``.

    The transpose is the state-feedback problem ``x' = A' x + I w + C' u``,
    ``z = [G'; 0] x + [0; I] u`` (``D12' C1 = 0``, ``D12' D12 = I``), whose
    static-gain optimum is the smallest gamma for which the Riccati
    equation ``A_d' X + X A_d + X (I / gamma^2 - C' C) X + G G' = 0``
    (``A_d = A'``) has a stabilising solution ``X >= 0``: bisection on its
    Hamiltonian ``[[A_d, R], [-G G', -A_d']]``.
    """
    n = A.shape[0]

    def feasible(gamma):
        R = np.eye(n) / gamma**2 - C.T @ C
        H = np.block([[A.T, R], [-G @ G.T, -A]])
        if np.min(abs(np.linalg.eigvals(H).real)) < 1e-9 * np.linalg.norm(H):
            return False
        T, Z, sdim = sla.schur(H, sort="lhp")
        if sdim != n:
            return False
        X1, X2 = Z[:n, :n], Z[n:, :n]
        if np.linalg.cond(X1) > 1e12:
            return False
        X = X2 @ np.linalg.inv(X1)
        X = 0.5 * (X + X.T)
        return np.linalg.eigvalsh(X).min() >= -1e-9 * max(1, np.linalg.norm(X))

    assert feasible(hi) and not feasible(lo)
    while hi - lo > rtol * hi:
        mid = np.sqrt(lo * hi)
        lo, hi = (lo, mid) if feasible(mid) else (mid, hi)
    return hi


@pytest.mark.parametrize("seed", [1, 6])
def test_hinf_continuous_matches_riccati_bisection(seed):
    plant, A, G, C, y = _noisy_plant(seed)
    reference = _hinf_filter_reference(A, G, C)
    raw = lpv.observer(plant, y, objective=lpv.Hinf(), backoff=None)
    assert raw.gamma == pytest.approx(reference, rel=1e-4)
    assert raw.gamma >= reference * (1 - 1e-6)
    design = lpv.observer(plant, y, objective=lpv.Hinf())
    assert design.gamma >= reference
    # The certified bound covers the error system that runs.
    assert ct.linfnorm(design.closed_loop())[0] <= design.gamma


def _scheduled_plant(dt=0):
    """Two-state plant with a stiffness k in [1, 4]; the position is
    measured (C_y constant), a force d and sensor noise v are unknown."""
    base = ct.ss(
        [[0.0, 1.0], [-1.0, 0.4]] if not dt else [[1.0, 0.1], [-0.1, 1.02]],
        [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]] if not dt else
        [[0.0, 0.0, 0.0], [0.1, 0.1, 0.0]],
        [[1.0, 0.0]], [[0.0, 0.0, 1.0]],
        inputs=["u", "d", "v"], outputs=["pos"], states=["x", "vel"], dt=dt,
    )  # fmt: skip
    term = ([[0.0, 0.0], [-1.0, 0.0]] if not dt else [[0.0, 0.0], [-0.1, 0.0]],
            0, 0, 0)  # fmt: skip
    return lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": (1.0, 4.0)})


@pytest.mark.parametrize("gains", ["scheduled", "common"])
@pytest.mark.parametrize("dt", [0, 0.1])
def test_polytopic_frozen_error_dynamics(gains, dt):
    plant = _scheduled_plant(dt)
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"],
                          objective=lpv.Hinf(), gains=gains)  # fmt: skip
    assert design.certificate.verified
    assert len(design.L) == (2 if gains == "scheduled" else 1)
    rng = np.random.default_rng(0)
    for k in [1.0, 4.0, *rng.uniform(1.0, 4.0, 10)]:
        error = design.closed_loop({"k": k})
        lam = np.linalg.eigvals(error.A)
        assert (lam.real.max() < 0) if not dt else (abs(lam).max() < 1)
        assert ct.linfnorm(error)[0] <= design.gamma * (1 + 1e-9)


def test_certificate_recomputed_with_numpy():
    # The Lyapunov and bounded-real inequalities of the error system with
    # the returned P and gains, written again here.
    plant = _scheduled_plant()
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.Hinf())
    P, g = design.P, design.gamma
    assert np.linalg.eigvalsh(P).min() > 0
    for j, (A, B, C, _) in enumerate(plant.vertex_data()):
        L = design.L[j]
        Ae, Be = A - L @ C, B[:, [1, 2]] - L @ np.array([[0.0, 1.0]])
        M = np.block([[Ae.T @ P + P @ Ae + np.eye(2), P @ Be],
                      [Be.T @ P, -g**2 * np.eye(2)]])  # fmt: skip
        assert np.linalg.eigvalsh(M).max() < 0


def test_certificate_refutes_a_wrong_gain():
    # The checks can fail: a gain that leaves the error unstable.
    plant = _scheduled_plant()
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.Hinf())
    err = ErrorData.of(plant, design.channels)
    bad = tuple(-L for L in design.L)
    certificate = error_certificate(err, bad, design.P, continuous=True,
                                    kind="Hinf", gamma=design.gamma)  # fmt: skip
    assert not certificate.verified
    assert any(c.what.startswith("frozen error eigenvalues")
               for c in certificate.failed)  # fmt: skip


def test_pole_region_of_the_error():
    plant = _scheduled_plant()
    design = lpv.observer(plant, "pos", u="u", constraints=[lpv.halfplane(2.0)])
    for k in np.linspace(1.0, 4.0, 7):
        assert np.linalg.eigvals(design.closed_loop({"k": k}).A).real.max() < -2.0


@pytest.mark.filterwarnings("ignore::ctrl_lpv.ParameterClipWarning")  # k = 0 at
# interconnect's linearization point, projected onto [1, 4]
@pytest.mark.parametrize("dt", [0, 0.1])
def test_estimator_converges_in_simulation(dt):
    # The plant scheduled by an input k(t), the estimator connected by
    # name: the estimate converges to the state for a time-varying k.
    plant = _scheduled_plant(dt).scheduled("inputs")
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.Hinf())
    est = design.estimator()
    assert est.input_labels == ["pos", "u", "k"] and est.name == "estimator"
    with pytest.raises(TypeError, match="^name:"):
        design.estimator(name=3)
    assert est.output_labels == ["x_hat", "vel_hat"]
    loop = ct.interconnect(
        [plant, est], inplist=["u", "d", "v", "k"],
        outlist=["pos", "x_hat", "vel_hat"],
    )  # fmt: skip
    T = np.arange(0, 20.0, dt if dt else 0.01)
    U = np.vstack([np.sin(T), 0 * T, 0 * T, 2.5 + 1.5 * np.sin(0.7 * T)])
    x0 = np.concatenate([[1.0, -0.5], [0.0, 0.0]])
    response = ct.input_output_response(loop, T, U, x0)
    # The plant measures only its position: its states are read from the
    # loop's state vector (plant first), the estimates from the outputs.
    x = response.states[:2]
    xhat = response.outputs[1:]
    np.testing.assert_allclose(xhat, response.states[2:])
    e0 = np.linalg.norm(x[:, 0] - xhat[:, 0])
    assert np.linalg.norm(x[:, -1] - xhat[:, -1]) < 1e-3 * e0


def test_refuses_undetectable_vertex():
    # An unstable mode that the measurement does not see, at one vertex.
    v1 = ct.ss([[1.0, 0.0], [0.0, -1.0]], [[1.0], [1.0]], [[1.0, 1.0]], 0)
    v2 = ct.ss([[1.0, 0.0], [0.0, -1.0]], [[1.0], [1.0]], [[0.0, 1.0]], 0)
    plant = lpv.pss([v1, v2], {"p": (0.0, 1.0)}, inputs="u", outputs="y")
    with pytest.raises(lpv.InfeasibleError, match="vertex 1 .*not detectable"):
        lpv.observer(plant, "y", gains="common")


def test_refuses_undetectable_discrete_mode():
    # |lambda| = 1.2 unobserved in discrete time (stable in continuous time
    # terms would be irrelevant: the test is |lambda| >= 1).
    v = ct.ss([[1.2, 0.0], [0.0, 0.5]], [[1.0], [1.0]], [[0.0, 1.0]], 0, dt=0.1)
    with pytest.raises(lpv.InfeasibleError, match="vertex 0 .*not detectable"):
        lpv.observer(lpv.PolytopicStateSpace([v]), 0)
    # ...while a stable unobserved mode is fine.
    v = ct.ss([[0.5, 0.0], [0.0, 1.2]], [[1.0], [1.0]], [[0.0, 1.0]], 0, dt=0.1)
    assert lpv.observer(lpv.PolytopicStateSpace([v]), 0).certificate.verified


def test_refuses_parameter_dependent_measurement_with_scheduled_gains():
    base = ct.ss([[0.0, 1.0], [-1.0, -1.0]], [[0.0], [1.0]], [[1.0, 0.0]], 0,
                 inputs="u", outputs="pos")  # fmt: skip
    plant = lpv.PolytopicStateSpace.from_affine(
        base, {"c": (0, 0, [[1.0, 0.0]], 0)}, {"c": (0.0, 1.0)}
    )
    with pytest.raises(ValueError, match="^y: C_y .*gains='common'"):
        lpv.observer(plant, "pos", u="u")
    design = lpv.observer(plant, "pos", u="u", gains="common")
    for c in (0.0, 0.5, 1.0):
        assert np.linalg.eigvals(design.closed_loop({"c": c}).A).real.max() < 0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"y": "u"}, "^y: unknown signal"),
        ({"y": None}, "^y: name"),
        ({"gains": "vertex"}, "^gains:"),
        ({"lyapunov": "quadratic"}, "^lyapunov:"),
        ({"lyapunov": "affine", "gains": "common"}, "^rate_bounds:"),
        ({"lyapunov": "affine", "rate_bounds": {"k": 1.0}}, "^gains:"),
        (
            {
                "lyapunov": "affine",
                "rate_bounds": {"k": 1.0},
                "gains": "common",
                "constraints": [lpv.halfplane(1.0)],
            },
            "^constraints:",
        ),  # fmt: skip
        ({"rate_bounds": {"k": 1.0}}, "^rate_bounds:"),
        ({"w": "d"}, "^w, z:"),
        ({"objective": lpv.Hinf(w="d")}, "^objective:"),
        ({"objective": lpv.Hinf(), "w": "u", "u": "u"}, "^w, u:"),
        ({"constraints": [lpv.GainBound(1.0)]}, "^constraints:"),
    ],
)
def test_bad_arguments_are_named(kwargs, match):
    plant = _scheduled_plant()
    kwargs = {"y": "pos", **kwargs}
    with pytest.raises((ValueError, TypeError), match=match):
        lpv.observer(plant, **kwargs)


def test_polytopic_h2_bound_covers_frozen_norms():
    plant = _scheduled_plant()
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.H2())
    assert design.bounds == {lpv.H2(): design.gamma}
    for k in np.linspace(1.0, 4.0, 13):
        assert ct.system_norm(design.closed_loop({"k": k}), p=2) <= design.gamma


def test_refusal_of_the_dual_says_it_is_the_observer():
    plant, A, G, C, y = _noisy_plant(1)
    reference = _hinf_filter_reference(A, G, C)
    with pytest.raises(lpv.SynthesisError, match=r"(?s)observer: this is the dual"):
        lpv.observer(plant, y, objective=lpv.Hinf(bound=0.5 * reference))


def test_affine_lyapunov_with_rate_bound():
    # A common gain certified with P(p) multi-affine for |dk/dt| <= 0.5.
    plant = _scheduled_plant()
    kwargs = dict(u="u", w=["d", "v"], objective=lpv.Hinf(), gains="common")
    design = lpv.observer(plant, "pos", lyapunov="affine", rate_bounds={"k": 0.5},
                          **kwargs)  # fmt: skip
    assert design.certificate.verified and design.rate_bounds == {"k": 0.5}
    worst = max(ct.linfnorm(design.closed_loop({"k": k}))[0]
                for k in np.linspace(1.0, 4.0, 31))  # fmt: skip
    assert worst <= design.gamma
    # The primal rate-bounded bounded-real inequality of the error system,
    # written again here, at the vertices and both signs of the rate:
    # [[A'P + PA + dP/dt, P B, C'], [B'P, -I, 0], [C, 0, -gamma^2 I]] < 0.
    P0, P1 = design.P
    dP = (P1 - P0) / 3.0  # dP/dk over k in [1, 4]
    g, L = design.gamma, design.L[0]
    for j, (A, B, C, D) in enumerate(plant.vertex_data()):
        Ae, Be, P = A - L @ C, B[:, [1, 2]] - L @ D[:, [1, 2]], design.P[j]
        np.testing.assert_allclose(design.lyapunov_matrix({"k": 1.0 + 3 * j}), P)
        for rate in (-0.5, 0.5):
            M = np.block([
                [Ae.T @ P + P @ Ae + rate * dP, P @ Be, np.eye(2)],
                [Be.T @ P, -np.eye(2), np.zeros((2, 2))],
                [np.eye(2), np.zeros((2, 2)), -(g**2) * np.eye(2)],
            ])  # fmt: skip
            assert np.linalg.eigvalsh(M).max() < 0
    # With a time-invariant parameter the bound is close to the worst
    # frozen norm, and never below it.
    frozen = lpv.observer(plant, "pos", lyapunov="affine", rate_bounds={"k": 0.0},
                          **kwargs)  # fmt: skip
    worst = max(ct.linfnorm(frozen.closed_loop({"k": k}))[0]
                for k in np.linspace(1.0, 4.0, 31))  # fmt: skip
    assert worst <= frozen.gamma <= 1.01 * worst


def test_affine_lyapunov_refused_in_discrete_time():
    with pytest.raises(ValueError, match="^lyapunov: 'affine' is for continuous"):
        lpv.observer(_scheduled_plant(0.1), "pos", gains="common",
                     lyapunov="affine", rate_bounds={"k": 0.1})  # fmt: skip


@pytest.mark.filterwarnings("ignore::ctrl_lpv.ParameterClipWarning")
def test_affine_estimator_converges_within_the_rate_bound():
    plant = _scheduled_plant().scheduled("inputs")
    design = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.Hinf(),
                          gains="common", lyapunov="affine",
                          rate_bounds={"k": 0.5})  # fmt: skip
    loop = ct.interconnect([plant, design.estimator()], inplist=["u", "d", "v", "k"],
                           outlist=["x_hat", "vel_hat"])  # fmt: skip
    # (The plant is open-loop unstable: a long horizon would measure the
    # integrator's relative error on growing states, not the observer.)
    T = np.arange(0, 20.0, 0.01)
    k = 2.5 + 1.5 * np.sin(0.3 * T)  # |dk/dt| <= 0.45
    U = np.vstack([np.sin(T), 0 * T, 0 * T, k])
    response = ct.input_output_response(loop, T, U, [1.0, -0.5, 0.0, 0.0])
    error = response.states[:2] - response.states[2:]
    assert np.linalg.norm(error[:, -1]) < 1e-3 * np.linalg.norm(error[:, 0])


def test_given_bound_is_met():
    plant, A, G, C, y = _noisy_plant(6)
    reference = _hinf_filter_reference(A, G, C)
    design = lpv.observer(plant, y, objective=lpv.Hinf(bound=1.5 * reference))
    assert design.gamma < 1.5 * reference
    assert ct.linfnorm(design.closed_loop())[0] < 1.5 * reference


def test_check_detectability_is_the_dual_pbh_test():
    # Detectable although not observable: the unobserved mode is stable.
    A = np.array([[1.0, 0.0], [0.0, -2.0]])
    sys = lpv.PolytopicStateSpace([ct.ss(A, [[1.0], [1.0]], [[1.0, 0.0]], 0)])
    assert lpv.check_detectability(sys, 0) == ()
    # The same plant measuring the stable state only: the mode 1 is unseen.
    sys = lpv.PolytopicStateSpace([ct.ss(A, [[1.0], [1.0]], [[0.0, 1.0]], 0)])
    with pytest.raises(lpv.InfeasibleError, match=r"eigenvalue 1 \(Re\(lambda\)"):
        lpv.check_detectability(sys, 0)
    # A marginal mode (lambda = 0) unseen is refused too.
    sys = lpv.PolytopicStateSpace(
        [ct.ss([[0.0, 0.0], [0.0, -1.0]], [[1.0], [1.0]], [[0.0, 1.0]], 0)]
    )
    with pytest.raises(lpv.InfeasibleError, match="eigenvalue 0 "):
        lpv.check_detectability(sys, 0)
