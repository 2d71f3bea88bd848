"""A load that falls back through a gap widened at rest (motor encoder alone).

At rest under a load torque the load leans on one flank. When the gap
widens (wear, or the paper's step of the half-gap from 0.03 to 0.045 at
2.5 s), the flank moves away and the load falls back under its torque,
through the new clearance, onto the same flank. Read by the motor encoder
alone, nothing says where the load is until it lands; the contact-mode
estimator read the motor's lurch as a load moving *forward* (the load 1e-3
rad ahead of the target while it fell 27 mrad behind), and the law swung
the motor across the gap and back (+-300 to 500 Nm) until the load was
caught: 27-28 mrad of fall and a recovery overshooting the target by up to
2.7 % (seeds 1-12, Td 8 Nm); under 2 or 5 Nm of load torque, and for a
step of the half-gap to 0.06, the load ended 46-76 mrad off for good (15
mrad under 30 Nm).

So a break of the contact at rest is handled as what it is (`watch`,
`landing_gap`, and the sampled law's fall mode in `servo_sampled`):

1. **the break**: at rest, the load leaning on a flank (the estimated
   shaft torque within `SETTLED_SHARE` of the load torque for
   `SETTLED_TIME`), the motor reading runs ahead of the prediction in the
   direction of the push and keeps doing so (beyond `BREAK_READING`, the
   sample before beyond a third of it): the motor lost the load. The load
   fell from its rest for as long as the motor's lurch says (the
   innovation ``Td t**2 / (2 Jm)``): its estimate restarts from the rest's
   angle and load torque, in free fall, and the motor's from its reading
   and the lurch's speed (``Td t / Jm``);
2. **the chase**: the motor follows the flank into the widened gap, at
   `chase_speed` (it grows as the square root of the load torque, so that
   the impact kicks a light load no further ahead than a heavy one), the
   load is predicted open loop under its torque (no contact: a gap of
   twice the widest), and the contact gains do not read the motor. Under
   `CHASE_TORQUE` (a light load, whose torque estimate misreads at the
   catch) the motor holds still and the load falls onto it;
3. **the landing**: the motor reading falls behind the prediction against
   the push (beyond `IMPACT_READING`, not within `BLIND_TIME` of the
   break): the load has met the flank, and the new half-gap is the
   predicted twist less the way closed since (`landing_gap`);
4. **the catch**: the motor holds where the shaft carries the load torque
   on that flank (the load's estimate, the new half-gap and the twist
   ``Td / ks``), with the load torque as its feedforward; the flank brakes
   the load; once the load no longer falls, a move on that flank alone
   (the shaft torque never asked to change sign,
   `ctrl_lpv.twomass.gap_crossing.one_flank_duration`) takes it back to
   the target.

Measured (1 ms, delay 1, 20-bit motor encoder, seeds 1-3; the step at 2.5
s): the paper's step (Td 8 Nm, 0.5 rad) takes the load 3.7-3.8 mrad off,
back within 1e-3 rad 0.22 s after it, 2e-5 to 1.7e-4 rad at 5 s, at most
40 Nm, and the whole run settles (2 %) in 0.205 s; holding still, the
load fell 25 mrad, came back in 0.56 s at up to 500 Nm, and the run
settled in 2.96 s. 3 to 30 Nm, 1 rad, the mirror image and a step to
0.06 rad: 2.8-9.0 mrad, back in 0.22-0.34 s (0.37-0.75 s held still);
Td 8 Nm at -0.5 rad, where the fall is past the target, 0.66-0.68 %
beyond it (4.9 %). 2 ms and 125 us alike (2 ms: 2.7-9.1 mrad, back in
0.23-0.47 s). 2 Nm, held still, as before: 20 mrad, 0.96 s.

A fall that never lands (a load torque that vanished, not a gap that
widened) ends after the time a fall across the widest gap (``2
alpha_max``) takes, and the law re-plans from the load's estimate.

**A load torque that appears at rest** finds the load free in the gap
(no load torque before: the estimator in its gap mode, the load's
estimate frozen). The load falls through the gap unseen and lands on a
flank; the gap mode's slow filter read the motor being dragged as the
motor alone (its speed estimate +0.4 rad/s while it was pushed back), the
load estimate never left the gap, and the load ended 4.9e-2 rad off under
8 Nm (3.3-8.1e-2 for 2 to 8 Nm, alpha 0.03 to 0.06). Now (`watch`,
`landing`, `soft_catch`):

1. **the landing**: at rest, the load free in the gap for `SETTLED_TIME`,
   the motor parked (its torque below the contact torque, its speed below
   `PARKED_SPEED`), the motor reading
   departs from the prediction and keeps doing so (beyond
   `IMPACT_READING`, the sample before beyond a third of it, the same
   sign; `landing`): the load is put on the flank the reading is dragged towards, at
   the speed the growth of the departure says, its load torque unknown;
2. **the soft catch**: for `LANDING_HOLD` the motor gives way to the load
   (`soft_catch`), while the estimator runs the Kalman gains of a load
   whose speed and torque are unknown
   (`ctrl_lpv.twomass.motor_estimator.LANDING_SPEED_SPREAD`);
3. **the verdict**: a load torque estimate beyond `LANDED_TORQUE` on
   the flank's side is a load torque, and a move on that flank takes the
   load back (as 4. above, the integral holding the estimate). A smaller
   one on that side is a light load (the estimator's knife edge: it is
   left where it rests, and no landing is looked for again until the next
   target); one that pulls away from the flank is a free
   load that bounced off it (with no load torque a drifting load lands
   too; estimates of -0.8 to -0.04 Nm on ten such touches): the watch goes
   on. Let go, the load's estimate returns to the middle of the gap,
   still (where it is in the gap the motor encoder does not see).

Measured (1 ms, delay 1, 20-bit motor encoder, 0.5 rad unless said, the
step at 2.5 s, seeds 1-3): 0 -> 8 Nm back within 1e-3 rad 0.75-0.77 s
after the step, 2.5-3.1e-5 rad at 5 s (before: 4.9e-2); 3 Nm 1.1 s,
5-8e-5; 30 Nm 0.55 s; -8 Nm, and 8 Nm at -0.5 rad, 0.76-0.78 s;
8 Nm at alpha 0.06 0.88-1.06 s, 0.5-1.7e-4; -5 Nm at alpha 0.06 and
-0.5 rad 1.0-1.3 s; 5 Nm at alpha 0.045 and 1 rad 1.0 s, 2.4-3.7e-4;
torque std of the last second 0.02 Nm in all. Under 2 Nm or less the
load stays on its flank 3.2-3.5e-2 off (6.6e-2 at alpha 0.06), quiet, as
before. 8 -> 0 and -8 -> 0 Nm rest in
the gap, quiet (0.00-0.96 Nm). At 2 ms: 0 -> 8 Nm 0.76 s, 5.0-5.4e-5 rad
(before: hunting at 108 Nm on seed 1), 0 -> 3 Nm 1.03-1.04 s, 8 -> 0 and
-8 -> 0 Nm quiet in the gap (0.00-2.85 Nm).
"""

