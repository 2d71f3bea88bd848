"""Synthesis checked against facts computed here, not by the library."""

import control as ct
import cvxpy as cp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import ctrl_lpv as lpv
from conftest import interior_deltas

SCHEDULED = {
    lpv.quadratic_stabilization: False,
    lpv.gain_scheduled_stabilization: True,
    lpv.hinf_state_feedback: False,
    lpv.gain_scheduled_hinf: True,
}


def frozen_gain(design, delta):
    gains = np.stack(design.gains)
    return np.tensordot(delta, gains, axes=1) if len(gains) > 1 else gains[0]


def independent_check(sys, design, u_index, seed=0):
    """Closed-loop Hurwitz and the Lyapunov inequality with the reported P."""
    P = design.P
    assert np.allclose(P, P.T)
    assert np.linalg.eigvalsh(P)[0] > 0
    data = sys.vertex_data()
    for delta in interior_deltas(sys.nvertices, count=30, seed=seed):
        A = sum(d * v[0] for d, v in zip(delta, data))
        B = sum(d * v[1] for d, v in zip(delta, data))[:, u_index]
        Acl = A - B @ frozen_gain(design, delta)
        assert np.linalg.eigvals(Acl).real.max() < 0
        # Congruence with P^-1 keeps the sign and the conditioning sane.
        W = np.linalg.inv(P)
        lyap = Acl @ W + W @ Acl.T
        assert np.linalg.eigvalsh(lyap)[-1] < 0


@pytest.mark.parametrize("function", list(SCHEDULED))
def test_designs_on_mass_spring(mass_spring, function):
    kwargs = {"w": "w", "z": ["x", "uw"]} if "hinf" in function.__name__ else {}
    design = function(mass_spring, u="u", **kwargs)
    assert design.certificate.verified
    assert len(design.gains) == (2 if SCHEDULED[function] else 1)
    assert design.gains[0].shape == (1, 2)
    independent_check(mass_spring, design, [1])
    assert design.u == ("u",)
    text = str(design)
    assert "certificate: verified" in text and "u = -K x" in text


@pytest.mark.parametrize("function", [lpv.hinf_state_feedback, lpv.gain_scheduled_hinf])
def test_gamma_bounds_frozen_hinf_norms(mass_spring, function):
    design = function(mass_spring, w="w", u="u", z=["x", "uw"])
    # g <= g_max is a non-strict side constraint, met to solver accuracy.
    assert design.gamma_opt <= design.gamma <= 1.2 * design.gamma_opt * (1 + 1e-6)
    for k in np.linspace(1.0, 4.0, 7):
        A, B_w, C, D = ct.ssdata(design.closed_loop(k))
        norm = ct.linfnorm(ct.ss(A, B_w, C, D))[0]
        assert norm <= design.gamma


def plain_cvxpy_hinf_gamma(A, B1, B2, C, D1, D2):
    """Lemma 2 for one vertex, written directly in cvxpy (independent)."""
    n, m = B2.shape
    nw, nz = B1.shape[1], C.shape[0]
    W = cp.Variable((n, n), symmetric=True)
    Z = cp.Variable((m, n))
    g = cp.Variable()
    M = cp.bmat(
        [
            [A @ W + W @ A.T + B2 @ Z + Z.T @ B2.T, B1, (C @ W + D2 @ Z).T],
            [B1.T, -np.eye(nw), D1.T],
            [C @ W + D2 @ Z, D1, -g * np.eye(nz)],
        ]
    )
    eps = 1e-8
    cons = [W >> eps * np.eye(n), 0.5 * (M + M.T) << -eps * np.eye(n + nw + nz)]
    cp.Problem(cp.Minimize(g), cons).solve(solver="CLARABEL")
    return float(np.sqrt(g.value))


