"""H-infinity output feedback against independent facts.

References: the Riccati conditions of Doyle, Glover, Khargonekar and
Francis (``tests/_hinf_of_reference.py``) for the LTI optimum in continuous
time; for discrete time the same bisection on a continuous plant whose
bilinear image ``z = (1 + s) / (1 - s)`` is designed (the map preserves the
H-infinity norm and maps stabilizing controllers one to one), and
python-control's `hinfsyn` (SLICOT) on the bilinear preimage of a discrete
plant; the discrete H2 optimum from the LQG predictor (two DAREs); closed
loops
built by `control.interconnect` from the returned controller system, their
norms from `control.linfnorm`, their eigenvalues from numpy.
"""

import control as ct
import numpy as np
import pytest
from scipy.linalg import solve_discrete_are

import ctrl_lpv as lpv
from _hinf_of_reference import optimal_gamma
from ctrl_lpv import CertificationError, InfeasibleError

W, Z = ["w0", "w1"], ["z0", "z1"]


def random_plant(seed, n=3, dt=0, vertices=1, stable=False):
    """A normalised plant (``D12 = [0; 1]``, ``D21 = [0, 1]``, ``D12' C1 =
    0``, ``B1 D21' = 0``: the Riccati assumptions), with unit-norm ``B2``
    and ``C2`` and a spectral radius of ``A`` near 1 (stable: shifted by
    -1.5; discrete time: scaled into the unit disk)."""
    rng = np.random.default_rng(seed)
    B2 = rng.standard_normal((n, 1))
    C2 = rng.standard_normal((1, n))
    B2, C2 = B2 / np.linalg.norm(B2), C2 / np.linalg.norm(C2)
    D = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    out = []
    for _ in range(vertices):
        A = rng.standard_normal((n, n)) / np.sqrt(n) - (
            1.5 * np.eye(n) if stable else 0
        )
        if dt:
            A = A / (1.2 * np.abs(np.linalg.eigvals(A)).max())
        B1 = np.hstack([rng.standard_normal((n, 1)) / np.sqrt(n), np.zeros((n, 1))])
        C1 = np.vstack([rng.standard_normal((1, n)) / np.sqrt(n), np.zeros((1, n))])
        out.append(ct.ss(A, np.hstack([B1, B2]), np.vstack([C1, C2]), D, dt,
                         inputs=W + ["u"], outputs=Z + ["y"]))  # fmt: skip
    domain = {"p": (0.0, 1.0)} if vertices == 2 else None
    return lpv.PolytopicStateSpace(out, domain=domain)


def reference_gamma(G):
    A, B, C, _ = ct.ssdata(G)
    return optimal_gamma(A, B[:, :2], B[:, 2:], C[:2], C[2:])


def design(sys, **kw):
    return lpv.hinf_output_feedback(sys, W, "u", Z, "y", **kw)


def loop_by_name(plant, controller):
    """The frozen closed loop w -> z, connected by name by python-control."""
    return ct.interconnect([plant, controller], inplist=W, outlist=Z)


def bilinear(sys):
    """Continuous-time image of a discrete plant under z = (1 + s)/(1 - s)."""
    A, B, C, D = ct.ssdata(sys)
    M = np.linalg.inv(A + np.eye(A.shape[0]))
    return ct.ss(M @ (A - np.eye(A.shape[0])), np.sqrt(2) * M @ B,
                 np.sqrt(2) * C @ M, D - C @ M @ B)  # fmt: skip


@pytest.mark.parametrize(
    ("seeds", "least"),
    [(range(0, 12, 3), 3), pytest.param(range(20), 19, marks=pytest.mark.slow)],
)
def test_lti_optimum_against_the_riccati_conditions(seeds, least):
    """The raw optimum (``backoff=None``) against the DGKF bisection.

    A certified gamma can never be below the true optimum; it must be
    within 1e-3 of it, or the design refuses (CertificationError: some
    plants with gamma in the hundreds defeat the solvers' accuracy at the
    optimum). Every certified closed loop, built by name by python-control,
    has its H-infinity norm at most gamma.
    """
    certified = 0
    for seed in seeds:
        sys = random_plant(seed)
        G = sys.vertices[0]
        gamma_ref = reference_gamma(G)
        try:
            d = design(sys, backoff=None)
        except CertificationError:
            continue
        certified += 1
        assert d.certificate.verified
        assert gamma_ref * (1 - 1e-6) <= d.gamma <= gamma_ref * (1 + 1e-3), seed
        cl = loop_by_name(G, d.controller().at([1.0]))
        assert np.linalg.eigvals(cl.A).real.max() < 0
        assert float(ct.linfnorm(cl)[0]) <= d.gamma * (1 + 1e-9)
    # Measured: 20 of 20 certify, worst gap 7.3e-4 (17 before the margin of
    # the performance blocks was made relative to gamma; docs/output_feedback.rst).
    assert certified >= least


