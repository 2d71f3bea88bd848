"""The load inertia and half-gap identified from a motor-encoder record
(issue 22).

The facts checked are the simulated drive's: the inertia and the half-gap
it was built with, and the settling, overshoot and error of the servo
designed on the identified ones, measured on the exact plant.
"""

from functools import cache

import numpy as np
import pytest

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass import ServoEstimator
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
def _commissioned(Jl, seed, alpha=0.03):
    """The servo designed on the load inertia and the half-gap identified
    from the nominal design's 0.5 rad move under 8 Nm on the drive."""
    found = twomass.identify_load_inertia(
        _nominal(), *_record(_nominal(), Jl, alpha=alpha, seed=seed)
    )
    design = twomass.servo_design(
        P.replace(Jl=found.Jl), dt=DT, delay=1, sensors="motor", certify=False,
        estimator=ServoEstimator(initial_half_gap=found.half_gap),
    )  # fmt: skip
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
    assert found.half_gap == pytest.approx(alpha, abs=1e-3)
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


@pytest.mark.parametrize(
    "theta_r, seed",
    [
        (0.1, 1),
        *(pytest.param(*c, marks=pytest.mark.slow) for c in [(-0.05, 2), (0.2, 3)]),
    ],
)
def test_the_commissioned_half_gap_holds_the_small_moves_at_a_wide_gap(theta_r, seed):
    """At the widest gap (0.06) under 8 Nm the nominal design's estimate
    starts at 0.03: the first contact comes late and throws the load (0.1
    rad: 5.8 % overshoot; -0.05 rad: 244 %, seed 2; 0.2 rad: 5.4 %).
    Commissioned on a 0.5 rad move of the drive, the half-gap found starts
    the estimate and the moves meet the motor encoder's targets."""
    before = _run(_nominal(), 8.0, 0.06, theta_r, T=2.0, seed=seed)
    assert before["overshoot"] > 2.0, before
    found, design = _commissioned(1.0, seed, alpha=0.06)
    assert found.half_gap == pytest.approx(0.06, abs=1e-3)
    after = _run(design, 8.0, 0.06, theta_r, T=2.0, seed=seed)
    _pressed_targets_hold(after)
    assert after["torque_std"] <= 3.0, after


def test_the_initial_half_gap_is_checked():
    with pytest.raises(ValueError, match="ServoEstimator.initial_half_gap"):
        ServoEstimator(initial_half_gap=-0.01)
    with pytest.raises(ValueError, match="estimator.initial_half_gap"):
        twomass.servo_design(
            dt=DT, delay=1, sensors="motor", certify=False,
            estimator=ServoEstimator(initial_half_gap=0.07),
        )  # fmt: skip
    # The default starts the estimate mid-range.
    assert _nominal().tuning.alpha_initial == pytest.approx(0.03)


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


#: Rows of `test_commissioned_grid` that miss on seeds 1-3. Strict: a pass
#: here is news.
_COMMISSIONED_MISSES = {
    (0.8, 8.0, 0.03, -0.05): "issue 22: 3.56-3.57 % since the first-contact "
    "prior carries the fall's speed error (`motor_estimator.LOAD_FALL_TIME`; "
    "0.68-1.89 % before, 3.15-3.28 % with 5 ms): the light load's first move "
    "along the load torque",
}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("Jl", [0.8, 0.9, 1.1, 1.2])
@pytest.mark.parametrize(
    "Td, alpha, theta_r",
    [(8.0, 0.03, 0.5), (8.0, 0.06, 0.5), (8.0, 0.03, -0.5), (8.0, 0.03, 0.05),
     (8.0, 0.03, -0.05), (5.0, 0.03, 1.0)],
)  # fmt: skip
def test_commissioned_grid(Jl, seed, Td, alpha, theta_r, request):
    """Commissioned on a 0.4 s record of the paper's move (8 Nm) on the
    drive, the design meets the motor encoder's targets on other loads and
    moves (but `_COMMISSIONED_MISSES`). (Commissioned at another half-gap,
    0.03, the widest gap at Jl x0.8 overshot 2.00-2.04 %.)"""
    if (Jl, Td, alpha, theta_r) in _COMMISSIONED_MISSES:
        request.applymarker(
            pytest.mark.xfail(
                strict=True, reason=_COMMISSIONED_MISSES[Jl, Td, alpha, theta_r]
            )
        )
    found, design = _commissioned(Jl, seed, alpha)
    assert found.factor == pytest.approx(Jl, rel=0.01)
    _pressed_targets_hold(_run(design, Td, alpha, theta_r, Jl=Jl, T=2.0, seed=seed))
