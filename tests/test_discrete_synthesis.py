"""Discrete-time synthesis and analysis (issue 13) against independent facts.

* Stability of a discrete closed loop: spectral radius of ``A - B K`` below
  one (Schur), computed here from the plant matrices and the returned gain.
* DT H-infinity norm: ``control.linfnorm`` of the discrete closed loop (with
  its ``dt``); the LTI optimum from the game Riccati equation (Basar and
  Bernhard, ch. 3) by bisection, cross-checked against an own cvxpy LMI
  (discrete bounded-real lemma), both in ``tests/_h2dt_reference.py``.
* DT pole region ``disk(r, c)``: ``|z - c| < r`` for every eigenvalue.
* The controller: a discrete ``NonlinearIOSystem`` whose closed-loop
  simulation with ``control.input_output_response`` is the recursion
  ``x[k+1] = (A - B K) x[k]`` computed here.

Plants whose discrete and continuous readings disagree (``A = -1.5`` is
Hurwitz but not Schur, ``A = 0.5`` Schur but not Hurwitz) catch a design
done with the wrong time domain.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _h2dt_reference import (
    affine_at,
    affine_system,
    box_corners,
    channels,
    closed_loop,
    dt_hinf_lmi,
    dt_hinf_riccati,
    h2_riccati,
    is_stable,
    lti_system,
    quadratically_stabilizable,
    random_box_polytope,
    random_lti,
    spectral_abscissa,
    vertex_system,
)

SEED = 2424
DT = 0.05
RTOL_OPT = 1e-3
RTOL_NORM = 1e-9


def _scalar(a, b=1.0, dt=DT):
    """One-state DT plant ``x+ = a x + b u`` with ``z = [x; u]``, ``w`` on x."""
    one = np.array([[1.0]])
    return lti_system(lpv, a * one, one, b * one, one, dt=dt)


def _box_case(nparams, m, seed, spread=0.2):
    """Affine DT family over ``[-1, 1]^k`` and check points (corners + random)."""
    rng = np.random.default_rng([SEED, nparams, m, seed])
    M0, terms = random_box_polytope(rng, nparams, 3, m, 1, dt=DT, spread=spread)
    sys = affine_system(lpv, M0, terms, dt=DT)
    corners = box_corners(nparams)
    points = corners + list(rng.uniform(-1, 1, (10, nparams)))

    def frozen(p):
        return affine_at(M0, terms, p)

    return sys, frozen, points, [frozen(c) for c in corners]


def _frozen_checks(design, frozen, points, bound=None):
    """Schur at every point; frozen DT H-infinity norms below `bound`."""
    worst_rho, worst_norm = 0.0, 0.0
    for p in points:
        A, B1, B2, C = frozen(p)
        K = design.gain(p)
        rho = spectral_abscissa(A - B2 @ K, dt=1)
        assert rho < 1, (p, rho)
        worst_rho = max(worst_rho, rho)
        if bound is not None:
            norm = ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=DT))[0]
            assert norm <= bound * (1 + RTOL_NORM), (p, norm, bound)
            worst_norm = max(worst_norm, norm)
    return worst_rho, worst_norm


# ----------------------------------------------------------------------
# The reference itself
# ----------------------------------------------------------------------
def test_reference_dt_hinf_riccati_matches_lmi():
    for i in range(4):
        rng = np.random.default_rng([SEED, 5, i])
        A, B1, B2, C, _, _ = random_lti(rng, n=1 + i, m=1 + i % 2, dt=1)
        gamma, K = dt_hinf_riccati(A, B1, B2, C, rtol=1e-6)
        assert ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=1))[0] <= gamma
        assert dt_hinf_lmi(A, B1, B2, C) == pytest.approx(gamma, rel=1e-4)


def test_reference_scalar_dt_hinf_brute_force():
    # x+ = a x + w + u, z = [x; u], u = -k x: |T(e^jw)|^2 = (1 + k^2) / |e^jw - f|^2
    # with f = a - k, largest at z = sign(f): ||T||_inf = sqrt(1 + k^2) / (1 - |f|).
    a = 1.4
    k = np.linspace(a - 0.999, a + 0.999, 20001)
    brute = np.min(np.sqrt(1 + k**2) / (1 - np.abs(a - k)))
    one = np.array([[1.0]])
    gamma, _ = dt_hinf_riccati(a * one, one, one, one, rtol=1e-8)
    assert gamma == pytest.approx(brute, rel=1e-6)


# ----------------------------------------------------------------------
# LTI discrete H-infinity vs Riccati
# ----------------------------------------------------------------------
@pytest.mark.parametrize("index, n, m", [(0, 1, 1), (1, 3, 2), (2, 5, 1)])
def test_lti_dt_hinf_matches_riccati(index, n, m):
    rng = np.random.default_rng([SEED, 9, index])
    A, B1, B2, C, _, _ = random_lti(rng, n=n, m=m, dt=1)
    gamma, _ = dt_hinf_riccati(A, B1, B2, C, rtol=1e-6)
    sys = lti_system(lpv, A, B1, B2, C, dt=DT)
    w, u, z = channels(B1.shape[1], m, C.shape[0])
    spec = lpv.Hinf(w, z)
    raw = lpv.synthesize(sys, u, objective=spec, backoff=None)
    assert raw.gamma_opt == pytest.approx(gamma, rel=RTOL_OPT)
    design = lpv.synthesize(sys, u, objective=spec)
    assert design.certificate.verified
    K = design.gain()
    assert is_stable(A - B2 @ K, dt=DT)
    norm = ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=DT))[0]
    assert design.gamma >= norm * (1 - RTOL_NORM)
    assert norm >= gamma * (1 - 1e-6)
    assert design.bounds[spec] == pytest.approx(design.gamma, rel=1e-12)


def test_paper_wrapper_on_dt_system():
    # "Same call": the four functions get DT conditions too.
    rng = np.random.default_rng([SEED, 9, 1])
    A, B1, B2, C, _, _ = random_lti(rng, n=3, m=2, dt=1)
    gamma, _ = dt_hinf_riccati(A, B1, B2, C, rtol=1e-6)
    sys = lti_system(lpv, A, B1, B2, C, dt=DT)
    w, u, z = channels(B1.shape[1], 2, C.shape[0])
    design = lpv.hinf_state_feedback(sys, w=w, u=u, z=z)
    K = design.gain()
    assert is_stable(A - B2 @ K, dt=DT)
    norm = ct.linfnorm(closed_loop(A, B1, B2, C, K, dt=DT))[0]
    assert design.gamma >= norm * (1 - RTOL_NORM) and norm >= gamma * (1 - 1e-6)
    stab = lpv.quadratic_stabilization(sys, u=u)
    assert is_stable(A - B2 @ stab.gain(), dt=DT)


# ----------------------------------------------------------------------
# Polytopic discrete H-infinity
# ----------------------------------------------------------------------
# (parameters, inputs, seed, gains); seeds whose corners are quadratically
# stabilizable by a common gain (own LMI, asserted below).
DT_CASES = [
    (1, 1, 0, "common"),
    (1, 1, 0, "scheduled"),
    (2, 2, 0, "common"),
    (2, 1, 4, "scheduled"),
]


@pytest.mark.parametrize(
    "nparams, m, seed, gains",
    DT_CASES,
    ids=[f"k{a}m{b}s{c}-{d}" for a, b, c, d in DT_CASES],
)
def test_polytopic_dt_hinf(nparams, m, seed, gains):
    sys, frozen, points, verts = _box_case(nparams, m, seed=seed)
    assert quadratically_stabilizable(verts, dt=1) is not None  # ground truth
    assert sys.dt == DT
    w, u, z = channels(1, m, verts[0][3].shape[0])
    design = lpv.synthesize(sys, u, objective=lpv.Hinf(w, z), gains=gains)
    assert design.certificate.verified
    assert design.scheduled == (gains == "scheduled")
    assert design.system.dt == DT
    _frozen_checks(design, frozen, points, bound=design.gamma)


def test_polytopic_dt_hinf_simplex_vertices():
    rng = np.random.default_rng([SEED, 33])
    M0, terms = random_box_polytope(rng, 2, 2, 1, 1, dt=DT)
    verts = [affine_at(M0, terms, c) for c in ([0, 0], [1, 0], [0, 1])]
    assert quadratically_stabilizable(verts, dt=1) is not None
    sys = vertex_system(lpv, verts, dt=DT)
    points = [np.eye(3)[j] for j in range(3)] + list(rng.dirichlet(np.ones(3), 8))

    def frozen(p):
        return tuple(sum(pj * v[k] for pj, v in zip(p, verts)) for k in range(4))

    w, u, z = channels(1, 1, verts[0][3].shape[0])
    for gains in ("common", "scheduled"):
        design = lpv.synthesize(sys, u, objective=lpv.Hinf(w, z), gains=gains)
        _frozen_checks(design, frozen, points, bound=design.gamma)


@pytest.mark.slow
@pytest.mark.parametrize("m, seed", [(2, 1), (2, 3), (1, 5), (1, 7), (2, 5), (2, 6)])
@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_polytopic_dt_hinf_many(m, seed, gains):
    sys, frozen, points, verts = _box_case(2, m, seed=seed)
    assert quadratically_stabilizable(verts, dt=1) is not None
    w, u, z = channels(1, m, verts[0][3].shape[0])
    design = lpv.synthesize(sys, u, objective=lpv.Hinf(w, z), gains=gains)
    _frozen_checks(design, frozen, points, bound=design.gamma)


# ----------------------------------------------------------------------
# Stabilization and analysis
# ----------------------------------------------------------------------
def test_dt_stabilization_of_a_hurwitz_but_not_schur_plant():
    # A = -1.5 is Hurwitz (a continuous-time reading needs no feedback) but
    # not Schur: a DT design must move it into the unit disk.
    sys = _scalar(-1.5)
    design = lpv.synthesize(sys, ("u0",))
    assert design.gamma is None
    k = design.gain()[0, 0]
    assert abs(-1.5 - k) < 1


@pytest.mark.parametrize("gains", ["common", "scheduled"])
def test_dt_polytopic_stabilization(gains):
    sys, frozen, points, verts = _box_case(2, 1, seed=4)
    assert quadratically_stabilizable(verts, dt=1) is not None
    design = lpv.synthesize(sys, ("u0",), gains=gains)
    assert design.certificate.verified
    _frozen_checks(design, frozen, points)


def test_dt_stabilization_with_dt_true():
    sys = _scalar(1.3, dt=True)
    assert sys.dt is True or sys.dt == 1
    design = lpv.synthesize(sys, ("u0",))
    assert abs(1.3 - design.gain()[0, 0]) < 1
    ctrl = design.controller()
    assert ctrl.isdtime(strict=True)


def test_dt_quadratic_stability_analysis():
    # Schur, not Hurwitz: stable in DT; P satisfies A'PA - P < 0.
    stable = lpv.quadratic_stability(_scalar(0.5))
    P = np.atleast_2d(stable.P)
    assert P[0, 0] > 0 and 0.25 * P[0, 0] - P[0, 0] < 0
    # Hurwitz, not Schur: unstable in DT.
    with pytest.raises(lpv.SynthesisError):
        lpv.quadratic_stability(_scalar(-1.5))


def test_dt_gain_bounds_analysis_of_a_fixed_gain():
    rng = np.random.default_rng([SEED, 9, 1])
    A, B1, B2, C, _, _ = random_lti(rng, n=3, m=2, dt=1)
    _, _, K = h2_riccati(A, B1, B2, C, dt=1)  # the DT LQR gain: Schur
    sys = lti_system(lpv, A, B1, B2, C, dt=DT)
    w, u, z = channels(B1.shape[1], 2, C.shape[0])
    cl = closed_loop(A, B1, B2, C, K, dt=DT)
    # LTI: the bounded-real lemma and the Gramian are exact.
    l2 = lpv.l2_gain_bound(sys, [K], w, u, z)
    norm = ct.linfnorm(cl)[0]
    assert l2.gamma >= norm * (1 - RTOL_NORM)
    assert l2.gamma == pytest.approx(norm, rel=RTOL_OPT)
    h2 = lpv.h2_bound(sys, [K], w, u, z)
    norm2 = ct.norm(cl, 2)
    assert h2.gamma >= norm2 * (1 - RTOL_NORM)
    assert h2.gamma == pytest.approx(norm2, rel=RTOL_OPT)


# ----------------------------------------------------------------------
# Pole regions in the z-plane
# ----------------------------------------------------------------------
@pytest.mark.parametrize("r, c", [(0.6, 0.0), (0.5, 0.4)])
def test_dt_disk_region(r, c):
    sys, frozen, points, verts = _box_case(1, 1, seed=0, spread=0.15)
    assert quadratically_stabilizable(verts, 1, disk=(r, c)) is not None  # own LMI
    w, u, z = channels(1, 1, verts[0][3].shape[0])
    for objective in (None, lpv.Hinf(w, z)):
        design = lpv.synthesize(
            sys, u, objective=objective, constraints=[lpv.disk(r, c)]
        )
        for p in points:
            A, _, B2, _ = frozen(p)
            ev = np.linalg.eigvals(A - B2 @ design.gain(p))
            assert np.all(np.abs(ev - c) < r), (p, ev)


def test_dt_disk_region_scheduled():
    sys, frozen, points, verts = _box_case(1, 1, seed=0, spread=0.15)
    # A common gain exists (own LMI), so vertex gains do too.
    assert quadratically_stabilizable(verts, 1, disk=(0.5, 0.1)) is not None
    design = lpv.synthesize(
        sys, ("u0",), gains="scheduled", constraints=[lpv.disk(0.5, 0.1)]
    )
    assert design.scheduled
    for p in points:
        A, _, B2, _ = frozen(p)
        ev = np.linalg.eigvals(A - B2 @ design.gain(p))
        assert np.all(np.abs(ev - 0.1) < 0.5), (p, ev)


@pytest.mark.parametrize(
    "region",
    [lambda: lpv.halfplane(0.0), lambda: lpv.sector(0.7), lambda: lpv.disk(0.5, 0.7)],
    ids=["halfplane", "sector", "disk-outside-unit-circle"],
)
def test_dt_refuses_continuous_regions(region):
    with pytest.raises(ValueError, match="constraints"):
        lpv.synthesize(_scalar(1.2), ("u0",), constraints=[region()])


# ----------------------------------------------------------------------
# The controller
# ----------------------------------------------------------------------
def _simulate(ctrl, A, B2, x0, steps, params=None):
    """Closed loop of a DT plant (outputs = states) and `ctrl`, by python-control."""
    n, m = B2.shape
    states = [f"x{i}" for i in range(n)]
    plant = ct.ss(
        A, B2, np.eye(n), 0, dt=DT, inputs=[f"u{i}" for i in range(m)],
        outputs=states, states=states, name="plant",
    )  # fmt: skip
    names = list(params) if params else []
    loop = ct.interconnect(
        [plant, ctrl],
        inplist=names or None,
        inputs=names or None,
        outlist=states,
        outputs=states,
        dt=DT,
    )
    T = np.arange(steps) * DT
    U = np.tile(np.array(list(params.values()))[:, None], steps) if params else 0
    X0 = np.concatenate([x0, np.zeros(loop.nstates - n)])
    return ct.input_output_response(loop, T, U, X0).outputs


def test_common_gain_controller_simulation():
    rng = np.random.default_rng([SEED, 9, 1])
    A, B1, B2, C, _, _ = random_lti(rng, n=3, m=2, dt=1)
    sys = lti_system(lpv, A, B1, B2, C, dt=DT)
    w, u, z = channels(B1.shape[1], 2, C.shape[0])
    design = lpv.synthesize(sys, u, objective=lpv.Hinf(w, z))
    ctrl = design.controller()
    assert isinstance(ctrl, ct.NonlinearIOSystem)
    assert ctrl.dt == DT and ctrl.isdtime(strict=True)
    K = design.gain()
    x0 = np.array([1.0, -0.5, 0.25])
    y = _simulate(ctrl, A, B2, x0, 30)
    x = [x0]
    for _ in range(29):
        x.append((A - B2 @ K) @ x[-1])
    np.testing.assert_allclose(y, np.array(x).T, rtol=1e-9, atol=1e-12)


def test_scheduled_controller_simulation():
    sys, frozen, points, verts = _box_case(1, 1, seed=0)
    design = lpv.synthesize(sys, ("u0",), gains="scheduled")
    ctrl = design.controller()  # parameter inputs named after the parameters
    assert ctrl.dt == DT and ctrl.isdtime(strict=True)
    p = points[-1]
    A, _, B2, _ = frozen(p)
    K = design.gain(p)
    x0 = np.array([0.3, 1.0, -1.0])
    y = _simulate(ctrl, A, B2, x0, 25, params={"p0": float(p[0])})
    x = [x0]
    for _ in range(24):
        x.append((A - B2 @ K) @ x[-1])
    np.testing.assert_allclose(y, np.array(x).T, rtol=1e-9, atol=1e-12)