def test_single_vertex_gamma_matches_plain_cvxpy_and_control():
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, -2.0, -0.5]])
    B1 = np.array([[0.0], [1.0], [0.5]])
    B2 = np.array([[0.0], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    D1 = np.zeros((2, 1))
    D2 = np.array([[0.0], [0.2]])
    plant = ct.ss(A, np.hstack([B1, B2]), C, np.hstack([D1, D2]),
                  inputs=["w", "u"], outputs=["y", "e"])  # fmt: skip
    sys = lpv.pss([plant])
    raw = lpv.hinf_state_feedback(sys, w="w", u="u", z=["y", "e"], backoff=None)
    reference = plain_cvxpy_hinf_gamma(A, B1, B2, C, D1, D2)
    assert raw.gamma == pytest.approx(reference, rel=0.01)
    assert raw.gamma_opt == pytest.approx(reference, rel=0.01)
    for design in (raw, lpv.hinf_state_feedback(sys, w="w", u="u", z=["y", "e"])):
        Acl, Bw, Ccl, Dcl = ct.ssdata(design.closed_loop(1.0))
        norm = ct.linfnorm(ct.ss(Acl, Bw, Ccl, Dcl))[0]
        assert norm <= design.gamma
    backed_off = lpv.hinf_state_feedback(sys, w="w", u="u", z=["y", "e"])
    assert np.linalg.norm(backed_off.gains[0]) < np.linalg.norm(raw.gains[0])


def test_given_gamma(mass_spring):
    best = lpv.hinf_state_feedback(mass_spring, w="w", u="u", z=["x", "uw"])
    design = lpv.hinf_state_feedback(
        mass_spring, w="w", u="u", z=["x", "uw"], gamma=2 * best.gamma
    )
    assert design.gamma <= 2 * best.gamma * (1 + 1e-9)
    with pytest.raises(lpv.InfeasibleError):
        lpv.hinf_state_feedback(
            mass_spring, w="w", u="u", z=["x", "uw"], gamma=0.5 * best.gamma_opt
        )


def test_non_stabilizable_vertex_is_named():
    good = ([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], np.eye(2), 0)
    # Second vertex: the first state is decoupled from the input, eigenvalue 0.
    bad = ([[0.0, 0.0], [0.0, -1.0]], [[0.0], [1.0]], np.eye(2), 0)
    sys = lpv.pss([good, bad], {"p": (0.0, 1.0)}, states=["a", "b"])
    with pytest.raises(
        lpv.InfeasibleError, match=r"vertex 1 \(p = \{'p': 1.0\}\)"
    ) as e:
        lpv.quadratic_stabilization(sys, u=0)
    assert "eigenvalue 0" in str(e.value) and "1*a" in str(e.value)


@pytest.mark.parametrize("scheduled", [False, True])
def test_pole_regions(unstable_pair, scheduled):
    function = (
        lpv.gain_scheduled_stabilization if scheduled else lpv.quadratic_stabilization
    )
    regions = [lpv.halfplane(1.0), lpv.disk(20.0)]
    design = function(unstable_pair, u="u", regions=regions)
    for delta in interior_deltas(2, count=30):
        A = sum(d * v.A for d, v in zip(delta, unstable_pair.vertices))
        B = sum(d * v.B for d, v in zip(delta, unstable_pair.vertices))
        eig = np.linalg.eigvals(A - B @ frozen_gain(design, delta))
        assert eig.real.max() < -1.0
        assert np.abs(eig).max() < 20.0


def test_sector_region(unstable_pair):
    angle = np.pi / 4
    design = lpv.quadratic_stabilization(
        unstable_pair, u="u", regions=[lpv.sector(angle)]
    )
    for v in unstable_pair.vertices:
        eig = np.linalg.eigvals(v.A - v.B @ design.gains[0])
        assert np.all(np.abs(eig.imag) <= -eig.real * np.tan(angle) + 1e-9)


def test_gain_bound(unstable_pair):
    free = lpv.quadratic_stabilization(
        unstable_pair, u="u", regions=[lpv.halfplane(2.0)]
    )
    bound = 30.0
    bounded = lpv.quadratic_stabilization(
        unstable_pair, u="u", regions=[lpv.halfplane(2.0)], gain_bound=bound
    )
    assert np.linalg.norm(bounded.gains[0], 2) <= bound
    assert bounded.certificate.verified
    assert free.certificate.verified
    # The gain bound is a sufficient condition: missing it proves nothing.
    with pytest.raises(lpv.CertificationError, match="gain_bound"):
        lpv.quadratic_stabilization(
            unstable_pair, u="u", regions=[lpv.halfplane(2.0)], gain_bound=0.1
        )


def test_scheduled_gain_interpolates(unstable_pair):
    design = lpv.gain_scheduled_stabilization(unstable_pair, u="u")
    np.testing.assert_allclose(
        design.gain(0.25), 0.75 * design.gains[0] + 0.25 * design.gains[1]
    )
    with pytest.raises(ValueError, match="p"):
        design.gain()


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"u": "nope"}, ValueError, "u: unknown signal 'nope'"),
        ({"u": "u", "w": "u"}, ValueError, "both exogenous and control"),
        ({"u": "u", "z": 7}, ValueError, "z: index 7"),
        ({"u": "u", "backoff": -1}, ValueError, "backoff"),
        ({"u": "u", "gamma": 0.0}, ValueError, "gamma"),
        ({"u": "u", "regions": ["disk"]}, TypeError, "regions"),
        ({}, ValueError, "u: name the control"),
    ],
)
def test_bad_arguments(mass_spring, kwargs, error, match):
    with pytest.raises(error, match=match):
        lpv.hinf_state_feedback(mass_spring, **kwargs)