def test_hinfsyn_gamma_is_not_always_achieved():
    """Why the reference is the Riccati bisection: on this plant
    python-control's `hinfsyn` reports a gamma far below the optimum, which
    its controller does not achieve; the library's certified gamma is the
    optimum, achieved."""
    G = random_plant(1).vertices[0]
    _, CL, gamma_hinfsyn, _ = ct.hinfsyn(ct.ss(*ct.ssdata(G)), 1, 1)
    gamma_ref = reference_gamma(G)
    assert gamma_hinfsyn < 0.6 * gamma_ref < gamma_ref < float(ct.linfnorm(CL)[0])
    d = design(random_plant(1), backoff=None)
    assert abs(d.gamma - gamma_ref) <= 1e-3 * gamma_ref


@pytest.mark.parametrize("seed", [0, 1, 5, 12])
def test_default_backoff_is_certified_and_well_conditioned(seed):
    sys = random_plant(seed)
    gamma_ref = reference_gamma(sys.vertices[0])
    raw, backed = design(sys, backoff=1e-3), design(sys)
    assert backed.gamma <= 1.2 * backed.gamma_opt * (1 + 1e-6)
    assert backed.gamma >= gamma_ref * (1 - 1e-6)
    assert backed.condition < raw.condition
    cl = loop_by_name(sys.vertices[0], backed.controller().at([1.0]))
    assert float(ct.linfnorm(cl)[0]) <= backed.gamma
    # The time spent, told as a state-feedback design tells it.
    assert sorted(backed.timing) == ["build", "compile", "solve", "verify"]
    assert min(backed.timing.values()) >= 0.0 and backed.timing["verify"] > 0.0


@pytest.mark.parametrize("seed", range(3))
def test_discrete_time_against_bilinear_hinfsyn(seed):
    sys = random_plant(seed, dt=0.1)
    _, CL, gamma_ref, _ = ct.hinfsyn(bilinear(sys.vertices[0]), 1, 1)
    d = design(sys, backoff=None)
    # At least as good as hinfsyn's own controller, and at its gamma when
    # that controller achieves it (see test_hinfsyn_gamma_is_not_always_...).
    achieved = float(ct.linfnorm(CL)[0])
    assert d.gamma <= achieved * (1 + 1e-3)
    if achieved <= gamma_ref * (1 + 1e-3):
        assert abs(d.gamma - gamma_ref) <= 1e-3 * gamma_ref
    K = d.controller()
    assert K.isdtime(strict=True) and K.dt == 0.1
    cl = loop_by_name(sys.vertices[0], K.at([1.0]))
    assert np.abs(np.linalg.eigvals(cl.A)).max() < 1
    assert float(ct.linfnorm(cl)[0]) <= d.gamma * (1 + 1e-9)


def riccati_plant_with_discrete_image(seed, dt=0.1):
    """A continuous plant under the Riccati assumptions (`random_plant`) and
    its bilinear image ``s = (z - 1) / (z + 1)`` as a discrete plant.

    The image's ``D22`` is ``C2 (I - A)^-1 B2``: ``C2`` is projected (and
    renormalised) so that it vanishes, because the design needs ``D22 = 0``;
    the continuous plant keeps ``D12, D21, D11, D22`` and the orthogonality
    conditions, so the DGKF bisection applies to it unchanged.
    """
    G = random_plant(seed).vertices[0]
    A, B, C, D = ct.ssdata(G)
    n = A.shape[0]
    M = np.linalg.inv(np.eye(n) - A)
    v = M @ B[:, 2]
    C = C.copy()
    C[2] -= (C[2] @ v) / (v @ v) * v
    C[2] /= np.linalg.norm(C[2])
    Gc = ct.ss(A, B, C, D, inputs=W + ["u"], outputs=Z + ["y"])
    Dd = D + C @ M @ B
    assert abs(Dd[2, 2]) < 1e-12
    Dd[2, 2] = 0.0  # rounding of C2 (I - A)^-1 B2 = 0
    Gd = ct.ss((np.eye(n) + A) @ M, np.sqrt(2) * M @ B, np.sqrt(2) * C @ M, Dd,
               dt, inputs=W + ["u"], outputs=Z + ["y"])  # fmt: skip
    return Gc, Gd


