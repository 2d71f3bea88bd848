"""Discrete-time polytopic systems, sampling, controllers and frozen sweeps.

Expected values come from python-control on frozen systems
(`control.sample_system`, `control.dlqr`, `control.linfnorm`), from
``scipy.linalg.expm`` and from recursions ``x[k+1] = A x[k] + B u[k]``
written here by hand.
"""

import copy
import dataclasses
import itertools
import types
import warnings

import control as ct
import numpy as np
import pytest
import scipy.linalg

import ctrl_lpv as lpv
from ctrl_lpv.discretization import DiscretizationBound
from ctrl_lpv.exceptions import NominalPointWarning

DT = 0.1


def a_of(p):
    """Discrete ``A(p)`` of the one-parameter example, written by hand."""
    return np.array([[1.0, DT], [-DT * p, 1.0 - 0.2 * DT]])


B_DT = np.array([[0.0], [DT]])


@pytest.fixture
def dsys():
    """Discrete-time plant over p in [1, 4], all states measured."""
    vertices = [
        ct.ss(a_of(p), B_DT, np.eye(2), np.zeros((2, 1)), dt=DT) for p in (1.0, 4.0)
    ]
    return lpv.pss(
        vertices, {"p": (1.0, 4.0)}, inputs=["u"], outputs=["x", "v"],
        states=["x", "v"], name="plant",
    )  # fmt: skip


# ----------------------------------------------------------------------
# The timebase
# ----------------------------------------------------------------------
def test_timebase_is_kept(dsys):
    assert dsys.dt == DT and dsys.isdtime() and dsys.isdtime(strict=True)
    assert not dsys.isctime()
    assert all(v.dt == DT for v in dsys.vertices)
    frozen = dsys.at(2.5)
    assert frozen.dt == DT
    np.testing.assert_allclose(frozen.A, a_of(2.5), atol=1e-15)
    for other in (
        dsys.scheduled("inputs"),
        copy.copy(dsys),
        copy.deepcopy(dsys),
        -dsys,
        dsys * 2.0,
        dsys[0, 0],
        dsys.append(dsys),
    ):
        assert other.dt == DT and other.at(2.5).dt == DT
    assert "dt = 0.1" in str(dsys)
    assert "dt=0.1" in repr(dsys)
    lin = dsys.linearize([0.0, 0.0], [0.0], params={"p": 4.0})
    assert lin.dt == DT
    np.testing.assert_allclose(lin.A, a_of(4.0), atol=1e-6)


def test_dt_from_keyword_and_from_affine():
    data = (a_of(0.0), B_DT, [[1.0, 0.0]], 0)
    term = (a_of(1.0) - a_of(0.0), 0, 0, 0)
    for dt in (DT, True):
        sys = lpv.PolytopicStateSpace.from_affine(
            data, {"p": term}, {"p": (1, 4)}, dt=dt
        )
        assert sys.dt is dt or sys.dt == dt
        assert sys.isdtime(strict=True) and sys.at(2.0).dt == sys.dt
        np.testing.assert_allclose(sys.at(2.0).A, a_of(2.0), atol=1e-15)
    base = ct.ss(*data, dt=DT)
    sys = lpv.PolytopicStateSpace.from_affine(base, {"p": term}, {"p": (1, 4)})
    assert sys.dt == DT
    tuples = lpv.pss([data, data], {"p": (0, 1)}, dt=0.5)
    assert tuples.dt == 0.5 and tuples.vertices[1].dt == 0.5
    assert lpv.pss([data]).dt == 0 and lpv.pss([data]).isctime()


