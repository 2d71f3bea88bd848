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

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.inertia import InertiaAdaptation, ServoInertia

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
    """After a move, the estimate is the true inertia (within 5 % of the
    nominal), and it does not change at rest."""
    res = _move(design, start=0.3, target=0.0, Jl=Jl)["res"]
    c = res.controller
    delta = c.states[c.state_labels.index("delta_Jl_hat")]
    t = c.time
    settled = delta[(t > 1.0) & (t < SWITCH)]
    assert abs(settled[-1] - (Jl - 1.0)) <= 0.05
    assert np.ptp(settled) == 0.0
    assert abs(delta[-1] - (Jl - 1.0)) <= 0.05


def test_estimate_is_idle_at_rest():
    """At rest (no planned acceleration) the adaptation is the drive
    observer: the correction goes to the load torque, the prediction is
    the observer's own."""
    adapt = InertiaAdaptation(Jl=5.6, gain=1.0, accel_floor=3.0, bounds=(-0.2, 0.2))
    rng = np.random.default_rng(0)
    xhat, corr = rng.normal(size=6), rng.normal(size=6)
    Phi, Gamma = rng.normal(size=(6, 6)), rng.normal(size=6)
    filtered, delta = adapt.correct(xhat, 0.1, corr, 0.0, 1.0)
    assert delta == 0.1
    np.testing.assert_array_equal(filtered, xhat + corr)
    np.testing.assert_allclose(
        adapt.predict(Phi, Gamma, filtered, 2.0, delta, 0.0),
        Phi @ filtered + Gamma * 2.0,
    )
    # Accelerating, in contact, the shaft pushing: the correction of the
    # load torque moves to the inertia, projected on the range.
    xhat[2] = 50.0
    filtered, delta = adapt.correct(xhat, 0.1, corr, 30.0, 1.0)
    assert delta != 0.1 and -0.2 <= delta <= 0.2


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
#: "Small moves across the gap"; 86 of 108 pass, 61 before the planned
#: crossing). A 0.05 rad move in 0.2 s brakes with 53 Nm (63 at Jl x1.2)
#: and the load torque gives 3-8, so the motor crosses the gap mid-move;
#: the crossing now starts half a crossing before the planned shaft
#: torque changes sign (`ctrl_lpv.twomass.gap_crossing`), and the gap
#: estimate learnt in the move no longer kicks the load through the
#: integral. Left: 0 -> -0.05 at alpha 0.06 with Td 3 (the planned torque
#: changes flank 7 ms into the move, too soon for a crossing planned from
#: rest: 0.34-0.36 s, 0.1 % overshoot), Td 0 at Jl x0.8 (1.7-2.1 %) and
#: Jl x1.2 with alpha 0.06 (Td 0: 4.1-5.4 %; 0 -> +0.05 against Td 3 and
#: 8: 2.1 % and 0.33 s), 0 -> +0.05 at Jl x0.8, Td 3, seed 6 (1.8 %).
#: Strict: a run that starts meeting them fails here, so that the list
#: is kept true.
_SMALL_MISSES = {
    (0.8, 0.0, 0.03, (0.0, -0.05), 5),
    (0.8, 0.0, 0.03, (0.0, 0.05), 6),
    (0.8, 0.0, 0.06, (0.0, -0.05), 5),
    (0.8, 0.0, 0.06, (0.0, -0.05), 6),
    (0.8, 0.0, 0.06, (0.0, 0.05), 5),
    (0.8, 0.0, 0.06, (0.0, 0.05), 6),
    (0.8, 3.0, 0.06, (0.0, -0.05), 5),
    (0.8, 3.0, 0.06, (0.0, -0.05), 6),
    (0.8, 3.0, 0.06, (0.0, 0.05), 6),
    (1.0, 3.0, 0.06, (0.0, -0.05), 5),
    (1.0, 3.0, 0.06, (0.0, -0.05), 6),
    (1.2, 0.0, 0.06, (0.0, -0.05), 5),
    (1.2, 0.0, 0.06, (0.0, -0.05), 6),
    (1.2, 0.0, 0.06, (0.0, 0.05), 5),
    (1.2, 0.0, 0.06, (0.0, 0.05), 6),
    (1.2, 3.0, 0.03, (0.0, 0.05), 6),
    (1.2, 3.0, 0.06, (0.0, -0.05), 5),
    (1.2, 3.0, 0.06, (0.0, -0.05), 6),
    (1.2, 3.0, 0.06, (0.0, 0.05), 5),
    (1.2, 3.0, 0.06, (0.0, 0.05), 6),
    (1.2, 8.0, 0.06, (0.0, 0.05), 5),
    (1.2, 8.0, 0.06, (0.0, 0.05), 6),
}


def _grid(moves, misses=frozenset()):
    cases = []
    for (Jl, Td, alpha), move, seed in itertools.product(
        itertools.product(*_AXES), moves, _SEEDS
    ):
        marks = ()
        if (Jl, Td, alpha, move, seed) in misses:
            marks = pytest.mark.xfail(strict=True, reason="issue 22: not yet")
        cases.append(pytest.param(Jl, Td, alpha, move, seed, marks=marks))
    return cases


def _targets(design, Jl, Td, alpha, move, seed):
    start, target = move
    m = _move(design, start=start, target=target, Jl=Jl, Td=Td, alpha=alpha, seed=seed)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


@pytest.mark.slow
@pytest.mark.parametrize("Jl, Td, alpha, move, seed", _grid(_MOVES))
def test_grid_of_moves_and_reversals(design, Jl, Td, alpha, move, seed):
    """Issue 22's must-show on moves of 0.1 to 1 rad both ways and
    reversals across the gap, Jl x 0.8 to 1.2: settling <= 0.3 s,
    overshoot <= 1.5 %."""
    _targets(design, Jl, Td, alpha, move, seed)


@pytest.mark.slow
@pytest.mark.parametrize("Jl, Td, alpha, move, seed", _grid(_SMALL, _SMALL_MISSES))
def test_grid_of_small_moves(design, Jl, Td, alpha, move, seed):
    """The same targets on 0.05 rad steps and the 0.1 rad reversal."""
    _targets(design, Jl, Td, alpha, move, seed)
