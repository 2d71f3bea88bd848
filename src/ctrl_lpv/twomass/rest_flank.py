"""The sampled servo's flank at rest: chosen once, changed on evidence.

At rest with a small load torque the shaft torque the servo asks for, ``T*``,
is zero up to the encoders' noise (0.2-0.3 Nm, mostly the load-speed
estimate's), inside the 0.5 Nm over which the continuous law turns the
backlash offset from one flank to the other. Read once per sample, the flank
choice turns that noise into motor swings across the gap: 111-223 Nm of
torque chatter (standard deviation) with the load quiet. A filter or a dead
zone on ``T*`` or a hysteresis on the flank only trades the chatter for load
limit cycles (the flank then lags the load, a relay with delay around a
free mass).

`RestFlank` makes the decision what it is at rest, a sequential test:

* **latch**: once the move has ended and the load is near the target (load
  error below `latch_error`, load speed below `latch_speed`) with a small
  load torque (the observer's ``|Td_hat|`` below `latch_torque`), the flank
  is latched on the side the continuous law's offset is turning to, once
  it is beyond `latch_flank` of the way (no jump of the motor reference).
  The offset is that of the shaft torque the rest needs, ``T*``: the law's
  asked shaft torque and the load torque estimate, which the law's
  integral holds only in contact; so the flank is the one a load torque
  presses the load onto (the asked torque alone read the load's bounce off
  the braking flank at a move's end as the side, and a load under 0.5-1
  Nm fell 2 mrad across the gap from it onto the motor's flip: a relay);
* **park**: the motor is parked `clearance` short of that flank (the load
  is not pushed by the gap estimate's error or the motor's noise; a load
  drifting onto the flank is caught at its own, small, speed);
* **damp, do not push**: while latched and the load error is below
  `band`, the load-position proportional term is faded out, so that
  catching a drifting load brakes it without throwing it back to the other
  flank (the shaft in contact is nearly undamped: a push from one flank
  came back as an elastic bounce, a ping-pong limit cycle);
* **hold a leaning load**: a load torque estimate beyond `lean_torque` on
  the latched flank's side means the load leans on that flank, in contact
  though below the observer's contact torque: the integral runs there
  (elsewhere out of contact it leaks), so that the load torque is held
  by the integral and not by a load error (with the proportional term
  faded, 1 Nm sat 2.2-2.6e-4 rad off the target);
* **flip on evidence**: the side changes only when ``-side T*`` stays beyond
  `flip_torque` long enough, a CUSUM test ``q <- max(0, q + dt (-side T* -
  flip_torque))`` against `flip_evidence` (a load torque of the other sign
  or a load drifting the other way: sustained; the noise: not);
* **not off a loaded flank**: while the shaft carries torque on the
  latched flank (the load bounces off it, or leans on it) the latch holds,
  no flip test and no release: ``T*`` reads the bounce's load speed (560
  Nm per rad/s of it) as a reason to change flank within 8 ms, and the
  flip let go of the loaded shaft mid-bounce; the load, thrown at 1.2e-2
  rad/s onto the other flank, came back as fast, a ping-pong at 100 Nm
  (Td 0.5 Nm, alpha 0.03, seed 1, 20 flips a second);
* **cross, do not slam**: a flip takes the parked motor across the gap along
  a quintic (`flank_offset`), with no flip test on the way, at a peak
  acceleration of `crossing_accel`; for a load that comes at the new flank,
  in `arrival_share` of its time to where it meets the parked motor
  (`flip_duration`), at its speed and under its load torque (a light load
  let fall from the flank it was caught on gains speed on the way: timed
  to its speed alone, it met the motor still crossing and was thrown back,
  a ping-pong). A step of the motor reference across the gap was a
  motor slamming at the torque limit (22 Nm of the last second's torque
  standard deviation per flip at alpha 0.03, 38 at 0.06) whose arrival
  overshot the clearance and hit the load, speeding it up (7e-4 rad/s in,
  1.6e-3 out): one flip begot the next. Loads faster than 5e-3 rad/s had
  still crossed by a step, at 300-500 Nm: after the 0.5 rad move at Td = 0,
  alpha 0.06 (1 ms, encoders, 2 of 30 seeds), and in 6 of 40 random moves
  at Td = 0 with the load inertia off by up to 20 %; timed, those flips
  peak at 11-34 Nm and 10-117 Nm;
* **release**: a load error beyond `release_error` (a new load torque, a
  knock) returns the flank to the continuous law;
* **quiet estimates**: while latched the drive observer runs on gains of
  lower intensities (`ctrl_lpv.twomass.servo_sampled.SampledServo.M_rest`):
  the parked motor moves with the speed estimates' noise, and a parked
  motor that jitters at 6e-3 rad/s kicks a load drifting onto it at 2e-4
  rad/s back at 1.4e-3.

While latched the rest loop is not the certified linear loop; the latch
engages only with ``|Td_hat| < latch_torque``, which the rest certificate's
load-torque floor excludes (`ctrl_lpv.twomass.servo_rest`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .gap_crossing import CROSSING_ACCEL, crossing_duration, crossing_offset

__all__ = ["RestFlank", "rest_flank_step", "flank_offset", "flip_duration"]


@dataclass(frozen=True)
class RestFlank:
    """Thresholds of the latched flank at rest (see the module docstring).

    Attributes
    ----------
    latch_error, latch_speed, latch_torque : float
        Latch when ``|e_l| <`` this (rad), ``|omega_l - v_r| <`` this
        (rad/s) and ``|Td_hat| <`` this (Nm) ...
    latch_flank : float
        ... and the continuous law's flank offset is beyond this share of
        the half-gap (the motor already on its way to that flank).
    release_error : float
        Release when ``|e_l| >`` this, rad.
    flip_torque, flip_evidence : float
        The CUSUM's drift, Nm, and threshold, Nm s.
    clearance : float
        The motor parks this short of the latched flank, rad.
    band : float
        Load error, rad, below which the load-position feedback is faded
        out while latched (back in full at twice this).
    band_torque : float
        ... and while the integral holds less than this load torque, Nm (a
        load held on its flank keeps the integral that holds it).
    crossing_accel : float
        Peak motor acceleration of a flip's crossing of the gap, rad/s^2
        (12: 4.8 Nm of motor torque at the peak, 0.17 s across the 0.06 rad
        gap of alpha = 0.03; 0 crosses by a step). The torque standard
        deviation of a flip over a second goes as ``accel^(3/4)``: at 50 a
        flip in the last second was 4-5 Nm of it alone, at 12 about 1.5;
        slower (8: a 22-38 Nm run in each of three 30-run sets at Td = 0)
        the motor arrives after the load it is to catch.
    arrival_share : float
        A flip towards a load that comes at the new flank crosses faster
        than `crossing_accel` where the slow crossing would arrive after
        the load: in this share of the load's time to where it meets the
        parked motor (`flip_duration`). On the 8 random moves at Td = 0 with
        the largest rest peaks (1 ms, encoders): at 0.8 the load met a
        motor just parked and bounced, flip after flip, on all 8 (18-27
        flank changes, 4.3-14 Nm of torque standard deviation in the last
        second); at 0.25 three crossings peaked at 181-500 Nm again.
    catch_accel : float
        The fastest crossing's peak acceleration, rad/s^2, for a load
        already where it meets the new flank (625: 250 Nm at the peak, 33
        ms across the parked gap of alpha = 0.06).
    lean_torque, lean_time : float
        Load torque estimate, Nm, filtered over `lean_time` s, on the latched
        flank's side beyond which the load leans on that flank: the
        integral runs (weight 1 from twice this; the observer's estimate on
        encoders is 0.1 Nm noisy per sample at 1 ms; unfiltered, it crossed
        0.4 Nm often enough at Td = 0 to change the rest).
    """

    latch_error: float = 3e-4
    latch_speed: float = 3e-3
    latch_torque: float = 2.0
    latch_flank: float = 0.9
    release_error: float = 1e-3
    flip_torque: float = 0.5
    flip_evidence: float = 0.02
    clearance: float = 1e-3
    band: float = 1e-4
    band_torque: float = 5.0
    lean_torque: float = 0.2
    lean_time: float = 0.2
    crossing_accel: float = 12.0
    arrival_share: float = 0.5
    catch_accel: float = CROSSING_ACCEL


def rest_flank_step(
    f: RestFlank,
    dt: float,
    side: float,
    evidence: float,
    *,
    resting: bool,
    error: float,
    speed: float,
    load_torque: float,
    tstar: float,
    psi: float,
    pressed: bool = False,
) -> tuple[float, float]:
    """One sample of the latch: the new ``(side, evidence)``.

    ``side`` is 0 (not latched: the continuous flank choice) or +-1 (the
    latched flank, the sign of the shaft torque it transmits); ``evidence``
    is the CUSUM statistic of a flip; ``tstar`` the shaft torque the rest
    needs (the law's asked shaft torque and the load torque estimate) and
    ``psi`` the continuous law's flank offset (-1 to 1) for it; ``pressed``
    whether the shaft carries torque on the latched flank (its estimate
    beyond the contact torque on that side): the latch holds then, no flip
    test and no release.
    """
    if not resting:
        return 0.0, 0.0
    if pressed:
        return side, evidence
    if side != 0.0 and abs(error) > f.release_error:
        return 0.0, 0.0
    if side == 0.0:
        # Latch on the flank the motor is already turning to (the
        # continuous offset psi beyond latch_flank): no jump of the motor
        # reference, no slam. At rest at the origin psi = 0: no side.
        if (
            abs(psi) >= f.latch_flank
            and abs(error) < f.latch_error
            and abs(speed) < f.latch_speed
            and abs(load_torque) < f.latch_torque
        ):
            return math.copysign(1.0, psi), 0.0
        return 0.0, 0.0
    evidence = max(0.0, evidence + dt * (-side * tstar - f.flip_torque))
    if evidence > f.flip_evidence:
        return -side, 0.0
    return side, evidence


def flip_duration(
    f: RestFlank,
    gap: float,
    side: float,
    *,
    error: float,
    speed: float,
    accel: float = 0.0,
) -> float:
    """The duration of a flip's crossing of `gap`, rad, to the flank `side`.

    The slow crossing (peak acceleration `RestFlank.crossing_accel`), unless
    the load (load error `error`, rad; speed `speed`, rad/s; acceleration
    `accel`, rad/s^2, the load torque's in the gap, where it speeds the load
    towards the flank) comes at the new flank: it meets the parked motor
    `clearance` past the target, and the crossing then ends within
    `arrival_share` of the load's time to there, at most as fast as
    `catch_accel`.
    """
    slow = crossing_duration(gap, f.crossing_accel)
    # Only an acceleration towards the flank counts: a load torque estimate
    # that says the load will slow down (at Td 0, 0.24 Nm of the
    # estimate's noise at Jl x0.8) delayed a crossing that the load then
    # met (thrown back at 3.8e-2 rad/s); one that says it comes faster at
    # worst crosses early.
    toward, pulled = -side * speed, max(0.0, -side * accel)
    if toward <= 0.0 and pulled == 0.0:
        return slow  # the load does not come
    fastest = crossing_duration(gap, f.catch_accel)
    distance = f.clearance + side * error
    if distance <= 0.0:
        # Where it meets the parked motor already: coming, or turning back.
        return fastest if toward >= 0.0 else slow
    # The time the load covers `distance`, ``toward t + pulled t^2 / 2``
    # (the stable form of the positive root).
    arrival = 2.0 * distance / (toward + math.sqrt(toward**2 + 2.0 * pulled * distance))
    return min(slow, max(fastest, f.arrival_share * arrival))


def flank_offset(
    f: RestFlank,
    dt: float,
    side: float,
    previous: float,
    crossing: tuple[float, float],
    *,
    alpha_hat: float,
    error: float,
    speed: float,
    accel: float = 0.0,
) -> tuple[float, float, float, tuple[float, float]]:
    """The latched flank offset: ``(psi, dpsi/dt, d2psi/dt2, crossing)``.

    The motor parks `clearance` short of the latched flank ``side``; a flip
    (`previous` the other side) starts a crossing of the gap from the old
    parking point, of the duration `flip_duration` gives for the load's
    error `error`, speed `speed` and acceleration `accel` (rad, rad/s,
    rad/s^2). `crossing` is ``(left, duration)``: the seconds the crossing
    under way has to run (0 when parked) and its duration, returned for the
    next sample; `alpha_hat` the half-gap estimate.
    """
    park = max(0.0, 1.0 - f.clearance / alpha_hat)
    gap = 2.0 * alpha_hat * park
    if f.crossing_accel <= 0.0 or gap <= 0.0:
        return side * park, 0.0, 0.0, (0.0, 0.0)
    left, duration = crossing
    if previous == -side:
        duration = flip_duration(
            f, gap, side, error=error, speed=speed, accel=accel
        )  # fmt: skip
        left = duration
    if left <= 0.0:
        return side * park, 0.0, 0.0, (0.0, 0.0)
    psi, dpsi, ddpsi = crossing_offset(-side, [left - 0.5 * duration], duration)
    return park * psi, park * dpsi, park * ddpsi, (max(0.0, left - dt), duration)
