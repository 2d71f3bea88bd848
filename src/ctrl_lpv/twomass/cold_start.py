"""The load torque the sampled servo does not know when it starts.

The servo on encoders starts with every state at zero: the drive
observer's load torque and the integral that holds the load torque at rest.
A first move from the origin under a load torque therefore runs on the
load-position feedback alone: with the integral held in moves, 8 Nm along
a 0.05 rad step left the load 0.9 mrad ahead of the plan through the move,
and the observer, whose load torque learns slowly and whose correction
while the plan accelerates goes to the inertia estimate
(`ctrl_lpv.twomass.inertia`), had 3 of the 8 Nm at the gap crossing that
brakes the load (2.5-3.2 % overshoot on six noise seeds, 1 ms, encoders;
``docs/servo.rst``, "The first move from mid-gap").

Three things fix what the start does not know:

* **the load's fall measures it.** While the load is free in the gap its
  motion is the load torque's alone, ``Jl d(omega_l)/dt = -cl omega_l -
  Td``, read by the load encoder. `ColdStart.correct` fits an offset of the
  observer's load torque to that encoder's readings there (not the
  motor's: no torque crosses the gap to the motor, and where a contact is
  made and not yet read the motor's reading carries the impact), a scalar
  Kalman filter from a prior of `ColdStart.prior` along the sensitivity of
  the observer's predicted state to the offset (through the observer's
  model and its own correction, as `ctrl_lpv.twomass.inertia` does for its
  fit). Only in the gap (the observer's contact weight 0) and while the
  motor reading agrees with the free motor (`ColdStart.contact_reading`: a
  gap narrower than its estimate is met before the twist estimate gets
  there). Unless its estimate is beyond `ColdStart.edge_significance` of
  its standard deviations the fall ends where the contact is read, not
  where the half-gap estimate puts the flank: the first estimate is
  ``alpha_max / 2``, and a wider gap ended the fit there, 15 ms into a 39
  ms fall (alpha 0.06, Td -3 Nm, 1 ms: -1.7 +- 1.9 Nm, not joined). A
  strong estimate ends it at that flank and joins there (joined at the
  contact, a 30 Nm fall left the load too far ahead for the restart below:
  10.1 % over at alpha 0.06, 0.3-0.6 % ending at the flank). A contact is
  read one or two samples after it is made, and those samples move the
  load's reading too (Td 0.5 read as 1.7 Nm before them, 3.5 after): a
  fall ended by a contact joins its estimate as it was two samples before.
  While it runs the observer reads a contact only beyond
  `ColdStart.contact_margin` times the contact torque (`ColdStart.falling`):
  its shaft-torque estimate wanders in the gap by up to the contact
  torque, and a contact read on that ran away, the contact model's shaft
  torque growing with the motor's speed across the gap (10-15 Nm read for
  the 25 ms before the load was met). The fit runs over the first fall
  only; when it is over its estimate joins the observer's if beyond
  `ColdStart.significance` of its standard deviations and the contact
  torque (`ColdStart.least_torque`). Its error is as its variance says
  (alpha 0.03, 1 ms, 40 seeds: standard deviation 1.20-1.27 Nm, 1.29
  claimed, mean +0.06 to +0.16 Nm at Td 0-1 Nm): 1 of 160 first moves
  without load torque joins one (20 before the three fixes of this
  paragraph), 8 Nm joins on 40 of 40, 3 Nm at alpha 0.03 on 7 of 40 (its
  fall tells it from none at 2.3 deviations). After it the
  observer's certified gains go on alone: a load torque that changes later
  is theirs;
* **the integral holds the estimate until a rest has taught it.** Once
  the fall's estimate has joined, in a move the way that load torque
  pushes the law's integral holds the observer's load torque
  (`ctrl_lpv.twomass.servo_sampled.integral_holding`, as on the motor
  encoder alone), handed back to the integral over `ColdStart.memory`
  seconds of rest. Not in a move against it (the load then lags the plan,
  which the rest at the end takes up; holding the estimate there ended
  0.05 rad moves at alpha 0.06 1.0-1.6 % past, against 0.04-0.8 %), nor
  after a rest: holding the observer's estimate in every move read a
  heavier or lighter load's inertia error as load torque (the small moves
  from rest of ``tests/test_servo_inertia.py``, Jl x0.8 and x1.2: 24 runs
  of 108 missed the targets against 18).

* **the move starts again from the fallen load.** Where the fall's
  estimate joins in a move the way the load torque pushes, the plan made
  at the start without it is behind the falling load (Td 30, alpha 0.06,
  -0.05 rad: 0.9 mrad and 0.09 rad/s at the join) and asks to accelerate it
  faster than the fall does: the planned crossings then keep the motor on
  the accelerating flank and cross to the holding one late (contact 11.7
  mrad before the target at 0.62 rad/s, 5.9 % over). `ColdStart.restart`
  plans the rest of the move from the load's estimated state with the
  shaft torque on the holding flank throughout, when that lengthens the
  move by at most `ColdStart.restart_slack`; and while the holding flank is
  asked and not reached, the motor at the flank the half-gap estimate puts
  it, that estimate takes the gap up at `ColdStart.take_up_rate`
  (`ColdStart.take_up`): the start's estimate holds the motor short of a
  wider gap (30 of 60 mrad) while the load falls.

None is covered by a certificate: the fit is a transient of the first
fall, the hand-over and the restart transients of the first move; the rest
certificate (`ctrl_lpv.twomass.servo_rest`) covers the loop after them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .drive_observer import DRIVE_STATES, _encoder_steps
from .gap_crossing import one_flank_duration
from .servo_kernel import _smoothstep

__all__ = ["ColdStart", "cold_start", "COLD_START_STATES"]

_TD = DRIVE_STATES.index("Td")
#: The take-up runs in full with the motor at the flank the half-gap
#: estimate puts it, fading to none this far (rad) short of it.
_TAKE_UP_REACH = 2e-3
#: Shaft torque, Nm, a restarted plan may ask of the other flank (the
#: encoders' noise in the shaft-torque estimate is 0.2-0.3 Nm).
_HOLDING_TOLERANCE = 0.5

#: The states in the sampled controller: the sensitivity of the observer's
#: predicted state to the load-torque offset (less its start, the unit
#: offset of ``Td``), the offset's variance (less its prior), its estimate
#: not yet joined to the observer's, whether the first fall is over, the
#: variance and estimate as they were one and two samples before, and the
#: share of the joined load torque that the integral does not hold yet (1
#: when it joins, decaying at rest).
COLD_START_STATES = [f"S_fall_{name}" for name in DRIVE_STATES] + [
    "P_fall_dev",
    "Td_fall",
    "fall_over",
    "P_fall_dev_1",
    "Td_fall_1",
    "P_fall_dev_2",
    "Td_fall_2",
    "torque_unheld",
]


@dataclass(frozen=True)
class ColdStart:
    """The load torque at a cold start (see the module docstring).

    Attributes
    ----------
    reading_variance : tuple of float
        Variance, rad^2, of each encoder angle's reading against the
        model, in the order the servo reads them.
    prior : float
        Standard deviation, Nm, of the load torque when the servo starts.
    margin : float
        Once its estimate is beyond `edge_significance` (or without a motor
        reading), the fit runs with the twist estimate at least ``2
        margin`` of the half-gap estimate short of a flank, in full, fading
        out to none at ``margin`` short of it: a contact made between two
        samples would read as a load torque. Before, the fall runs on to
        the contact.
    contact_margin : float
        While the first fall runs, the drive observer reads a contact from
        this multiple of the contact torque (`falling`).
    memory : float
        Time constant, s, at rest of the integral taking the joined load
        torque over from the observer's estimate.
    significance : float
        When the fall is over the fit's estimate joins the observer's if
        beyond this many of its standard deviations (2.5: the estimate's
        error is its standard deviation's, 1.2-1.3 Nm after a fall at alpha
        0.03, 1 ms; at 2 falls without load torque joined 8 of 160 times,
        1.2-3.8 Nm, and a light load's rest after such a join hunts; at 3 the
        2 ms first moves at alpha 0.06 under 3 Nm lost their join, and 4 of
        6 seeds settled in 0.30-0.31 s, 0.17 s joined),
    edge_significance : float
        beyond this many (4), the estimate ends the fall at the half-gap
        estimate's flank: tested at every sample, at 2 the noise alone
        ended falls there, the estimate at its peak (Td 0, alpha 0.03, +0.5
        rad, 40 seeds, the fit then reading the motor too: 5 joined,
        2.5-4.0 Nm),
    least_torque : float
        and beyond this, Nm (the servo's contact torque): a smaller load
        torque is the rest's to learn. Told by a fall that ran on to the
        contact, 0.38 Nm read as 1.17 (1.5 of its standard deviations off)
        joined, and the rest after the move relayed at 75 Nm.
    restart_slack : float
        Longest, s, by which `restart` may lengthen the move (the Td 30
        first 0.05 rad move at alpha 0.06 needs 28 ms more, and 0.02 left
        it 5.9 % over on seed 1; a 0.05 rad step along 8 Nm would need
        0.25 s more, and keeps its plan: restarted, such steps settled in
        0.34-0.46 s).
    take_up_rate : float
        Rate, rad/s, at which `take_up` widens the half-gap estimate.
    contact_reading : float
        The fall is over where the motor encoder's reading departs from its
        prediction by more than this, rad (`cold_start`: eight counts, 5e-5
        rad on 20 bits): in the gap the motor is free and its prediction
        exact to the reading's noise (at most 1.8e-5 rad in a fall at 1 ms,
        20 bits), and a shaft torque of 10 Nm over a 2 ms sample moves it by
        5e-5 rad. The twist estimate alone ends the fall only at
        the half-gap estimate: a gap narrower than that (the first estimate
        is ``alpha_max / 2``) was met while the fit ran, and the fit read the
        motor's push as a load torque (2 ms, half-gap 0.005, Td 1 Nm, +0.05
        rad: +65 Nm, the move 16 % over).
    motor_reading : int or None
        Index of the motor encoder among the readings (None: not read, no
        `contact_reading` test).
    """

    reading_variance: tuple
    prior: float = 10.0
    margin: float = 0.2
    contact_margin: float = 2.0
    memory: float = 0.1
    significance: float = 2.5
    edge_significance: float = 4.0
    least_torque: float = 1.5
    restart_slack: float = 0.05
    take_up_rate: float = 1.0
    contact_reading: float = 5e-5
    motor_reading: int | None = None

    def initial(self) -> np.ndarray:
        """The states (`COLD_START_STATES`) when the servo starts."""
        return np.zeros(len(COLD_START_STATES))

    def correct(
        self, predicted, filtered, states, innovation, gain, rows, Phi, *,
        contact, alpha_hat,
    ):  # fmt: skip
        """The filtered estimate with the load-torque fit's step, and the
        fit's states for the next sample.

        Parameters
        ----------
        predicted, filtered : ndarray
            The drive observer's state (`DRIVE_STATES`) predicted for this
            sample and corrected with its readings.
        states : array_like
            This object's states (`COLD_START_STATES`).
        innovation : ndarray
            The readings less their prediction.
        gain : ndarray
            The observer's filter gain of this sample.
        rows : list of int
            The states the encoders read (`DRIVE_STATES` indices).
        Phi : ndarray
            The observer's sampled model over the sample.
        contact : float
            The observer's contact weight in ``[0, 1]``.
        alpha_hat : float
            The half-gap estimate, rad.

        Returns
        -------
        filtered : ndarray
        states : ndarray
            The states for the next sample (``torque_unheld`` 1 where the
            estimate joins, else as it was: `hand_over` moves it).
        """
        states = np.asarray(states, float)
        n = len(DRIVE_STATES)
        sens = states[:n].copy()
        sens[_TD] += 1.0
        P, pending, over = self.prior**2 + states[n], states[n + 1], states[n + 2]
        H = sens[rows]
        sens = sens - gain @ H
        # The estimate now and a sample before: the next sample's one and
        # two samples back.
        history = [P - self.prior**2, pending, *states[n + 3 : n + 5]]
        weight = (1.0 - over) * (1.0 - contact)
        if self.motor_reading is None or self._told(pending, P, self.edge_significance):
            # Short of the flank the half-gap estimate puts: a contact made
            # between two samples would read as a load torque. A fall that
            # has not told its load torque yet runs on to the contact the
            # motor reading tells (a gap wider than the first estimate).
            twist = abs(predicted[0] - predicted[3])
            edge = (1.0 - self.margin) * alpha_hat
            weight *= _smoothstep((edge - twist) / (self.margin * alpha_hat))
        read = self._contact_read(innovation)
        met = contact > 0.0 or read
        if read:
            # The motor reading breaks with the free motor: a contact the
            # half-gap estimate does not predict (a gap narrower than it).
            weight = 0.0
        if weight > 0.0:
            # The fall is the load's: its encoder alone reads it. No torque
            # crosses the gap to the motor, and in the samples in which the
            # contact is made and not yet read the motor's reading carries
            # the impact (read too, it biased the estimate by +0.5-0.9 Nm at
            # alpha 0.03, Td 0-3 Nm, 40 seeds; docs/servo.rst).
            fall = [i for i in range(len(rows)) if i != self.motor_reading]
            Hf = H[fall]
            variance = np.asarray(self.reading_variance, float)[fall]
            # The offset's gain from readings weighted by `weight` (1/weight
            # times as noisy), written without dividing by a vanishing one.
            spread = weight * P * np.outer(Hf, Hf) + np.diag(variance)
            K = weight * P * np.linalg.solve(spread, Hf)
            pending += K @ (innovation[fall] - Hf * pending)
            P -= P * (K @ Hf)
        # Once the fall is over, and only what tells a load torque from
        # none: a fall of 20 ms is too short for one of 1 Nm, whose estimate
        # then took the sign of the noise (-1.2 Nm; the crossing at the end
        # of the move planned on the wrong flank), and an estimate joined at
        # its first significant sample is biased by the noise that made it.
        unheld = states[-1]
        if weight == 0.0 and not over and P < self.prior**2:
            over = 1.0
            if met:
                # Ended by a contact, read one or two samples after it was
                # made: the estimate joins as it was before it.
                P, pending = self.prior**2 + states[n + 5], states[n + 6]
            if self._told(pending, P):
                filtered = filtered + sens * pending
                pending = 0.0
                unheld = 1.0
        sens = np.asarray(Phi) @ sens
        sens[_TD] -= 1.0
        return filtered, np.array(
            [*sens, P - self.prior**2, pending, over, *history, unheld]
        )

    def falling(self, states, innovation) -> bool:
        """Whether the first fall runs on: not over, and the motor reading
        (`innovation`, the readings less their prediction) with the free
        motor. The drive observer then reads a contact from
        `contact_margin` times the contact torque."""
        over = states[len(DRIVE_STATES) + 2]
        return not over and not self._contact_read(innovation)

    def _told(self, estimate, variance, significance=None) -> bool:
        """Whether the fall's `estimate` tells a load torque: beyond
        `significance` (default `ColdStart.significance`) of its standard
        deviations and `least_torque`."""
        if significance is None:
            significance = self.significance
        return (
            estimate * estimate > significance**2 * variance
            and abs(estimate) > self.least_torque
        )

    def _contact_read(self, innovation) -> bool:
        motor = self.motor_reading
        return motor is not None and abs(innovation[motor]) > self.contact_reading

    def restart(self, plan, unheld_before, unheld, load, load_torque, Jl, cl):
        """The plan, restarted from the load where the fall's estimate joins.

        Parameters
        ----------
        plan : list of float
            ``[r, v_r, a_r, j_r, goal, time_to_go]`` (the sampled servo's).
        unheld_before, unheld : float
            ``torque_unheld`` at the last sample and now (it is 0 until the
            estimate joins, 1 at the join).
        load : tuple of float
            The load's estimated angle and speed, rad and rad/s.
        load_torque, Jl, cl : float
            The load torque estimate, Nm, and the load's inertia and
            friction.

        Returns
        -------
        list of float
            `plan` itself but at the join in a move the way the load torque
            pushes, where the rest of the move from the load's state, its
            acceleration the fall's, keeps the shaft torque on the holding
            flank in at most `restart_slack` more than the time to go.
        """
        time_to_go = plan[5]
        if not (unheld_before == 0.0 < unheld and time_to_go > 0.0):
            return plan
        if plan[1] * load_torque >= 0.0:
            return plan
        theta, omega = load
        fall = -(load_torque + cl * omega) / Jl
        # On the holding flank: ``Jl a + cl v`` may brake by the load torque
        # and the tolerance.
        longest = time_to_go + self.restart_slack
        duration = one_flank_duration(
            (theta, omega, fall, 0.0), plan[4], time_to_go, Jl, cl,
            math.copysign(1.0, load_torque), abs(load_torque) + _HOLDING_TOLERANCE,
            longest,
        )  # fmt: skip
        if duration >= longest:
            return plan
        return [theta, omega, fall, 0.0, plan[4], duration]

    def take_up(self, unheld, state, shaft_torque, alpha_hat, contact, tc):
        """Rate, rad/s, of the half-gap estimate's take-up of the gap.

        While the fall's load torque is not yet held by the integral
        (`unheld`, its share), the shaft torque asked, `shaft_torque`, is
        on the flank that holds the load torque (beyond the contact torque
        `tc`), the observer reads no contact (`contact`, its weight) and
        the motor is at the flank the half-gap estimate `alpha_hat` puts it
        (the twist estimate of `state`, `DRIVE_STATES`, within 2 mrad of
        it): the gap is wider than the estimate.
        """
        load_torque = state[_TD]
        if load_torque * shaft_torque <= 0.0 or abs(load_torque) <= tc:
            return 0.0
        twist = math.copysign(1.0, shaft_torque) * (state[0] - state[3])
        there = _smoothstep((twist - alpha_hat) / _TAKE_UP_REACH + 1.0)
        return self.take_up_rate * unheld * (1.0 - contact) * there

    def hand_over(self, unheld: float, resting: bool, dt: float) -> float:
        """How much of the load torque the fall measured the integral does
        not hold yet, a sample of `dt` on: falling to 0 at rest over
        `memory`, held in moves."""
        if not resting:
            return unheld
        return unheld * (1.0 - min(1.0, dt / self.memory))


def cold_start(encoder_counts, measured=("theta_m", "theta_l")) -> ColdStart:
    """The `ColdStart` of encoders with `encoder_counts` (motor, load) per
    revolution, of which `measured` are read: a reading's variance of a
    third of a count squared (its quantization, a twelfth, and half a count
    of noise), and a contact read beyond eight motor counts."""
    motor, load = _encoder_steps(encoder_counts)
    steps = {"theta_m": motor, "theta_l": load}
    return ColdStart(
        reading_variance=tuple(steps[name] ** 2 / 3.0 for name in measured),
        contact_reading=8.0 * motor,
        motor_reading=measured.index("theta_m") if "theta_m" in measured else None,
    )
