"""`ctrl_lpv.synthesize`: routing, bad input, parameter-dependent Lyapunov functions.

The H2 and discrete-time references are in test_h2.py and
test_discrete_synthesis.py, the literature PDL examples in test_pdl.py.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv


def _oscillator(kmax=10.0, dt=0):
    """``x'' + 0.5 x' + k x = u`` for ``k`` in ``[1, kmax]`` (time-invariant k).

    Every frozen system is stable, but no constant Lyapunov matrix exists for
    ``kmax = 10``: the stiffness range is too wide for the damping.
    """
    vertices = [
        ct.ss([[0.0, 1.0], [-k, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]], 0, dt=dt)
        for k in (1.0, kmax)
    ]
    return lpv.PolytopicStateSpace(vertices, domain=lpv.box(k=(1.0, kmax)))


def _frozen_worst(kmax=10.0):
    grid = np.linspace(1.0, kmax, 400)
    return max(
        ct.linfnorm(ct.ss([[0.0, 1.0], [-k, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]], 0))[0]
        for k in grid
    )


@pytest.fixture(scope="module")
def plant():
    """Two vertices, w and u inputs, z = [x1; u]."""
    A0 = np.array([[0.0, 1.0], [-2.0, -0.4]])
    A1 = np.array([[0.0, 0.0], [-1.5, 0.0]])
    B = np.array([[0.0, 0.0], [1.0, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 0.0]])
    D = np.array([[0.0, 0.0], [0.0, 1.0]])
    vertices = [
        ct.ss(A0 + p * A1, B, C, D, inputs=["w", "u"], outputs=["y", "uz"])
        for p in (-1.0, 1.0)
    ]
    return lpv.PolytopicStateSpace(vertices, domain=lpv.box(p=(-1.0, 1.0)))


def test_paper_case_goes_to_the_paper_engine(plant):
    design = lpv.synthesize(plant, "u", objective=lpv.Hinf("w"), gains="scheduled")
    reference = lpv.gain_scheduled_hinf(plant, "w", "u")
    assert design.method == "Theorem 2"
    assert design.gamma == pytest.approx(reference.gamma, rel=1e-9)
    assert design.bounds == {lpv.Hinf("w"): design.gamma}


def test_pdl_stability_where_no_constant_lyapunov_matrix_exists():
    sys = _oscillator()
    with pytest.raises(lpv.SynthesisError):
        lpv.quadratic_stability(sys)
    result = lpv.quadratic_stability(sys, lyapunov="affine", rate_bounds={"k": 0.0})
    P_lower, P_upper = result.P
    # Independent check: P(k) = delta P_lower + (1 - delta) P_upper > 0 with
    # A(k)' P(k) + P(k) A(k) < 0 at every frozen k of a fine grid.
    for k in np.linspace(1.0, 10.0, 201):
        delta = (10.0 - k) / 9.0
        P = delta * P_lower + (1 - delta) * P_upper
        assert result.lyapunov_matrix({"k": k}) == pytest.approx(P, rel=1e-12)
        A = np.array([[0.0, 1.0], [-k, -0.5]])
        assert np.linalg.eigvalsh(P).min() > 0
        assert np.linalg.eigvalsh(A.T @ P + P @ A).max() < 0


def test_pdl_gain_bound_tight_for_time_invariant_and_growing_with_the_rate():
    sys = _oscillator()
    worst = _frozen_worst()
    zero = np.zeros((1, 2))
    bounds = [
        lpv.l2_gain_bound(
            sys, zero, 0, 0, 0, lyapunov="affine", rate_bounds={"k": nu}
        ).gamma
        for nu in (0.0, 0.3, 1.0)
    ]
    # Never below the worst frozen norm (a lower bound of every valid bound
    # for time-invariant parameters), and close to it at nu = 0.
    assert bounds[0] >= worst * (1 - 1e-6)
    assert bounds[0] <= worst * 1.01
    assert bounds[0] <= bounds[1] * (1 + 1e-6) <= bounds[2] * (1 + 1e-6)


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_pdl_designs_bound_their_frozen_closed_loops(plant, gains):
    design = lpv.synthesize(
        plant, "u", objective=lpv.Hinf("w"), gains=gains, lyapunov="affine",
        rate_bounds={"p": 0.5},
    )  # fmt: skip
    assert design.certificate.verified and design.lyapunov == "affine"
    for p in np.linspace(-1.0, 1.0, 21):
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        assert np.linalg.eigvals(A).real.max() < 0
        assert ct.linfnorm(ct.ss(A, B, C, D))[0] < design.gamma
    controller = design.controller()
    x = np.array([0.3, -0.2])
    inputs = np.r_[x, 0.4] if gains == "scheduled" else x
    assert controller.output(0, [], inputs) == pytest.approx(-design.gain(0.4) @ x)


def test_mixed_h2_with_hinf_constraint(plant):
    bound = 1.5
    design = lpv.synthesize(
        plant, "u", objective=lpv.H2("w"), constraints=[lpv.Hinf("w", bound=bound)]
    )
    assert design.bounds[lpv.Hinf("w", bound=bound)] < bound
    for p in np.linspace(-1.0, 1.0, 11):
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        cl = ct.ss(A, B, C, D)
        assert ct.linfnorm(cl)[0] < bound
        assert ct.norm(cl, 2) <= design.gamma


@pytest.mark.parametrize(
    ("kwargs", "error", "name"),
    [
        ({"gains": "vertex"}, ValueError, "gains"),
        ({"objective": "Hinf"}, TypeError, "objective"),
        ({"constraints": [5]}, TypeError, "constraints"),
        ({"constraints": 5}, TypeError, "constraints"),
        ({"constraints": [lpv.Hinf("w")]}, ValueError, "constraints"),
        (
            {"constraints": [lpv.GainBound(1.0), lpv.GainBound(2.0)]},
            ValueError,
            "constraints",
        ),
        ({"lyapunov": "affine"}, ValueError, "rate_bounds"),
        ({"lyapunov": "quadratic"}, ValueError, "lyapunov"),
        ({"lyapunov": "affine", "rate_bounds": {"q": 0.0}}, ValueError, "rate_bounds"),
        ({"lyapunov": "affine", "rate_bounds": {"p": -1.0}}, ValueError, "rate_bounds"),
        ({"lyapunov": "affine", "rate_bounds": [0.0]}, TypeError, "rate_bounds"),
        ({"lyapunov": "affine", "rate_bounds": {"p": "0"}}, TypeError, "rate_bounds"),
        (
            {"objective": lpv.H2("w"), "rate_bounds": {"p": 0.0}},
            ValueError,
            "rate_bounds",
        ),
        (
            {
                "lyapunov": "affine",
                "rate_bounds": {"p": 0.0},
                "constraints": [lpv.disk(5.0)],
            },
            ValueError,
            "constraints",
        ),
    ],
)
def test_bad_input_names_the_argument(plant, kwargs, error, name):
    with pytest.raises(error, match=name):
        lpv.synthesize(plant, "u", **kwargs)


def test_specs_validate_their_arguments():
    with pytest.raises(ValueError, match="bound"):
        lpv.Hinf("w", bound=-1.0)
    with pytest.raises(TypeError, match="bound"):
        lpv.GainBound("1")
    with pytest.raises(TypeError, match="w"):
        lpv.H2(w=1.5)


def test_h2_refuses_feedthrough_in_continuous_time():
    sys = lpv.PolytopicStateSpace(
        [ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0]], [[1.0, 0.0]])]
    )
    with pytest.raises(ValueError, match="H2"):
        lpv.h2_state_feedback(sys, w=0, u=1)


def test_affine_lyapunov_needs_a_box():
    vertices = [ct.ss([[a]], [[1.0]], [[1.0]], 0) for a in (-1.0, 1.0, 0.5)]
    sys = lpv.PolytopicStateSpace(vertices, domain=lpv.Simplex(3))
    with pytest.raises(ValueError, match="ParameterBox"):
        lpv.synthesize(sys, 0, lyapunov="affine", rate_bounds={})


def test_discrete_regions_are_disks_inside_the_unit_circle():
    sys = _oscillator(dt=0.1)
    with pytest.raises(ValueError, match="constraints"):
        lpv.synthesize(sys, 0, constraints=[lpv.halfplane(0.1)])
    with pytest.raises(ValueError, match="unit circle"):
        lpv.synthesize(sys, 0, constraints=[lpv.disk(0.5, 0.7)])


def test_two_specs_of_one_kind_on_different_channels(plant):
    bound = 2.0
    design = lpv.synthesize(
        plant,
        "u",
        objective=lpv.Hinf("w", "y"),
        constraints=[lpv.Hinf("w", "uz", bound=bound)],
    )
    assert design.bounds[lpv.Hinf("w", "uz", bound=bound)] < bound
    for p in np.linspace(-1.0, 1.0, 11):
        # the objective's channel, w -> y
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        assert ct.linfnorm(ct.ss(A, B, C, D))[0] <= design.gamma
        # w -> uz = u = -K(p) x, written from the plant's data.
        K = design.gain({"p": p})
        assert ct.linfnorm(ct.ss(A, B, -K, 0))[0] < bound


def test_time_limit_refuses_before_compiling(plant):
    with pytest.raises(lpv.CertificationError, match="time_limit"):
        lpv.synthesize(
            plant, "u", objective=lpv.H2("w"), gains="scheduled", lyapunov="affine",
            rate_bounds={"p": 1.0}, time_limit=1e-9,
        )  # fmt: skip


@pytest.mark.slow  # about 70 s: 7 eps x 4 rungs x 3 W bounds, each refuted
def test_extended_lmis_refusal_is_not_a_proof(plant):
    # Far below what any gain reaches (the H-infinity optimum is about 1).
    # The extended LMIs are posed at one fixed eps each: a refutation of them
    # is not a refutation of the problem, so the refusal must not claim it.
    with pytest.raises(lpv.SynthesisError) as info:
        lpv.synthesize(
            plant, "u", objective=lpv.Hinf("w", bound=1e-3), lyapunov="affine",
            rate_bounds={"p": 0.0},
        )  # fmt: skip
    assert isinstance(info.value, lpv.CertificationError)


def _frozen_loop(Acl, K, W):
    """The fields the constraint specs' residuals read, for a fixed W."""
    from ctrl_lpv.synthesis.frozen import FrozenLoop

    P = np.linalg.inv(W)
    zero = np.zeros_like(W)
    B2 = np.ones((Acl.shape[0], K.shape[0]))
    eig = np.linalg.eigvals(Acl)
    return FrozenLoop(Acl + B2 @ K, B2, K, Acl, eig, P, zero, W, zero)