from __future__ import annotations

import math

__all__ = [
    "BREAK_READING",
    "IMPACT_READING",
    "SETTLED_TIME",
    "SETTLED_SHARE",
    "BLIND_TIME",
    "CHASE_SPEED",
    "CHASE_ACCEL",
    "CHASE_GAIN",
    "CHASE_TORQUE",
    "BRAKING_SHARE",
    "FALL_STATES",
    "LANDED",
    "LANDED_TORQUE",
    "LANDING_HOLD",
    "PARKED_SPEED",
    "CATCH_STIFFNESS",
    "watch",
    "landing",
    "landing_gap",
    "soft_catch",
    "chase",
    "chase_speed",
    "fall_duration",
]

#: Motor-reading innovation, rad, in the push's direction, that says the
#: contact broke at rest (the sample before beyond a third of it: it grows as
#: ``t**2``). At rest the innovation is within 6e-6 rad (half a count of
#: noise on the 20-bit encoder); a gap step under 8 Nm gives 1.1e-5,
#: 4.0e-5, 9.0e-5, 1.5e-4 rad 1-4 ms after it. At 3e-5 without the growth
#: test, the residual transient of a move's end (3.2e-5 then 1.9e-5) read as
#: a break, and the held motor let the load sag onto it.
BREAK_READING = 1e-4
#: Motor-reading innovation, rad, against the push, that says the falling
#: load met the flank. 2e-5 read the fall's own model errors as landings
#: (the step at 8 Nm on seed 2 then ended 7e-2 rad off).
IMPACT_READING = 5e-5
#: Time, s, the load must have leant on the flank at rest (the estimated
#: shaft torque within `SETTLED_SHARE` of the load torque) before a break
#: is looked for: the end of a move is not a rest.
SETTLED_TIME = 0.05
SETTLED_SHARE = 0.25
#: Time, s, from the break within which a landing is not looked for: the
#: break is read a few samples late, and its first readings are the lurch's.
#: (As a fall of 1e-3 rad, 37 ms under 8 Nm and 75 ms under 2 Nm, the
#: chasing motor met the load within it and pushed it on: 1.2 mrad past its
#: rest, then a half-gap read 5 mrad short and a hunt at 500 Nm.)
BLIND_TIME = 4e-3
#: Share of the load torque the move back may use to brake the load (the
#: rest keeps the shaft torque on the flank): at 0.75, from a load fallen
#: 25 mrad (before the chase), the recovery of the paper's step took 0.46
#: s; a move of the servo's own duration (0.2 s)
#: asked for braking through the gap, and the motor crossed it twice at the
#: load (Tm -257 then -500 Nm, the load bouncing 25 mrad).
BRAKING_SHARE = 0.75

