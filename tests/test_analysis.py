import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv


def test_quadratic_stability_of_closed_loop(unstable_pair):
    design = lpv.quadratic_stabilization(unstable_pair, u="u")
    loop = lpv.pss(
        [(v.A - v.B @ design.gains[0], v.B, v.C, v.D) for v in unstable_pair.vertices],
        unstable_pair.domain,
    )
    result = lpv.quadratic_stability(loop)
    for v in loop.vertices:
        assert np.linalg.eigvalsh(v.A.T @ result.P + result.P @ v.A)[-1] < 0
    with pytest.raises(lpv.InfeasibleError):
        lpv.quadratic_stability(unstable_pair)


@pytest.mark.parametrize("function", [lpv.hinf_state_feedback, lpv.gain_scheduled_hinf])
def test_l2_gain_bound_of_design_gains(mass_spring, function):
    design = function(mass_spring, w="w", u="u", z=["x", "uw"])
    bound = lpv.l2_gain_bound(mass_spring, list(design.gains), "w", "u", ["x", "uw"])
    # The analysis LMI is the synthesis LMI at fixed gains: the same bound,
    # up to the effect of the strict-inequality margins.
    assert bound.gamma <= design.gamma * (1 + 1e-3)
    for k in np.linspace(1.0, 4.0, 5):
        A, Bw, C, D = ct.ssdata(design.closed_loop(k))
        assert ct.linfnorm(ct.ss(A, Bw, C, D))[0] <= bound.gamma * (1 + 1e-9)


def test_frozen_sweep(mass_spring):
    design = lpv.gain_scheduled_hinf(mass_spring, w="w", u="u", z=["x", "uw"])
    sweep = lpv.frozen_sweep(
        mass_spring, list(design.gains), "u", points=9, w="w", z=["x", "uw"]
    )
    assert sweep.points.shape == (9, 1)
    assert np.all(sweep.max_real < 0)
    assert np.all(sweep.hinf <= design.gamma)
    k = sweep.points[4, 0]
    A, *_ = ct.ssdata(design.closed_loop(k))
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(A)), sweep.poles[4], rtol=1e-10
    )


def test_gains_argument_checked(mass_spring):
    with pytest.raises(ValueError, match="gains"):
        lpv.frozen_sweep(mass_spring, np.ones((2, 2)), "u")
    with pytest.raises(ValueError, match="gains"):
        lpv.frozen_sweep(mass_spring, [np.ones((1, 2))] * 3, "u")


def tilted_box():
    """x' = (-1 + 2a - 2b) x + u on a, b in [0, 1].

    Constant (-1) on the diagonal a = b; the worst point is the corner
    (a, b) = (1, 0), where the pole is +1, and the best (0, 1), at -3.
    """
    return lpv.PolytopicStateSpace.from_affine(
        ([[-1.0]], [[1.0]], [[1.0]], 0),
        {"a": ([[2.0]], 0, 0, 0), "b": ([[-2.0]], 0, 0, 0)},
        {"a": (0.0, 1.0), "b": (0.0, 1.0)},
        inputs="u",
    )


@pytest.mark.parametrize("points", [None, 2, 9, 30])
def test_frozen_sweep_default_points_reach_off_diagonal_corners(points):
    sys = tilted_box()
    sweep = lpv.frozen_sweep(sys, np.zeros((1, 1)), "u", points=points)
    P = sweep.points
    corners = {(0.0, 0.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1.0)}
    assert corners <= {tuple(p) for p in P}
    # Interior points too, all inside the box.
    assert np.any(np.all((P > 0) & (P < 1), axis=1))
    assert np.all((P >= 0) & (P <= 1))
    # The pole at each point, from the formula, and the worst corner found.
    np.testing.assert_allclose(
        sweep.max_real, -1 + 2 * P[:, 0] - 2 * P[:, 1], rtol=1e-12, atol=1e-12
    )
    worst = P[np.argmax(sweep.max_real)]
    np.testing.assert_array_equal(worst, [1.0, 0.0])
    assert sweep.max_real.max() == pytest.approx(1.0)


def test_frozen_sweep_default_grid_size():
    sweep = lpv.frozen_sweep(tilted_box(), np.zeros((1, 1)), "u")
    assert sweep.points.shape == (49, 2)  # 7 x 7 for the default 51
    assert len({tuple(p) for p in sweep.points}) == 49


def test_frozen_sweep_on_a_simplex_samples_inside(unstable_pair):
    vertices = [
        (v.A * s, v.B, v.C, v.D) for v in unstable_pair.vertices for s in (1.0, 0.5)
    ][:3]
    sys = lpv.pss(vertices, inputs="u")  # the simplex of 3 convex coordinates
    sweep = lpv.frozen_sweep(sys, np.zeros((1, 2)), "u", points=20)
    assert sweep.points.shape == (20, 3)
    np.testing.assert_array_equal(sweep.points[:3], np.eye(3))
    assert all(sys.domain.contains(p) for p in sweep.points)
    # Same points on every call (seeded).
    again = lpv.frozen_sweep(sys, np.zeros((1, 2)), "u", points=20)
    np.testing.assert_array_equal(sweep.points, again.points)
    for p, poles in zip(sweep.points, sweep.poles):
        A = sum(pj * v[0] for pj, v in zip(p, vertices))
        np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A)), poles)


@pytest.mark.parametrize("bad", [1, 0, -3, 2.5, True, "9"])
def test_frozen_sweep_point_count_checked(mass_spring, bad):
    with pytest.raises(ValueError, match="points"):
        lpv.frozen_sweep(mass_spring, np.zeros((1, 2)), "u", points=bad)