def test_discrete_time_optimum_against_the_riccati_conditions():
    """The raw discrete-time optimum against the DGKF bisection.

    Why this is a reference: the bilinear map ``z = (1 + s) / (1 - s)``
    sends the imaginary axis onto the unit circle and the open left
    half-plane onto the open unit disk, so ``Gd(z) = Gc(s)`` has the same
    H-infinity norm as ``Gc`` and stabilizing controllers correspond one to
    one (``Kd(z) = Kc(s)``, the closed loop being the same substitution in
    the linear fractional map); the optimal discrete gamma is therefore the
    optimal continuous gamma of ``Gc``, found by the Riccati bisection
    independently of any LMI solver. The map is checked here on frequency
    responses (``Gd(e^{j theta}) = Gc(j tan(theta / 2))``).

    As in continuous time: every certified gamma is at least the optimum
    and within 1e-3 of it, or the design refuses (CertificationError; two
    of these plants, with optima near 49 and 309, defeat the solvers);
    the closed loop built by python-control from the returned controller is
    Schur with its H-infinity norm at most gamma.
    """
    certified = 0
    for seed in range(8):
        Gc, Gd = riccati_plant_with_discrete_image(seed)
        theta = np.array([0.3, 1.1, 2.9])
        np.testing.assert_allclose(Gd(np.exp(1j * theta)),
                                   Gc(1j * np.tan(theta / 2)), atol=1e-12)  # fmt: skip
        A, B, C, _ = ct.ssdata(Gc)
        gamma_ref = optimal_gamma(A, B[:, :2], B[:, 2:], C[:2], C[2:])
        try:
            d = design(lpv.pss([Gd]), backoff=None)
        except CertificationError:
            continue
        certified += 1
        assert d.certificate.verified
        assert gamma_ref * (1 - 1e-6) <= d.gamma <= gamma_ref * (1 + 1e-3), seed
        cl = loop_by_name(Gd, d.controller().at([1.0]))
        assert cl.isdtime(strict=True)
        assert np.abs(np.linalg.eigvals(cl.A)).max() < 1
        assert float(ct.linfnorm(cl)[0]) <= d.gamma * (1 + 1e-9)
    # Measured: 6 of 8 certify (seeds 3 and 6 refused).
    assert certified >= 5


def test_certificate_holds_when_recomputed_independently():
    """The design's P meets the bounded-real inequality of each vertex loop
    built by python-control (not by the library's closed-loop formula)."""
    sys = random_plant(5, vertices=2, stable=True)
    d = design(sys)
    controller = d.controller()
    for j, p in enumerate((0.0, 1.0)):
        cl = loop_by_name(sys.vertices[j], controller.at({"p": p}))
        A, B, C, D = ct.ssdata(cl)
        # interconnect orders the states plant first, then controller.
        P, g = d.P, d.gamma
        F = np.block([
            [A.T @ P + P @ A, P @ B, C.T],
            [B.T @ P, -g * np.eye(2), D.T],
            [C, D, -g * np.eye(2)],
        ])  # fmt: skip
        assert np.linalg.eigvalsh(F).max() < 0
    assert np.linalg.eigvalsh(d.P).min() > 0


def test_polytopic_frozen_loops_and_time_varying_simulation():
    sys = random_plant(7, vertices=2, stable=True)
    d = design(sys)
    controller = d.controller()
    worst = 0.0
    for p in np.linspace(0.0, 1.0, 21):
        cl = loop_by_name(sys.at({"p": p}), controller.at({"p": p}))
        assert np.linalg.eigvals(cl.A).real.max() < 0
        worst = max(worst, float(ct.linfnorm(cl)[0]))
    assert worst <= d.gamma
    # A fast parameter, scheduled plant and controller, zero input: the
    # state decays (one quadratic Lyapunov function for every trajectory).
    plant = lpv.PolytopicStateSpace(sys.vertices, domain=sys.domain,
                                    scheduling="inputs")  # fmt: skip
    loop = ct.interconnect([plant, controller], inplist=W + ["p"], outlist=Z)
    T = np.linspace(0.0, 10.0, 2001)
    p = 0.5 + 0.5 * np.sign(np.sin(7.0 * T))
    x0 = np.ones(loop.nstates)
    r = ct.input_output_response(loop, T, [np.zeros((2, T.size)), p], x0,
                                 solve_ivp_kwargs={"max_step": 0.01})  # fmt: skip
    assert np.linalg.norm(r.states[:, -1]) < 1e-3 * np.linalg.norm(x0)


