"""The `Peak` spec of `synthesize`: an invariant ellipsoid under peak-bounded inputs.

Independent facts: the exact peak of scalar loops (``x' = -c x + w`` peaks
at ``1 / c``, ``x+ = c x + w`` at ``1 / (1 - |c|)``, for ``|w| <= 1``), the
invariance limit of a saturated scalar plant (``x' = x + sat(u) + w`` with
``|w| <= w_max`` cannot keep ``|x| <= r`` for ``r >= 1 - w_max``),
steady states of the frozen loops under constant inputs, and simulations
with switching inputs and a time-varying parameter.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

import ctrl_lpv as lpv

R = 0.5  # weight of the effort in z = [x; R u]


def _scalar(a, dt=0):
    system = ct.ss(
        [[a]], [[1.0, 1.0]], [[1.0], [0.0]], [[0.0, 0.0], [0.0, R]], dt=dt,
        inputs=["w", "u"], outputs=["x", "ru"],
    )  # fmt: skip
    return lpv.PolytopicStateSpace([system])


def test_continuous_scalar_optimum_is_the_exact_peak():
    # x' = -x + u + w, u = -k x: |x| peaks at 1 / (1 + k) (w = 1), and
    # |z| = |x| sqrt(1 + R^2 k^2).
    def exact(k):
        return np.sqrt(1 + R**2 * k**2) / (1 + k)

    best = minimize_scalar(exact, bounds=(0, 100), method="bounded").fun
    design = lpv.synthesize(_scalar(-1.0), "u", objective=lpv.Peak("w", ["x", "ru"]))
    assert design.gamma_opt == pytest.approx(best, rel=1e-4)
    assert design.gamma >= exact(design.gains[0][0, 0])


def test_discrete_scalar_optimum_is_the_exact_peak():
    # x+ = x / 2 + u + w: |x| peaks at 1 / (1 - |1/2 - k|).
    def exact(k):
        return np.sqrt(1 + R**2 * k**2) / (1 - abs(0.5 - k))

    best = minimize_scalar(exact, bounds=(-0.4, 1.4), method="bounded").fun
    design = lpv.synthesize(
        _scalar(0.5, dt=1), "u", objective=lpv.Peak("w", ["x", "ru"])
    )
    assert design.gamma_opt == pytest.approx(best, rel=1e-3)
    assert design.gamma >= exact(design.gains[0][0, 0])


@pytest.fixture(scope="module")
def plant():
    """``x'' = p x + x'/2 + u + w``, ``p`` in [1, 3] (unstable), z = [x1; u/5]."""
    vertices = [
        ct.ss(
            [[0.0, 1.0], [p, 0.5]],
            [[0.0, 0.0], [1.0, 1.0]],
            [[1.0, 0.0], [0.0, 0.0]],
            [[0.0, 0.0], [0.0, 0.2]],
            inputs=["w", "u"],
            outputs=["y", "uz"],
        )
        for p in (1.0, 3.0)
    ]
    return lpv.PolytopicStateSpace(vertices, domain=lpv.box(p=(1.0, 3.0)))


def _blend(plant, p, which):
    lam = (p - 1.0) / 2.0
    first, last = plant.vertices
    return (1 - lam) * getattr(first, which) + lam * getattr(last, which)


def _simulate(plant, gain_at, x0, w_of, schedule, u_max=np.inf, T=20.0):
    """States and outputs of ``x' = A(p) x + B_w w + B_u sat(-K(p) x)``."""

    def rhs(t, x):
        p = schedule(t)
        B = _blend(plant, p, "B")
        u = np.clip(-gain_at(p) @ x, -u_max, u_max)
        return _blend(plant, p, "A") @ x + B[:, 0] * w_of(t) + B[:, 1] * u[0]

    sol = solve_ivp(rhs, (0, T), x0, rtol=1e-9, atol=1e-12, max_step=0.02)
    z = [
        np.array([x[0], 0.2 * np.clip(-gain_at(schedule(t)) @ x, -u_max, u_max)[0]])
        for t, x in zip(sol.t, sol.y.T)
    ]
    return sol.y.T, np.array(z)


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_polytopic_peak_bounds_switching_inputs_and_varying_parameter(plant, gains):
    w_max = 0.5
    spec = lpv.Peak("w", w_max=w_max)
    design = lpv.synthesize(plant, "u", objective=spec, gains=gains)
    assert design.certificate.verified and design.bounds[spec] == design.gamma
    P = design.P
    for p in np.linspace(1.0, 3.0, 9):
        # Constant w: the frozen loop settles at z = -Ccl Acl^-1 Bw w.
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        steady = -C @ np.linalg.solve(A, B[:, 0] * w_max)
        assert np.linalg.norm(steady) < design.gamma
    for omega in (0.3, 1.0, 3.0):
        states, z = _simulate(
            plant,
            lambda p: design.gain(p),
            np.zeros(2),
            lambda t, omega=omega: w_max * np.sign(np.sin(omega * t)),
            lambda t: 2.0 + np.sin(2.0 * t),
        )
        assert np.einsum("ti,ij,tj->t", states, P, states).max() <= 1 + 1e-6
        assert np.linalg.norm(z, axis=1).max() <= design.gamma


