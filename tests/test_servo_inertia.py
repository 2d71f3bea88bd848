"""The sampled servo on a load heavier or lighter than nominal (issue 22).

Moves and reversals across the gap at ``Jl x 0.8 .. 1.2``: the exact
backlash plant integrated between samples (`sampled_response`), read by 20-
and 17-bit encoders with half a count of noise, 1 ms, one sample of delay,
|Tm| <= 500 Nm; settling and overshoot computed here from the plant's load
angle. Without the inertia estimate these reversals overshoot by 2.6-6.3 %
at ``Jl x 1.2`` (checked below on one of them).
"""

import itertools

import numpy as np
import pytest

from _issue22 import grid_mark
from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.drive_observer import (
    DRIVE_STATES,
    drive_observer,
    observer_matrices,
)
from ctrl_lpv.twomass.inertia import INERTIA_STATES, InertiaAdaptation, ServoInertia

DT = 1e-3
ENCODERS = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}
SWITCH, T = 2.0, 4.0


@pytest.fixture(scope="module")
def design():
    return twomass.servo_design(dt=DT, delay=1, sensors="encoders", certify=False)


def _move(design, *, start, target, Jl, Td=3.0, alpha=0.03, seed=5):
    """Rest at `start` (reached from 0), then a move to `target` at SWITCH."""
    params = twomass.Parameters()
    plant = twomass.plant(params.replace(Jl=Jl * params.Jl), alpha=alpha)
    res = sampled_response(
        plant, design.controller(), T,
        inputs={"Td": Td, "theta_r": lambda t: start if t < SWITCH else target},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    t, theta_l = res.plant.time, res.plant.outputs[2]
    after = t >= SWITCH
    e, step = theta_l[after] - target, target - start
    outside = np.flatnonzero(np.abs(e) > 0.02 * abs(step))
    since = t[after] - SWITCH
    settling = 0.0
    if outside.size:
        settling = since[outside[-1] + 1] if outside[-1] + 1 < e.size else np.inf
    overshoot = max(0.0, float(np.max(np.sign(step) * e))) / abs(step) * 100
    return dict(settling=settling, overshoot=overshoot, res=res)


@pytest.mark.parametrize("start, target", [(0.5, 0.0), (-0.3, 0.05)])
def test_reversal_on_a_heavier_load(design, start, target):
    """Jl x 1.2: a reversal across the gap after a move the other way."""
    m = _move(design, start=start, target=target, Jl=1.2)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


def test_a_load_running_ahead_is_braked_not_let_go(design):
    """Jl x1.2, Td 0, alpha 0.06, a 0.05 rad step from rest: the heavier
    load runs ahead at the end of the move and the observer reads its
    inertia as 2.5-4.5 Nm of load torque; the hold's planned crossing is
    dropped while the feedback asks for braking
    (`gap_crossing.torque_sign_changes`; main d3f5b07 crossed, let the load
    run free and overshot 3.15 %)."""
    m = _move(design, start=0.0, target=0.05, Jl=1.2, Td=0.0, alpha=0.06, seed=5)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


@pytest.mark.parametrize("seed", [5, 6, 7])
def test_the_holds_crossing_is_not_taken_back(design, seed):
    """Td 3, alpha 0.06, a 0.05 rad step from rest: the crossing into the
    hold releases the braking and the load runs ahead; decided where it
    starts, the crossing is finished, not sent back from mid-gap (decided
    on every sample, the motor reached the torque limit at the move's end:
    500 Nm for 3 ms, 257 Nm without the rule). At rest the hold is kept
    while the load torque stops the load past the target: the load
    arriving 2e-5 rad short at 1.4e-2 rad/s had the other flank asked for
    one sample, 500 Nm (seeds 5 and 7; where it is, not where it stops)."""
    m = _move(design, start=0.0, target=0.05, Jl=1.0, Td=3.0, alpha=0.06, seed=seed)
    p = m["res"].plant
    end = (p.time > SWITCH + 0.1) & (p.time < SWITCH + 0.35)
    assert np.max(np.abs(p.inputs[0][end])) < 400.0
    assert m["overshoot"] <= 1.5


def test_nominal_inertia_overshoots_the_same_reversal():
    """The same reversal with the inertia estimate off: the nominal inertia
    in the feedforward and the observer overshoots it (the cause fixed)."""
    off = twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", certify=False,
        inertia=ServoInertia(enabled=False),
    )  # fmt: skip
    m = _move(off, start=-0.3, target=0.05, Jl=1.2)
    assert m["overshoot"] > 3.0