def test_common_controller_for_a_constant_A():
    base = random_plant(3)
    G = base.vertices[0]
    A, B, C, D = ct.ssdata(G)
    other = ct.ss(A, B * np.r_[1.0, 0.5, 1.0], C * np.c_[[2.0, 1.0, 1.0]], D,
                  inputs=G.input_labels, outputs=G.output_labels)  # fmt: skip
    sys = lpv.PolytopicStateSpace([G, other], domain={"p": (0.0, 1.0)})
    d = design(sys, gains="common")
    K0, K1 = d.controllers
    for a, b in zip(K0, K1):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)


# ---------------------------------------------------------------- refusals


def test_y_naming_an_input_is_refused():
    with pytest.raises(ValueError, match=r"y: 'u' is an input"):
        lpv.hinf_output_feedback(random_plant(0), W, "u", Z, "u")


def test_unknown_signal_is_refused():
    with pytest.raises(ValueError, match="y: unknown signal 'q'"):
        lpv.hinf_output_feedback(random_plant(0), W, "u", Z, "q")


def test_parameter_dependent_input_matrix_is_refused():
    sys = random_plant(0, vertices=2)
    A, B, C, D = ct.ssdata(sys.vertices[1])
    B = B.copy()
    B[:, 2] *= 2.0
    bad = lpv.PolytopicStateSpace(
        [sys.vertices[0], ct.ss(A, B, C, D, inputs=W + ["u"], outputs=Z + ["y"])],
        domain=sys.domain,
    )
    with pytest.raises(ValueError, match=r"B2 .* differs between vertex 0 and 1"):
        design(bad)


def test_nonzero_D22_is_refused():
    G = random_plant(0).vertices[0]
    A, B, C, D = ct.ssdata(G)
    D = D.copy()
    D[2, 2] = 0.1
    bad = lpv.pss([ct.ss(A, B, C, D, inputs=W + ["u"], outputs=Z + ["y"])])
    with pytest.raises(ValueError, match="D22"):
        design(bad)


def test_undetectable_vertex_is_refused():
    A = np.diag([1.0, -1.0])  # the unstable mode is not seen by y
    B = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])
    D = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    G = ct.ss(A, B, C, D, inputs=W + ["u"], outputs=Z + ["y"])
    with pytest.raises(InfeasibleError, match="detectable"):
        design(lpv.pss([G]))


def test_common_controller_with_varying_A_is_refused():
    with pytest.raises(ValueError, match="gains: .*not a convex problem"):
        design(random_plant(0, vertices=2), gains="common")


@pytest.mark.parametrize(
    ("kw", "match"),
    [(dict(gains="all"), "gains"), (dict(backoff=-1.0), "backoff"),
     (dict(margin=0.0), "margin")],
)  # fmt: skip
def test_bad_options_are_named(kw, match):
    with pytest.raises((ValueError, TypeError), match=match):
        design(random_plant(0), **kw)


def test_synthesize_with_y_is_the_output_feedback_design():
    sys = random_plant(5)
    direct = design(sys)
    via = lpv.synthesize(sys, "u", y="y", objective=lpv.Hinf(W, Z))
    assert isinstance(via, lpv.OutputFeedbackDesign)
    assert abs(via.gamma - direct.gamma) <= 1e-6 * direct.gamma


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        (dict(objective=lpv.Peak(W, Z)), "objective"),
        (dict(objective=lpv.Hinf(W, Z, bound=5.0)), "objective"),
        (dict(objective=lpv.Hinf(W, Z), lyapunov="affine", rate_bounds={"p": 1.0}),
         "lyapunov"),
        (dict(objective=lpv.Hinf(W, Z), constraints=[lpv.Peak(W, Z, bound=9.0)]),
         "constraints"),
    ],
)  # fmt: skip
def test_synthesize_with_y_refuses_what_is_not_implemented(kw, match):
    with pytest.raises(ValueError, match=match):
        lpv.synthesize(random_plant(5), "u", y="y", **kw)


# ---------------------------------------------------------------------- H2


def h2syn_norm(G):
    """Closed-loop H2 norm of python-control's `h2syn` controller (SLICOT
    SB10HD, Riccati based: the LTI optimum)."""
    P = ct.ss(*ct.ssdata(G))
    return float(ct.norm(P.lft(ct.h2syn(P, 1, 1)), 2))