@pytest.mark.parametrize("x0, certified", [(0.5, True), (0.65, True), (0.75, False)])
def test_saturated_scalar_invariance_limit(x0, certified):
    # x' = x + sat(u) + w, |u| <= 1, |w| <= 0.3: at x = r > 0 the worst
    # derivative is r - 1 + 0.3, so no |x| <= r with r >= 0.7 is invariant.
    plant = lpv.PolytopicStateSpace(
        [ct.ss([[1.0]], [[1.0, 1.0]], [[1.0]], [[0.0, 0.0]], inputs=["w", "u"])]
    )
    specs = {
        "objective": lpv.Peak("w", w_max=0.3),
        "constraints": [lpv.Saturation(1.0, points=[[x0]])],
    }
    if not certified:
        with pytest.raises(lpv.SynthesisError):
            lpv.synthesize(plant, "u", **specs)
        return
    design = lpv.synthesize(plant, "u", **specs)
    radius = 1 / np.sqrt(design.P[0, 0])
    assert x0 <= radius < 0.7
    assert design.gamma >= radius
    k = design.gains[0][0, 0]
    for w in (0.3, -0.3):
        sol = solve_ivp(lambda t, x, w=w: x + np.clip(-k * x, -1, 1) + w, (0, 30),
                        [x0 if w > 0 else -x0], rtol=1e-10, atol=1e-12)  # fmt: skip
        assert np.abs(sol.y).max() <= radius * (1 + 1e-9)


def test_saturation_with_peak_holds_the_saturated_loop_in_the_ellipsoid(plant):
    u_max, w_max = 1.0, 0.2
    # The raw optimum (the back-off would pick a gain that keeps this
    # ellipsoid inside the linear region, where saturation is never active).
    design = lpv.synthesize(
        plant, "u", objective=lpv.Peak("w", w_max=w_max),
        constraints=[lpv.Saturation(u_max, points=[[0.2, 0.0]])], gains="scheduled",
        backoff=None,
    )  # fmt: skip
    P = design.P
    L = np.linalg.cholesky(np.linalg.inv(P))
    saturated = False
    for angle in np.linspace(0, 2 * np.pi, 8, endpoint=False):
        x0 = (1 - 1e-9) * L @ np.array([np.cos(angle), np.sin(angle)])
        states, _ = _simulate(
            plant, lambda p: design.gain(p), x0,
            lambda t, angle=angle: w_max * np.sign(np.sin(1.3 * t + angle)),
            lambda t: 2.0 + np.sin(3.0 * t), u_max=u_max, T=10.0,
        )  # fmt: skip
        assert np.einsum("ti,ij,tj->t", states, P, states).max() <= 1 + 1e-6
        u = [design.gain(p) @ x0 for p in np.linspace(1.0, 3.0, 9)]
        saturated |= bool(np.abs(u).max() > u_max)
    assert saturated  # the saturation is active from some of those starts


def test_peak_refusals_name_the_reason(plant):
    with pytest.raises(ValueError, match="w_max"):
        lpv.Peak("w", w_max=-1.0)
    with pytest.raises(ValueError, match="at most one Peak"):
        lpv.synthesize(plant, "u", objective=lpv.Peak("w"),
                       constraints=[lpv.Peak("w", "y", bound=3.0)])  # fmt: skip
    with pytest.raises(ValueError, match="Peak with a common gain"):
        lpv.synthesize(plant, "u", objective=lpv.Peak("w"), lyapunov="affine",
                       rate_bounds={"p": 0.0})  # fmt: skip
    feedthrough = lpv.PolytopicStateSpace(
        [ct.ss([[-1.0]], [[1.0, 1.0]], [[1.0]], [[1.0, 0.0]], inputs=["w", "u"])]
    )
    with pytest.raises(ValueError, match="feedthrough"):
        lpv.synthesize(feedthrough, "u", objective=lpv.Peak("w"))


def test_hinf_objective_with_a_peak_constraint(plant):
    alone = lpv.synthesize(plant, "u", objective=lpv.Peak("w"), backoff=None)
    peak = lpv.Peak("w", bound=1.5 * alone.gamma_opt)
    design = lpv.synthesize(plant, "u", objective=lpv.Hinf("w"), constraints=[peak])
    assert design.bounds[peak] < peak.bound
    for p in np.linspace(1.0, 3.0, 9):
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        assert ct.linfnorm(ct.ss(A, B, C, D))[0] <= design.gamma
        steady = -C @ np.linalg.solve(A, B[:, 0])
        assert np.linalg.norm(steady) < peak.bound


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_discrete_polytopic_peak(plant, gains):
    sampled = lpv.PolytopicStateSpace(
        [ct.c2d(v, 0.1) for v in plant.vertices], domain=plant.domain
    )
    design = lpv.synthesize(sampled, "u", objective=lpv.Peak("w"), gains=gains)
    rng = np.random.default_rng(3)
    for p in np.linspace(1.0, 3.0, 9):
        A, B, C, D = ct.ssdata(design.closed_loop({"p": p}))
        assert np.abs(np.linalg.eigvals(A)).max() < 1
        # A bounded input of random signs from rest: |z[k]| stays below.
        x, worst = np.zeros(2), 0.0
        for w in rng.choice([-1.0, 1.0], size=400):
            worst = max(worst, np.linalg.norm(C @ x + D[:, 0] * w))
            x = A @ x + B[:, 0] * w
        assert worst <= design.gamma
        steady = C @ np.linalg.solve(np.eye(2) - A, B[:, 0])
        assert np.linalg.norm(steady) < design.gamma
