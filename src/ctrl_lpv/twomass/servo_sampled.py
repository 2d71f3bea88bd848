"""The servo as it runs on a drive: once per sample, on encoder angles.

`sampled_servo` turns a `ServoTuning` into a discrete-time python-control
system. Per sample ``t_k`` it reads the encoder angles ``theta_m``,
``theta_l`` and the target ``theta_r`` and:

1. corrects the drive observer's prediction with the readings
   (`ctrl_lpv.twomass.drive_observer`: speeds, shaft and load torques,
   scheduled on its own shaft-torque estimate);
2. with ``delay=1`` predicts the state at ``t_{k+1}``, when the command
   computed now will act, from the command already on its way (the
   delay compensation of a Smith predictor); with ``delay=0`` uses the
   corrected estimate;
3. evaluates the continuous servo's law there (`servo_kernel`:
   feedforward of the planned move, the backlash offset on the flank the
   asked shaft torque needs, feedback with the discrete-time gain), with
   the reference planned for the instant the command acts;
4. advances the integral, the gap estimate and the planner by one sample.

With ``reference="stream"`` the planner is replaced by the tracker of a
streamed set-point (`ctrl_lpv.twomass.stream`): step 3 evaluates the
feedforward on the tracker's speed, acceleration and jerk extrapolated to
the instant the command acts (the torque half a sample further, the
middle of its hold), plus the observer's load torque (a streamed set-point
rarely rests, and the integral is held while it moves); the feedback, the
flank offset and the observer are unchanged, and nothing is re-planned.

Changes of the continuous law make it robust to sampling and to the
encoders' quantization: the gap estimate learns from contacts during moves,
and at rest only from static readings while the load leans on a flank (a
load torque beyond the contact torque; without one the shaft-torque
estimate is of the order of the quantization noise, and a wandering
estimate moves the motor against the flank), slowly. In a move it learns
only while the move asks for a shaft torque beyond ``learn_torque``
on the flank the estimate is on (at the end of a move the motor may swing
across the gap, and a streamed set-point's reversal crosses it twice a
period; the observer, scheduled on its own estimate, reads a crossing as a
contact for a few samples: learning from it halved the gap estimate at
alpha = 0.06 and left a 2e-2 rad limit cycle, or stopped the motor
mid-gap on a streamed sine), and a reading well below the estimate teaches
it only where static (``narrowing_band``: the observer reads a landing
on a flank as a contact 10-20 ms early, the motor still in the gap).

A contact asked for and not made probes a wider gap from the contact
torque on (not twice it), so that the load is not left in a dead band of
the gap estimate's error, but only while the load error is beyond
``probe_error`` (a contact made at a small load torque reads as the gap
through the estimate's noise: probing then widened the estimate past the
gap and started hunting). At rest the flank is latched (`rest_flank`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np

from . import gap_crossing as _gx
from . import gap_fall as _fall
from .cold_start import COLD_START_STATES
from .drive_observer import DRIVE_STATES
from .free_rest import FREE_REST_STATES, free_rest_stepper
from .inertia import INERTIA_STATES
from .rest_flank import flank_offset, rest_flank_step
from .servo_kernel import ServoTuning, _smoothstep
from .stream import jerk_model
from .trajectory import PLAN_GAINS, replan_duration

__all__ = [
    "SampledServo",
    "sampled_servo",
    "plan_stepper",
    "plan_snap",
    "flat_feedforward",
    "integral_holding",
    "SAMPLED_STATES",
    "SAMPLED_INPUTS",
    "CONTACT_TWIST",
    "GAP_READING_SPAN",
]

SAMPLED_STATES = [
    "r", "v_r", "a_r", "j_r", "goal", "time_to_go",
    "theta_m_hat", "omega_m_hat", "Ts_hat", "theta_l_hat", "omega_l_hat",
    "Td_hat", "int_e_l", "alpha_hat_dev", "Tm_prev", "flank_side",
    "flank_evidence", "Td_rest", "flank_crossing", "hold_crossing", "contact_age",
    "flip_duration",
]  # fmt: skip
#: The motor-encoder estimator's states, or the inertia estimate, follow these.
_NS = len(SAMPLED_STATES)
#: ``hold_crossing``: the planned crossing into the rest's hold, decided
#: where it starts and held to the end of the move: 0 undecided, `_PLANNED`,
#: or the braking flank (+1 or -1) kept instead.
_PLANNED = 2.0
_HOLD = SAMPLED_STATES.index("hold_crossing")
_AGE = SAMPLED_STATES.index("contact_age")
_FLIP = SAMPLED_STATES.index("flip_duration")
_FREE_ENGAGED = FREE_REST_STATES.index("free_engaged")
SAMPLED_INPUTS = ["theta_m", "theta_l", "theta_r"]
#: The motor-encoder estimator's extra states: the sensitivity of the
#: prediction to the half-gap and the half-gap variance (less its initial),
#: the samples left in which the half-gap learns, whether the half-gap is
#: known (`MotorEstimator.gap_check`), the samples in contact since
#: (`MotorEstimator.contact_clock`), and the fall mode's
#: (`gap_fall.FALL_STATES`).
MOTOR_STATES = [
    "S_theta_m", "S_omega_m", "S_theta_l", "S_omega_l", "S_Td", "P_alpha_dev",
    "learn_window", "gap_episode", "gap_shift", "gap_known", "contact_clock",
    *_fall.FALL_STATES,
]  # fmt: skip
_FALL = _NS + 11
_UNHELD = COLD_START_STATES.index("torque_unheld")
_LIGHT = _fall.FALL_STATES.index("light_load")

_STREAM_REST_ACCEL = 1e-3  # rad/s^2
#: A contact read for this long, s, is no longer a landing misread
#: (``contact_age``; the gap estimate's narrowing readings).
_LANDING_TIME = 0.01
# A streamed set-point's gap crossings are planned above this speed (rad/s):
# where a streamed move stops, the tracker's acceleration rings (1.5 rad/s^2
# after a quintic's end, 4e-3 rad/s) and would plan a crossing to nowhere.
_STREAM_CROSSING_SPEED = 0.05

#: The drive observer counts a contact only where its twist estimate is
#: beyond this share of the half-gap estimate on the side of its shaft
#: torque: a motor crossing the gap at rest was read as a contact, and the
#: latch flipped back on the misread, bursts of flips at 500 Nm (1 ms,
#: encoders; docs/servo.rst, "The Td = 0 rest: crossings, not slams").
CONTACT_TWIST = 0.3
#: A reading of the half-gap at a contact is kept up to this multiple of
#: ``alpha_max``. The readings of a gap of alpha_max scatter about it; cut
#: there, their mean and the estimate ended a move 1.1e-4 rad short at alpha
#: 0.06 (1 ms, Td 0, +-0.5 rad, seeds 1-16; 2.0e-5 long when kept, as at
#: alpha 0.03), and the free rest's walls stood as far past the target
#: (docs/servo.rst, "The gap read at its largest, and the parked motor").
GAP_READING_SPAN = 1.25

#: The instant, as a share of the sample from its start, at which the plan's
#: torque is held over the sample (`flat_feedforward`'s ``lead``): a torque
#: that is a ramp over the sample twists the shaft at the sample's end as
#: the ramp's value at a third of it does (the twist is two integrations
#: from the motor torque: ``int_0^T (T - s) s ds / int_0^T (T - s) ds =
#: T / 3``).
HOLD_INSTANT = 1.0 / 3.0


def integral_holding(load_torque, k1, k5, ks):
    """The law's load-angle integral that holds `load_torque` at rest on a
    flank (its equilibrium, ``Tm = -k1 Td / ks - k5 xi = Td``), for the
    motor-angle gain `k1`, the integral gain `k5` and the shaft stiffness
    `ks`."""
    return -load_torque * (1.0 + k1 / ks) / k5


def _held_torque(xi, k1, k5, ks):
    """The load torque that the law's integral `xi` holds at rest (the
    inverse of `integral_holding`)."""
    return -xi * k5 / (1.0 + k1 / ks)


def _integral_share(speed, hold):
    """The share of the integral handed to the load-torque estimate per
    sample in a move (motor encoder alone): 1 at the plan's speed `hold`
    and beyond (where the law holds its integral), 0 at rest."""
    if hold <= 0.0:
        return 0.0
    return 1.0 - _smoothstep(1.0 - abs(speed) / hold)


@dataclass(frozen=True)
class SampledServo:
    """The numbers of the sampled servo beyond the continuous law's.

    Attributes
    ----------
    dt : float
        Sample time, s.
    delay : int
        Samples between reading the encoders and the command acting (0 or
        1).
    Phi, Gamma, M : tuple of ndarray
        The observer's sampled model and its filter gain ``Phi^-1 L`` at
        the gap and in contact (`ctrl_lpv.twomass.drive_estimator`); the
        observer counts the gap below the law's ``contact_torque`` of
        shaft-torque estimate.
    reference : {"plan", "stream"}
        ``"plan"``: ``theta_r`` is a target, reached by a planned
        rest-to-rest move; ``"stream"``: ``theta_r`` is a set-point
        streamed every sample, followed through the tracker of
        `ctrl_lpv.twomass.stream`.
    stream_gain : tuple of float or None
        The tracker's correction gain (``reference="stream"``).
    measured : tuple of str
        The encoder angles read, the controller's first inputs:
        ``("theta_m", "theta_l")`` (both encoders) or ``("theta_m",)`` (the
        motor encoder alone, `ctrl_lpv.twomass.motor_observer`); the
        columns of `M`.
    estimator : `ctrl_lpv.twomass.motor_estimator.MotorEstimator` or None
        The motor-encoder estimator (`Phi`, `Gamma`, `M` unused), or None
        for the linear drive observer.
    inertia : `ctrl_lpv.twomass.inertia.InertiaAdaptation` or None
        The load-inertia estimate learnt along moves (drive observer only;
        its state ``delta_Jl_hat`` last), or None for the nominal inertia.
    M_rest : tuple of ndarray or None
        The observer's filter gains at the gap and in contact while the
        flank is latched at rest (`rest_flank`), from quieter intensities
        (`ctrl_lpv.twomass.sampled_tuning.SampledTuning.rest_rates`); None:
        `M` throughout. The switch is not covered by the observer's
        certificate (each gain set is certified on its own), as the latch
        is not by the rest's.
    cold_start : `ctrl_lpv.twomass.cold_start.ColdStart` or None
        The load torque measured by the load's fall at a cold start, and
        held by the integral in moves along it until the first rest (drive
        observer only; its states after the inertia estimate's), or None.
    free_rest : `ctrl_lpv.twomass.free_rest.FreeRest` or None
        The rest of a free load, by a wall and a dead catch, within the
        latched flank (`ServoTuning.rest_flank`; drive observer only, its
        reading variance set; its states last), or None.
    exact_feedforward : bool
        The feedforward with the shaft's damper and the torque's hold
        (`flat_feedforward`, `ctrl_lpv.twomass.sampled_tuning.SampledTuning.
        exact_feedforward`), else without.
    """

    dt: float
    delay: int
    Phi: tuple
    Gamma: tuple
    M: tuple
    reference: str = "plan"
    stream_gain: tuple | None = None
    measured: tuple = ("theta_m", "theta_l")
    estimator: object = None
    inertia: object = None
    M_rest: tuple | None = None
    cold_start: object = None
    exact_feedforward: bool = False
    free_rest: object = None


def plan_stepper(c: ServoTuning, dt: float):
    """The servo's planner advanced by one sample of `dt`.

    The rest of the move is the minimum-snap polynomial from the present
    plan to rest at the goal in the time-to-go (`ctrl_lpv.twomass.trajectory`),
    evaluated a sample on (`gap_crossing.advance_move`) down to the goal, where
    the time-to-go is 0. A target changed mid-move, short of where the move
    was heading, is reached without passing it where the accel limit allows
    (`gap_crossing.no_reversal_duration`; at 1.7 times it, the re-plan's
    bound from speed, a stop from 1.8 rad/s in 22 mrad saturated the motor
    and threw the load 7 mrad past). (The continuous planner's floor on the
    time-to-go, a fixed linear filter over the last 40 ms, is not used
    sampled: its tail reversed the reference, -2.8e-3 rad/s after +1.2e-2,
    the planned crossing read it as a change of flank and let go of the
    braking load at 8e-3 rad/s, the start of the Td = 0 rest's flips;
    docs/servo.rst, "The move's end".)

    Returns
    -------
    callable
        ``plan_step(plan, target) -> next plan`` on ``plan = [r, v_r, a_r,
        j_r, goal, time_to_go]`` (the first six of `SAMPLED_STATES`): a new
        target re-plans the move from the present plan.
    """

    def plan_step(plan, target):
        """The planner one sample on: a new target re-plans the move."""
        r, v, a, j, g, h = plan
        if target != g:
            g, h = target, replan_duration(target - r, v, c.accel_limit, c.min_duration)
            h = _gx.no_reversal_duration(
                (r, v, a, j), g, h, c.accel_limit, c.horizon_floor
            )
        if h <= dt * (1.0 + 1e-9):  # the move ends within this sample
            return [g, 0.0, 0.0, 0.0, g, 0.0]
        e, v, a, j = _gx.advance_move(r - g, v, a, j, h, dt)
        return [g + e, v, a, j, g, h - dt]

    return plan_step


def plan_snap(r, v, a, j, g, h):
    """The snap of the minimum-snap move from ``(r, v, a, j)`` to rest at
    `g` in `h` s (0 once the move has ended, ``h = 0``)."""
    if h <= 0.0:
        return 0.0
    p0, p1, p2, p3 = PLAN_GAINS
    return -(p0 * (r - g) / h**4 + p1 * v / h**3 + p2 * a / h**2 + p3 * j / h)


def flat_feedforward(
    c: ServoTuning, v, a, j, snap, scale=1.0, *, lead=0.0, damped=True
):
    """Flat feedforward of the contact model along a reference, with the load
    inertia ``scale * c.Jl``.

    The shaft carries ``F = Jl a + cl v`` through its spring and its damper,
    ``ks d + cs d' = F``: the twist ``d = (F - tau F') / ks`` with ``tau =
    cs / ks`` (0.6 ms; to first order in it: the next term, ``tau^2 F'' /
    ks``, is at most 6.7e-5 rad along a 0.5 rad move). Without the damper's
    share the motor ran up to 1.7 mrad behind its reference while a 0.5 rad
    move braked (0.1 mrad with it over the last 20 ms), and
    the load ended the move with 3 Nm still on the shaft, thrown back off the
    braking flank at 2.3-2.7 mrad/s (1 ms, exact angles).

    Parameters
    ----------
    c : `ServoTuning`
    v, a, j, snap : float
        The load reference's speed and its next three derivatives.
    scale : float, optional
        The load inertia as a multiple of ``c.Jl``.
    lead : float, optional
        The motor torque is the one `lead` seconds on, s (the torque held
        over a sample at the instant it acts as the plan's,
        `HOLD_INSTANT`); the motor inertia's share of the plan's fifth
        derivative, not computed by the planner, is left out (``Jm lead
        F''' / ks``: up to 1.2 Nm along a 0.5 rad move at 1 ms, and a step
        at the plan's end, where its snap steps).
    damped : bool, optional
        False: the shaft's damper neglected (the feedforward of the motor
        encoder alone, of 2 ms and slower, and of the cascade:
        `ctrl_lpv.twomass.sampled_tuning.SampledTuning.exact_feedforward`).

    Returns
    -------
    F : float
        The shaft torque that moves the load along the reference, Nm.
    twist : float
        The shaft twist that carries it, rad.
    wmf : float
        The motor speed that gives it, rad/s.
    tff : float
        The motor torque, Nm.
    """
    Jl = scale * c.Jl
    F, F1, F2 = Jl * a + c.cl * v, Jl * j + c.cl * a, Jl * snap + c.cl * j
    tau = c.cs / c.ks if damped else 0.0
    wmf = v + (F1 - tau * F2) / c.ks
    tff = c.Jm * (a + F2 / c.ks) + c.cm * wmf + F
    tff += lead * (F1 + c.Jm * j + c.cm * (a + F2 / c.ks))
    return F, (F - tau * F1) / c.ks, wmf, tff


def sampled_servo(
    c: ServoTuning, s: SampledServo, name: str = "servo"
) -> ct.NonlinearIOSystem:
    """The servo law of `c`, sampled as `s` says, as a python-control system.

    Returns
    -------
    `control.NonlinearIOSystem`
        ``dt = s.dt``; inputs `SAMPLED_INPUTS`, output ``["Tm"]`` (within
        the torque limit, acting from ``t_{k + delay}`` to the next
        sample), states `SAMPLED_STATES`, all zero at rest at the origin.
    """
    ks, cs = c.ks, c.cs
    k1, k2, k3, k4, k5 = c.gain
    limit, dt, delayed = c.torque_limit, s.dt, s.delay == 1
    a0, amax, teps, tc = c.alpha_initial, c.alpha_max, c.flank_width, c.contact_torque
    leak, gam, probe, hold = (
        c.integral_leak,
        c.estimate_rate,
        c.probe_rate,
        c.integral_hold,
    )
    learn, probe_error, rest = c.learn_torque, c.probe_error, c.rest_flank
    static_speed, narrowing = c.static_speed, c.narrowing_band
    rest_rate = c.rest_estimate_rate
    ratio = ks / k1
    deadband = c.flank_deadband
    Phi, Gam, M = (np.asarray(m) for m in (s.Phi, s.Gamma, s.M))
    M_rest = None if s.M_rest is None else np.asarray(s.M_rest)
    rows = [DRIVE_STATES.index(name) for name in s.measured]
    nread = len(rows)
    motor = s.estimator
    inertia = s.inertia
    cold = s.cold_start if motor is None else None
    states = SAMPLED_STATES if motor is None else SAMPLED_STATES + MOTOR_STATES
    if inertia is not None:
        states = SAMPLED_STATES + INERTIA_STATES
    # The cold start's states follow the inertia estimate's, the free
    # rest's the cold start's.
    first_cold = len(states)
    if cold is not None:
        states = states + COLD_START_STATES
    rest_wall = None
    if s.free_rest is not None and motor is None and rest is not None:
        rest_wall = free_rest_stepper(s.free_rest, c, dt)
        first_free = len(states)
        states = states + FREE_REST_STATES

    def blend(pair, w):
        return pair[0] + w * (pair[1] - pair[0])

    def flank_share(torque):
        """The continuous law's flank offset (-1 to 1) for the asked shaft
        `torque`."""
        return math.copysign(_smoothstep((abs(torque) - deadband) / teps), torque)

    plan_step = plan_stepper(c, dt)
    filtered_share = 0.0 if rest is None else 1.0 - math.exp(-dt / rest.lean_time)

    streamed = s.reference == "stream"
    # Both with the drive observer only (the motor encoder's estimator has
    # its own contact and fall logic).
    crossings = motor is None
    contact_twist = CONTACT_TWIST if motor is None else 0.0
    # A streamed set-point's torque is always taken at the hold's instant
    # (its tracker's extrapolation had it first, at half a sample).
    exact = s.exact_feedforward
    lead = HOLD_INSTANT * dt if exact or streamed else 0.0
    if streamed:
        Lz, Pz = np.asarray(s.stream_gain, float), jerk_model(dt)
        # The set-point where the command computed now acts, `delay` samples
        # on.
        to_act = jerk_model(s.delay * dt)

    def reference(plan, target, scale=1.0):
        """The reference where the command acts, its torque, the next plan."""
        if not streamed:
            # The plan where the command acts, `delay` samples on: the plan
            # of the reading's instant left the load a sample behind it (4.8
            # mrad at 4.4 rad/s on a 0.5 rad move, 0.5 with this).
            next_plan = plan_step(plan, target)
            r, v, a, j, g, h = next_plan if delayed else plan
            snap = plan_snap(r, v, a, j, g, h)
            ff = flat_feedforward(c, v, a, j, snap, scale, lead=lead, damped=exact)
            return (r, v, a, j, *ff, g, h), next_plan
        # Streamed: correct the tracker with the sample, extrapolate it (the
        # constant-jerk model has no snap), no planning.
        predicted = np.asarray(plan[:4])
        z = predicted + Lz * (target - predicted[0])
        r, v, a, j = to_act @ z
        ff = flat_feedforward(c, v, a, j, 0.0, scale, lead=lead, damped=exact)
        return (r, v, a, j, *ff, target, 0.0), [*(Pz @ z), target, 0.0]

    def law(x, y):
        plan, xhat = list(x[0:6]), np.asarray(x[6:12])
        xi, dah, u_prev, side, evidence = x[12], x[13], x[14], x[15], x[16]
        innovation = np.asarray(y[:nread]) - xhat[rows]
        read_from = tc
        if cold is not None:
            first_fall = x[first_cold : first_cold + len(COLD_START_STATES)]
            if cold.falling(first_fall, innovation):
                # The first fall: a contact is read from a wider margin
                # (`cold_start`).
                read_from = cold.contact_margin * tc
        contact = _smoothstep(abs(xhat[2]) / read_from - 1.0)
        if contact_twist > 0.0:
            # A contact needs the twist on the side of the shaft torque: a
            # motor crossing the gap at rest was read as a contact (the
            # estimate integrating the motor's speed as twist, -45 Nm with
            # the shaft free), and the latch flipped on the misread, back
            # and forth within 10 ms.
            side_twist = math.copysign(1.0, xhat[2]) * (xhat[0] - xhat[3])
            contact *= _smoothstep(side_twist / (contact_twist * (a0 + dah)))
        # How long the contact has been read on its flank (signed, s).
        age, flank_now = 0.0, math.copysign(1.0, xhat[2])
        if contact > 0.5:
            held_on = x[_AGE] * flank_now >= 0.0
            age = (x[_AGE] if held_on else 0.0) + flank_now * dt
        if motor is None:
            Ph, Gh = blend(Phi, contact), blend(Gam, contact)
            # Latched at rest (the flank of the last sample), and not on a
            # flip's crossing of the gap: the quieter gains (`M_rest`).
            latched = x[15] != 0.0 and x[18] <= 0.0
            gain = blend(M if M_rest is None or not latched else M_rest, contact)
            # With delay=1 the command computed now acts from the next
            # sample, on the state the command already on its way leads to.
            if inertia is None:
                filtered = xhat + gain @ innovation
            else:
                # The load inertia learnt along moves (`inertia`).
                learnt = x[_NS : _NS + len(INERTIA_STATES)]
                filtered, learnt = inertia.correct(
                    xhat, learnt, innovation, gain, rows, Ph, plan[2], contact
                )
                dJ = learnt[0]
            if cold is not None:
                # The load torque at a cold start, from the load's fall in
                # the gap (`cold_start`).
                filtered, started = cold.correct(
                    xhat, filtered, first_fall, innovation, gain, rows, Ph,
                    contact=contact, alpha_hat=a0 + dah,
                )  # fmt: skip
            if inertia is None:
                ahead = Ph @ filtered + Gh * u_prev
            else:
                ahead = inertia.predict(Ph, Gh, filtered, u_prev, dJ)
        else:
            # Motor encoder alone: the dead-zone model, the half-gap
            # estimated with it (`motor_estimator`).
            # The half-gap learns near the prediction's contact changes and
            # where a move's reading breaks with the model
            # (`MotorEstimator.learns`).
            plan_rest = plan[5] <= 0.0
            # Unless a load torque presses the load onto a flank (its
            # estimate and the integral's, both beyond the contact torque):
            # a load in the gap then does not stop, and a reading that
            # breaks with the model is the gap's (a gap narrowing at rest
            # under 8 Nm, 0.045 -> 0.03, overshoots 7.0 %, 13.6 % without;
            # a gap widening is a fall, `gap_fall`).
            pressed = abs(xhat[5]) > tc and abs(_held_torque(xi, k1, k5, ks)) > tc
            resting = plan_rest and not pressed
            learning = motor.learns(x[_NS + 6], y[0] - xhat[0], resting)
            # The load torque is unknown at the first contact: from the
            # first at which the half-gap is known, the time-varying
            # Kalman gains of an unknown load torque
            # (`motor_estimator.first_contact_gains`); before, a contact's
            # innovation is the gap's.
            check, clock = list(x[_NS + 7 : _NS + 10]), x[_NS + 10]
            filtered, sens, dP, gap = motor.correct(
                xhat, x[_NS : _NS + 5], x[_NS + 5], a0 + dah, y[0], learning,
                clock if check[2] > 0.0 else None,
            )  # fmt: skip
            # A contact broken at rest under a load torque: the gap widened,
            # the load falls back onto the flank (`gap_fall`).
            fall = list(x[_FALL : _FALL + len(_fall.FALL_STATES)])
            if y[nread] != plan[4]:
                fall[_LIGHT] = 0.0  # a new target: landings are watched again
            if fall[0] == 0.0:
                fall, broke = _fall.watch(
                    fall, xhat, filtered, y[0], plan_rest, a0 + dah, c, dt, x[14]
                )
                if broke is not None:
                    return fall_step(x, y, fall, broke)
            else:
                return fall_step(x, y, fall, xhat)
            ahead, sens_ahead, dP_ahead = motor.predict(
                filtered, sens, u_prev, gap, dP, resting
            )
        at = ahead if delayed else filtered
        tm, wm, tsh, tl, wl = at[:5]
        scale = 1.0 if inertia is None else 1.0 + dJ
        if cold is not None and not streamed:
            # Where the fall's load torque joins, the move starts again from
            # the falling load (`ColdStart.restart`).
            plan = cold.restart(
                plan, x[first_cold + _UNHELD], started[-1], (tl, wl), at[5],
                scale * c.Jl, c.cl,
            )  # fmt: skip
        (r, v, a, j, F, twist, wmf, tff, g, h), next_plan = reference(
            plan, y[nread], scale
        )
        if streamed:
            # A streamed set-point rarely rests: the integral is held while
            # it moves, so the observer's load torque joins the feedforward
            # (and keeps the shaft on the flank that carries it).
            F, twist, tff = F + at[5], twist + at[5] / ks, tff + at[5]
        # The flank offset, as in the continuous law (`servo_kernel`).
        el, dl = tl - r, wl - v
        ah = a0 + dah
        at_rest = h <= 0.0 and abs(r - g) < 1e-6 and abs(v) < 1e-5
        if streamed:
            # A streamed set-point rests only once the tracker has stopped
            # accelerating too: a sine's turning point (v = 0 for one
            # sample) is not a rest, and must not latch the flank.
            at_rest = at_rest and abs(a) < _STREAM_REST_ACCEL
        # Latched at rest (`rest_flank`): near the target the load-position
        # feedback fades out, so that catching a drifting load brakes it
        # without throwing it to the other flank.
        band = 1.0
        if at_rest and side != 0.0 and abs(ratio * k5 * xi) < rest.band_torque:
            band = _smoothstep(abs(el) / rest.band - 1.0)
        # On the motor encoder alone (a flank dead band) at rest without a
        # load torque to hold (the estimate below half the dead band, in
        # full from the dead band on), the load feedback fades out: the load
        # is not observable in the gap, and a push on its estimated error
        # was a contact that the estimator read as a load torque (Td_hat
        # 2.7, -6.4, +19.5 Nm), the next push, a hunt (Td 0, alpha 0.045,
        # 0.25 rad: 200-259 Nm on seeds 1-3; now 0.00 Nm, the load where
        # it coasted, within the gap).
        free = 1.0
        if at_rest and deadband > 0.0:
            free = _smoothstep(abs(at[5]) / (0.5 * deadband) - 1.0)
            band *= free
        kp = k3 * band
        # (free = 1 leaves every sum below as it was, to the last bit.)
        tstar = (
            F - ratio * (kp * el + free * k4 * dl + free * k5 * xi)
            if c.anti_hunting else F
        )  # fmt: skip
        psi = flank_share(tstar)
        if at_rest and motor is None and rest is not None and c.anti_hunting:
            # Unlatched at rest (a load torque beyond the latch's), a load
            # torque that pushes the load towards the target brings it
            # there: the flank stays the one that holds it. (A move ending
            # 1.4 mrad short, Jl x0.8, Td 3-5 Nm: the load-position term
            # asked for the other flank, the motor crossed the gap to push,
            # the load came on its own and the crossing back met it, a
            # relay at 120-150 Nm.) Where the load stops under its load
            # torque, not where it is: a load that reaches the target moving
            # against the load torque coasts past it (Td 3, alpha 0.06, a
            # 0.05 rad step: at the move's end the load 2e-5 short at 1.4e-2
            # rad/s, stopping 1.7e-4 past; the other flank was asked for one
            # sample, 500 Nm).
            holding = math.copysign(1.0, at[5])
            if abs(at[5]) >= rest.latch_torque:
                stop = el
                if holding * dl > 0.0:
                    stop += dl * abs(dl) * scale * c.Jl / (2.0 * abs(at[5]))
                if holding * stop > 0.0:
                    psi = holding
        dpsi = ddpsi = 0.0
        decided = 0.0 if at_rest else x[_HOLD]
        if crossings and not at_rest and c.anti_hunting:
            # The planned shaft torque's sign changes ahead: the motor
            # starts across the gap before the braking is needed
            # (`gap_crossing`; measured with both encoders only). A
            # streamed set-point's reversals are seen on its tracker's
            # extrapolation over a crossing.
            accel = _gx.STREAM_CROSSING_ACCEL if streamed else _gx.CROSSING_ACCEL
            dur = _gx.crossing_duration(2.0 * ah, accel)
            if streamed:
                # Not at a stop: the tracker's ringing there is no reversal.
                sgn, changes = 0.0, []
                if abs(v) >= _STREAM_CROSSING_SPEED:
                    sgn, changes = _gx.streamed_sign_changes(
                        v, a, j, dur, scale * c.Jl, c.cl, at[5], tc
                    )
            else:
                now, J = [r, v, a, j, g, h], scale * c.Jl
                sgn, changes = _gx.torque_sign_changes(now, J, c.cl, at[5], tc)
                # The last change's crossing (into the rest's hold) is
                # decided where it starts, on the feedback now: a load
                # running ahead keeps the braking flank to the end of the
                # move. Never taken back once under way: the crossing
                # releases the braking and the load runs ahead (decided on
                # every sample, 27 of the 108 small moves sent the motor
                # back from mid-gap, 26 at the torque limit).
                due = len(changes) == 1 and changes[0] < 0.5 * dur
                if due and decided == 0.0:
                    kept = _gx.torque_sign_changes(
                        now, J, c.cl, at[5], tc,
                        correction=-ratio * (kp * el + free * k4 * dl),
                    )[1]  # fmt: skip
                    decided = _PLANNED if kept else sgn
                elif changes and not due:
                    decided = 0.0
                if decided != _PLANNED and decided != 0.0:
                    sgn, changes = decided, []
            if sgn != 0.0:
                psi, dpsi, ddpsi = _gx.crossing_offset(sgn, changes, dur)
        flip = (0.0, 0.0)
        # The load torque while latched, filtered over `lean_time` from the
        # latch on (the observer's estimate is 0.1 Nm noisy per sample on
        # encoders, and at the end of a move it holds the inertia error of
        # the settling load: 1.8 Nm at Jl x0.8).
        td_filtered = x[17] + filtered_share * (at[5] - x[17])
        wall = None
        if rest is not None and c.anti_hunting:
            previous, left = side, x[18]
            # No flip test while the motor crosses the gap to the new flank.
            if left <= 0.0 or not at_rest:
                # The shaft torque the rest needs (`rest_flank`): the load
                # torque estimate joins the asked one, whose integral holds
                # it only in contact. A free rest holds the latch: its own
                # tests flip and release it (released on the load error, a
                # drifting load the wall caught 1e-3 rad off went back to
                # the latched law at 500 Nm).
                needed = tstar + at[5]
                free_held = (
                    rest_wall is not None and x[first_free + _FREE_ENGAGED] == 1.0
                )
                side, evidence = rest_flank_step(
                    rest, dt, side, evidence, resting=at_rest, error=el, speed=dl,
                    load_torque=at[5], tstar=needed, psi=flank_share(needed),
                    pressed=side * tsh > tc or free_held,
                )  # fmt: skip
            if rest_wall is not None:
                # A free load's rest (`free_rest`): the motor alone, a soft
                # wall the load stops on.
                wall = rest_wall(
                    x[first_free:], resting=at_rest,
                    latched=at_rest and side != 0.0 and left <= 0.0,
                    side=side, evidence=evidence, target=r,
                    load=y[1], load_error=el, load_speed=dl, load_torque=at[5],
                    rest_torque=td_filtered, motor=tm, motor_speed=wm, alpha_hat=ah,
                )  # fmt: skip
                side, evidence = wall.side, wall.evidence
                if wall.parked:
                    previous = side
            if side != 0.0:
                # The load the flip is to catch falls in the gap under a
                # load torque the rest sees (beyond `lean_torque`, the
                # estimate's noise): a light load let fall from the flank it
                # was caught on came 0.2 s later at 17 mrad/s, onto a motor
                # still crossing, and was thrown back (a ping-pong).
                load_accel = 0.0
                if abs(td_filtered) > rest.lean_torque:
                    load_accel = -(td_filtered + c.cl * dl) / (scale * c.Jl)
                psi, dpsi, ddpsi, flip = flank_offset(
                    rest, dt, side, previous, (left, x[_FLIP]),
                    alpha_hat=ah, error=el, speed=dl, accel=load_accel,
                )  # fmt: skip
        thm = r + twist + ah * psi
        wmf, tff = wmf + ah * dpsi, tff + c.Jm * ah * ddpsi + c.cm * ah * dpsi
        # In the gap the load feedback cannot reach the load: while a planned
        # crossing is under way it would only hold the motor off its flank.
        # (Summed so that without a crossing it is the sum before to the last
        # bit: the Td = 0 rest is chaotic, one rounding of this sum turned
        # Td 0, alpha 0.03, seed 1 from 0.4 to 22 Nm of chatter.)
        reach = psi * psi if dpsi != 0.0 else 1.0
        raw = tff - (
            k1 * (tm - thm) + k2 * (wm - wmf)
            + reach * kp * el + reach * free * k4 * dl + reach * free * k5 * xi
        )  # fmt: skip
        parked = wall is not None and wall.parked
        if parked and wall.command is not None:
            raw = wall.command
        u = min(max(raw, -limit), limit)

        # Integral: conditional on saturation, in contact only, held in moves.
        td_rest = 0.0 if side == 0.0 else td_filtered
        leaning = 0.0
        if side != 0.0:
            leaning = _smoothstep(side * td_rest / rest.lean_torque - 1.0)
        if (raw > limit and el < 0.0) or (raw < -limit and el > 0.0):
            dxi = 0.0
        elif c.anti_hunting:
            held = contact
            if leaning > 0.0:
                # Latched, a load torque on the latched flank keeps the load
                # leaning on it, in contact below the contact torque too:
                # the integral holds it (leaking, the proportional term
                # alone, faded near the target, left Td = 1 Nm 2.2-2.6e-4
                # rad off).
                held = max(contact, leaning)
            dxi = held * el - (1.0 - held) * leak * xi
        else:
            dxi = el
        dxi *= _smoothstep(1.0 - abs(v) / hold) if hold > 0.0 else 1.0
        # Latched near the target the integral fades with the proportional
        # term (a free load is not pushed), unless the load leans.
        dxi *= max(band, leaning)
        # Gap estimate: the flank read at contacts, probing at rest.
        ddah = learnt_gap = 0.0
        # Parked on a soft wall (`free_rest`) the gap estimate holds.
        if c.gap_estimate and not parked:
            flank = math.copysign(1.0, tsh) * ((tm - tl) - (tsh - cs * (wm - wl)) / ks)
            flank = min(max(flank, 0.0), GAP_READING_SPAN * amax)
            # A static reading: the shaft not twisting (in contact ``omega_m
            # - omega_l`` is the shaft torque's rate over ``ks``: 1 rad/s
            # along a 0.05 rad move, below 0.1 only at its torque peaks).
            static = _smoothstep(1.0 - abs(wm - wl) / static_speed)
            if at_rest:
                # At rest only while the load leans on the flank the shaft
                # torque is on (a load torque beyond the contact torque):
                # without it the shaft-torque estimate is of the order of
                # the quantization noise and the contact flickers. Slowly:
                # the reading's noise moves the motor, and the load, with
                # the estimate.
                lean = _smoothstep(abs(at[5]) / tc - 1.0) * (at[5] * tsh > 0.0)
                learnt_gap = rest_rate * static * lean * contact * (flank - ah)
            else:
                # Only where the move asks for torque on the flank the
                # estimate is on: not in a gap crossing (at the end of a
                # move, or a streamed set-point's reversal), where the
                # estimate runs on the contact model for a few samples and
                # would read the crossing as a narrower gap.
                learning = 1.0
                if learn > 0.0:
                    learning = _smoothstep(abs(F) / learn - 1.0) * (F * tsh > 0.0)
                # The same within a move: the observer reads the motor's
                # landing on a flank as a contact 10-20 ms early, the motor
                # still in the gap (readings of 0.012-0.04 against 0.06).
                # Such a reading is narrower than the gap: a reading more
                # than `narrowing` below the estimate teaches it only where
                # static or from a contact held beyond the landing's time.
                # (Gating every reading on a static one taught the estimate
                # 3.6 of the 30 mrad it missed in a 0.05 rad move; on a
                # static one or a narrow band alone, a gap narrower than the
                # first estimate, 0.03, was not learnt: 0, 0.01 and 0.02 read
                # as 0.025-0.030 after a 0.5 rad move, and the rest without
                # a load torque hunted at 129-163 Nm.)
                held = _smoothstep(abs(age) / _LANDING_TIME - 1.0)
                trusted = max(
                    static, held, _smoothstep(1.0 - (ah - flank) / narrowing)
                )  # fmt: skip
                learnt_gap = gam * trusted * learning * contact * (flank - ah)
            ddah = learnt_gap
            asked = _smoothstep(abs(tstar) / tc - 1.0)
            # A contact asked for and not made leaves a load error: without
            # one, "no contact" is the shaft-torque estimate's noise.
            if probe_error > 0.0:
                asked *= _smoothstep(abs(el) / probe_error - 1.0)
            still = _smoothstep(1.0 - (abs(v) + abs(wl)) / c.rest_speed)
            # A load torque beyond the contact torque makes the contact at
            # rest by itself: a contact read as lost there is the shaft
            # torque estimate's noise (1-2 Nm on encoders), and probing on
            # it held the estimate 3 mrad wide against the rest's reading,
            # whose integral give-back (below) then bled the integral.
            if at_rest:
                asked *= 1.0 - _smoothstep(abs(at[5]) / tc - 1.0)
            # Latched, the motor parks short of the flank on purpose: the
            # contact not made there is the clearance, not a wider gap.
            # (Probed, the estimate grew 2 mrad past the gap at rest, the
            # parked motor then pressed on the load and pushed it around.)
            if side == 0.0:
                ddah += probe * (1.0 - contact) * asked * still * (ah < amax)
            if cold is not None and v * at[5] < 0.0:
                # In the first move the way the fall's load torque pushes,
                # the gap is taken up where the holding flank is not met
                # (`ColdStart.take_up`).
                take_up = cold.take_up(started[-1], at, tstar, ah, contact, tc)
                ddah += take_up * (ah < amax)
        if delayed:
            predicted = ahead
        elif motor is None and inertia is not None:
            predicted = inertia.predict(Ph, Gh, filtered, u, dJ)
        elif motor is None:
            predicted = Ph @ filtered + Gh * u
        else:
            predicted, sens_ahead, dP_ahead = motor.predict(
                filtered, sens, u, gap, dP, resting
            )
        xi_next = xi + dt * dxi
        # In a move the integral holds the load torque estimated now, not
        # the last rest's: on the motor encoder alone (`motor_estimator`),
        # and on encoders a load torque measured at a cold start, in a move
        # the way it pushes, until a rest has taught the integral
        # (`cold_start`; a streamed set-point's feedforward carries the
        # estimate instead).
        estimated = 1.0 if motor is not None else 0.0
        if cold is not None and not streamed and v * at[5] < 0.0:
            estimated = started[-1]
        if estimated > 0.0 and not at_rest:
            xi_next += (
                estimated
                * _integral_share(v, hold)
                * (integral_holding(at[5], k1, k5, ks) - xi_next)
            )
        if learnt_gap != 0.0:
            # The gap estimate learnt from a flank reading moves the flank
            # offset by psi d(alpha_hat): the integral gives back what it
            # held of the old estimate's error (bumpless, as for a gain
            # change). Only what it holds: an integral that did not hold the
            # old error (no contact at rest) has nothing to give back, nor
            # has probing.
            give = k1 * psi * dt * learnt_gap / k5
            if give * xi_next < 0.0:
                xi_next = math.copysign(max(abs(xi_next) - abs(give), 0.0), xi_next)
        state = [*next_plan, *predicted, xi_next, dah + dt * ddah, u, side]
        state += [evidence, td_rest, flip[0], decided, age, flip[1]]
        if inertia is not None:
            state += list(learnt)
        if cold is not None:
            started[-1] = cold.hand_over(started[-1], at_rest, dt)
            state += list(started)
        if rest_wall is not None:
            state += list(wall.state) if wall is not None else list(x[first_free:])
        if motor is not None:
            window = motor.learning_window(filtered, predicted, gap, x[_NS + 6])
            state[13] = gap - a0
            check = motor.gap_check(check, a0 + dah, gap, learning)
            clock = motor.contact_clock(clock, filtered, gap, check[2])
            state += [*sens_ahead, dP_ahead, window, *check, clock, *fall]
        return u, np.asarray(state)

    def fall_step(x, y, fall, predicted):
        """One sample of the fall mode (`gap_fall`): the motor holds still
        while the load falls (predicted open loop) and while the flank it
        met brakes it, or gives way to a load that landed from a free rest;
        then a move on that flank takes it back."""
        side, hold, clock, caught = fall[:4]
        landed = caught == _fall.LANDED
        alpha = a0 + x[13] if caught else 2.0 * amax
        filtered, sens, dP, _ = motor.correct(
            np.asarray(predicted), x[_NS : _NS + 5], x[_NS + 5], alpha, y[0], False,
            round(clock / dt) if landed else None, landed,
        )  # fmt: skip
        innovation = y[0] - predicted[0]
        ahead, sens_ahead, dP_ahead = motor.predict(filtered, sens, x[14], alpha, dP)
        at = ahead if delayed else filtered
        td = abs(filtered[5])
        # Until the load is met, the motor chases it into the widened gap
        # (`gap_fall.chase`); then it holds, carrying the load torque.
        way, speed, accel = 0.0, 0.0, 0.0
        if not caught:
            way, speed, accel = _fall.chase(
                clock + (dt if delayed else 0.0), 2.0 * amax, td
            )
        if landed:
            u = _fall.soft_catch(at[0] - hold, at[1], c.Jm, c.Jl)
        else:
            u = side * (c.Jm * accel + c.cm * speed + caught * td) - (
                k1 * (at[0] - hold - side * way) + k2 * (at[1] - side * speed)
            )
        u = min(max(u, -limit), limit)
        state = list(x)
        fall = [side, hold, clock + dt, caught, 0.0, 0.0, 0.0, 0.0, fall[_LIGHT]]
        # The move back to the target: on the flank, the load torque it
        # carries (or a plain re-plan, 0); None: not yet.
        back = None
        if landed:
            if clock > _fall.LANDING_HOLD:
                if side * filtered[5] > _fall.LANDED_TORQUE:
                    back = td
                    state[12] = integral_holding(filtered[5], k1, k5, ks)
                else:
                    # A light load torque (left at rest until the next
                    # target) or none (a free load bounced off the flank:
                    # its estimate pulls away from it). The load's estimate
                    # goes back to the middle of the gap, still: where it
                    # is in the gap the motor encoder does not see (left on
                    # the flank, a load that had not landed there touched
                    # the other one after the catch, read as a contact on
                    # the wrong side: 500 Nm at 2 ms).
                    fall[_LIGHT] = float(side * filtered[5] > 0.0)
                    ahead[3:6] = [ahead[0], 0.0, 0.0]
                    fall[0] = 0.0
        elif (
            not caught
            and clock > _fall.BLIND_TIME
            and side * innovation < -_fall.IMPACT_READING
        ):
            gap = min(
                max(_fall.landing_gap(side, filtered, innovation, c.Jm, ks), 0.0), amax
            )
            state[13] = gap - a0
            # The motor holds where the shaft carries the load torque on
            # the flank met (at the chase's reference, 0.5 mrad further on,
            # the press flung the load ahead of the move back: 300 Nm).
            fall[1] = filtered[3] + side * (gap + td / ks)
            fall[2], fall[3] = 0.0, 1.0
        elif (caught and side * filtered[4] >= 0.0) or clock > _fall.fall_duration(
            2.0 * amax, td, c.Jl, tc
        ):
            back = td if caught else 0.0
        if back is not None:
            target = y[nread]
            start = (filtered[3], filtered[4], 0.0, 0.0)
            D = replan_duration(
                target - start[0], start[1], c.accel_limit, c.min_duration
            )
            if back > 0.0:
                D = _gx.one_flank_duration(
                    start, target, D, c.Jl, c.cl, side, _fall.BRAKING_SHARE * back
                )
            state[0:6] = [*start, target, D]
            fall[0] = 0.0
        if fall[0] == 0.0:
            fall = [0.0] * (len(_fall.FALL_STATES) - 1) + [fall[_LIGHT]]
        state[6:12] = ahead
        state[14] = u
        state[_NS : _NS + 6] = [*sens_ahead, dP_ahead]
        state[_FALL : _FALL + len(_fall.FALL_STATES)] = fall
        return u, np.asarray(state)

    return law_system(law, [*s.measured, "theta_r"], states, s.dt, name)


def law_system(law, inputs, states, dt, name) -> ct.NonlinearIOSystem:
    """A sampled law ``law(x, u) -> (Tm, next x)`` as a python-control
    system with output ``Tm``; update and output see the same ``(t, x,
    u)``, so the law runs once per sample."""
    last = {}

    def evaluate(t, x, u):
        key = (t, x.tobytes(), np.asarray(u, float).tobytes())
        if key not in last:
            last.clear()
            last[key] = law(x, u)
        return last[key]

    return ct.NonlinearIOSystem(
        lambda t, x, u, params=None: evaluate(t, x, u)[1],
        lambda t, x, u, params=None: [evaluate(t, x, u)[0]],
        inputs=inputs, outputs=["Tm"], states=states, dt=dt, name=name,
    )  # fmt: skip