def test_region_residual_is_a_fact_about_the_eigenvalues():
    from scipy.linalg import solve_continuous_lyapunov

    Acl = np.array([[-1.0, 3.0], [0.0, -2.0]])
    K = np.zeros((1, 2))
    # (Acl + d I) W + W (Acl + d I)' = -I: the decay-d region LMI holds.
    W = solve_continuous_lyapunov(Acl + 0.5 * np.eye(2), -np.eye(2))
    loop = _frozen_loop(Acl, K, W)
    assert lpv.halfplane(0.5).residual(loop, True) < 0
    # The eigenvalue -1 is outside Re(s) < -1.5 whatever W is.
    assert lpv.halfplane(1.5).residual(loop, True) > 0
    assert lpv.disk(2.5).residual(loop, True) < lpv.disk(1.5).residual(loop, True)
    assert lpv.disk(1.5).residual(loop, True) > 0


def test_gain_bound_residual_is_the_relative_excess_of_the_norm():
    K = np.array([[3.0, 4.0]])  # ||K||_2 = 5
    loop = _frozen_loop(-np.eye(2), K, np.eye(2))
    assert lpv.GainBound(4.0).residual(loop, True) == pytest.approx(0.25)
    assert lpv.GainBound(10.0).residual(loop, True) == pytest.approx(-0.5)


def test_general_engine_regions_hold_on_frozen_loops(plant):
    design = lpv.synthesize(
        plant, "u", objective=lpv.H2("w"), constraints=[lpv.halfplane(1.0),
        lpv.sector(np.pi / 4), lpv.halfplane(1.0)], gains="scheduled",
    )  # fmt: skip
    for p in np.linspace(-1.0, 1.0, 11):
        A = design.closed_loop({"p": p}).A
        eig = np.linalg.eigvals(A)
        assert eig.real.max() < -1.0
        assert np.all(np.abs(eig.imag) < -eig.real)
