"""The `Saturation` spec of `synthesize`: a certified region under input saturation.

Independent facts: the null-controllable region of a scalar unstable plant
(no region of attraction reaches past ``|x| = b u_max / a``), simulations of
the saturated closed loop (``sat`` in the plant, a time-varying parameter)
from points on the boundary of the certified ellipsoid, and
``control.linfnorm`` of the frozen linear loops for the mixed design.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv


def _scalar(a=1.0, b=1.0):
    return lpv.PolytopicStateSpace(
        [ct.ss([[a]], [[b]], [[1.0]], [[0.0]], inputs=["u"])]
    )


@pytest.fixture(scope="module")
def plant():
    """An unstable polytopic plant: ``x'' = p x + x'/2 + u + w/20``, ``p`` in [1, 3].

    Outputs ``[x1; u/5]`` for the mixed design. The certified ellipsoid also
    bounds the states the linear loop reaches with unit disturbance energy,
    so the disturbance is small enough for it to fit under the saturation.
    """
    vertices = [
        ct.ss(
            [[0.0, 1.0], [p, 0.5]],
            [[0.0, 0.0], [0.05, 1.0]],
            [[1.0, 0.0], [0.0, 0.0]],
            [[0.0, 0.0], [0.0, 0.2]],
            inputs=["w", "u"],
            outputs=["y", "uz"],
        )
        for p in (1.0, 3.0)
    ]
    return lpv.PolytopicStateSpace(vertices, domain=lpv.box(p=(1.0, 3.0)))


POINTS = [[0.1, 0.0], [0.0, 0.2], [-0.1, 0.1]]


def _boundary_points(P, count=12):
    """Points with ``x' P x = 1`` (just inside) around the ellipsoid."""
    L = np.linalg.cholesky(np.linalg.inv(P))
    angles = np.linspace(0, 2 * np.pi, count, endpoint=False)
    return [(1 - 1e-9) * L @ np.array([np.cos(t), np.sin(t)]) for t in angles]


def _simulate_saturated(plant, gain_at, u_max, x0, schedule, T=30.0):
    """``x' = A(p) x + B(p) sat(-K(p) x)`` with ``p = schedule(t)``."""
    A = [v.A for v in plant.vertices]
    B = [v.B[:, [1]] for v in plant.vertices]

    def rhs(t, x):
        p = schedule(t)
        lam = (p - 1.0) / 2.0
        Ap = (1 - lam) * A[0] + lam * A[1]
        Bp = (1 - lam) * B[0] + lam * B[1]
        u = np.clip(-gain_at(p) @ x, -u_max, u_max)
        return Ap @ x + Bp @ u

    return solve_ivp(rhs, (0, T), x0, rtol=1e-9, atol=1e-12, max_step=0.05)


@pytest.mark.parametrize("x0, certified", [(0.5, True), (0.95, True), (1.2, False)])
def test_scalar_null_controllable_region(x0, certified):
    # x' = x + sat(u), |u| <= 1: from |x| >= 1 no input brings x back, so a
    # certified region stops short of 1, and a point beyond is refused.
    spec = lpv.Saturation(1.0, points=[[x0]])
    if not certified:
        with pytest.raises(lpv.SynthesisError):
            lpv.synthesize(_scalar(), "u", constraints=spec)
        return
    design = lpv.synthesize(_scalar(), "u", constraints=spec)
    P, K = design.P[0, 0], design.gains[0][0, 0]
    assert x0**2 * P <= 1.0
    assert design.bounds[spec] == pytest.approx(x0**2 * P)
    radius = 1 / np.sqrt(P)
    assert radius < 1.0  # inside the null-controllable region
    assert K > 1.0  # stabilizing
    # Inside the radius the saturated loop x' = x - sat(K x) converges.
    sol = solve_ivp(
        lambda t, x: x - np.clip(K * x, -1, 1), (0, 400), [0.999 * radius], rtol=1e-10
    )
    assert abs(sol.y[0, -1]) < 1e-6


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_region_holds_under_saturation_and_varying_parameter(plant, gains):
    spec = lpv.Saturation(1.0, points=POINTS)
    design = lpv.synthesize(plant, "u", constraints=[spec], gains=gains)
    assert design.certificate.verified
    P = design.P
    for x0 in POINTS:
        assert np.asarray(x0) @ P @ np.asarray(x0) < 1.0

    def schedule(t):
        return 2.0 + np.sin(3.0 * t)  # p(t) across the whole range

    for x0 in _boundary_points(P):
        sol = _simulate_saturated(plant, design.gain, 1.0, x0, schedule)
        V = np.einsum("it,ij,jt->t", sol.y, P, sol.y)
        assert V.max() <= 1.0 + 1e-7  # E is invariant
        assert V[-1] < 1e-6  # and in the region of attraction
    # The certificate is not empty: some of those starts do saturate.
    K = design.gains[0]
    assert max(abs(K @ x0).max() for x0 in _boundary_points(P)) > 1.0