#: The motor's chase of the falling load (`chase`, `chase_speed`): its
#: speed, rad/s per square root of the load torque's Nm, at most
#: `CHASE_SPEED`, rad/s, reached at `CHASE_ACCEL`, rad/s^2. At 0.5 rad/s
#: whatever the torque, a light load (2 to 5 Nm) kicked ahead by the impact
#: drifted off the flank, and the move back from it swung at 300-500 Nm or
#: lost it (2 ms).
CHASE_GAIN = 0.125
CHASE_SPEED = 0.5
CHASE_ACCEL = 100.0
#: Load torque, Nm, under which the motor holds still while the load falls
#: (the estimate of a light load's torque misreads at the catch: 2 Nm read
#: as 1 Nm, and the move back lost the load at 2 ms; 3 and 4 Nm recover).
CHASE_TORQUE = 2.5

#: `FALL_STATES`' ``fall_caught`` of a load that landed from a free rest
#: (`watch`): the estimator's landing gains run from the landing on.
LANDED = 2.0
#: Time, s, a load that landed from a free rest is caught softly
#: (`soft_catch`) before its load torque estimate says what it was.
LANDING_HOLD = 0.2
#: Load torque estimate, Nm, on the flank's side at the end of the soft
#: catch, beyond which a landing was a load torque and the load is taken
#: back. Light loads read low (1.5 Nm for 2, 0.4-0.5 for 1; 2.8 for 3, 8.0
#: for 8): at the contact torque (1.5 Nm) 2 Nm came back on two seeds of
#: three, but landings read at 1.6-1.7 Nm (a step from 5 to 2 Nm; 8 Nm at
#: Jl x0.8, read through the wrong inertia) were taken back and hunted
#: (51-130 Nm), where they had rested quietly.
LANDED_TORQUE = 2.0
#: Motor speed estimate, rad/s, below which the motor counts as parked for
#: a landing to be looked for (parked at rest it reads 2e-5 to 7e-5).
PARKED_SPEED = 1e-3
#: Stiffness of the soft catch, Nm/rad (critically damped on motor and
#: load together: 11 rad/s).
CATCH_STIFFNESS = 2000.0

#: The sampled law's states of the fall mode: the push's side (0 out of the
#: fall mode), the motor angle held, a clock (out of the fall mode: the
#: time leant at rest), whether the flank was met (1, or `LANDED`), the
#: last innovation, the rest's load angle and load torque estimates, the
#: time at rest free in the gap, and whether a landing at this target was
#: a light load (1: no landing is watched for until the next target).
FALL_STATES = [
    "fall_side", "fall_hold", "fall_clock", "fall_caught", "fall_innovation",
    "rest_theta_l", "rest_Td", "free_clock", "light_load",
]  # fmt: skip


