"""Rest-to-rest minimum-snap moves, planned online in feedback form.

A move of the load from rest to rest over a distance ``d`` in a time ``D``
that minimises the integral of the squared snap (fourth derivative) is the
seventh-order polynomial

.. math::

    r(t) = r_0 + d\\,\\phi(t/D), \\qquad
    \\phi(s) = 35 s^4 - 84 s^5 + 70 s^6 - 20 s^7,

with velocity, acceleration and jerk zero at both ends and a bounded snap,
so that the flat feedforward of the elastic two-mass drive (which needs the
snap) is bounded too.  Its peak acceleration is ``PEAK_ACCEL * d / D**2``
(`PEAK_ACCEL` = 7.513), hence the torque-feasible duration of `move_duration`.

The planner of the servo generates the same move as a chain of four
integrators ``r'''' = snap`` driven by the minimum-snap law that reaches
the goal at rest within the time-to-go ``h``::

    snap = -(840 (r - g) / h**4 + 480 v / h**3 + 120 a / h**2 + 16 j / h)

By the principle of optimality, the remainder of a minimum-snap move is the
minimum-snap move from the current state, so with ``dh/dt = -1`` this
feedback reproduces the polynomial exactly, from rest or from any moving
state (a re-plan when the target changes mid-move).  The time-to-go stops
at a floor ``h_min``; from there on the law is a fixed, well damped linear
filter (poles ``(-3.21 +- 4.77j) / h_min`` and ``(-4.79 +- 1.57j) /
h_min``) that finishes the last fraction of a per mille of the move.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "PLAN_GAINS",
    "PEAK_ACCEL",
    "move_duration",
    "replan_duration",
    "rest_to_rest",
    "planner_functions",
    "reference_generator",
]

#: Gains of the minimum-snap law on ``(r - g, v, a, j)``, to be divided by
#: ``h**4, h**3, h**2, h``.
PLAN_GAINS = (840.0, 480.0, 120.0, 16.0)

#: Peak of ``|phi''|`` on ``[0, 1]``: the peak acceleration of a move is
#: ``PEAK_ACCEL * distance / duration**2``.
PEAK_ACCEL = 7.5132065830912325


def move_duration(distance, accel_limit: float, min_duration: float = 0.0):
    """Shortest rest-to-rest minimum-snap move within an acceleration limit.

    Parameters
    ----------
    distance : float or array_like
        Move distance, rad (its sign does not matter).
    accel_limit : float
        Admissible peak acceleration of the load, rad/s^2 (> 0).
    min_duration : float, optional
        Floor of the duration, s.

    Returns
    -------
    float or ndarray
        ``max(min_duration, sqrt(PEAK_ACCEL |distance| / accel_limit))``.

    Raises
    ------
    ValueError
        If `accel_limit` is not positive or `min_duration` is negative.

    Examples
    --------
    >>> round(move_duration(0.5, 60.0), 4)
    0.2502
    """
    if not (np.isfinite(accel_limit) and accel_limit > 0):
        raise ValueError(f"accel_limit: must be a positive number, got {accel_limit}")
    if not (np.isfinite(min_duration) and min_duration >= 0):
        raise ValueError(f"min_duration: must be >= 0, got {min_duration}")
    d = np.sqrt(PEAK_ACCEL * np.abs(np.asarray(distance, float)) / accel_limit)
    d = np.maximum(d, min_duration)
    return float(d) if d.ndim == 0 else d


def replan_duration(
    distance: float, speed: float, accel_limit: float, min_duration: float
) -> float:
    """Duration of a move planned from a moving state, within the limit.

    The longest of `min_duration`, the torque-feasible duration of the
    distance to go from rest (`move_duration`), and ``3 |speed| /
    accel_limit`` (a mean deceleration of a third of the limit). The
    online planner and the sampled servo's planner both re-plan with it.
    The speed term is a heuristic, not a bound: the minimum-snap move
    that stops a speed ``v`` where it starts peaks at ``5.03 |v| / h``, so
    a reversal that re-plans at full speed brakes at up to 1.7 times
    `accel_limit` for a moment (the servo's torque limit clips it).

    Parameters
    ----------
    distance : float
        Distance to go, rad (its sign does not matter).
    speed : float
        Present planned speed, rad/s.
    accel_limit, min_duration : float
        As in `move_duration` (not checked here: called every sample).

    Returns
    -------
    float
        The duration, s.
    """
    ramp = math.sqrt(PEAK_ACCEL * abs(distance) / accel_limit)
    return max(min_duration, ramp, 3.0 * abs(speed) / accel_limit)


def rest_to_rest(t, distance: float, duration: float) -> np.ndarray:
    """The minimum-snap move and its derivatives at times `t`.

    Parameters
    ----------
    t : array_like
        Times from the start of the move, s (clipped to ``[0, duration]``).
    distance : float
        Move distance, rad.
    duration : float
        Move duration, s (> 0).

    Returns
    -------
    ndarray
        Shape ``(5, len(t))``: position, velocity, acceleration, jerk and
        snap.

    Examples
    --------
    >>> rest_to_rest([0.0, 0.5, 1.0], 2.0, 1.0)[0]
    array([0., 1., 2.])
    """
    if not (math.isfinite(duration) and duration > 0):
        raise ValueError(f"duration: must be positive, got {duration}")
    s = np.clip(np.asarray(t, float) / duration, 0.0, 1.0)
    c = np.array([0, 0, 0, 0, 35, -84, 70, -20], float)
    out = []
    for k in range(5):
        poly = np.polynomial.polynomial.Polynomial(c).deriv(k) if k else None
        coef = c if k == 0 else poly.coef
        out.append(distance * np.polynomial.polynomial.polyval(s, coef) / duration**k)
    return np.array(out)


def planner_functions(
    accel_limit: float,
    min_duration: float,
    horizon_floor: float,
    goal_rate: float = 2000.0,
    replan_rate: float = 1e4,
    goal_tolerance: float = 1e-6,
):
    """Scalar functions of the online planner (states ``r, v, a, j, g, h``).

    Parameters
    ----------
    accel_limit, min_duration : float
        As in `move_duration`.
    horizon_floor : float
        Floor ``h_min`` of the time-to-go, s.
    goal_rate : float, optional
        Rate (1/s) at which the goal memory ``g`` follows the target.
    replan_rate : float, optional
        Rate (1/s) at which the time-to-go is reset to the duration of the
        new move while the goal memory differs from the target by more than
        `goal_tolerance` (a smooth indicator of a new target).
    goal_tolerance : float, optional
        Target change, rad, that counts as a new target.

    Returns
    -------
    (callable, callable)
        ``snap(r, v, a, j, g, h)`` and ``rates(r, v, g, h, theta_r) -> (dg/dt,
        dh/dt)``.
    """
    p0, p1, p2, p3 = PLAN_GAINS
    hmin = horizon_floor
    kg, kh, geps = goal_rate, replan_rate, goal_tolerance
    alim, dmin = accel_limit, min_duration

    def snap(r, v, a, j, g, h):
        he = h if h > hmin else hmin
        return -(p0 * (r - g) / he**4 + p1 * v / he**3 + p2 * a / he**2 + p3 * j / he)

    def rates(r, v, g, h, target):
        q = (target - g) / geps
        ind = q * q / (1.0 + q * q)
        # Torque-feasible duration: the distance to go, and braking from the
        # present speed when the target changes mid-move.
        dreq = replan_duration(target - r, v, alim, dmin)
        s = (h - hmin) / (0.25 * hmin)
        s = 0.0 if s < 0.0 else (1.0 if s > 1.0 else s)
        return kg * (target - g), -s + kh * ind * (dreq - h)

    return snap, rates


def reference_generator(
    accel_limit: float,
    *,
    min_duration: float = 0.12,
    horizon_floor: float = 0.04,
    name: str = "planner",
):
    """The online planner alone, as an I/O system.

    Parameters
    ----------
    accel_limit : float
        Peak load acceleration of a move from rest, rad/s^2.
    min_duration : float, optional
        Shortest move, s.
    horizon_floor : float, optional
        Floor of the time-to-go, s.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        Input ``theta_r`` (the target), outputs ``["r", "v_r", "a_r",
        "j_r"]`` (the planned load angle and its derivatives), states
        ``["r", "v_r", "a_r", "j_r", "goal", "time_to_go"]``.
    """
    from ..interconnection import BlockKernel, kernel_nlsys

    move_duration(1.0, accel_limit, min_duration)  # validates the numbers
    snap, rates = planner_functions(accel_limit, min_duration, horizon_floor)

    def rhs(t, x, u):
        r, v, a, j, g, h = x
        dg, dh = rates(r, v, g, h, u[0])
        return (v, a, j, snap(r, v, a, j, g, h), dg, dh)

    def out(t, x, u):
        return tuple(x[:4])

    kernel = BlockKernel(out=out, rhs=rhs, state_outputs=(0, 1, 2, 3))
    return kernel_nlsys(
        kernel, inputs=["theta_r"], outputs=["r", "v_r", "a_r", "j_r"],
        states=["r", "v_r", "a_r", "j_r", "goal", "time_to_go"],
        feedthrough=False, name=name,
    )  # fmt: skip