def test_h2_lti_optimum_matches_h2syn():
    """Raw optimum within 1e-3 of h2syn's closed-loop H2 norm, or a refusal;
    never below it (h2syn's controller is optimal)."""
    certified = 0
    for seed in range(8):
        sys = random_plant(seed)
        G = sys.vertices[0]
        reference = h2syn_norm(G)
        try:
            d = lpv.h2_output_feedback(sys, W, "u", Z, "y", backoff=None)
        except CertificationError:
            continue
        certified += 1
        assert d.certificate.verified and d.bounds == {lpv.H2(W, Z): d.gamma}
        assert reference * (1 - 1e-6) <= d.gamma <= reference * (1 + 1e-3), seed
        cl = loop_by_name(G, d.controller().at([1.0]))
        assert np.linalg.eigvals(cl.A).real.max() < 0
        assert float(ct.norm(cl, 2)) <= d.gamma
        assert np.all(d.controllers[0][3] == 0)  # strictly proper
    assert certified >= 6


def lqg_predictor_norm(G, dt):
    """Closed-loop H2 norm of the discrete LQG controller with a one-step
    predictor (two DAREs, scipy), the H2 optimum among strictly proper
    controllers."""
    A, B, C, _ = ct.ssdata(G)
    B1, B2, C1, C2 = B[:, :2], B[:, 2:], C[:2], C[2:]
    X = solve_discrete_are(A, B2, C1.T @ C1, np.eye(1))
    F = np.linalg.solve(np.eye(1) + B2.T @ X @ B2, B2.T @ X @ A)
    S = solve_discrete_are(A.T, C2.T, B1 @ B1.T, np.eye(1))
    L = A @ S @ C2.T @ np.linalg.inv(C2 @ S @ C2.T + np.eye(1))
    K = ct.ss(A - B2 @ F - L @ C2, L, -F, 0, dt, inputs=["y"], outputs=["u"])
    return float(ct.norm(loop_by_name(G, K), 2))


def test_h2_discrete_time_optimum_against_the_lqg_predictor():
    """The raw discrete-time H2 optimum against discrete LQG.

    Why this is a reference: with ``D11 = 0``, ``D12' [C1 D12] = [0 I]`` and
    ``[B1; D21] D21' = [0; I]`` (`random_plant`), the squared H2 norm of a
    discrete closed loop is the stationary ``E[z'z]`` under unit white
    noise ``w``, and among strictly proper controllers (``u_k`` from
    ``y_0 .. y_{k-1}``, as the design's) the separation principle makes the
    LQ gain of the control DARE acting on the one-step Kalman predictor of
    the filter DARE optimal (e.g. Anderson and Moore, *Optimal Filtering*,
    and *Optimal Control: Linear Quadratic Methods*). The reference is that
    controller's closed-loop norm from `control.norm`, independent of the
    design. The bilinear map does not preserve H2 norms, so it is not used.

    Every certified bound is within 1e-3 of the reference and at least it,
    and no returned controller does better than the reference (measured:
    8 of 8 certified, within 2.2e-4).
    """
    certified = 0
    for seed in range(0, 8, 2):
        sys = random_plant(seed, dt=0.1)
        G = sys.vertices[0]
        reference = lqg_predictor_norm(G, 0.1)
        try:
            d = lpv.h2_output_feedback(sys, W, "u", Z, "y", backoff=None)
        except CertificationError:
            continue
        certified += 1
        assert d.certificate.verified
        assert reference * (1 - 1e-6) <= d.gamma <= reference * (1 + 1e-3), seed
        assert np.all(d.controllers[0][3] == 0)  # strictly proper
        cl = loop_by_name(G, d.controller().at([1.0]))
        assert np.abs(np.linalg.eigvals(cl.A)).max() < 1
        assert reference * (1 - 1e-6) <= float(ct.norm(cl, 2)) <= d.gamma
    assert certified >= 3


def test_h2_default_backoff_bounds_the_frozen_norms():
    sys = random_plant(4, vertices=2, stable=True)
    d = lpv.synthesize(sys, "u", y="y", objective=lpv.H2(W, Z))
    assert d.gamma <= 1.2 * d.gamma_opt * (1 + 1e-6)
    controller = d.controller()
    for p in np.linspace(0.0, 1.0, 11):
        cl = loop_by_name(sys.at({"p": p}), controller.at({"p": p}))
        assert float(ct.norm(cl, 2)) <= d.gamma


def test_h2_needs_no_feedthrough_from_w_to_z():
    G = random_plant(0).vertices[0]
    A, B, C, D = ct.ssdata(G)
    D = D.copy()
    D[0, 0] = 0.5
    bad = lpv.pss([ct.ss(A, B, C, D, inputs=W + ["u"], outputs=Z + ["y"])])
    with pytest.raises(ValueError, match="D11"):
        lpv.h2_output_feedback(bad, W, "u", Z, "y")