@pytest.mark.parametrize("Jl", [0.85, 1.15])
def test_inertia_estimate_learns_the_load(design, Jl):
    """After a move the estimate is most of the way to the true inertia
    (within 6 % of the nominal: 0.094 at Jl x1.15, 0.122 with the
    observer's model on the learnt inertia only along the plan, which does
    not move the prediction at rest), after the next within 5 %, and it
    does not change at rest."""
    res = _move(design, start=0.3, target=0.0, Jl=Jl)["res"]
    c = res.controller
    delta = c.states[c.state_labels.index("delta_Jl_hat")]
    t = c.time
    settled = delta[(t > 1.0) & (t < SWITCH)]
    assert abs(settled[-1] - (Jl - 1.0)) <= 0.06
    assert np.ptp(settled) == 0.0
    assert abs(delta[-1] - (Jl - 1.0)) <= 0.05


def _adaptation(dt=2e-3, gain=0.1):
    params = twomass.Parameters()
    return InertiaAdaptation(
        Jl=params.Jl, gain=gain, accel_floor=3.0, memory=0.1, bounds=(-0.2, 0.2),
        dt=dt, cl=params.cl,
    )  # fmt: skip


def test_estimate_is_idle_at_rest():
    """At rest (no planned acceleration) the correction is the drive
    observer's and delta is held; with delta 0 the prediction is the
    observer's own."""
    adapt = _adaptation()
    rng = np.random.default_rng(0)
    xhat, innovation = rng.normal(size=6), rng.normal(size=2)
    Phi, Gamma, M = rng.normal(size=(6, 6)), rng.normal(size=6), rng.normal(size=(6, 2))
    learnt = rng.normal(size=len(INERTIA_STATES))
    learnt[0] = 0.1
    filtered, after = adapt.correct(xhat, learnt, innovation, M, [0, 3], Phi, 0.0)
    assert after[0] == 0.1
    np.testing.assert_array_equal(filtered, xhat + M @ innovation)
    np.testing.assert_array_equal(
        adapt.predict(Phi, Gamma, filtered, 2.0, 0.0), Phi @ filtered + Gamma * 2.0
    )
    # Accelerating, in contact, the shaft pushing: delta moves, projected
    # on the range.
    xhat[2] = 50.0
    _, after = adapt.correct(xhat, learnt, innovation, M, [0, 3], Phi, 30.0)
    assert after[0] != 0.1 and -0.2 <= after[0] <= 0.2


def _fit_move(
    Td, delta, *, dt=2e-3, accel=50.0, rest=0.0, rates=(300.0, 50.0), gain=0.1
):
    """The drive observer of the 2 ms servo (in contact) with the estimate,
    on the linear contact model of the drive driven by the torque that
    accelerates both inertias along a bang-bang rest-to-rest move (after
    `rest` seconds at rest, 0.1 s at +accel, 0.1 s at -accel, then 0.1 s
    at rest), with a load torque `Td` and the load inertia ``(1 + delta)
    Jl``; exact angle readings. Returns the times from the move's start,
    the estimates ``(Td_hat, delta_hat)`` and the estimate's last states."""
    params = twomass.Parameters()
    true = params.replace(Jl=(1.0 + delta) * params.Jl)
    kw = dict(dt=dt, shaft_torque_rate=rates[0], load_torque_rate=rates[1])
    Phi, Gamma, M = (m[1] for m in observer_matrices(drive_observer(params, **kw)))
    Phi_true, Gamma_true, _ = (
        m[1] for m in observer_matrices(drive_observer(true, **kw))
    )
    adapt = _adaptation(dt, gain=gain)
    rows = [DRIVE_STATES.index("theta_m"), DRIVE_STATES.index("theta_l")]
    t = np.arange(-rest, 0.3 - dt / 2, dt)
    a_r = np.where(t < 0.1, accel, np.where(t < 0.2, -accel, 0.0))
    a_r[t < 0.0] = 0.0
    x, xhat = np.zeros(6), np.zeros(6)
    x[5] = Td
    # The shaft carries the load torque before the move (at rest in
    # contact); the observer does not know it yet.
    x[2] = Td
    learnt = adapt.initial()
    trace = []
    for a in a_r:
        u = (params.Jm + true.Jl) * a + Td
        filtered, learnt = adapt.correct(
            xhat, learnt, x[rows] - xhat[rows], M, rows, Phi, a
        )
        xhat = adapt.predict(Phi, Gamma, filtered, u, learnt[0])
        x = Phi_true @ x + Gamma_true * u
        trace.append((filtered[5], learnt[0]))
    return t, np.array(trace), learnt