def test_mixed_hinf_with_saturation(plant):
    spec = lpv.Saturation(1.0, points=POINTS)
    design = lpv.synthesize(
        plant, "u", objective=lpv.Hinf("w", ["y", "uz"]), constraints=[spec]
    )
    alone = lpv.synthesize(plant, "u", objective=lpv.Hinf("w", ["y", "uz"]))
    K = design.gains[0]
    for p in np.linspace(1.0, 3.0, 9):
        frozen = plant.at({"p": p})
        A, B, C, D = frozen.A, frozen.B, frozen.C, frozen.D
        loop = ct.ss(A - B[:, [1]] @ K, B[:, [0]], C - D[:, [1]] @ K, D[:, [0]])
        assert design.gamma >= ct.linfnorm(loop)[0]
    # The region costs performance: the optimum cannot improve.
    assert design.gamma_opt >= alone.gamma_opt * (1 - 1e-3)
    assert design.bounds[spec] < 1.0
    sol = _simulate_saturated(plant, design.gain, 1.0, _boundary_points(design.P)[3],
                              lambda t: 1.0 if t < 1 else 3.0)  # fmt: skip
    assert np.abs(sol.y[:, -1]).max() < 1e-5


def test_scheduled_with_parameter_dependent_lyapunov(plant):
    spec = lpv.Saturation(1.0, points=POINTS)
    design = lpv.synthesize(
        plant, "u", constraints=[spec], gains="scheduled", lyapunov="affine",
        rate_bounds={"p": 0.0},
    )  # fmt: skip
    assert design.certificate.verified
    for p in (1.0, 2.0, 3.0):
        P = design.lyapunov_matrix({"p": p})
        for x0 in POINTS:
            assert np.asarray(x0) @ P @ np.asarray(x0) < 1.0
        for x0 in _boundary_points(P, 6):
            sol = _simulate_saturated(plant, design.gain, 1.0, x0, lambda t, p=p: p)
            assert np.abs(sol.y[:, -1]).max() < 1e-5


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"u_max": -1.0}, ValueError, "u_max"),
        ({"u_max": "1"}, TypeError, "u_max"),
        ({"u_max": [1.0, 2.0]}, ValueError, "u_max"),
        ({"u_max": 1.0, "points": [[1.0, 2.0, 3.0]]}, ValueError, "points"),
        ({"u_max": 1.0, "points": 3.0}, TypeError, "points"),
    ],
)
def test_bad_saturation_specs(plant, kwargs, error, match):
    with pytest.raises(error, match=match):
        lpv.synthesize(plant, "u", constraints=lpv.Saturation(**kwargs))


def test_saturation_refusals_name_the_reason(plant):
    with pytest.raises(ValueError, match="at most one Saturation"):
        lpv.synthesize(
            plant, "u", constraints=[lpv.Saturation(1.0), lpv.Saturation(2.0)]
        )
    with pytest.raises(ValueError, match="common gain and lyapunov='affine'"):
        lpv.synthesize(
            plant, "u", constraints=lpv.Saturation(1.0), lyapunov="affine",
            rate_bounds={"p": 0.0},
        )  # fmt: skip


def test_discrete_time_region_against_the_null_controllable_one():
    # x+ = 1.1 x + sat(u), |u| <= 1: from |x| >= 10, |x+| >= 1.1 |x| - 1 >=
    # |x|, so no region of attraction reaches |x| = 10. A point inside is
    # certified with the discrete-time sector condition, a point beyond 10
    # never is, and the saturated sampled loop converges from the certified
    # ellipsoid's boundary.
    discrete = lpv.PolytopicStateSpace(
        [ct.ss([[1.1]], [[1.0]], [[1.0]], [[0.0]], dt=0.1, inputs=["u"])]
    )
    design = lpv.synthesize(
        discrete, "u", constraints=lpv.Saturation(1.0, points=[[8.0]])
    )
    assert design.certificate.verified
    P, K = float(design.P[0, 0]), float(design.gains[0][0, 0])
    edge = 1.0 / np.sqrt(P)
    assert 8.0 <= edge < 10.0
    for x in (edge, -edge):
        for _ in range(200):
            x = 1.1 * x + float(np.clip(-K * x, -1.0, 1.0))
        assert abs(x) < 1e-6
    with pytest.raises(lpv.SynthesisError):
        lpv.synthesize(discrete, "u", constraints=lpv.Saturation(1.0, points=[[10.5]]))
