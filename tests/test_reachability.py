"""Ultimate bounds for peak-bounded inputs, checked against independent facts.

Facts used: the exact ultimate bound of a scalar system, the exact worst-case
peak of an LTI output (the L1 norm of its impulse response), which no valid
bound may undercut, and simulations (scipy, rtol 1e-8) with bang-bang and
resonant inputs that must respect the certified ellipsoid and its decay.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import InfeasibleError
from ctrl_lpv.reachability import Ellipsoid, ultimate_bound


def simulate(rhs, x0, t_end, max_step=0.01):
    sol = solve_ivp(
        rhs, (0.0, t_end), x0, rtol=1e-8, atol=1e-11, max_step=max_step,
        dense_output=False,
    )  # fmt: skip
    assert sol.success
    return sol.t, sol.y


def resonator(wn=10.0, zeta=0.05):
    A = np.array([[0.0, 1.0], [-(wn**2), -2 * zeta * wn]])
    E = np.array([[0.0], [1.0]])
    return A, E


@pytest.mark.parametrize("a, b, wmax", [(2.0, 1.0, 1.0), (0.3, 5.0, 0.2)])
def test_scalar_bound_is_the_exact_one(a, b, wmax):
    # dx/dt = -a x + b w, |w| <= wmax: |x| ends up at most b wmax / a, and
    # w = wmax reaches it: no smaller bound exists.
    res = ultimate_bound(([[-a]], [[b]]), w_max=wmax)
    assert res.certificate.verified
    exact = b * wmax / a
    assert exact <= res.bounds[0] <= exact * (1 + 1e-3)
    assert res.decay == pytest.approx(a, rel=2e-2)  # optimal lambda = a


@pytest.fixture(scope="module")
def resonator_bound():
    A, E = resonator()
    return ultimate_bound((A, E), w_max=0.5, output=np.array([[1.0, 0.0]]))


def test_resonator_bound_is_not_below_the_true_peak(resonator_bound):
    A, E = resonator()
    C = np.array([[1.0, 0.0]])
    res = resonator_bound
    # Worst-case peak of |C x| for |w| <= 1: the L1 norm of the impulse
    # response (attained by w(t) = sign h(T - t) as T grows).
    T = np.linspace(0.0, 20.0, 40_001)
    _, h = ct.impulse_response(ct.ss(A, E, C, 0), T)
    peak = 0.5 * np.trapezoid(np.abs(h), T)
    assert res.bounds[0] >= peak
    assert res.bounds[0] <= 2.0 * peak  # not vacuous


@pytest.mark.parametrize("kind", ["bang-bang", "resonance", "worst"])
def test_resonator_trajectories_respect_the_certificate(kind, resonator_bound):
    A, E = resonator()
    C = np.array([[1.0, 0.0]])
    res = resonator_bound
    P, rho, lam = res.P, res.rho, res.decay
    wn, T_end = 10.0, 8.0
    tt = np.linspace(0, T_end, 16001)
    _, h = ct.impulse_response(ct.ss(A, E, C, 0), tt)

    def w(t, x):
        if kind == "bang-bang":
            return 0.5 * np.sign(np.sin(wn * t))
        if kind == "resonance":
            return 0.5 * np.sin(wn * np.sqrt(1 - 0.05**2) * t)
        return 0.5 * np.sign(np.interp(T_end - t, tt, h))  # peak at T_end

    # Start outside the ellipsoid (3 times its boundary) and inside it.
    for x0 in (3.0 * np.array([1.0, 0.0]) / np.sqrt(P[0, 0] / rho), np.zeros(2)):
        t, x = simulate(lambda t, x: A @ x + E[:, 0] * w(t, x), x0, T_end, 0.01)
        V = np.einsum("it,ij,jt->t", x, P, x)
        assert np.all(V <= res.level_bound(V[0], t) * (1 + 1e-7) + 1e-12)
        if x0[0] != 0:
            assert V[-1] <= rho * (1 + 1e-6) + V[0] * np.exp(-lam * T_end)
        if x0[0] == 0:
            assert np.all(V <= rho * (1 + 1e-7))
            assert np.max(np.abs(C @ x)) <= res.bounds[0]
    if kind == "worst":
        # The worst-case input comes close to the bound: it is not loose by
        # more than the ellipsoid's usual conservatism.
        assert np.abs(C @ x[:, -1])[0] > 0.5 * res.bounds[0]


def polytopic_pair():
    v1 = ct.ss([[0.0, 1.0], [-4.0, -3.0]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    v2 = ct.ss([[0.0, 1.0], [-9.0, -3.0]], [[0.0], [2.0]], [[1.0, 0.0]], 0)
    return lpv.pss([v1, v2], {"p": (0.0, 1.0)}, inputs="w", outputs="y")


def test_polytopic_time_varying_trajectories_stay_in_the_bound():
    sys = polytopic_pair()
    res = ultimate_bound(sys, w="w", w_max=0.3, output="y")
    assert res.outputs == ("y",)
    data = sys.vertex_data()
    P, rho = res.P, res.rho
    for delta in (
        lambda t: 0.5 + 0.5 * np.sign(np.sin(3.0 * t)),  # switching
        lambda t: 0.5 + 0.5 * np.sin(7.0 * t),
    ):

        def rhs(t, x, delta=delta):
            d = delta(t)
            A = (1 - d) * data[0][0] + d * data[1][0]
            E = (1 - d) * data[0][1] + d * data[1][1]
            w = 0.3 * np.sign(np.sin(2.0 * t) + 0.3 * np.sin(5.0 * t))
            return A @ x + E[:, 0] * w

        t, x = simulate(rhs, np.zeros(2), 15.0)
        V = np.einsum("it,ij,jt->t", x, P, x)
        assert np.all(V <= rho * (1 + 1e-7))
        assert np.max(np.abs(x[0])) <= res.bound("y")


def test_frozen_vertex_bounds_are_not_above_the_polytopic_one():
    sys = polytopic_pair()
    whole = ultimate_bound(sys, w="w", w_max=1.0, output="y")
    for A, B, C, _ in sys.vertex_data():
        vertex = ultimate_bound((A, B), w_max=1.0, output=C)
        assert vertex.bounds[0] <= whole.bounds[0] * (1 + 1e-3)


def test_feedthrough_and_box_bounds():
    # y = x + 2 w1 with two inputs: the D term adds |D| w_max exactly.
    sys = ct.ss([[-1.0]], [[1.0, 0.5]], [[1.0]], [[2.0, 0.0]], inputs=["w1", "w2"])
    res = ultimate_bound(sys, w_max=[1.0, 2.0])
    state_part = res.ellipsoid.support([[1.0]])[0]
    assert res.bounds[0] == pytest.approx(state_part + 2.0)
    # The exact ultimate bound of x for the box is |1| * 1 + |0.5| * 2 = 2;
    # the ellipsoid over the box is no better.
    assert state_part >= 2.0 * (1 - 1e-9)
    assert state_part <= 2.0 * 1.5


def test_fixed_decay_and_level_bound():
    res = ultimate_bound(([[-2.0]], [[1.0]]), decay=1.0)
    assert res.decay == pytest.approx(1.0)
    # lambda = 1 is not optimal (2 is): the bound is sqrt(1/(lambda (4 - lambda))).
    assert res.bounds[0] == pytest.approx(np.sqrt(1 / 3), rel=1e-3)
    assert res.level_bound(5.0, 0.0) == pytest.approx(5.0)


def test_unstable_vertex_is_refused_as_infeasible():
    A1 = np.array([[-1.0, 0.0], [0.0, -2.0]])
    A2 = np.array([[0.5, 0.0], [0.0, -2.0]])
    with pytest.raises(InfeasibleError, match="vertex 1 is not Hurwitz"):
        ultimate_bound(([A1, A2], np.ones((2, 1))))


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(w_max=-1.0), "w_max"),
        (dict(w_max=[1.0, 2.0]), "w_max"),
        (dict(decay=0.0), "decay"),
        (dict(output=np.ones((1, 3))), "output"),
        (dict(weights=[0.0]), "weights"),
    ],
)
def test_bad_arguments_name_the_argument(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ultimate_bound(([[-1.0, 0.0], [0.0, -1.0]], [[1.0], [0.0]]), **kwargs)


def test_bad_system_types():
    with pytest.raises(TypeError, match="sys"):
        ultimate_bound("not a system")
    with pytest.raises(ValueError, match="w"):
        ultimate_bound(ct.ss([[-1.0]], [[1.0]], [[1.0]], 0), w="nope")


def test_ellipsoid_helpers():
    ell = Ellipsoid(np.diag([4.0, 1.0]), level=1.0)
    assert ell.contains([0.5, 0.0]) and not ell.contains([0.6, 0.0])
    np.testing.assert_allclose(ell.support(np.eye(2)), [0.5, 1.0])
    axes, _ = ell.semi_axes()
    np.testing.assert_allclose(axes, [0.5, 1.0])
    np.testing.assert_allclose(ell.scaled(2.0).support(np.eye(2)), [1.0, 2.0])


def test_ellipsoid_inclusion():
    small = Ellipsoid(np.diag([4.0, 4.0]))
    big = Ellipsoid(np.diag([1.0, 2.0]))
    assert small.inside(big) and not big.inside(small)
    assert not small.scaled(3.0).inside(big)


def test_bound_is_invariant_under_a_change_of_units():
    A, E = resonator()
    C = np.array([[1.0, 0.0]])
    ref = ultimate_bound((A, E), output=C)
    S = np.diag([1e4, 1e-2])  # other units for both states
    Si = np.linalg.inv(S)
    new = ultimate_bound((S @ A @ Si, S @ E), output=C @ Si)
    assert new.bounds[0] == pytest.approx(ref.bounds[0], rel=1e-3)


def test_state_dependent_bounded_perturbation_is_covered():
    # The inequality holds pointwise in time, so w may be any function of
    # the state within its bound: here a dead-zone-like term
    # w = 0.5 sat(x1 / 0.01) (the two-mass use: ks sat_alpha(theta_d)).
    A, E = resonator()
    res = ultimate_bound((A, E), w_max=0.5, output=np.array([[1.0, 0.0]]))

    def rhs(t, x):
        return A @ x + E[:, 0] * 0.5 * np.clip(x[0] / 0.01, -1.0, 1.0)

    x0 = np.array([0.0, 3.0])
    t, x = simulate(rhs, x0, 6.0)
    V = np.einsum("it,ij,jt->t", x, res.P, x)
    assert V[0] > res.rho  # starts outside
    assert np.all(V <= res.level_bound(V[0], t) * (1 + 1e-7) + 1e-12)