def test_fit_separates_load_torque_from_inertia():
    """A load torque of 30 Nm unknown when a rest-to-rest move starts: by
    the end of the move (the planned acceleration integrated to zero) the
    load-torque estimate holds most of it and delta is back near zero,
    though while the plan accelerated the two could not be told apart (a
    share of the correction per sample by the acceleration alone held the
    load torque at 2-4 Nm through such a move); at rest delta is held and
    the observer takes the load torque the rest of the way. (Measured:
    34.2 Nm and -0.041 at the move's end, 28.2 Nm 0.1 s later; with the
    observer's model on the learnt inertia only along the plan, 30.0 Nm
    and -0.021, then 29.5 Nm: the learnt model, right at rest and at
    impacts, carries the load-torque estimate's error into the load's
    acceleration while delta is not yet zero.)"""
    t, trace, _ = _fit_move(30.0, 0.0)
    end = np.searchsorted(t, 0.2)
    assert abs(trace[end, 0] - 30.0) <= 5.0
    assert abs(trace[end, 1]) <= 0.05
    assert np.ptp(trace[end + 1 :, 1]) == 0.0
    assert abs(trace[-1, 0] - 30.0) <= 2.0


@pytest.mark.parametrize("delta", [0.15, -0.1])
def test_fit_learns_an_inertia_error_in_one_move(delta):
    """An inertia error without load torque: the move's fit moves delta
    towards it (at least a third of the way in one move, not beyond a fifth
    past it: 0.177 for 0.15, -0.110 for -0.1) and keeps it at rest."""
    t, trace, _ = _fit_move(0.0, delta)
    end = np.searchsorted(t, 0.2)
    assert 0.33 * abs(delta) <= np.sign(delta) * trace[end, 1] <= 1.2 * abs(delta)
    assert np.ptp(trace[end + 1 :, 1]) == 0.0


def test_rest_hands_the_load_torque_correction_to_the_inertia():
    """At rest the observer learns the load torque: over ``memory`` the
    estimate counts it known (``Td_known`` from 0 at a cold start to 1),
    and then, while the plan accelerates, the observer's load-torque
    correction goes to delta (as the inertia error it is) instead of to
    the load torque: with the load following the plan, the share moved
    leaves the prediction of the drive (its angles, speeds and shaft
    torque) where the whole correction on the load torque put it."""
    adapt = _adaptation(dt=1e-3)
    rng = np.random.default_rng(1)
    Phi, M = rng.normal(size=(6, 6)) * 0.1, rng.normal(size=(6, 2))
    Gamma = rng.normal(size=6)
    rows = [0, 3]
    learnt = adapt.initial()
    assert learnt[INERTIA_STATES.index("Td_known_dev")] == 0.0
    for _ in range(1000):  # 1 s at rest
        _, learnt = adapt.correct(np.zeros(6), learnt, np.zeros(2), M, rows, Phi, 0.0)
    assert learnt[INERTIA_STATES.index("Td_known_dev")] > 0.99
    learnt[0] = 0.1
    xhat, innovation = rng.normal(size=6), 1e-3 * rng.normal(size=2)
    accel = 30.0
    # In contact, the shaft accelerating the load (of inertia 1.1 Jl) as
    # planned.
    xhat[2] = 1.1 * adapt.Jl * accel + xhat[5] + adapt.cl * xhat[4]
    filtered, after = adapt.correct(xhat, learnt, innovation, M, rows, Phi, accel)
    share = accel**2 / (accel**2 + adapt.accel_floor**2)
    correction = M @ innovation
    # (After 1 s at rest the load torque counts as known within 1e-4.)
    np.testing.assert_allclose(
        filtered[5] - xhat[5], (1.0 - share) * correction[5], rtol=1e-2
    )
    assert np.sign(after[0] - 0.1) == np.sign(correction[5])
    moved = adapt.predict(Phi, Gamma, filtered, 1.0, after[0])
    whole = adapt.predict(Phi, Gamma, xhat + correction, 1.0, 0.1)
    untouched = adapt.predict(Phi, Gamma, xhat, 1.0, 0.1)
    assert np.abs(moved - whole)[:5].max() <= 1e-5 * np.abs(whole - untouched)[:5].max()