def watch(fall, predicted, filtered, reading, rest, alpha, c, dt, torque):
    """One sample of the watch for a break, or a landing, at rest.

    Parameters
    ----------
    fall : list of float
        The `FALL_STATES`, out of the fall mode (side 0).
    predicted, filtered : array_like
        The estimator's prediction for this sample and its correction
        (``theta_m, omega_m, Ts, theta_l, omega_l, Td``).
    reading : float
        The motor encoder's reading, rad.
    rest : bool
        The plan is at rest.
    alpha : float
        The half-gap estimate, rad.
    c : `ctrl_lpv.twomass.servo_kernel.ServoTuning`
        The drive data (``Jm``, ``Jl``, ``ks``) and the contact torque.
    dt : float
        Sample time, s.
    torque : float
        The motor torque acting over the last sample, Nm.

    Returns
    -------
    fall : list of float
        The states one sample on; with a break or a landing, in the fall
        mode.
    estimate : list of float or None
        With a break, the prediction with the load restarted from its rest
        in free fall since the break; with a landing, the load on the flank
        it met (`landing`); else None.
    """
    fall = list(fall)
    tc = c.contact_torque
    innovation = reading - predicted[0]
    leant = rest and abs(filtered[5]) > tc
    push = math.copysign(1.0, filtered[5])
    growing = push * innovation > BREAK_READING and push * fall[4] > BREAK_READING / 3
    if leant and growing and fall[2] > SETTLED_TIME:
        td = fall[6]
        since = math.sqrt(2.0 * c.Jm * abs(innovation) / max(abs(td), tc))
        broke = [float(v) for v in predicted]
        # The motor ran free since: its lurch is read, not predicted.
        broke[0] = reading
        broke[1] = predicted[1] + td / c.Jm * since
        broke[3] = fall[5] - td / (2.0 * c.Jl) * since**2
        broke[4] = -td / c.Jl * since
        broke[5] = td
        return _entered(push, predicted[0], 0.0, fall[8]), broke
    # Free: the load in the gap, the motor parked and still (a motor the
    # law moves departs from the prediction too: the gap mode's filter is
    # slow; at 2 ms one moving at 1.3e-2 rad/s read as a landing).
    free = (
        rest and not leant and abs(torque) < tc
        and abs(predicted[1]) < PARKED_SPEED
        and abs(predicted[0] - predicted[3]) <= alpha
    )  # fmt: skip
    if free and fall[7] > SETTLED_TIME and not fall[8]:
        landed = landing(predicted, reading, fall[4], alpha, c, dt)
        if landed is not None:
            side, estimate = landed
            return _entered(side, reading, LANDED, 0.0), estimate
    if leant and abs(filtered[2] - filtered[5]) < SETTLED_SHARE * abs(filtered[5]):
        fall[2] += dt
        fall[5], fall[6] = predicted[3], predicted[5]
    else:
        fall[2] = 0.0
    fall[7] = fall[7] + dt if free else 0.0
    fall[4] = innovation
    return fall, None


def _entered(side, hold, caught, light):
    """The `FALL_STATES` on entering the fall mode."""
    return [side, hold, 0.0, caught, 0.0, 0.0, 0.0, 0.0, light]


