"""The free-load rest by a wall and a dead catch (`twomass.free_rest`)."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.linalg import expm

from _issue22 import knife_edge
from ctrl_lpv import twomass
from ctrl_lpv.sampled import sampled_response
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.free_rest import (
    FREE_REST_STATES,
    FreeRest,
    free_rest_stepper,
)

DT = 1e-3
ENCODERS = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}
LOAD_STEP = 2.0 * math.pi / 2**17
FREE = FreeRest(reading_variance=LOAD_STEP**2 / 3.0)
P = twomass.Parameters()
# The drive's numbers the stepper reads (the law's motor gains for the stiff
# approach: those of the 1 ms design, rounded).
TUNING = SimpleNamespace(
    Jm=P.Jm, Jl=P.Jl, cm=P.cm, cl=P.cl, gain=(7315.0, 91.0, 0.0, 0.0, 0.0)
)


def _coast(t, e0, v0, torque=0.0):
    """The free load's error and speed: ``Jl v' = -cl v - torque``."""
    tau = P.Jl / P.cl
    v_end = -torque / P.cl
    v = v_end + (v0 - v_end) * np.exp(-t / tau)
    e = e0 + v_end * t + tau * (v0 - v_end) * (1.0 - np.exp(-t / tau))
    return e, v


def _parked(load_errors, load_speed, *, seed=1, side=1.0, motor=0.03 - 1e-3):
    """The stepper along load readings (encoder quantized, half a count of
    noise), the target 0, the motor a free inertia (from rest at `motor`)
    under its command, held over each sample, the load out of its reach."""
    step = free_rest_stepper(FREE, TUNING, DT)
    rng = np.random.default_rng(seed)
    a = np.array([[0.0, 1.0, 0.0], [0.0, -P.cm / P.Jm, 1.0 / P.Jm], [0.0, 0.0, 0.0]])
    hold = expm(a * DT)
    z, x = np.zeros(len(FREE_REST_STATES)), np.array([motor, 0.0])
    z[FREE_REST_STATES.index("free_allowed")] = 1.0  # after a move
    rows = []
    for e in load_errors:
        reading = ENCODERS["theta_l"](e, rng)
        out = step(
            z, resting=True, latched=True, side=side, evidence=0.0,
            target=0.0, load=reading, load_error=e, load_speed=load_speed,
            load_torque=0.0, rest_torque=0.0, motor=x[0], motor_speed=x[1],
            alpha_hat=0.03,
        )  # fmt: skip
        z = out.state
        torque = 0.0 if out.command is None else out.command
        x = (hold @ [*x, torque])[:2]
        rows.append((out.command, z.copy()))
    return rows


def test_drift_filter_follows_a_coasting_load():
    """A load coasting free (no load torque) from 3e-4 rad short of the
    target at 2e-4 rad/s, read by a 17-bit encoder: the drift filter's speed
    is the analytic coast's within 2e-5 rad/s after half a second, its
    error within two counts, and the rest stays engaged (a coast is no load
    torque for the lean filter: ``Jl a + cl v = 0``)."""
    t = DT * np.arange(1, 1501)
    e, v = _coast(t, -3e-4, 2e-4)
    rows = _parked(e, 2e-4)
    speed = np.array([z[FREE_REST_STATES.index("drift_v")] for _, z in rows])
    error = np.array([z[FREE_REST_STATES.index("drift_e")] for _, z in rows])
    late = t >= 0.5
    assert np.abs(speed[late] - v[late]).max() <= 2e-5
    assert np.abs(error[late] - e[late]).max() <= 2.0 * LOAD_STEP
    assert all(command is not None for command, _ in rows)
    assert rows[-1][1][FREE_REST_STATES.index("free_engaged")] == 1.0


def test_a_load_torque_hands_the_rest_back():
    """The same load under 0.5 Nm of load torque (beyond `leave_torque`):
    the lean filter sees the load accelerated by it and hands the rest back
    to the latched law within 0.3 s, not to engage again before the next
    move."""
    t = DT * np.arange(1, 1001)
    e, _ = _coast(t, -3e-4, 0.0, torque=-0.5)
    rows = _parked(e, 0.0)
    handed = [k for k, (command, _) in enumerate(rows) if command is None]
    assert handed and t[handed[0]] <= 0.3
    z = rows[-1][1]
    assert z[FREE_REST_STATES.index("free_allowed")] == 0.0
    assert z[FREE_REST_STATES.index("free_engaged")] == 0.0


def test_the_wall_stands_short_of_the_target_and_of_the_load():
    """Engaged with the load 1e-4 rad short of the target (on the wall's
    side, still), the wall is placed short of the target by at least the
    clearance, at the half-gap estimate past the motor's flank; the motor is
    taken there along the stiff approach and held there softly (the
    command's stiffness, measured by a displaced motor, is the hold's)."""
    rows = _parked(np.full(400, -1e-4), 0.0)
    z = rows[-1][1]
    wall = z[FREE_REST_STATES.index("wall_to")]
    depth = z[FREE_REST_STATES.index("wall_depth")]
    assert depth <= -FREE.clearance
    assert wall == pytest.approx(0.03 + depth, abs=1e-15)
    assert -1e-4 - FREE.wall_margin <= depth
    assert z[FREE_REST_STATES.index("wall_phase")] == 2.0  # held
    step = free_rest_stepper(FREE, TUNING, DT)
    torques = [
        step(
            z, resting=True, latched=True, side=1.0, evidence=0.0,
            target=0.0, load=-1e-4, load_error=-1e-4, load_speed=0.0,
            load_torque=0.0, rest_torque=0.0, motor=wall + d, motor_speed=0.0,
            alpha_hat=0.03,
        ).command
        for d in (0.0, 1e-4)
    ]  # fmt: skip
    assert (torques[0] - torques[1]) / 1e-4 == pytest.approx(FREE.hold_stiffness)


def test_the_rest_waits_for_a_parked_motor():
    """A slow, still load with no load torque engages the free rest only
    with the motor parked: a motor arriving at 0.19 rad/s (a move's end on
    encoders) would run into the load the wall is placed for."""
    step = free_rest_stepper(FREE, TUNING, DT)
    z = np.zeros(len(FREE_REST_STATES))
    z[FREE_REST_STATES.index("free_allowed")] = 1.0  # after a move
    engaged = FREE_REST_STATES.index("free_engaged")
    for speed, expected in ((0.19, 0.0), (0.5 * FREE.entry_motor_speed, 1.0)):
        out = step(
            z, resting=True, latched=True, side=1.0, evidence=0.0,
            target=0.0, load=-1e-4, load_error=-1e-4, load_speed=0.0,
            load_torque=0.0, rest_torque=0.0, motor=0.03 - 1e-3,
            motor_speed=speed, alpha_hat=0.03,
        )  # fmt: skip
        assert out.state[engaged] == expected
        assert (out.command is not None) == bool(expected)


def test_settings_are_checked():
    with pytest.raises(TypeError, match="ServoAntiHunting.free_rest"):
        twomass.ServoAntiHunting(free_rest=1.0)
    with pytest.raises(ValueError, match="reading_variance"):
        free_rest_stepper(FreeRest(), TUNING, DT)


@pytest.fixture(scope="module")
def design():
    return twomass.servo_design(dt=DT, delay=1, sensors="encoders", certify=False)


def test_states_only_on_both_encoders_up_to_fast_sampling(design):
    """The free rest's states end the sampled servo's on both encoders (its
    reading variance the load encoder's); not on the motor encoder alone,
    not at 2 ms by default, not when switched off."""
    labels = design.controller().state_labels
    assert labels[-len(FREE_REST_STATES) :] == FREE_REST_STATES
    assert design.tuning.rest_flank is not None
    for other in (
        twomass.servo_design(dt=DT, delay=1, sensors="motor", certify=False),
        twomass.servo_design(dt=2e-3, delay=1, sensors="encoders", certify=False),
        twomass.servo_design(
            dt=DT, delay=1, sensors="encoders", certify=False,
            anti_hunting=twomass.ServoAntiHunting(free_rest=None),
        ),
    ):  # fmt: skip
        assert "free_engaged" not in other.controller().state_labels


def _rest(design, *, alpha, theta_r=0.5, seed=1, T=4.0, Td=0.0, inertia=1.0):
    plant = twomass.plant(dataclasses.replace(P, Jl=inertia * P.Jl), alpha=alpha)
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": theta_r},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    t, e = res.plant.time, res.plant.outputs[2] - theta_r
    last = t >= T - 1.0
    return res, e, last


@pytest.mark.parametrize("seed", [1, 2])
def test_the_load_rests_on_a_still_motor(design, seed):
    """Td = 0, alpha 0.06, 0.5 rad: the load rests within the issue's
    2e-4 rad of the target with a peak-to-peak below 2e-4 over the last
    second and the torque quiet, the free rest engaged, and the motor,
    held on its wall with no load terms, within 5e-5 rad of it (the latched
    law's parked motor: 3.2e-4 peak-to-peak on encoders)."""
    res, e, last = _rest(design, alpha=0.06, seed=seed)
    x, labels, t = (
        res.controller.states,
        res.controller.state_labels,
        res.controller.time,
    )
    assert abs(e[-1]) <= 2e-4 and np.ptp(e[last]) <= 2e-4
    assert np.std(res.plant.inputs[0][last]) <= 3.0
    assert x[labels.index("free_engaged")][-1] == 1.0
    held = (x[labels.index("wall_phase")] == 2.0) & (t >= t[-1] - 1.0)
    motor = np.interp(t[held], res.plant.time, res.plant.outputs[0])
    assert held.sum() >= 500
    assert np.abs(motor - x[labels.index("wall_to")][held]).max() <= 5e-5


@pytest.mark.parametrize("seed", [1, 2])
def test_a_load_torque_arriving_at_rest_is_held_on_the_flank(design, seed):
    """Td = 0 until the free rest holds the load, then 1 Nm (below the
    observer's contact torque): the rest is handed back to the latched law,
    whose integral holds the load on the flank at the target (the shaft in
    contact over the last second, carrying the load torque)."""
    res, e, last = _rest(
        design, alpha=0.06, T=5.0, seed=seed, Td=lambda t: 1.0 if t >= 2.5 else 0.0
    )
    labels = res.controller.state_labels
    engaged = res.controller.states[labels.index("free_engaged")]
    t = res.controller.time
    assert engaged[(t > 2.0) & (t < 2.5)].min() == 1.0
    assert engaged[-1] == 0.0
    shaft = res.plant.outputs[4][last]
    assert np.abs(e[last]).max() <= 1e-4
    assert shaft.min() > 0.0 and abs(shaft.mean() - 1.0) <= 0.05


_TD0_ROWS = [(0.03, 0.5), (0.06, 0.5), (0.06, -0.5), (0.03, 0.05)]


def _misses(design, seeds):
    missed = 0
    for alpha, theta_r in _TD0_ROWS:
        for seed in seeds:
            res, e, last = _rest(design, alpha=alpha, theta_r=theta_r, seed=seed)
            std = np.std(res.plant.inputs[0][last])
            missed += abs(e[-1]) > 2e-4 or np.ptp(e[last]) > 2e-4 or std > 3.0
    return missed


@pytest.mark.slow
def test_the_free_rest_misses_fewer_targets_than_the_latched_law(design):
    """The four Td = 0 rows of the bench on noise seeds 1-6, the issue's
    rest targets (end error and last-second peak-to-peak 2e-4 rad, torque
    standard deviation 3 Nm): the free rest misses none of 24 runs (none of
    384 on seeds 1-96, docs/servo.rst), the latched law alone about a
    third."""
    latched = twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", certify=False,
        anti_hunting=twomass.ServoAntiHunting(free_rest=None),
    )  # fmt: skip
    seeds = range(1, 7)
    free, old = _misses(design, seeds), _misses(latched, seeds)
    assert free == 0
    assert old >= 4


@pytest.mark.slow
@pytest.mark.parametrize("seed", [33, 50])
def test_a_motor_arriving_late_is_not_a_wall(design, seed):
    """Td 0, alpha 0.03, 0.5 rad, seeds where the free rest engaged on a
    motor still arriving on its flank (0.19 rad/s on seed 33, the load's
    speed read as 5e-4 rad/s for 1.4e-3): the motor ran into the load, the
    wall's catch was stiff, and the latched law's flips a 440 Nm ping-pong
    (92 Nm of torque std on seed 33). Waiting for the parked motor, the
    issue's rest."""
    res, e, last = _rest(design, alpha=0.03, seed=seed, T=5.0)
    assert abs(e[-1]) <= 2e-4 and np.ptp(e[last]) <= 2e-4
    assert np.std(res.plant.inputs[0][last]) <= 3.0


# Td 0 first moves off the bench's rows (alpha, load inertia factor, step,
# noise seed; drawn at random), each missed by the free rest that placed its
# walls on the move's half-gap estimate (1.1-2.1e-4 rad wide at the end of
# the move): torque std 3.4-15.2 Nm, or the load resting or swinging beyond
# 2e-4 rad (docs/servo.rst, "The free rest's walls on the measured
# half-gap").
_OFF_BENCH = [
    (0.055, 0.8, 0.16, 5007),
    (0.0467, 1.097, -0.322, 5013),
    (0.0552, 1.1, -0.301, 7056),
    pytest.param(
        0.0546,
        1.155,
        0.482,
        8010,
        marks=knife_edge(
            "stop 63: the rest's peak-to-peak 9.0e-4 rad once the first "
            "fall ran to the contact; random Td 0 first moves miss on 6 "
            "of 300, 3 before"
        ),
    ),
    (0.0406, 1.115, 0.324, 8020),
]


@pytest.mark.slow
@pytest.mark.parametrize("alpha, inertia, theta_r, seed", _OFF_BENCH)
def test_walls_on_the_measured_half_gap(design, alpha, inertia, theta_r, seed):
    """The issue's rest (end error and last-second peak-to-peak 2e-4 rad,
    torque std 3 Nm), and the half-gap the walls stand on (the move's
    estimate and the offset measured where the load touched them) is the
    plant's within a load-encoder count."""
    res, e, last = _rest(
        design, alpha=alpha, theta_r=theta_r, seed=seed, T=5.0, inertia=inertia
    )
    assert abs(e[-1]) <= 2e-4 and np.ptp(e[last]) <= 2e-4
    assert np.std(res.plant.inputs[0][last]) <= 3.0
    x, labels = res.controller.states, res.controller.state_labels
    half_gap = (
        design.tuning.alpha_initial
        + x[labels.index("alpha_hat_dev")][-1]
        + x[labels.index("gap_offset")][-1]
    )
    assert abs(half_gap - alpha) <= LOAD_STEP