def test_not_a_polytopic_system():
    with pytest.raises(TypeError, match="sys: expected a PolytopicStateSpace"):
        lpv.quadratic_stabilization(ct.rss(2, 1, 1), u=0)


# ----------------------------------------------------------------------
# Property-based: random polytopes
# ----------------------------------------------------------------------
@st.composite
def stabilizable_polytopes(draw):
    """Random polytopes quadratically stabilizable by construction.

    A_j = B_j K0 + S_j - c_j I with S_j skew-symmetric makes A_j - B_j K0 have
    the common Lyapunov matrix I, so Lemma 1 and Theorem 1 are feasible; the
    vertices are then hidden by a common change of coordinates.
    """
    n = draw(st.integers(2, 8))
    m = draw(st.integers(1, 2))
    N = draw(st.integers(2, 8))
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(m, n))
    # Well-conditioned coordinates (cond(T) <= 4): an orthogonal matrix
    # times a diagonal scaling.
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q @ np.diag(rng.uniform(0.5, 2.0, size=n))
    Ti = np.linalg.inv(T)
    vertices = []
    for _ in range(N):
        B = rng.normal(size=(n, m))
        S = rng.normal(size=(n, n))
        A = B @ K0 + (S - S.T) - rng.uniform(0.1, 1.0) * np.eye(n)
        B1 = rng.normal(size=(n, 1))
        C = rng.normal(size=(1, n))
        C_z = np.vstack([C @ Ti, np.zeros((m, n))])
        D_z = np.zeros((1 + m, 1 + m))
        D_z[1:, 1:] = np.eye(m)  # z = [C x, u]
        vertices.append((T @ A @ Ti, T @ np.hstack([B1, B]), C_z, D_z))
    return lpv.pss(vertices), list(range(1, 1 + m))


FAST = settings(
    max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)


@FAST
@given(stabilizable_polytopes(), st.sampled_from(list(SCHEDULED)))
def test_random_polytopes_every_design_is_certified(case, function):
    sys, u = case
    kwargs = (
        {"w": [0], "z": list(range(sys.noutputs))}
        if "hinf" in function.__name__
        else {}
    )
    design = function(sys, u=u, **kwargs)
    assert design.certificate.verified
    independent_check(sys, design, u)
    if design.gamma is not None:
        A, Bw, C, D = ct.ssdata(
            design.closed_loop(np.full(sys.nvertices, 1 / sys.nvertices))
        )
        assert ct.linfnorm(ct.ss(A, Bw, C, D))[0] <= design.gamma


@st.composite
def polytopes_with_bad_vertex(draw):
    n = draw(st.integers(2, 6))
    N = draw(st.integers(2, 6))
    bad = draw(st.integers(0, N - 1))
    eig = draw(st.floats(0.0, 2.0))
    rng = np.random.default_rng(draw(st.integers(0, 2**31 - 1)))
    vertices = []
    for j in range(N):
        A = rng.normal(size=(n, n))
        B = rng.normal(size=(n, 2))  # columns: w, u
        if j == bad:
            # Uncontrollable mode at eig >= 0: last state decoupled from u.
            A[-1, :] = 0.0
            A[-1, -1] = eig
            B[-1, 1] = 0.0
            T = rng.normal(size=(n, n)) + 3 * np.eye(n)
            A, B = T @ A @ np.linalg.inv(T), T @ B
        vertices.append((A, B, np.eye(n), 0))
    return lpv.pss(vertices), bad


@FAST
@given(polytopes_with_bad_vertex(), st.sampled_from(list(SCHEDULED)))
def test_non_stabilizable_vertex_always_raises(case, function):
    sys, bad = case
    kwargs = {"w": 0, "z": [0]} if "hinf" in function.__name__ else {}
    with pytest.raises(lpv.InfeasibleError, match=f"vertex {bad} "):
        function(sys, u=1, **kwargs)