@pytest.fixture(scope="module")
def design_2ms():
    return twomass.servo_design(dt=2e-3, delay=1, sensors="encoders", certify=False)


@pytest.mark.parametrize("Jl", [0.8, 1.2])
def test_fit_learns_the_inertia_in_one_move_at_2ms(design_2ms, Jl):
    """2 ms, a cold start (the load torque of 5 Nm unknown when the 0.5 rad
    move starts): after the one move the estimate is the true inertia
    within 5 % of its error (0.01 of nominal), and issue 22's settling of
    0.3 s is met (without an inertia estimate at 2 ms, main 9ded357, seed
    1: 0.300 s at Td 5, alpha 0.06, Jl x0.8; 0.386 s at Jl x1.2, -1 rad)."""
    plant = twomass.plant(
        twomass.Parameters().replace(Jl=Jl * twomass.Parameters().Jl), alpha=0.03
    )
    res = sampled_response(
        plant, design_2ms.controller(), 1.5, inputs={"Td": 5.0, "theta_r": 0.5},
        delay=1, sensors=ENCODERS, seed=1,
    )  # fmt: skip
    c = res.controller
    delta = c.states[c.state_labels.index("delta_Jl_hat")]
    assert abs(delta[-1] - (Jl - 1.0)) <= 0.01
    t, e = res.plant.time, res.plant.outputs[2] - 0.5
    outside = np.flatnonzero(np.abs(e) > 0.02 * 0.5)
    assert t[outside[-1] + 1] <= 0.3


def test_cold_start_with_a_large_load_torque_at_2ms():
    """2 ms (the slow observer of `sampled_tuning`, the estimate on by
    default): a 0.5 rad move from a cold start against Td = 30 Nm settles
    within issue 22's 0.3 s (the load torque is not read as inertia; 0.40 s
    with the per-sample share this fit replaced, 0.29 s without any
    estimate) and the estimate ends near the true inertia."""
    dt = 2e-3
    design = twomass.servo_design(dt=dt, delay=1, sensors="encoders", certify=False)
    plant = twomass.plant(twomass.Parameters(), alpha=0.03)
    res = sampled_response(
        plant, design.controller(), 1.5, inputs={"Td": 30.0, "theta_r": 0.5},
        delay=1, sensors=ENCODERS, seed=1,
    )  # fmt: skip
    t, e = res.plant.time, res.plant.outputs[2] - 0.5
    outside = np.flatnonzero(np.abs(e) > 0.02 * 0.5)
    assert t[outside[-1] + 1] <= 0.3
    assert np.max(e) <= 0.015 * 0.5
    c = res.controller
    assert abs(c.states[c.state_labels.index("delta_Jl_hat")][-1]) <= 0.05


def test_rest_certificate_is_unchanged(design):
    """The rest certificate covers the same loop with the estimate on and
    off (at rest the estimate does not act)."""
    off = twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", inertia=ServoInertia(enabled=False)
    )
    on = twomass.servo_design(dt=DT, delay=1, sensors="encoders")
    assert on.certificate.verified
    assert on.certificate.rest_error_bound == off.certificate.rest_error_bound
    assert on.certificate.rest_ripple_bound == off.certificate.rest_ripple_bound


@pytest.mark.parametrize(
    "kwargs, error, name",
    [
        (dict(gain=-1.0), ValueError, "ServoInertia.gain"),
        (dict(accel_floor=0.0), ValueError, "ServoInertia.accel_floor"),
        (dict(enabled="yes"), TypeError, "ServoInertia.enabled"),
    ],
)
def test_settings_are_checked(kwargs, error, name):
    with pytest.raises(error, match=name):
        ServoInertia(**kwargs)


def test_inertia_argument_is_checked():
    with pytest.raises(TypeError, match="inertia"):
        twomass.servo_design(dt=DT, delay=1, sensors="encoders", inertia=False)