@pytest.mark.parametrize(
    "vertices, kwargs, match",
    [
        (
            [ct.ss([[0.5]], 1, 1, 0, dt=0.1), ct.ss([[-1.0]], 1, 1, 0)],
            {},
            "vertices",
        ),
        (
            [ct.ss([[0.5]], 1, 1, 0, dt=0.1), ct.ss([[0.2]], 1, 1, 0, dt=0.2)],
            {},
            "vertices",
        ),
        (
            [ct.ss([[0.5]], 1, 1, 0, dt=0.1), ct.ss([[0.2]], 1, 1, 0, dt=True)],
            {},
            "vertices",
        ),
        ([ct.ss([[0.5]], 1, 1, 0, dt=0.1)] * 2, {"dt": 0.2}, "dt"),
        ([([[0.5]], 1, 1, 0)] * 2, {"dt": -0.1}, "dt"),
        ([([[0.5]], 1, 1, 0)] * 2, {"dt": None}, "dt"),
    ],
)
def test_bad_timebases(vertices, kwargs, match):
    with pytest.raises(ValueError, match=match):
        lpv.pss(vertices, {"p": (0.0, 1.0)}, **kwargs)


def test_combining_with_a_continuous_system_is_refused(dsys):
    with pytest.raises(ValueError):
        dsys * ct.ss([[-1.0]], [[1.0]], [[1.0]], 0)


# ----------------------------------------------------------------------
# Simulation: the next-state map
# ----------------------------------------------------------------------
def test_frozen_simulation_is_the_recursion(dsys):
    T = np.arange(30) * DT
    u = np.sin(T)
    x0 = np.array([1.0, -0.5])
    res = ct.input_output_response(dsys, T, u, X0=x0, params={"p": 3.0})
    x = x0.copy()
    expected = []
    for k in range(len(T)):
        expected.append(x)
        x = a_of(3.0) @ x + B_DT[:, 0] * u[k]
    np.testing.assert_allclose(res.states, np.array(expected).T, atol=1e-12)
    step = ct.step_response(dsys, T=T, params={"p": 3.0})
    ref = ct.step_response(ct.ss(a_of(3.0), B_DT, np.eye(2), 0, dt=DT), T=T)
    np.testing.assert_allclose(step.outputs, ref.outputs, atol=1e-12)


def test_scheduled_simulation_is_the_recursion(dsys):
    T = np.arange(40) * DT
    p = 2.5 + 1.5 * np.sin(T)
    res = ct.input_output_response(
        dsys.scheduled("inputs"), T, [np.zeros_like(T), p], X0=[1.0, 0.0]
    )
    x, expected = np.array([1.0, 0.0]), []
    for k in range(len(T)):
        expected.append(x)
        x = a_of(p[k]) @ x
    np.testing.assert_allclose(res.states, np.array(expected).T, atol=1e-12)


# ----------------------------------------------------------------------
# Sampling
# ----------------------------------------------------------------------
@pytest.fixture
def msd():
    """Mass-spring-damper, stiffness k in [0, 2] and damping c in [0, 1]."""
    base = ct.ss(
        [[0.0, 1.0], [-1.0, -0.5]], [[0.0], [1.0]], [[1.0, 0.0]], 0,
        inputs="u", outputs="y", states=["x", "v"], name="msd",
    )  # fmt: skip
    terms = {
        "k": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0),
        "c": ([[0.0, 0.0], [0.0, -1.0]], [[0.0], [0.5]], 0, 0),
    }
    return lpv.PolytopicStateSpace.from_affine(base, terms, {"k": (0, 2), "c": (0, 1)})


def stacked_expm(X):
    """``expm`` of stacked small matrices: Taylor series with squaring.

    Written here (einsum, no BLAS) as an independent check of the library's
    ``scipy.linalg.expm``; scaled to norm <= 1/2, 30 terms reach rounding.
    """
    norm = np.abs(X).sum(axis=2).max()
    squarings = max(0, int(np.ceil(np.log2(max(norm, 1e-300) / 0.5))))
    Y = X / 2.0**squarings
    E = term = np.broadcast_to(np.eye(X.shape[1]), X.shape).copy()
    for k in range(1, 30):
        term = np.einsum("pij,pjk->pik", term, Y) / k
        E = E + term
    for _ in range(squarings):
        E = np.einsum("pij,pjk->pik", E, E)
    return E


