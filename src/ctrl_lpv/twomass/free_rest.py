"""The sampled servo's rest without a load torque: a wall and a dead catch.

With the flank latched at rest (`rest_flank`) and no load torque, the load
is free in the gap: it coasts on its own friction (``Jl / cl`` = 5.6 s) and
meets the parked motor's flank. Two things kept that rest from settling on
encoders (1 ms: about a third of the runs after a move missed the end-error
or the peak-to-peak target, ``docs/servo.rst``):

* **the parked motor jitters.** The law's load terms (position, speed,
  integral) carry the load encoder's noise onto the motor: 0.32 mrad
  peak-to-peak of parked motor, against 1.2e-5 rad with the motor on its
  own feedback alone;
* **a catch on a stiff motor is elastic.** A load arriving on the motor held
  by the law's motor-position gain (7315 Nm/rad) comes back at 0.87 of its
  speed; on 30 Nm/rad and the law's motor-speed damping, at 0.03. A load
  bouncing between walls does not come to rest.

`FreeRest` makes the parked motor a wall the load stops dead on:

* **engage** at a latched rest after a move (not at the start, where the
  load may be anywhere in the gap) with a slow load (`entry_speed`), a
  parked motor (`entry_motor_speed`) and a small load-torque estimate
  (`leave_torque`); the latch's own flip test and its release on the load
  error are off while engaged (they read the load's speed and error, not
  its coast);
* **the motor alone, on a soft hold**: ``Tm = -hold_stiffness (theta_m -
  theta_wall) - hold_damping omega_m``, no load terms;
* **the load's drift by a Kalman filter on the load encoder** (a free mass
  with viscous friction: position and speed), whose covariance is
  re-inflated where the innovation's two-sided CUSUM (`catch_drift`,
  `catch_evidence`) sees a catch or a kick; a second filter (position,
  speed, acceleration) tells a load torque from a coast: the load speeding
  up beyond `leave_torque` of ``-(Jl a + cl v)`` for `lean_time` hands the
  rest back to the latched law;
* **the wall where the coast ends**: the flank changes where the load's
  coast (``e + Jl/cl v``) ends beyond `flip_margin` on the far side, by a
  CUSUM (`flip_evidence`) after `settle_time` on a flank; the wall is placed
  once per flank, `clearance` short of the target or short of where the
  load will be when the motor has arrived (`approach_accel`, `guard`), and
  reached along a stiff rest-to-rest quintic (the law's motor gains: a catch
  during a soft approach is elastic), held soft from then on;
* **the half-gap measured at the walls**: where the load touches the held
  motor (pushed `contact_deflection` off its wall), the load's reading
  measures the half-gap (`gap_time`), and the walls are placed on it, not
  on the move's estimate (up to 6e-4 rad off: walls that stood past the
  target, or reached into a load resting on the other flank and kicked it);
* **a push towards the target**: a load at rest (or receding slower than
  `recede_speed`) that would stay beyond `target_band` is pushed by the soft
  wall at ``|e| / push_arrival`` (within `push_speeds`) over
  `push_time`, and caught by the other wall;
* **leave** (back to the latched law until the next move) when the motor is
  held `displacement` off its wall (a load torque the soft hold yields to),
  the filtered load-torque estimate exceeds `leave_torque`, or the lean
  filter sees a load torque (the wall held and the load not on it).

Measured (1 ms, one sample of delay, 20/17-bit encoders with half a count of
noise; ``docs/servo.rst``): the four Td = 0 rows of the bench, runs missing
a target fall from 41, 28, 32 and 34 of 96 (four sets of 24 noise seeds)
to 3, 4, 2 and 5, and to none since the half-gap's readings are kept past
alpha_max and the rest waits for a parked motor (1 of 192 on seeds
97-144). Random Td 0 first moves off those rows (alpha 0 to 0.06, Jl x0.8
to x1.2, 0.05 to 1 rad both ways; 300 runs): 25 missed, 12 above 3 Nm of
torque std; 5 since the walls stand on the measured half-gap, none above
3 Nm. Not certified: the rest certificate's load-torque floor excludes it,
as it does the latch (`ctrl_lpv.twomass.servo_rest`); its states follow the
cold start's in the sampled servo (`FREE_REST_STATES`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .gap_crossing import QUINTIC_PEAK_SPEED, crossing_duration, rest_to_rest

__all__ = ["FreeRest", "FREE_REST_STATES", "FreeRestStep", "free_rest_stepper"]

#: The states in the sampled controller: whether the free rest may engage
#: (from the first move on, until it hands a rest back; 0 at the start,
#: where the load may be anywhere in the gap), whether it is engaged, the
#: time on the flank and the flip CUSUM; the drift filter's load error and
#: speed, its covariance and the innovation's CUSUMs; the lean filter's load
#: error, speed and acceleration, its covariance and the time it has seen a
#: load torque; the wall's phase, its start and end, the time since they
#: were set and the duration, its depth past the target, and the time since
#: the last push.
FREE_REST_STATES = [
    "free_allowed", "free_engaged", "free_flank_age", "free_flip_evidence",
    "drift_e", "drift_v", "drift_P_ee", "drift_P_ev", "drift_P_vv",
    "catch_up", "catch_down",
    "lean_e", "lean_v", "lean_a",
    *(f"lean_P_{i}{j}" for i in "eva" for j in "eva"), "lean_clock",
    "wall_phase", "wall_from", "wall_to", "wall_clock", "wall_duration",
    "wall_depth", "push_age", "gap_offset",
]  # fmt: skip
_I = {name: i for i, name in enumerate(FREE_REST_STATES)}
_ALLOWED, _ENGAGED, _AGE, _FLIP = (_I[n] for n in FREE_REST_STATES[:4])
_E, _V, _PEE, _PEV, _PVV, _UP, _DOWN = (_I[n] for n in FREE_REST_STATES[4:11])
_LEAN, _LEAN_P, _LEAN_CLOCK = _I["lean_e"], _I["lean_P_ee"], _I["lean_clock"]
_PHASE, _FROM, _TO, _CLOCK, _DURATION = (_I[n] for n in FREE_REST_STATES[24:29])
_DEPTH, _PUSH_AGE, _GAP = _I["wall_depth"], _I["push_age"], _I["gap_offset"]

#: Wall phases: to be placed, the stiff approach, held, the soft push.
UNPLACED, APPROACH, HELD, PUSH = 0.0, 1.0, 2.0, 3.0


@dataclass(frozen=True)
class FreeRest:
    """Thresholds of the free-load rest (see the module docstring).

    Attributes
    ----------
    entry_speed : float
        Engage with the observer's load speed below this, rad/s ...
    entry_motor_speed : float
        ... and the motor's below this, rad/s: parked (a motor still
        arriving on its flank at 0.19 rad/s, the load's speed read as 5e-4
        rad/s for 1.4e-3, ran into the load the wall was placed for and
        kicked it to 2.5e-3; the wall's later catch was a stiff one, and
        the latched law's flips a 440 Nm ping-pong).
    leave_torque : float
        Engage with ``|Td_hat|`` below this, Nm; leave when the filtered
        estimate (`rest_flank.RestFlank.lean_time`) or the lean filter's
        exceeds it.
    hold_stiffness, hold_damping : float
        The soft hold's gains, Nm/rad and Nm s/rad.
    reading_variance : float or None
        Variance of a load-encoder reading, rad^2; None: set by
        `ctrl_lpv.twomass.servo_design` from the encoder counts (a third of
        a count squared, as `ctrl_lpv.twomass.cold_start.cold_start`).
    speed_diffusion : float
        Random-walk intensity of the load speed in the drift filter,
        (rad/s)^2 / s.
    drift_prior : (float, float)
        Standard deviations of the drift filter's load error and speed at
        entry, rad and rad/s.
    catch_drift, catch_evidence : float
        The innovation CUSUM's drift and threshold, in standard deviations
        of the innovation.
    catch_inflation : (float, float)
        Standard deviations, rad and rad/s, added to both filters' load error
        and speed at a catch.
    catch_settle : float
        After a catch the flank test waits at least this long, s.
    accel_diffusion : float
        Random-walk intensity of the load acceleration in the lean filter,
        (rad/s^2)^2 / s.
    lean_prior : (float, float, float)
        Standard deviations of the lean filter's load error, speed and
        acceleration at entry.
    lean_time : float
        The lean filter's load torque lasts this long, the wall held and
        the load not on it, before the rest is handed back, s. (Counted in
        every phase, it read as a load torque a load thrown by the stiff
        approach and a load leaving the wall it hit: the rest was handed
        back for good, and the latched law's flips were a 12-20 Nm
        ping-pong.)
    flip_margin, flip_evidence : float
        The flip CUSUM's drift, rad, and threshold, rad s, on the load's
        coast end past the target on the far side.
    settle_time : float
        No flip test within this long of a flank change or entry, nor push,
        s.
    clearance : float
        The wall's least depth short of the target, rad.
    wall_margin : float
        The wall stands this far short of the predicted load, rad.
    approach_accel : float
        Peak acceleration of the stiff approach, rad/s^2.
    guard : float
        The load is predicted this long past the approach's end, s.
    arrival_error, arrival_speed, arrival_timeout : float
        The approach has arrived within these of the wall (rad, rad/s), or
        this long after its end (s).
    still_speed : float
        A load slower than this, rad/s, is at rest (a push's condition).
    target_band : float
        A load at rest beyond this of the target is pushed, rad. A push is a
        crossing of the whole band (the pushed load coasts 5.6 s x its
        speed, caught by the other wall), and both walls stand short by the
        half-gap estimate's error (1e-4 rad at alpha 0.06): only a load about
        to leave the issue's 2e-4 rad is pushed (at 1.5e-4 the four Td 0
        rows of the bench missed 28 of 384 runs on seeds 1-96, at 1.8e-4 14).
    push_wait : float
        Between pushes, s.
    recede_speed, recede_horizon : float
        A load receding towards the target slower than `recede_speed` is
        pushed if it would still be beyond `target_band` after
        `recede_horizon` s.
    push_arrival : float
        A push aims to take the load across its error in this long, s ...
    push_speeds : (float, float)
        ... at a speed within these, rad/s.
    push_time : float
        Duration of a push, s.
    displacement : float
        Leave when the motor is this far off its wall, rad.
    contact_deflection : float
        A held motor pushed this far off its wall towards its flank is in
        contact with the load, rad: the load's reading measures the
        half-gap there, unless the load leaves faster than `still_speed` ...
    gap_time : float
        ... averaged over this long, s; the walls are placed on the
        half-gap measured, not on the estimate of the move (at the end of a
        move it was up to 6e-4 rad off: walls that stood that far past the
        target, or reached into the load resting on the other flank and
        kicked it).
    """

    entry_speed: float = 5e-4
    entry_motor_speed: float = 1e-2
    leave_torque: float = 0.2
    hold_stiffness: float = 30.0
    hold_damping: float = 91.0
    reading_variance: float | None = None
    speed_diffusion: float = 1e-10
    drift_prior: tuple = (3e-4, 3e-3)
    catch_drift: float = 0.5
    catch_evidence: float = 10.0
    catch_inflation: tuple = (1e-4, 2e-3)
    catch_settle: float = 0.15
    accel_diffusion: float = 1e-2
    lean_prior: tuple = (3e-5, 3e-3, 1.0)
    lean_time: float = 0.05
    flip_margin: float = 1e-4
    flip_evidence: float = 2e-5
    settle_time: float = 0.3
    clearance: float = 2e-5
    wall_margin: float = 5e-5
    approach_accel: float = 20.0
    guard: float = 0.05
    arrival_error: float = 1e-5
    arrival_speed: float = 2e-3
    arrival_timeout: float = 0.1
    still_speed: float = 3e-5
    target_band: float = 1.8e-4
    push_wait: float = 0.5
    recede_speed: float = 3e-4
    recede_horizon: float = 1.0
    push_arrival: float = 0.5
    push_speeds: tuple = (3e-4, 2e-3)
    push_time: float = 0.2
    displacement: float = 5e-4
    contact_deflection: float = 2e-5
    gap_time: float = 0.05


class FreeRestStep(NamedTuple):
    """One sample of the free rest: its next `state`, the latch's `side`
    and `evidence`, whether the rest is `parked` on it this sample (the gap
    estimate then holds), and the motor `command` (None: the latched
    law's)."""

    state: np.ndarray
    side: float
    evidence: float
    parked: bool
    command: float | None


def free_rest_stepper(f: FreeRest, c, dt: float):
    """The free rest of `f` one sample of `dt` on, for the servo tuning `c`
    (`ctrl_lpv.twomass.servo_kernel.ServoTuning`: the nominal load inertia
    and friction, the motor's, and the law's motor gains for the stiff
    approach).

    Returns
    -------
    callable
        ``step(z, **reading) -> FreeRestStep`` on the states `z`
        (`FREE_REST_STATES`); the reading's keywords are those of the
        function's signature below.
    """
    if f.reading_variance is None:
        raise ValueError("FreeRest.reading_variance: not set (the encoder counts)")
    R = f.reading_variance
    coast = c.Jl / c.cl
    decay = math.exp(-dt / coast)
    reach = coast * (1.0 - decay)
    lean_model = np.array([[1.0, dt, 0.5 * dt * dt], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
    inflation = np.diag([f.catch_inflation[0] ** 2, f.catch_inflation[1] ** 2, 0.0])
    k1, k2 = c.gain[0], c.gain[1]
    soft = f.hold_stiffness, f.hold_damping
    gap_share = 1.0 - math.exp(-dt / f.gap_time)

    def enter(z, load, load_error, load_speed):
        z[:] = 0.0
        z[_ALLOWED] = z[_ENGAGED] = 1.0
        z[_E], z[_V] = load_error, load_speed
        z[_PEE], z[_PVV] = f.drift_prior[0] ** 2, f.drift_prior[1] ** 2
        z[_LEAN : _LEAN + 3] = [load, load_speed, 0.0]
        z[_LEAN_P : _LEAN_P + 9] = np.diag(np.square(f.lean_prior)).ravel()

    def lean(z, load, counting):
        """The lean filter one sample on: the time it has seen a load torque
        (`counting`: the wall held, the load not on it)."""
        x = lean_model @ z[_LEAN : _LEAN + 3]
        P = lean_model @ z[_LEAN_P : _LEAN_P + 9].reshape(3, 3) @ lean_model.T
        P[2, 2] += f.accel_diffusion * dt
        gain = P[:, 0] / (P[0, 0] + R)
        x = x + gain * (load - x[0])
        P = P - np.outer(gain, P[0, :])
        z[_LEAN : _LEAN + 3], z[_LEAN_P : _LEAN_P + 9] = x, P.ravel()
        torque = -(c.Jl * x[2] + c.cl * x[1])
        speeding = counting and abs(torque) > f.leave_torque and x[1] * x[2] > 0.0
        z[_LEAN_CLOCK] = z[_LEAN_CLOCK] + dt if speeding else 0.0

    def drift(z, load):
        """The drift filter one sample on, re-inflated at a catch."""
        e, v = z[_E] + reach * z[_V], decay * z[_V]
        Pee, Pev, Pvv = z[_PEE], z[_PEV], z[_PVV]
        n00 = Pee + 2.0 * reach * Pev + reach * reach * Pvv
        n01 = decay * (Pev + reach * Pvv)
        n11 = decay * decay * Pvv + f.speed_diffusion * dt
        innovation = load - e
        normed = innovation / math.sqrt(n00 + R)
        z[_UP] = max(0.0, z[_UP] + normed - f.catch_drift)
        z[_DOWN] = max(0.0, z[_DOWN] - normed - f.catch_drift)
        if z[_UP] > f.catch_evidence or z[_DOWN] > f.catch_evidence:
            z[_UP] = z[_DOWN] = 0.0
            P = z[_LEAN_P : _LEAN_P + 9].reshape(3, 3) + inflation
            z[_LEAN_P : _LEAN_P + 9] = P.ravel()
            n00 += inflation[0, 0]
            n11 += inflation[1, 1]
            z[_AGE] = min(z[_AGE], f.settle_time - f.catch_settle)
        S = n00 + R
        g0, g1 = n00 / S, n01 / S
        z[_E], z[_V] = e + g0 * innovation, v + g1 * innovation
        z[_PEE], z[_PEV], z[_PVV] = (1 - g0) * n00, (1 - g0) * n01, n11 - g1 * n01

    def place(z, side, target, motor, alpha_hat):
        """The wall on `side`, short of the load where the motor arrives."""
        nominal = target + side * (alpha_hat - f.clearance)
        horizon = crossing_duration(nominal - motor, f.approach_accel) + f.guard
        depth = min(-f.clearance, side * (z[_E] + z[_V] * horizon) - f.wall_margin)
        wall = target + side * (depth + alpha_hat)
        z[_PHASE], z[_FROM], z[_TO], z[_CLOCK] = APPROACH, motor, wall, 0.0
        z[_DURATION] = crossing_duration(wall - motor, f.approach_accel)
        z[_DEPTH] = depth

    def push(z, side, target, alpha_hat):
        """A load that stays off the target is pushed towards it."""
        ze, zv = side * z[_E], side * z[_V]
        slow = zv > -f.still_speed and abs(zv) < f.recede_speed
        stays = ze + max(zv, 0.0) * f.recede_horizon < -f.target_band
        if not (z[_AGE] > f.settle_time and z[_PUSH_AGE] > f.push_wait):
            return
        if not (slow and stays):
            return
        contact = side * (z[_TO] - target) - alpha_hat
        speed = min(max(-ze / f.push_arrival, f.push_speeds[0]), f.push_speeds[1])
        travel = max(ze - contact, 0.0) + speed * f.push_time / QUINTIC_PEAK_SPEED
        z[_PHASE], z[_FROM], z[_TO] = PUSH, z[_TO], z[_TO] + side * travel
        z[_CLOCK], z[_DURATION], z[_PUSH_AGE] = 0.0, f.push_time, 0.0

    def command(z, motor, motor_speed):
        """The motor torque of the wall's phase, and whether the motor is
        held `displacement` off its wall (the hold yields)."""
        ref, speed, accel = rest_to_rest(z[_CLOCK], z[_DURATION], z[_FROM], z[_TO])
        ended = z[_CLOCK] >= z[_DURATION]
        if z[_PHASE] == PUSH and ended:
            z[_PHASE] = HELD
        if z[_PHASE] == APPROACH and ended:
            arrived = (
                abs(motor - z[_TO]) < f.arrival_error
                and abs(motor_speed) < f.arrival_speed
            )
            if arrived or z[_CLOCK] > z[_DURATION] + f.arrival_timeout:
                z[_PHASE] = HELD
        kp, kd = (k1, k2) if z[_PHASE] == APPROACH else soft
        feedback = kp * (motor - ref) + kd * (motor_speed - speed)
        u = c.Jm * accel + c.cm * speed - feedback
        return u, ended and abs(motor - ref) > f.displacement

    def step(
        z, *, resting, latched, side, evidence, target, load,
        load_error, load_speed, load_torque, rest_torque, motor, motor_speed,
        alpha_hat,
    ) -> FreeRestStep:  # fmt: skip
        """One sample: `resting` (the plan at rest), `latched` (and the
        flank latched, not crossing), the latch's `side` and `evidence`
        after its own step (held while the rest is engaged), the `target`, the
        `load` encoder's reading, the observer's `load_error`,
        `load_speed`, `load_torque` and its filtered `rest_torque`, the
        `motor` angle and `motor_speed` where the command acts, and the
        half-gap estimate `alpha_hat`."""
        z = np.array(z, dtype=float)
        if not resting:
            z[_ALLOWED] = 1.0
        engaged = z[_ENGAGED] == 1.0
        if latched and not engaged and abs(rest_torque) > f.leave_torque:
            z[_ALLOWED] = 0.0
        quiet = (
            abs(load_speed) < f.entry_speed
            and abs(motor_speed) < f.entry_motor_speed
            and abs(load_torque) < f.leave_torque
        )
        if not latched or not z[_ALLOWED] or not (engaged or quiet):
            z[_ENGAGED] = 0.0
            return FreeRestStep(z, side, evidence, False, None)
        if not engaged:
            enter(z, load - target, load_error, load_speed)
        # The load on the held motor pushes it towards its flank: a contact.
        touching = side * (z[_TO] - motor) > f.contact_deflection
        # A load that a stiff wall meets, or that leaves the wall it hit, is
        # thrown, not leaning on a load torque.
        lean(z, load - target, counting=z[_PHASE] == HELD and not touching)
        drift(z, load - target)
        z[_AGE] += dt
        if z[_AGE] > f.settle_time:
            coast_end = side * (z[_E] + coast * z[_V])
            z[_FLIP] = max(0.0, z[_FLIP] + dt * (coast_end - f.flip_margin))
            if z[_FLIP] > f.flip_evidence:
                side, evidence = -side, 0.0
                z[_FLIP] = z[_AGE] = 0.0
                z[_PHASE] = UNPLACED
        half_gap = alpha_hat + z[_GAP]
        if z[_PHASE] == UNPLACED:
            place(z, side, target, motor, half_gap)
        z[_CLOCK] += dt
        z[_PUSH_AGE] += dt
        if z[_PHASE] == HELD:
            push(z, side, target, half_gap)
        if z[_PHASE] == HELD and touching and side * z[_V] < f.still_speed:
            # The half-gap is the load's distance to the motor it touches
            # (the shaft's twist, under 0.1 Nm, is 3e-5 rad); not once the
            # load leaves it (the motor's deflection outlasts the contact).
            measured = side * (motor - load) - alpha_hat
            z[_GAP] += gap_share * (measured - z[_GAP])
        u, yielded = command(z, motor, motor_speed)
        if yielded or abs(rest_torque) > f.leave_torque or z[_LEAN_CLOCK] > f.lean_time:
            z[_ENGAGED], z[_ALLOWED] = 0.0, 0.0
            return FreeRestStep(z, side, evidence, True, None)
        return FreeRestStep(z, side, evidence, True, u)

    return step
