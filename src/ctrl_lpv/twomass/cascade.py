"""The cascade P/PI position control a drive engineer would tune: the reference row.

Industrial position drives run cascaded loops (Schroeder, *Elektrische
Antriebe - Regelung von Antriebssystemen*, Springer, ch. on cascade
control; Ellis, *Control System Design Guide*, 4th ed., 2012, chs. on
velocity and position loops): an inner motor-speed PI loop on a speed
computed from the motor encoder, and an outer position P loop, here on the
load encoder (dual-encoder feedback), both with the trajectory's speed and
torque feedforward. `cascade_design` builds that controller for the
two-mass drive with the sampled servo's trajectory, feedforward, sample
time, delay and encoders, so that the comparison with the servo is on equal
terms; only the feedback differs.

Per sample ``t_k`` the controller reads ``theta_m``, ``theta_l`` and the
target ``theta_r`` and computes

* the planned move and its flat feedforward, as the servo's
  (`ctrl_lpv.twomass.servo_sampled.plan_stepper`, `flat_feedforward`),
  the shaft's damper and the torque's hold left out as a drive's model
  does: the load reference ``r``, the motor speed ``omega_ff`` and the
  torque ``T_ff``;
* the motor speed by filtered differencing, as drives do:
  ``omega_raw = (theta_m[k] - theta_m[k-1]) / dt`` through a first-order
  low-pass of time constant ``filter_time``;
* the speed command ``omega* = omega_ff + Kp (r - theta_l)``;
* the torque ``Tm = T_ff + Kv (e_w + xi / Ti)``, ``e_w = omega* -
  omega_hat``, ``xi`` the integral of ``e_w`` (held while the command
  saturates in the direction of ``e_w``: anti-windup), clipped at the
  torque limit.

The tuning rule (`cascade_design`): bandwidth separation with the
symmetric optimum (Kessler, "Das symmetrische Optimum", Regelungstechnik 6,
1958) for the speed loop.

1. The small time constants of the speed loop add up to ``T_sigma =
   (delay + 1/2) dt + dt / 2 + filter_time`` (computation delay, the hold,
   the differencing, the filter).
2. Speed P gain from the motor inertia: ``Kv = Jm / (a T_sigma)``, the
   symmetric optimum's gain for the plant ``1 / (Jm s)`` the loop sees
   above the shaft resonance (``a = 2``), speed-loop crossover
   ``1 / (a T_sigma)``. On this drive (``Jl / Jm = 14``) that gain also
   damps the shaft resonance: the motor acts as a damper on it.
3. Below the antiresonance the motor drags the load: the loop sees ``1 /
   ((Jm + Jl) s)`` and crosses over at ``w_low = Kv / (Jm + Jl)``. The
   integral time follows the symmetric optimum on that crossover, ``Ti =
   a^2 / w_low`` (the symmetric optimum's ``a^2 T_sigma`` for the motor
   inertia alone is 15 times too fast here and destabilises the load), and
4. the position loop is a factor ``position_ratio`` (default 4) slower
   than the speed loop that moves the load: ``Kp = w_low / position_ratio``.

With the servo's 1 ms, one sample of delay and a 1 ms filter: ``Kv = 66.7``
Nm s/rad, ``Ti = 0.36`` s, ``Kp = 2.8`` 1/s. The position gain is what the
shaft allows: the load's antiresonance ``sqrt(ks / Jl) = 24`` rad/s is
barely damped by the shaft (``cs = 2``), and a load-position loop at the
usual quarter of the speed loop's motor-side bandwidth (42 1/s) is unstable
(the test checks both facts on the linear loop).
"""

from __future__ import annotations

from dataclasses import dataclass

import control as ct
import numpy as np

from .._checks import real_number
from .parameters import Parameters
from .servo_kernel import ServoTuning
from .servo_sampled import flat_feedforward, law_system, plan_snap, plan_stepper

__all__ = ["CascadeDesign", "cascade_design", "CASCADE_STATES"]

CASCADE_STATES = [
    "r", "v_r", "a_r", "j_r", "goal", "time_to_go",
    "theta_m_prev", "omega_m_hat", "int_e_w",
]  # fmt: skip