def test_stacked_expm_agrees_with_scipy():
    X = np.array([[[0.0, 1.0], [-2.0, -0.3]], [[0.1, 0.0], [0.0, -3.0]]])
    for Xi, Ei in zip(X, stacked_expm(X)):
        np.testing.assert_allclose(Ei, scipy.linalg.expm(Xi), rtol=1e-13, atol=1e-14)


def true_errors(frozen, model, Ts, points):
    """Largest ||Phi(p) - Phi_model(p)|| and the same for Gamma, by expm.

    ``frozen(p) -> (A, B)`` is the continuous-time system at ``p`` and
    ``model(p) -> (Phi, Gamma)`` the polytopic discrete model there.
    """
    points = list(points)
    AB = [frozen(p) for p in points]
    n, m = AB[0][1].shape
    M = np.zeros((len(points), n + m, n + m))
    for i, (A, B) in enumerate(AB):
        M[i, :n, :n], M[i, :n, n:] = A, B
    E = stacked_expm(Ts * M)
    models = [model(p) for p in points]
    Phi = np.stack([pm[0] for pm in models])
    Gamma = np.stack([pm[1] for pm in models])
    return (
        np.linalg.norm(E[:, :n, :n] - Phi, 2, axis=(1, 2)).max(),
        np.linalg.norm(E[:, :n, n:] - Gamma, 2, axis=(1, 2)).max(),
    )


def msd_frozen(p):
    """The mass-spring-damper at (k, c), from its affine formula."""
    k, c = p
    return np.array([[0.0, 1.0], [-1.0 - k, -0.5 - c]]), np.array(
        [[0.0], [1.0 + 0.5 * c]]
    )


def box_model(sysd):
    """Bilinear interpolation of the sampled vertices over [0, 2] x [0, 1]."""
    data = [(v.A, v.B) for v in sysd.vertices]  # order (0,0), (0,1), (2,0), (2,1)

    def model(p):
        a, b = p[0] / 2.0, p[1]
        w = [(1 - a) * (1 - b), (1 - a) * b, a * (1 - b), a * b]
        return tuple(sum(wj * d[i] for wj, d in zip(w, data)) for i in (0, 1))

    return model


def test_sample_is_exact_at_the_vertices(msd):
    sysd = msd.sample(0.2)
    assert isinstance(sysd, lpv.PolytopicStateSpace) and sysd.dt == 0.2
    assert sysd.domain == msd.domain
    for v, vd in zip(msd.vertices, sysd.vertices):
        ref = ct.sample_system(v, 0.2)
        for a, b in zip((vd.A, vd.B, vd.C, vd.D), (ref.A, ref.B, ref.C, ref.D)):
            np.testing.assert_allclose(a, b, atol=1e-13)
    assert sysd.input_labels == ["u"] and sysd.state_labels == ["x", "v"]
    assert sysd.name == "msd$sampled"


@pytest.mark.parametrize("Ts", [0.05, 0.2, 0.5])
def test_zoh_bound_covers_a_dense_sweep(msd, Ts):
    sysd = msd.sample(Ts)
    bound = sysd.discretization_error
    assert isinstance(bound, DiscretizationBound) and bound.Ts == Ts
    assert not bound.exact
    grid = itertools.product(np.linspace(0, 2, 25), np.linspace(0, 1, 25))
    phi, gamma = true_errors(msd_frozen, box_model(sysd), Ts, grid)
    assert phi > 0 and gamma > 0  # the vertexwise ZOH is not exact inside
    assert phi <= bound.phi and gamma <= bound.gamma
    # Tight on a box (scaled norms and a sampled grid; see
    # tests/test_discretization_bound.py): the 2-norm bound was 5.5 to 11
    # times the error for Phi, 1.4 to 11 for Gamma.
    assert bound.phi < 1.5 * phi and bound.gamma < 1.5 * gamma