def landing(predicted, reading, before, alpha, c, dt):
    """A load resting free in the gap that has landed on a flank: ``(side,
    estimate)``, or None.

    A load torque that appears at rest makes the free load fall through
    the gap, unseen by the motor encoder, until it lands on a flank and
    drags the motor along: the reading departs from the prediction of the
    motor alone in the fall's direction, as ``ks v t**3 / (6 Jm)`` a time
    ``t`` after the landing at the speed ``v``. Beyond `IMPACT_READING`,
    and lasting (the innovation `before` beyond a third of it, the same
    sign), the load is put on that flank, at the speed the growth says
    (``t`` from the ratio of the two innovations; about none where it does
    not grow), its load torque unknown
    (`ctrl_lpv.twomass.motor_estimator.LANDING_SPEED_SPREAD`).
    """
    innovation = reading - predicted[0]
    if abs(innovation) <= IMPACT_READING or innovation * before <= 0.0:
        return None
    ratio = before / innovation
    if ratio <= 1.0 / 3.0:
        return None
    since = dt / max(1.0 - ratio ** (1.0 / 3.0), 1e-3)
    speed = min(6.0 * c.Jm * abs(innovation) / (c.ks * since**3), 1.0)
    fall = math.copysign(1.0, innovation)
    landed = [float(v) for v in predicted]
    landed[0] = reading
    landed[3] = reading + fall * alpha
    landed[4] = fall * speed
    landed[5] = 0.0
    # The flank's side: the sign of the shaft torque that holds the load
    # against the fall.
    return -fall, landed


def landing_gap(side, filtered, innovation, Jm, ks):
    """The half-gap where the falling load met the flank: the predicted
    twist less the way closed since. The shaft force ramps with the
    penetration, so the motor's reading departs by ``ks v t**3 / (6 Jm)``
    a time ``t`` after the landing at the closing speed ``v``."""
    closing = max(side * (filtered[1] - filtered[4]), 0.0)
    since = (6.0 * Jm * abs(innovation) / (ks * max(closing, 1e-6))) ** (1.0 / 3.0)
    return side * (filtered[0] - filtered[3]) - closing * since


def chase(time, widest, load_torque):
    """The motor's way into a gap widened under `load_torque` (Nm), its
    speed and acceleration, `time` s after the break: up to
    `chase_speed` at `CHASE_ACCEL`, and no further than `widest` rad;
    none under `CHASE_TORQUE`."""
    speed = chase_speed(load_torque)
    if time <= 0.0 or speed == 0.0:
        return 0.0, 0.0, 0.0
    ramp = speed / CHASE_ACCEL
    if time < ramp:
        way, speed, accel = 0.5 * CHASE_ACCEL * time**2, CHASE_ACCEL * time, CHASE_ACCEL
    else:
        way, accel = speed * (time - 0.5 * ramp), 0.0
    if way >= widest:
        return widest, 0.0, 0.0
    return way, speed, accel


def chase_speed(load_torque):
    """The speed, rad/s, at which the motor chases a load falling under
    `load_torque` (Nm): ``CHASE_GAIN sqrt(|load_torque|)``, at most
    `CHASE_SPEED`; 0 under `CHASE_TORQUE`.

    Met at the relative speed ``v``, the load is kicked ahead at up to
    ``2 Jm v / (Jm + Jl)`` and its torque brings it back within ``(2 Jm v /
    (Jm + Jl))**2 Jl / (2 Td)``: with ``v`` growing as ``sqrt(Td)``, the
    same for every load torque (8e-4 rad at most on the paper's drive)."""
    load_torque = abs(load_torque)
    if load_torque < CHASE_TORQUE:
        return 0.0
    return min(CHASE_GAIN * math.sqrt(load_torque), CHASE_SPEED)


def fall_duration(distance, load_torque, Jl, tc):
    """The time a load of inertia `Jl` takes to fall `distance` under
    `load_torque` (at least the contact torque `tc`), s."""
    return math.sqrt(2.0 * abs(distance) * Jl / max(abs(load_torque), tc))


def soft_catch(offset, speed, Jm, Jl):
    """The motor torque of a soft catch: the motor gives way to a load that
    landed on its flank, a spring of `CATCH_STIFFNESS` about the angle it
    was held at (`offset` from it, rad; `speed`, rad/s), critically damped
    on the motor and load inertias together. Held stiffly instead (the
    law's motor gains; the verdict, then at 1.5 Nm, the same), load torques
    stepped at rest hunted on 5 of 54 runs (46-188 Nm: -5 Nm and 2 Nm at
    alpha 0.06, 5 -> 2 Nm on all three seeds); with it, none beyond 4.6 Nm."""
    damping = 2.0 * math.sqrt((Jm + Jl) * CATCH_STIFFNESS)
    return -(CATCH_STIFFNESS * offset + damping * speed)
