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
   angle and load torque, in free fall;
2. **the fall**: the motor holds still (the law's motor-angle and -speed
   gains on the motor alone), the load is predicted open loop under its
   torque (no contact: a gap of twice the widest), and the contact gains
   do not read the motor;
3. **the landing**: the motor reading falls behind the prediction against
   the push (beyond `IMPACT_READING`, not within the first `BLIND_FALL` of
   fall, where the break's own transient is): the load has met the flank,
   and the new half-gap is the predicted twist less the way closed since
   (`landing_gap`);
4. **the catch**: the motor still holds, the flank brakes the load; once
   the load no longer falls, a move on that flank alone (the shaft torque
   never asked to change sign, `ctrl_lpv.twomass.trajectory.one_flank_duration`)
   takes it back to the target. Measured (1 ms, delay 1, 20-bit motor
   encoder, seeds 1-3): the paper's step is back within 2 % 0.46 s after
   it, 0.00 % beyond the target, 3.0-3.6e-4 rad at 5 s; 2, 5 and 30 Nm and
   a step to 0.06 recover too (0.32-0.74 s, 1.6e-4 to 7.5e-4 rad), where
   they ended 15-76 mrad off.

A fall that never lands (a load torque that vanished, not a gap that
widened) ends after the time a fall across the widest gap (``2
alpha_max``) takes, and the law re-plans from the load's estimate.
"""

from __future__ import annotations

import math

__all__ = [
    "BREAK_READING",
    "IMPACT_READING",
    "SETTLED_TIME",
    "SETTLED_SHARE",
    "BLIND_FALL",
    "BRAKING_SHARE",
    "FALL_STATES",
    "watch",
    "landing_gap",
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
#: Fall, rad, within which a landing is not looked for: under 30 Nm the
#: break's transient read as a landing 3 ms in, with the half-gap unchanged.
BLIND_FALL = 1e-3
#: Share of the load torque the move back may use to brake the load (the
#: rest keeps the shaft torque on the flank): at 0.75 the recovery of the
#: paper's step takes 0.46 s; a move of the servo's own duration (0.2 s)
#: asked for braking through the gap, and the motor crossed it twice at the
#: load (Tm -257 then -500 Nm, the load bouncing 25 mrad).
BRAKING_SHARE = 0.75

#: The sampled law's states of the fall mode: the push's side (0 out of the
#: fall mode), the motor angle held, a clock (out of the fall mode: the
#: time leant at rest), whether the flank was met, the last innovation, and
#: the rest's load angle and load torque estimates.
FALL_STATES = [
    "fall_side", "fall_hold", "fall_clock", "fall_caught", "fall_innovation",
    "rest_theta_l", "rest_Td",
]  # fmt: skip


def watch(fall, predicted, filtered, reading, leant, dt, tc, Jm, Jl):
    """One sample of the watch for a break at rest.

    Parameters
    ----------
    fall : list of float
        The `FALL_STATES`, out of the fall mode (side 0).
    predicted, filtered : array_like
        The estimator's prediction for this sample and its correction
        (``theta_m, omega_m, Ts, theta_l, omega_l, Td``).
    reading : float
        The motor encoder's reading, rad.
    leant : bool
        At rest, with a load torque estimate beyond the contact torque `tc`.
    dt, tc, Jm, Jl : float
        Sample time, contact torque (Nm), motor and load inertia.

    Returns
    -------
    fall : list of float
        The states one sample on; with a break, in the fall mode.
    broke : list of float or None
        With a break, the prediction with the load restarted from its rest
        in free fall since the break; else None.
    """
    fall = list(fall)
    innovation = reading - predicted[0]
    push = math.copysign(1.0, filtered[5])
    growing = push * innovation > BREAK_READING and push * fall[4] > BREAK_READING / 3
    if leant and growing and fall[2] > SETTLED_TIME:
        td = fall[6]
        since = math.sqrt(2.0 * Jm * abs(innovation) / max(abs(td), tc))
        broke = [float(v) for v in predicted]
        broke[3] = fall[5] - td / (2.0 * Jl) * since**2
        broke[4] = -td / Jl * since
        broke[5] = td
        fall = [push, predicted[0], 0.0, 0.0, 0.0, 0.0, 0.0]
        return fall, broke
    if leant and abs(filtered[2] - filtered[5]) < SETTLED_SHARE * abs(filtered[5]):
        fall[2] += dt
        fall[5], fall[6] = predicted[3], predicted[5]
    else:
        fall[2] = 0.0
    fall[4] = innovation
    return fall, None


def landing_gap(side, filtered, innovation, Jm, ks):
    """The half-gap where the falling load met the flank: the predicted
    twist less the way closed since. The shaft force ramps with the
    penetration, so the motor's reading departs by ``ks v t**3 / (6 Jm)``
    a time ``t`` after the landing at the closing speed ``v``."""
    closing = max(side * (filtered[1] - filtered[4]), 0.0)
    since = (6.0 * Jm * abs(innovation) / (ks * max(closing, 1e-6))) ** (1.0 / 3.0)
    return side * (filtered[0] - filtered[3]) - closing * since


def fall_duration(distance, load_torque, Jl, tc):
    """The time a load of inertia `Jl` takes to fall `distance` under
    `load_torque` (at least the contact torque `tc`), s."""
    return math.sqrt(2.0 * abs(distance) * Jl / max(abs(load_torque), tc))
