"""The LPV model (30), the published gain and the paper's LMIs."""

import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv import twomass

P = twomass.Parameters()


def physics(x, Td, theta_r, Tm, p, error_coordinates):
    """Equations (1)-(6) with theta_s = (1 + p) theta_d, written directly."""
    x1, wm, x3, wl = x
    theta_m = x1 + theta_r if error_coordinates else x1
    theta_l = x3 + theta_r
    Ts = P.ks * (1 + p) * (theta_m - theta_l) + P.cs * (wm - wl)
    return np.array(
        [wm, (Tm - P.cm * wm - Ts) / P.Jm, wl, (Ts - P.cl * wl - Td) / P.Jl]
    )


def linear_map(f, size):
    """Matrix of a linear function by its action on unit vectors."""
    return np.column_stack([f(np.eye(size)[i]) for i in range(size)])


@pytest.mark.parametrize("p", [-0.95, -0.5, 0.0])
def test_paper_model_matches_equations(p):
    sys = twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="paper")
    assert sys.input_labels == ["Td", "theta_r", "Tm"]
    assert sys.state_labels == ["theta_m", "omega_m", "e_l", "omega_l"]
    frozen = sys.at(p)
    A = linear_map(lambda x: physics(x, 0, 0, 0, p, False), 4)
    B = linear_map(lambda w: physics(np.zeros(4), *w, p, False), 3)
    np.testing.assert_allclose(frozen.A, A, rtol=1e-14)
    np.testing.assert_allclose(frozen.B, B, rtol=1e-14)
    # z = theta_l = x3 + theta_r: C = [0 0 1 0], D1 = [0 1].
    np.testing.assert_array_equal(frozen.C, [[0, 0, 1, 0]])
    np.testing.assert_array_equal(frozen.D, [[0, 1, 0]])


@pytest.mark.parametrize("p", [-0.95, 0.0])
def test_tracking_model_matches_equations(p):
    sys = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    assert sys.input_labels == ["Td", "Tm"]
    assert sys.state_labels == ["e_m", "omega_m", "e_l", "omega_l", "int_e_l"]
    frozen = sys.at(p)
    A = linear_map(lambda x: physics(x, 0, 0, 0, p, True), 4)
    np.testing.assert_allclose(frozen.A[:4, :4], A, rtol=1e-14)
    np.testing.assert_array_equal(frozen.A[4], [0, 0, 1, 0, 0])
    B = linear_map(lambda w: physics(np.zeros(4), w[0], 0.5, w[1], p, True), 2)
    np.testing.assert_allclose(frozen.B[:4], B, rtol=1e-14)


def test_published_gain_sign():
    # Section V: K = 1e4 [-1.292820 -0.018157 -2.949388 -0.180820] for u = K x.
    published = 1e4 * np.array([-1.292820, -0.018157, -2.949388, -0.180820])
    np.testing.assert_array_equal(twomass.paper_gain(), -published[None, :])


def test_published_gain_eigenvalues_across_p():
    sys = twomass.lpv_model(p_bounds=(-1.0, 0.0), formulation="paper")
    K = twomass.paper_gain()
    b = sys.vertices[0].B[:, [2]]
    # At p = -1 the mode Jl omega_l + (cl + cs) theta_l - cs theta_m does not
    # see the input: an eigenvalue stays at exactly 0 whatever the gain.
    left = np.array([-P.cs, 0.0, P.cl + P.cs, P.Jl])
    A_gap = sys.at(-1.0).A
    np.testing.assert_allclose(left @ A_gap, 0, atol=1e-12)
    assert left @ b == pytest.approx(0.0)
    eig = np.linalg.eigvals(A_gap - b @ K)
    assert np.min(np.abs(eig)) < 1e-9
    for p in np.linspace(-0.95, 0.0, 20):
        assert np.linalg.eigvals(sys.at(p).A - b @ K).real.max() < 0


def test_paper_lmis_on_full_range_are_infeasible():
    sys = twomass.lpv_model(p_bounds=(-1.0, 0.0), formulation="paper")
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.gain_scheduled_hinf(sys, w=["Td", "theta_r"], u="Tm", z="theta_l")
    message = str(info.value)
    assert "vertex 0 (p = {'p': -1.0})" in message
    assert "eigenvalue 0 " in message


def test_default_tracking_design_is_certified():
    sys = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    design = lpv.hinf_state_feedback(sys, w="Td", u="Tm", z=sys.output_labels)
    assert design.certificate.verified
    for p in np.linspace(-0.95, 0.0, 11):
        A = design.closed_loop(p).A
        assert np.linalg.eigvals(A).real.max() < 0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"formulation": "other"}, "formulation"),
        ({"p_bounds": (0.0, -1.0)}, "p_bounds"),
        ({"p_bounds": (-1.5, 0.0)}, "p_bounds"),
        ({"integral": True}, "integral"),
        ({"formulation": "tracking", "torque_weight": 0.0}, "torque_weight"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        twomass.lpv_model(**kwargs)