@dataclass(frozen=True)
class CascadeDesign:
    """A sampled cascade P/PI position controller and its tuning.

    Attributes
    ----------
    params : `Parameters`
        Drive data of the tuning.
    torque_limit : float
        The controller's output limit, Nm.
    dt : float
        Sample time, s.
    delay : int
        Samples between reading the encoders and the command acting.
    encoder_counts : (int, int)
        Counts per revolution of the motor and load encoders.
    tuning : `ServoTuning`
        The servo's planner and feedforward numbers (shared trajectory).
    position_gain : float
        ``Kp``, load-position P gain, 1/s.
    speed_gain : float
        ``Kv``, motor-speed P gain, Nm s/rad.
    integral_time : float
        ``Ti``, s.
    filter_time : float
        Time constant of the speed filter, s.
    small_time : float
        ``T_sigma``, the sum of the speed loop's small time constants, s.
    """

    params: Parameters
    torque_limit: float
    dt: float
    delay: int
    encoder_counts: tuple
    tuning: ServoTuning
    position_gain: float
    speed_gain: float
    integral_time: float
    filter_time: float
    small_time: float

    def controller(self, name: str = "cascade") -> ct.NonlinearIOSystem:
        """The cascade as a discrete-time python-control system.

        Parameters
        ----------
        name : str, optional
            System name (default ``"cascade"``).

        Returns
        -------
        `control.NonlinearIOSystem`
            ``dt`` of the design; inputs ``["theta_m", "theta_l",
            "theta_r"]`` (encoder angles and target), output ``["Tm"]``
            within the torque limit (acting ``delay`` samples later),
            states `CASCADE_STATES`, all zero at rest at the origin.
        """
        if not isinstance(name, str):
            raise TypeError(f"name: expected a string, got {type(name).__name__}")
        return _cascade_system(self, name)


def cascade_design(
    servo,
    *,
    filter_time: float | None = None,
    position_ratio: float = 4.0,
    symmetry: float = 2.0,
) -> CascadeDesign:
    """Tune the cascade P/PI reference for a sampled servo design.

    The cascade takes the servo's drive data, torque limit, sample time,
    delay, encoders, planner and feedforward; its gains follow the rule of
    the module notes (symmetric optimum on the motor inertia for the speed
    P gain, on the whole drive for the integral, position loop a factor
    `position_ratio` slower).

    Parameters
    ----------
    servo : `ServoDesign`
        A sampled design (``servo_design(dt=..., sensors="encoders")``,
        ``reference="plan"``).
    filter_time : float, optional
        Time constant of the speed filter, s (default one sample).
    position_ratio : float, optional
        Speed-loop crossover over position gain (default 4; the rule of
        thumb is 3-5).
    symmetry : float, optional
        The symmetric optimum's ``a`` (default 2: a phase margin of about
        37 degrees).

    Returns
    -------
    `CascadeDesign`

    Raises
    ------
    TypeError
        For a `servo` that is not a `ServoDesign`.
    ValueError
        For a continuous-time or streamed servo design, or non-positive
        settings (named).
    """
    from .servo import ServoDesign

    if not isinstance(servo, ServoDesign):
        raise TypeError(f"servo: expected a ServoDesign, got {type(servo)!r}")
    if servo.dt is None or servo.reference != "plan":
        raise ValueError(
            "servo: expected a sampled design with reference='plan' "
            "(servo_design(dt=..., sensors='encoders'))"
        )
    dt = servo.dt
    filter_time = dt if filter_time is None else filter_time
    filter_time = real_number(filter_time, "filter_time", minimum=0.0)
    position_ratio = real_number(position_ratio, "position_ratio", positive=True)
    symmetry = real_number(symmetry, "symmetry", positive=True)
    if symmetry <= 1.0:
        raise ValueError(f"symmetry: expected a > 1, got {symmetry:g}")
    p = servo.params
    small = (servo.delay + 0.5) * dt + 0.5 * dt + filter_time
    speed_gain = p.Jm / (symmetry * small)
    low = speed_gain / (p.Jm + p.Jl)
    return CascadeDesign(
        params=p, torque_limit=servo.torque_limit, dt=dt, delay=servo.delay,
        encoder_counts=tuple(servo.encoder_counts), tuning=servo.tuning,
        position_gain=low / position_ratio, speed_gain=speed_gain,
        integral_time=symmetry**2 / low, filter_time=filter_time, small_time=small,
    )  # fmt: skip


def _cascade_system(d: CascadeDesign, name: str) -> ct.NonlinearIOSystem:
    c, dt, limit = d.tuning, d.dt, d.torque_limit
    kp, kv, ti = d.position_gain, d.speed_gain, d.integral_time
    smoothing = dt / (d.filter_time + dt)  # backward-Euler first-order filter
    plan_step = plan_stepper(c, dt)

    def law(x, y):
        plan = list(x[0:6])
        previous, speed, xi = x[6], x[7], x[8]
        theta_m, theta_l, target = (float(v) for v in y)
        r, v, a, j, g, h = plan
        _, _, speed_ff, torque_ff = flat_feedforward(
            c, v, a, j, plan_snap(*plan), damped=False
        )
        speed = speed + smoothing * ((theta_m - previous) / dt - speed)
        error = speed_ff + kp * (r - theta_l) - speed
        raw = torque_ff + kv * (error + xi / ti)
        u = min(max(raw, -limit), limit)
        # Anti-windup: hold the integral while the output saturates with it.
        winding = (raw > limit and error > 0.0) or (raw < -limit and error < 0.0)
        state = [*plan_step(plan, target), theta_m, speed,
                 xi if winding else xi + dt * error]  # fmt: skip
        return u, np.asarray(state)

    return law_system(law, ["theta_m", "theta_l", "theta_r"], CASCADE_STATES, dt, name)
