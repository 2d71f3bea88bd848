"""The load inertia identified from a motor-encoder record (issue 22).

The facts checked are the simulated drive's: the inertia it was built with,
and the settling, overshoot and error of the servo designed on the
identified inertia, measured on the exact plant.
"""

from functools import cache

import numpy as np
import pytest

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from test_servo_motor import _pressed_targets_hold, _run

DT = 1e-3
P = twomass.Parameters()
MOTOR = {"theta_m": Encoder(2**20, 0.5)}


@cache
def _nominal():
    return twomass.servo_design(P, dt=DT, delay=1, sensors="motor", certify=False)


def _record(design, Jl, *, Td=8.0, alpha=0.03, theta_r=0.5, T=0.4, seed=1, flank=0):
    """The motor reading and the torque applied over each sample of a move
    on the drive of load inertia ``Jl x`` nominal, from rest with the load
    mid-gap (`flank` 0) or leaning on the flank `flank` (+1: behind the
    motor) under its load torque."""
    plant = twomass.plant(P.replace(Jl=Jl * P.Jl), alpha=alpha)
    X0 = [0.0, 0.0, -flank * alpha - (Td / P.ks if flank else 0.0), 0.0, flank * alpha]
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": theta_r},
        X0=X0, delay=1, sensors=MOTOR, seed=seed,
    )  # fmt: skip
    # With one sample of delay the command computed at t_k acts from t_{k+1}.
    applied = np.concatenate([[0.0], res.controller.outputs[0][:-1]])
    return res.controller.inputs[0], applied


@cache
def _commissioned(Jl, seed):
    found = twomass.identify_load_inertia(
        _nominal(), *_record(_nominal(), Jl, seed=seed)
    )
    design = twomass.servo_design(
        P.replace(Jl=found.Jl), dt=DT, delay=1, sensors="motor", certify=False
    )
    return found, design


@pytest.mark.parametrize(
    "Jl, Td, alpha, flank",
    [pytest.param(0.85, 8.0, 0.03, 0, marks=pytest.mark.slow), (1.15, -8.0, 0.06, -1)],
)
def test_the_inertia_of_the_simulated_drive_is_found(Jl, Td, alpha, flank):
    """From mid-gap, and from a load leaning on its flank at rest."""
    found = twomass.identify_load_inertia(
        _nominal(), *_record(_nominal(), Jl, Td=Td, alpha=alpha, flank=flank)
    )
    assert found.factor == pytest.approx(Jl, rel=0.015)
    assert found.Jl == pytest.approx(found.factor * P.Jl)
    assert found.sharpness >= 2.0
    # The estimate is the minimum of the profile it reports.
    assert found.innovation <= found.innovations.min() * (1.0 + 1e-9)


@pytest.mark.parametrize("Jl", [pytest.param(0.8, marks=pytest.mark.slow), 1.2])
def test_the_design_on_the_identified_inertia_meets_the_targets(Jl):
    """Jl x0.8 and x1.2 under 8 Nm: the nominal design misses the motor
    encoder's targets on the paper's move (settling <= 0.5 s, overshoot <=
    2 %, |e| <= 1e-3 rad); designed on the identified inertia it meets them."""
    before = _run(_nominal(), 8.0, 0.03, 0.5, Jl=Jl, T=2.0, seed=2)
    assert before["overshoot"] > 2.0 or before["error"] > 1e-3, before
    found, design = _commissioned(Jl, 2)
    assert found.factor == pytest.approx(Jl, rel=0.015)
    after = _run(design, 8.0, 0.03, 0.5, Jl=Jl, T=2.0, seed=2)
    _pressed_targets_hold(after)
    # The rest is quiet: no limit cycle on the motor torque.
    assert after["torque_std"] <= 3.0, after


def test_a_record_at_rest_is_refused():
    theta_m, torque = _record(_nominal(), 1.0, Td=0.0, theta_r=0.0, T=0.1)
    with pytest.raises(ValueError, match="does not identify the load inertia"):
        twomass.identify_load_inertia(_nominal(), theta_m, torque)


def test_bad_arguments_are_named():
    theta_m, torque = np.zeros(50), np.zeros(50)
    encoders = twomass.servo_design(dt=DT, delay=1, sensors="encoders", certify=False)
    with pytest.raises(ValueError, match="design"):
        twomass.identify_load_inertia(encoders, theta_m, torque)
    with pytest.raises(ValueError, match="torque"):
        twomass.identify_load_inertia(_nominal(), theta_m, torque[:-1])
    with pytest.raises(ValueError, match="theta_m"):
        twomass.identify_load_inertia(_nominal(), [0.0, np.nan] * 10, np.zeros(20))
    with pytest.raises(ValueError, match="search"):
        twomass.identify_load_inertia(_nominal(), theta_m, torque, search=(1.3, 1.1))


#: The widest gap's first move overshoots 1.79 % on the nominal drive and
#: design, 1.86-1.87 % at Jl x0.8 on the design with the exact inertia (seeds
#: 1-3): the identified x0.796-0.797 tips it to 2.00-2.04 %.
_WIDEST_LIGHT = pytest.mark.xfail(
    strict=False, reason="the widest gap's first move at Jl x0.8: 2.0 % overshoot"
)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("Jl", [0.8, 0.9, 1.1, 1.2])
@pytest.mark.parametrize(
    "Td, alpha, theta_r",
    [(8.0, 0.03, 0.5), (8.0, 0.06, 0.5), (8.0, 0.03, -0.5), (8.0, 0.03, 0.05),
     (8.0, 0.03, -0.05), (5.0, 0.03, 1.0)],
)  # fmt: skip
def test_commissioned_grid(Jl, seed, Td, alpha, theta_r, request):
    """Commissioned on a 0.4 s record of the paper's move (8 Nm, 0.03 rad),
    the design meets the motor encoder's targets on other loads and moves."""
    if (Jl, alpha) == (0.8, 0.06):
        request.applymarker(_WIDEST_LIGHT)
    found, design = _commissioned(Jl, seed)
    assert found.factor == pytest.approx(Jl, rel=0.01)
    _pressed_targets_hold(_run(design, Td, alpha, theta_r, Jl=Jl, T=2.0, seed=seed))