_AXES = ([0.8, 1.0, 1.2], [0.0, 3.0, 8.0], [0.03, 0.06])
_SEEDS = [5, 6]
#: Moves of 0.1 to 1 rad: steps both ways and reversals across the gap.
_MOVES = [(0.5, 0.0), (-0.3, 0.05), (0.0, 1.0), (1.0, 0.0)]
#: 0.05 rad steps from rest and the 0.1 rad reversal.
_SMALL = [(0.05, -0.05), (0.0, -0.05), (0.0, 0.05)]
#: The runs of `_SMALL` that miss the targets (measured; docs/servo.rst,
#: "Small moves across the gap", "The move's end", "The learnt inertia at
#: rest", "The flank a load torque presses", "The gap read at its largest"
#: and "The hold's crossing and a load running ahead"): 107 of 108 pass.
#: Left (on the machine of stop 61): Td 0 at Jl x1.2 to 0.05 rad on seed
#: 6, the rest after the move
#: (0.168 s, 0.9 % at the move's end; from 2.8 s the load drifts at 1e-3
#: rad/s, 1.6 % past at the end of the run; 3.1 % at the move's end before
#: the hold's crossing was decided on the feedback). Td 0 at Jl x0.8 to
#: -0.05 rad on seed 6 (0.60 s, 2.1 %: the latch's flip met the drifting
#: load) passes since a held contact teaches a narrower gap ("Gaps narrower
#: than the first estimate"). Strict: a run that starts meeting them fails
#: here, so that the list is kept true.
_SMALL_MISSES = frozenset()
#: On the knife edge (`_issue22.grid_mark`): the run above, and the same
#: row's step to -0.05 rad on seed 5.
_SMALL_EDGE = {
    (1.2, 0.0, 0.06, (0.0, 0.05), 6): "missed on the machine of stop 61, met on "
    "that of stop 62",
    (1.2, 0.0, 0.06, (0.0, -0.05), 5): "met on the machine of stop 61, 1.503 % on "
    "that of stop 62",
}
#: The runs of `_MOVES` that miss (measured as above): none since the
#: feedforward has the shaft's damper and the torque's hold (before it Jl
#: x0.8, Td 3, alpha 0.06, 0.5 -> 0 on seed 6 at 2.3 % and the -0.3 ->
#: 0.05 reversal on seed 5 at 4.4 %).
_MOVES_MISSES = frozenset()


def _grid(moves, misses=frozenset(), edge=None):
    cases = []
    for (Jl, Td, alpha), move, seed in itertools.product(
        itertools.product(*_AXES), moves, _SEEDS
    ):
        marks = grid_mark((Jl, Td, alpha, move, seed), misses, edge)
        cases.append(pytest.param(Jl, Td, alpha, move, seed, marks=marks))
    return cases


def _targets(design, Jl, Td, alpha, move, seed):
    start, target = move
    m = _move(design, start=start, target=target, Jl=Jl, Td=Td, alpha=alpha, seed=seed)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


@pytest.mark.slow
@pytest.mark.parametrize("Jl, Td, alpha, move, seed", _grid(_MOVES, _MOVES_MISSES))
def test_grid_of_moves_and_reversals(design, Jl, Td, alpha, move, seed):
    """Issue 22's must-show on moves of 0.1 to 1 rad both ways and
    reversals across the gap, Jl x 0.8 to 1.2: settling <= 0.3 s,
    overshoot <= 1.5 %."""
    _targets(design, Jl, Td, alpha, move, seed)


@pytest.mark.slow
@pytest.mark.parametrize(
    "Jl, Td, alpha, move, seed", _grid(_SMALL, _SMALL_MISSES, _SMALL_EDGE)
)
def test_grid_of_small_moves(design, Jl, Td, alpha, move, seed):
    """The same targets on 0.05 rad steps and the 0.1 rad reversal."""
    _targets(design, Jl, Td, alpha, move, seed)


def _gap_estimate(design, res):
    """The controller's half-gap estimate along `res`: times, values."""
    c = res.controller
    dev = c.states[c.state_labels.index("alpha_hat_dev")]
    return c.time, design.tuning.alpha_initial + dev


def test_gap_learnt_at_rest_under_a_load_torque(design):
    """Td 3, alpha 0.06: at rest before the move the load leans on a flank
    and the gap estimate learns the plant's half-gap there (it starts at
    0.03); the 0.05 rad step the load torque helps then meets issue 22's
    targets (main 2bf04ca: 0.336 s, the integral holding the old estimate's
    error on the other flank and unwinding after the move)."""
    m = _move(design, start=0.0, target=-0.05, Jl=1.0, Td=3.0, alpha=0.06, seed=5)
    t, alpha_hat = _gap_estimate(design, m["res"])
    assert abs(alpha_hat[np.searchsorted(t, SWITCH)] - 0.06) <= 1e-3
    assert m["settling"] <= 0.3
    assert m["overshoot"] <= 1.5


