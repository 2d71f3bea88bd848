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
        A, Bw, C, D = design.closed_loop(k)
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
    A, *_ = design.closed_loop(k)
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(A)), sweep.poles[4], rtol=1e-10
    )


def test_gains_argument_checked(mass_spring):
    with pytest.raises(ValueError, match="gains"):
        lpv.frozen_sweep(mass_spring, np.ones((2, 2)), "u")
    with pytest.raises(ValueError, match="gains"):
        lpv.frozen_sweep(mass_spring, [np.ones((1, 2))] * 3, "u")
