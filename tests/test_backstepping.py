"""The backstepping baseline and the benchmark's quick run."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrl_lpv import twomass
from ctrl_lpv.twomass.backstepping import DEFAULT_GAINS, BacksteppingLaw

P = twomass.Parameters()


def test_settles_on_exact_plant_with_known_load():
    response = twomass.simulate(twomass.backstepping_controller(Td_hat=8.0), Td=8.0)
    theta_l = response.outputs[response.output_labels.index("theta_l")]
    after = response.time >= 1.0
    assert np.all(np.abs(theta_l[after] - 0.5) < 2e-3)


def test_lyapunov_function_decreases_on_design_model():
    """Along the design model (smooth dead zone, no cs, Td = Td_hat)."""
    law = BacksteppingLaw(P, DEFAULT_GAINS, P.alpha, 10.0, 1e-3, 8.0)

    def rhs(t, x):
        x1, x2, x3, x4 = x
        Dd, _ = law.D(x3 - x1)
        u = law.torque(x, 0.5)
        return [x2, (P.ks * Dd - P.cl * x2 - 8.0) / P.Jl, x4,
                (u - P.cm * x4 - P.ks * Dd) / P.Jm]  # fmt: skip

    T = np.linspace(0.0, 2.0, 4001)
    sol = solve_ivp(rhs, (0, 2), np.zeros(4), t_eval=T, rtol=1e-10, atol=1e-12,
                    method="LSODA")  # fmt: skip
    V = np.array([law.lyapunov(x, 0.5) for x in sol.y.T])
    # The smoothed inverse is not exact, so z = 0 is only reached up to a
    # residual; above it V must decrease monotonically.
    above = V[:-1] > 1e-3
    assert np.all(np.diff(V)[above] <= 1e-9 * V[:-1][above])
    assert V[-1] < 1e-8 * V[0]


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"gains": (1, 2, 3)}, "gains"),
        ({"gains": (1, 2, 3, -4)}, "gains"),
        ({"alpha": -0.1}, "alpha"),
        ({"eps": 0.0}, "eps"),
        ({"torque_limit": 0.0}, "torque_limit"),
    ],
)
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        twomass.backstepping_controller(**kwargs)