def test_first_move_learns_the_gap(design):
    """Td 0, alpha 0.06, Jl x0.8: nothing is learnt at rest (no load
    torque), and the first 0.05 rad move's contacts teach the estimate the
    plant's half-gap by the end of the plan (0.2 s): the flank readings in
    contact are dynamic (the shaft torque changes along the move), and only
    the crossings' readings, narrower than the gap, are kept out (learning
    from static readings only left it at 0.033 and the load 16 % past the
    target). The move's own overshoot, over 0.4 s from the step, is the
    inertia error of a first move (2.0 %); what the rest does after it at
    Td 0 and Jl x0.8 is `test_grid_of_small_moves`'s (5.1 % on this run)."""
    m = _move(design, start=0.0, target=-0.05, Jl=0.8, Td=0.0, alpha=0.06, seed=5)
    t, alpha_hat = _gap_estimate(design, m["res"])
    assert alpha_hat[np.searchsorted(t, SWITCH)] == pytest.approx(0.03)
    assert abs(alpha_hat[np.searchsorted(t, SWITCH + 0.2)] - 0.06) <= 1e-3
    p = m["res"].plant
    move = (p.time >= SWITCH) & (p.time < SWITCH + 0.4)
    assert np.max(-0.05 - p.outputs[2][move]) / 0.05 * 100 <= 3.0


@pytest.mark.parametrize(
    "kwargs, error, name",
    [
        (dict(static_speed=0.0), ValueError, "ServoEstimator.static_speed"),
        (dict(narrowing_band=-1e-3), ValueError, "ServoEstimator.narrowing_band"),
        (dict(rest_estimate_rate=-1.0), ValueError, "rest_estimate_rate"),
        (dict(rest_estimate_rate="5"), TypeError, "rest_estimate_rate"),
    ],
)
def test_gap_settings_are_checked(kwargs, error, name):
    with pytest.raises(error, match=name):
        twomass.ServoEstimator(**kwargs)


@pytest.mark.parametrize("delta", [-0.2, 0.2])
def test_learnt_model_is_the_drive_on_the_learnt_inertia(delta):
    """The observer's model on the learnt inertia (`learnt_model`) predicts
    over a sample at 1 ms what the exact sampled model of the drive on that
    inertia does, in contact (a shaft torque of 100 Nm, a load torque of 8
    Nm and a moving load) and in the gap (the load torque alone): within
    1 % of what the nominal model misses, the load's acceleration taken
    at the sample's start (at rest and at impacts the nominal model read
    the inertia error as a load torque)."""
    params = twomass.Parameters()
    adapt = _adaptation(dt=1e-3)
    true = params.replace(Jl=(1.0 + delta) * params.Jl)

    def model(p):
        return observer_matrices(
            drive_observer(p, dt=1e-3, shaft_torque_rate=300.0, load_torque_rate=2.0)
        )[0]

    for mode in (0, 1):  # gap, contact
        Phi, Phi_true = model(params)[mode], model(true)[mode]
        x = np.array([0.0, 2.0, 100.0 * mode, 0.0, 1.5, 8.0])
        learnt = adapt.learnt_model(Phi, delta) @ x
        missed = np.abs(Phi @ x - Phi_true @ x)
        for i in (3, 4):  # the load's angle and speed
            assert missed[i] > 0.0
            assert abs(learnt[i] - (Phi_true @ x)[i]) <= 0.01 * missed[i]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_light_load_rests_without_a_load_torque(design, seed):
    """Td 0, alpha 0.03, Jl x0.8, 0.5 rad: the rest is quiet (issue 22's
    2e-4 rad end error and last-second peak-to-peak, 3 Nm of torque
    standard deviation). With the observer's model on the nominal inertia
    at rest (the learnt inertia along the plan only) the light load's
    bounces read as a load torque of 1-2 Nm and the rest hunted on every
    seed of 1-16 (70-93 Nm on seeds 1-3)."""
    params = twomass.Parameters()
    plant = twomass.plant(params.replace(Jl=0.8 * params.Jl), alpha=0.03)
    res = sampled_response(
        plant, design.controller(), 5.0, inputs={"Td": 0.0, "theta_r": 0.5},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    t, e = res.plant.time, res.plant.outputs[2] - 0.5
    last = t >= 4.0
    assert abs(e[-1]) <= 2e-4 and np.ptp(e[last]) <= 2e-4
    assert np.std(res.plant.inputs[0][last]) <= 3.0