def test_zoh_bound_on_a_simplex_domain():
    rng = np.random.default_rng(3)
    vertices = [
        (rng.normal(size=(3, 3)) - 2 * np.eye(3), rng.normal(size=(3, 2)), np.eye(3), 0)
        for _ in range(3)
    ]
    sysd = lpv.pss(vertices).sample(0.1)
    points = rng.dirichlet(np.ones(3), size=300)

    def frozen(w):
        return tuple(
            sum(wj * np.asarray(v[i], float) for wj, v in zip(w, vertices))
            for i in (0, 1)
        )

    def model(w):
        return tuple(
            sum(wj * d[i] for wj, d in zip(w, sysd.vertex_data())) for i in (0, 1)
        )

    phi, gamma = true_errors(frozen, model, 0.1, points)
    bound = sysd.discretization_error
    assert 0 < phi <= bound.phi and 0 < gamma <= bound.gamma


def test_lti_sampling_is_exact():
    G = ct.ss([[0.0, 1.0], [-2.0, -0.3]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    sysd = lpv.pss([G]).sample(0.3)
    assert sysd.discretization_error.exact
    assert sysd.discretization_error.phi == sysd.discretization_error.gamma == 0
    ref = ct.sample_system(G, 0.3)
    np.testing.assert_allclose(sysd.at([1.0]).A, ref.A, atol=1e-13)
    np.testing.assert_allclose(sysd.at([1.0]).B, ref.B, atol=1e-13)


def test_euler_is_exactly_polytopic(msd):
    sysd = msd.sample(0.1, method="euler")
    assert sysd.discretization_error.exact
    for p in ([0.3, 0.9], [1.7, 0.2]):
        ref = ct.sample_system(msd.at(p), 0.1, method="euler")
        np.testing.assert_allclose(sysd.at(p).A, ref.A, atol=1e-14)
        np.testing.assert_allclose(sysd.at(p).B, ref.B, atol=1e-14)


def test_sampling_entry_points(msd):
    with warnings.catch_warnings():
        warnings.simplefilter("error", NominalPointWarning)
        via = ct.sample_system(msd, 0.2, name="d", copy_names=False)
    assert via.name == "d" and via.dt == 0.2 and via.input_labels == ["u[0]"]
    np.testing.assert_allclose(via.at([1, 0.5]).A, msd.sample(0.2).at([1, 0.5]).A)
    renamed = msd.sample(0.2, states=["q1", "q2"])
    assert renamed.state_labels == ["q1", "q2"]
    kept = msd.scheduled("inputs").sample(0.2)
    assert kept.scheduling == "inputs" and kept.input_labels == ["u", "k", "c"]


@pytest.mark.parametrize(
    "call, error, match",
    [
        (lambda s: s.sample(0.1, method="tustin"), ValueError, "method"),
        (lambda s: s.sample(0.1, method="bilinear"), ValueError, "method"),
        (lambda s: s.sample(0.1, method="gbt", alpha=0.5), ValueError, "method"),
        (lambda s: s.sample(0.0), ValueError, "Ts"),
        (lambda s: s.sample(-1.0), ValueError, "Ts"),
        (lambda s: s.sample(0.1).sample(0.1), ValueError, "discrete"),
        (lambda s: s.sample(0.1, foo=1), TypeError, "foo"),
    ],
)
def test_bad_sampling(msd, call, error, match):
    with pytest.raises(error, match=match):
        call(msd)


# ----------------------------------------------------------------------
# Controllers
# ----------------------------------------------------------------------
def fake_design(system, gains):
    """A stand-in with the attributes `state_feedback` reads."""
    return types.SimpleNamespace(
        system=system,
        gains=tuple(gains),
        states=tuple(system.state_labels),
        u=("u",),
        scheduled=len(gains) > 1,
    )


def test_common_gain_controller_is_discrete(dsys):
    K, _, _ = ct.dlqr(dsys.at(2.5), np.eye(2), np.eye(1))
    ctrl = lpv.state_feedback(fake_design(dsys, [K]))
    assert ctrl.dt == DT and ctrl.isdtime(strict=True) and ctrl.nstates == 0
    loop = ct.interconnect([dsys, ctrl], inputs=[], outputs=["x", "v", "u"])
    assert loop.dt == DT
    T = np.arange(50) * DT
    x0 = np.array([1.0, 0.5])
    for p in (1.0, 2.5, 4.0):
        res = ct.input_output_response(loop, T, 0, X0=x0, params={"p": p})
        Acl = a_of(p) - B_DT @ K
        expected = np.array([np.linalg.matrix_power(Acl, k) @ x0 for k in range(50)])
        np.testing.assert_allclose(res.outputs[:2], expected.T, atol=1e-12)
        np.testing.assert_allclose(res.outputs[2], -(K @ expected.T)[0], atol=1e-12)


def test_scheduled_controller_is_discrete(dsys):
    gains = [ct.dlqr(v, np.eye(2), np.eye(1))[0] for v in dsys.vertices]
    ctrl = lpv.state_feedback(fake_design(dsys, gains))
    assert ctrl.dt == DT and ctrl.input_labels == ["x", "v", "p"]
    T = np.arange(40) * DT
    p = 2.5 + 1.5 * np.cos(T)
    plant = dsys.scheduled("inputs")
    loop = ct.interconnect([plant, ctrl], inputs=["p"], outputs=["x", "v"], name="loop")
    res = ct.input_output_response(loop, T, p, X0=[1.0, 0.0])
    x, expected = np.array([1.0, 0.0]), []
    for k in range(len(T)):
        expected.append(x)
        lam = (p[k] - 1.0) / 3.0
        K = (1 - lam) * gains[0] + lam * gains[1]
        x = (a_of(p[k]) - B_DT @ K) @ x
    np.testing.assert_allclose(res.outputs, np.array(expected).T, atol=1e-12)


def test_real_design_object_with_a_discrete_system(dsys):
    ct_sys = lpv.pss(
        [(-np.eye(2), B_DT, np.eye(2), np.zeros((2, 1)))] * 2, {"p": (1.0, 4.0)},
        inputs=["u"], outputs=["x", "v"], states=["x", "v"],
    )  # fmt: skip
    design = lpv.quadratic_stabilization(ct_sys, "u")
    K = ct.dlqr(dsys.at(2.5), np.eye(2), np.eye(1))[0]
    ddesign = dataclasses.replace(design, system=dsys, gains=(K,))
    ctrl = lpv.state_feedback(ddesign)
    assert ctrl.dt == DT
    np.testing.assert_allclose(
        ctrl.output(0, [], [1.0, 2.0]), -K @ [1.0, 2.0], atol=1e-14
    )


def test_discrete_integral_augmentation_is_an_accumulator(dsys):
    plant = lpv.pss(
        [(v.A, v.B, [[1.0, 0.0]], 0) for v in dsys.vertices], dsys.domain,
        inputs=["u"], outputs=["y"], states=["x", "v"], dt=DT,
    )  # fmt: skip
    aug = lpv.integral_augmentation(plant, "y")
    assert aug.dt == DT and aug.integral_signals == {"int_y": "y"}
    for p in (1.0, 4.0):
        expected = np.zeros((3, 3))
        expected[:2, :2] = a_of(p)
        expected[2] = [1.0, 0.0, 1.0]
        np.testing.assert_allclose(aug.at(p).A, expected, atol=1e-15)
        np.testing.assert_allclose(aug.at(p).B, np.vstack([B_DT, [[0.0]]]))
    # A gain that stabilizes the augmented vertices (dlqr at the center).
    K = ct.dlqr(aug.at(2.5), np.diag([1.0, 1.0, 0.1]), np.eye(1))[0]
    ctrl = lpv.state_feedback(fake_design(aug, [K]), states={"x": "xm", "v": "vm"})
    assert ctrl.dt == DT and ctrl.nstates == 1 and ctrl.state_labels == ["int_y"]
    meas = lpv.pss(
        [(v.A, v.B, np.vstack([np.eye(2), [[1.0, 0.0]]]), 0) for v in dsys.vertices],
        dsys.domain, inputs=["u"], outputs=["xm", "vm", "y"], states=["x", "v"],
        dt=DT,
    )  # fmt: skip
    loop = ct.interconnect([meas, ctrl], inputs=[], outputs=["y", "u"])
    T = np.arange(60) * DT
    res = ct.input_output_response(loop, T, 0, X0=[1.0, 0.0, 0.0], params={"p": 2.0})
    x, q, ys = np.array([1.0, 0.0]), 0.0, []
    for _ in T:
        u = -(K @ np.r_[x, q])[0]
        y = x[0]
        ys.append((y, u))
        x, q = a_of(2.0) @ x + B_DT[:, 0] * u, q + y
    np.testing.assert_allclose(res.outputs, np.array(ys).T, atol=1e-12)


# ----------------------------------------------------------------------
# Frozen sweeps
# ----------------------------------------------------------------------
def test_frozen_sweep_reports_spectral_radius_and_dt_hinf(dsys):
    plant = lpv.pss(
        [(v.A, np.hstack([v.B, v.B]), [[1.0, 0.0]], 0) for v in dsys.vertices],
        dsys.domain, inputs=["w", "u"], outputs=["z"], states=["x", "v"], dt=DT,
    )  # fmt: skip
    K = ct.dlqr(dsys.at(2.5), np.eye(2), np.eye(1))[0]
    sweep = lpv.frozen_sweep(plant, K, "u", points=[[1.0], [2.5], [4.0]], w="w", z="z")
    assert sweep.dt == DT
    z = np.exp(1j * np.linspace(0, np.pi, 20001))
    for i, p in enumerate((1.0, 2.5, 4.0)):
        Acl = a_of(p) - B_DT @ K
        eig = np.linalg.eigvals(Acl)
        assert sweep.spectral_radius[i] == pytest.approx(np.abs(eig).max(), rel=1e-12)
        assert sweep.max_real[i] == pytest.approx(eig.real.max(), rel=1e-12)
        # H-infinity norm on the unit circle by brute force.
        # 2x2 resolvent by hand: C (zI - A)^-1 B with C = [1, 0], B = B_DT.
        (a, b), (c, d) = Acl
        det = (z - a) * (z - d) - b * c
        peak = np.abs(b * B_DT[1, 0] / det).max()
        assert sweep.hinf[i] >= peak * (1 - 1e-9)
        assert sweep.hinf[i] == pytest.approx(peak, rel=1e-4)
    assert sweep.stable.all()
    unstable = lpv.frozen_sweep(
        plant, np.zeros((1, 2)), "u", points=[[4.0]], w="w", z="z"
    )
    # a_of(4) has |eig| > 1 (det = 1 - 0.02 + 0.04 > 1): unstable open loop.
    assert unstable.spectral_radius[0] > 1 and not unstable.stable[0]
    assert unstable.hinf[0] == np.inf


def test_sampled_plant_designed_and_simulated_end_to_end():
    """sample -> synthesize (DT H-infinity) -> controller -> closed loop."""
    base = ct.ss(
        [[0.0, 1.0], [-1.0, -0.5]], [[0.0, 0.0], [1.0, 1.0]],
        [[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]],
        inputs=["w", "u"], outputs=["z", "uz"], states=["x", "v"], name="msd",
    )  # fmt: skip
    term = ([[0.0, 0.0], [-3.0, 0.0]], 0, 0, 0)
    sysd = lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": (0, 1)})
    sysd = sysd.sample(0.1)
    design = lpv.synthesize(sysd, "u", objective=lpv.Hinf(w="w", z=["z", "uz"]))
    K = design.gains[0]
    sweep = lpv.frozen_sweep(sysd, K, "u", points=11, w="w", z=["z", "uz"])
    assert sweep.stable.all() and sweep.hinf.max() <= design.gamma
    ctrl = lpv.state_feedback(design)
    assert ctrl.dt == 0.1
    meas = lpv.pss(
        [(A, B, np.eye(2), np.zeros((2, 2))) for A, B, _, _ in sysd.vertex_data()],
        sysd.domain, inputs=["w", "u"], outputs=["x", "v"], states=["x", "v"],
        dt=0.1,
    )  # fmt: skip
    loop = ct.interconnect([meas, ctrl], inputs=["w"], outputs=["x", "v", "u"])
    T = np.arange(80) * 0.1
    w = np.sin(T)
    res = ct.input_output_response(loop, T, w, X0=[1.0, 0.0], params={"k": 0.4})
    (A0, B0, _, _), (A1, B1, _, _) = sysd.vertex_data()
    A, B = 0.6 * A0 + 0.4 * A1, 0.6 * B0 + 0.4 * B1
    x, rows = np.array([1.0, 0.0]), []
    for wk in w:
        u = -(K @ x)[0]
        rows.append([x[0], x[1], u])
        x = A @ x + B @ [wk, u]
    np.testing.assert_allclose(res.outputs, np.array(rows).T, atol=1e-12)


@pytest.mark.parametrize("seed", range(12))
def test_zoh_bound_holds_on_random_boxes(seed):
    """Random affine and multilinear boxes of 1 to 3 parameters."""
    rng = np.random.default_rng(seed)
    k, n, m = (int(v) for v in rng.integers(1, 4, size=3))
    bounds = {f"p{i}": tuple(np.sort(rng.normal(size=2) * 2)) for i in range(k)}
    box = lpv.ParameterBox(bounds)
    vertices = [
        (rng.normal(size=(n, n)), rng.normal(size=(n, m)), np.eye(n), 0)
        for _ in range(2**k)
    ]
    sys = lpv.pss(vertices, box)
    Ts = float(rng.choice([0.01, 0.1, 0.5, 1.0]))
    sysd = sys.sample(Ts)
    points = box.lower + rng.random((300, k)) * (box.upper - box.lower)
    weights = np.array([box.weights(p) for p in points])
    # multilinear weights written here: product over coordinates
    lam = (points - box.lower) / (box.upper - box.lower)
    corners = np.array(list(itertools.product((0, 1), repeat=k)))
    mine = np.prod(np.where(corners[None], lam[:, None], 1 - lam[:, None]), axis=2)
    np.testing.assert_allclose(weights, mine, atol=1e-14)

    def combine(data, index):
        return np.einsum("pj,jab->pab", mine, np.stack([d[index] for d in data]))

    A, B = combine(sys.vertex_data(), 0), combine(sys.vertex_data(), 1)
    M = np.zeros((len(points), n + m, n + m))
    M[:, :n, :n], M[:, :n, n:] = A, B
    E = stacked_expm(Ts * M)
    phi = np.linalg.norm(E[:, :n, :n] - combine(sysd.vertex_data(), 0), 2, axis=(1, 2))
    gamma = np.linalg.norm(
        E[:, :n, n:] - combine(sysd.vertex_data(), 1), 2, axis=(1, 2)
    )
    bound = sysd.discretization_error
    assert phi.max() <= bound.phi * (1 + 1e-9) + 1e-14
    assert gamma.max() <= bound.gamma * (1 + 1e-9) + 1e-14
