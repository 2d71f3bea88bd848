"""Gap crossings planned along a move: the motor's flank offset in time.

The contact model's flat feedforward puts the motor on the flank that
transmits the planned shaft torque ``F(t) = Jl a_r + cl v_r + Td_hat``
(`ctrl_lpv.twomass.servo_sampled`). A small move against the backlash
changes the sign of ``F`` mid-move (the braking needs more than the load
torque gives), so the motor must cross the gap ``2 alpha`` while the load
moves. Switching the flank when ``F`` changes sign steps the motor
reference by ``2 alpha``: the motor crosses at full torque, the load runs
free meanwhile, and the motor lands on the braking flank at several rad/s.

The sign changes are predictable: the rest of a minimum-snap move is the
seventh-order polynomial from the planner's present state to rest at the
goal in the time-to-go (`ctrl_lpv.twomass.trajectory`), so ``F`` along it
is a polynomial of degree six. `torque_sign_changes` finds where it
changes sign (ignoring stretches below a threshold, which need no flank),
and `crossing_offset` starts the motor across the gap before: the flank
offset ``psi`` in ``[-1, 1]`` (the motor's place in the gap, in units of
the gap estimate) follows the quintic of a crossing of duration ``T_x``
centred on the sign change, so that the motor is mid-gap, crossing at the
quintic's peak speed, when the braking torque is needed; the flank choice
then completes the crossing. The motor's own acceleration for it
(``Jm alpha_hat psi''``) is part of the feedforward (`servo_sampled`).

Measured on the small-move grid (0.05 rad steps from rest and the 0.1 rad
reversal, Jl x0.8-1.2, Td 0-8 Nm, alpha 0.03 and 0.06, seed 5; docs/servo.rst,
"Small moves across the gap"): 44 of 54 runs meet 0.3 s / 1.5 % (32
without). Compared with the rest latch off (45 for this one): the whole
quintic centred on the sign change, reaching the new flank ``T_x / 2``
after it, 40; half-way points at 0.4 or 0.6 of the crossing at the sign
change, 41; ``T_x`` from 1000 instead of 625 rad/s^2, 45.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "remaining_move",
    "advance_move",
    "torque_sign_changes",
    "one_flank_duration",
    "no_reversal_duration",
    "streamed_sign_changes",
    "crossing_duration",
    "crossing_offset",
    "QUINTIC_PEAK_ACCEL",
    "CROSSING_ACCEL",
    "STREAM_CROSSING_ACCEL",
    "rest_to_rest",
    "QUINTIC_PEAK_SPEED",
]

#: Peak of ``|q''|`` of the quintic ``q(s) = 10 s^3 - 15 s^4 + 6 s^5``.
QUINTIC_PEAK_ACCEL = 10.0 / math.sqrt(3.0)
#: Peak of ``q'`` of the same quintic (its mean is 1).
QUINTIC_PEAK_SPEED = 1.875

# End conditions at u = 1 on the coefficients of u^4 .. u^7 (value and the
# first three derivatives), inverted once.
_END = np.array(
    [[1, 1, 1, 1], [4, 5, 6, 7], [12, 20, 30, 42], [24, 60, 120, 210]], float
)
_END_INV = np.linalg.inv(_END)
_GRID = 96
#: Peak motor acceleration of a planned crossing, rad/s^2: half the
#: torque limit on the motor inertia (250 Nm / 0.4 kg m^2), 33 ms for the
#: 0.12 rad gap of alpha = 0.06.
CROSSING_ACCEL = 625.0
#: The same for a streamed set-point's reversals (`streamed_sign_changes`):
#: 40 Nm on the motor inertia, 83 ms across the 0.12 rad gap. Measured on
#: the 0.2 rad 1 Hz sine (1 ms, delay 1, encoders; peak torque after the
#: first second / max |e|): the flank choice alone 434-500 Nm / 0.34-0.70
#: mrad; 625 rad/s^2 500 Nm; 150: 97-128 Nm / 0.27-0.67 mrad; 100: 65-76
#: Nm / 0.31-0.76 mrad; 75: 49-64 Nm / 0.32-1.25 mrad (the gap-step row aside,
#: 3.1-3.4 mrad in each; the sine's rigid-body
#: torque 47 Nm): a slower crossing leaves the load free longer.
STREAM_CROSSING_ACCEL = 100.0


def remaining_move(x0, v, a, j, h):
    """Coefficients, in normalised time ``u = tau / h``, of the rest of the
    minimum-snap move from ``(r - g, v, a, j)`` to rest at the goal.

    Returns
    -------
    ndarray
        Shape ``(8,)``: ``p(u) = sum c_k u^k`` (position relative to the
        goal), lowest order first.
    """
    b = np.array([x0, v * h, 0.5 * a * h * h, j * h**3 / 6.0])
    rhs = -np.array(
        [b.sum(), b[1] + 2 * b[2] + 3 * b[3], 2 * b[2] + 6 * b[3], 6 * b[3]]
    )
    return np.concatenate([b, _END_INV @ rhs])


def advance_move(x0, v, a, j, h, tau):
    """The state of the rest of the minimum-snap move `tau` s on.

    Evaluates the polynomial of `remaining_move` (exact, however short the
    time-to-go `h`), from ``(r - g, v, a, j)``; at or past the end of the
    move (``tau >= h``), the goal at rest.

    Returns
    -------
    tuple of float
        ``(r - g, v, a, j)`` at ``tau``.
    """
    if tau >= h:
        return 0.0, 0.0, 0.0, 0.0
    c = remaining_move(x0, v, a, j, h)
    powers = (tau / h) ** np.arange(8.0)
    k = np.arange(8.0)
    d1 = c[1:] * k[1:]
    d2 = d1[1:] * k[1:-1]
    d3 = d2[1:] * k[1:-2]
    return (
        float(c @ powers), float(d1 @ powers[:7]) / h, float(d2 @ powers[:6]) / h**2,
        float(d3 @ powers[:5]) / h**3,
    )  # fmt: skip


def _torque_coefficients(c, h, Jl, cl, Td):
    """``F(u) = Jl p''/h^2 + cl p'/h + Td`` as coefficients in ``u``."""
    k = np.arange(8.0)
    d1 = (c[1:] * k[1:]) / h
    d2 = (d1[1:] * k[1:-1]) / h
    F = cl * d1
    F[:-1] += Jl * d2
    F[0] += Td
    return F


def torque_sign_changes(plan, Jl, cl, Td, significant, correction=0.0):
    """Times (from now, s) where the planned shaft torque changes flank.

    Parameters
    ----------
    plan : sequence of float
        ``[r, v, a, j, g, h]``.
    Jl, cl, Td : float
        Load inertia, friction and load torque (estimate).
    significant : float
        A sign of ``F`` counts only on stretches where ``|F|`` exceeds it
        (Nm); a smaller excursion keeps the flank before it.
    correction : float
        The feedback's correction to the asked shaft torque now, Nm. A last
        change into the rest's hold (after it, to the end of the move, ``F``
        asks no more than ``Td``, within `significant`) is dropped where
        ``Td + correction`` no longer asks for that flank: a load running
        ahead of the plan is braked, not let go. (Jl x1.2, Td 0, alpha
        0.06, a 0.05 rad step: the load running ahead at the end of the
        move, an estimate of 2.5-4.5 Nm of load torque, the inertia's error,
        planned the hold's crossing and let the load run 3.1-3.4 % past.)

    Returns
    -------
    side : float
        The flank of ``F`` now (+1 or -1; the first significant one if ``F``
        is small now, 0 if it never is significant).
    changes : list of float
        The times of the significant sign changes from now, in order.
    """
    r, v, a, j, g, h = plan
    F = _planned_torque(remaining_move(r - g, v, a, j, h), h, Jl, cl, Td)
    side, changes = _sign_changes(F, h, significant)
    hold = math.copysign(1.0, Td)
    if changes and abs(Td) > significant and hold * (Td + correction) < significant:
        after = np.flatnonzero(hold * F < 0.0)[-1] + 1
        if np.max(np.abs(F[after:])) <= abs(Td) + significant:
            changes = changes[:-1]
    return side, changes


def one_flank_duration(
    start, goal: float, shortest: float, Jl: float, cl: float, side: float,
    spare: float, longest: float = 1.0,
) -> float:  # fmt: skip
    """The shortest duration of a minimum-snap move that stays on one flank.

    From `shortest` on, in steps of 5 %, the first duration whose move
    from ``start = (r, v, a, j)`` to rest at `goal` (`remaining_move`) asks
    a shaft torque ``F = Jl a + cl v`` that a load torque pressing on the
    flank `side` (+1 or -1) carries: ``side F >= -spare`` along the move,
    with `spare` the share of the load torque that may brake. At most
    `longest`.

    Examples
    --------
    >>> D = one_flank_duration((0.0, 0.0, 0.0, 0.0), 0.02, 0.2, 5.6, 1.0, 1.0, 6.0)
    >>> round(D, 3)
    0.377
    """
    r, v, a, j = start
    u = np.linspace(0.0, 1.0, 41)
    duration = shortest
    while duration < longest:
        c = remaining_move(r - goal, v, a, j, duration)
        F = np.polynomial.polynomial.polyval(
            u, _torque_coefficients(c, duration, Jl, cl, 0.0)
        )
        if np.min(side * F) >= -spare:
            return duration
        duration *= 1.05
    return longest


def no_reversal_duration(
    start, goal: float, longest: float, accel_limit: float, shortest: float
) -> float:  # fmt: skip
    """The longest duration, up to `longest`, of a minimum-snap move that
    reaches `goal` from a state moving towards it without passing it.

    A target changed mid-move to one short of where the move was heading
    is re-planned as a move of the usual duration (`replan_duration`), which
    from speed runs past the new goal and comes back (from 1.2 rad/s with
    47 mrad to go, 36 mrad past it). From `longest` down in steps of 5 %,
    the first duration whose move from ``start = (r, v, a, j)``
    (`remaining_move`) does not pass the goal, with its peak acceleration
    within `accel_limit`; not below `shortest`. A state at rest or moving
    away from the goal, or no such duration: `longest`.

    Examples
    --------
    >>> D = no_reversal_duration((0.0, 1.2, 0.0, 0.0), 0.047, 0.2, 60.0, 0.04)
    >>> round(D, 3)
    0.088
    """
    r, v, a, j = start
    if (goal - r) * v <= 0.0:
        return longest
    u = np.linspace(0.0, 1.0, 81)
    ahead = math.copysign(1.0, goal - r)
    duration = longest
    while duration >= shortest:
        c = remaining_move(r - goal, v, a, j, duration)
        past = np.max(ahead * np.polynomial.polynomial.polyval(u, c))
        accel = np.polynomial.polynomial.polyval(
            u, np.polynomial.polynomial.polyder(c, 2)
        )
        if past <= 1e-9 * abs(goal - r) and np.max(np.abs(accel)) <= (
            accel_limit * duration**2
        ):
            return duration
        duration *= 0.95
    return longest


def streamed_sign_changes(v, a, j, duration, Jl, cl, Td, significant):
    """`torque_sign_changes` about a streamed set-point, for a crossing of
    `duration` (s) centred on the change.

    A streamed set-point has no plan: its tracker's constant-jerk
    extrapolation (`ctrl_lpv.twomass.stream`) from the speed `v`, the
    acceleration `a` and the jerk `j` stands for it, short next to a motion
    controller's profile, from half a crossing back to half a crossing
    ahead. A change up to half a crossing ago is returned too (a negative
    time, with `side` the flank before it): `crossing_offset` then finishes
    the crossing along its quintic, where the planned crossing leaves the
    rest to the flank choice (a jump of half the gap, the slam a streamed
    reversal must not make: it has no move whose time it costs).
    """
    h = duration
    t0 = -0.5 * h
    v0, a0 = v + a * t0 + 0.5 * j * t0 * t0, a + j * t0
    c = np.array([0.0, v0 * h, 0.5 * a0 * h * h, j * h**3 / 6.0, 0.0, 0.0, 0.0, 0.0])
    F = _planned_torque(c, h, Jl, cl, Td)
    side, changes = _sign_changes(F, h, significant)
    return side, [t + t0 for t in changes]


def _planned_torque(c, h, Jl, cl, Td):
    """``F`` at `_GRID` points over the position polynomial `c` (in ``u =
    tau / h``, lowest order first)."""
    return np.polynomial.polynomial.polyval(
        np.linspace(0.0, 1.0, _GRID), _torque_coefficients(c, h, Jl, cl, Td)
    )


def _sign_changes(F, h, significant):
    """`torque_sign_changes` of the planned torque `F` over `h` s."""
    sign = np.where(F >= 0.0, 1.0, -1.0)
    cuts = np.flatnonzero(sign[1:] != sign[:-1]) + 1
    bounds = [0, *cuts.tolist(), _GRID]
    step = h / (_GRID - 1)
    first = side = 0.0
    changes = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        if np.max(np.abs(F[lo:hi])) <= significant:
            continue  # too small to need the flank: keeps the one before
        s = sign[lo]
        if side == 0.0:
            first = side = s
        elif s != side:
            # The zero between samples lo - 1 and lo, linearly interpolated.
            f0, f1 = F[lo - 1], F[lo]
            changes.append((lo - 1 + f0 / (f0 - f1)) * step)
            side = s
    return float(first), changes


def crossing_duration(gap, accel):
    """Duration of a quintic crossing of `gap` (rad, the full ``2 alpha``)
    at a peak motor acceleration `accel` (rad/s^2)."""
    return math.sqrt(QUINTIC_PEAK_ACCEL * abs(gap) / accel)


def _quintic(s, duration):
    """``q(s) = 10 s^3 - 15 s^4 + 6 s^5`` and its first two derivatives in
    time, ``s = t / duration``."""
    q = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
    dq = 30.0 * s * s * (1.0 - s) ** 2 / duration
    ddq = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / duration**2
    return q, dq, ddq


def rest_to_rest(t, duration, start, end):
    """Position, speed and acceleration at `t` of the quintic from rest at
    `start` (``t = 0``) to rest at `end` (``t = duration``), held there
    after."""
    if duration <= 0.0 or t >= duration:
        return end, 0.0, 0.0
    d = end - start
    q, dq, ddq = _quintic(max(t, 0.0) / duration, duration)
    return start + d * q, d * dq, d * ddq


def crossing_offset(side, changes, duration):
    """The planned flank offset now and its first two time derivatives.

    Parameters
    ----------
    side : float
        The flank of the planned shaft torque now (`torque_sign_changes`).
    changes : list of float
        Times of its sign changes from now, s; a negative first one (a
        change up to half a crossing ago, `streamed_sign_changes`) puts the
        offset on the crossing's second half.
    duration : float
        Duration ``T_x`` of the crossing centred on the next sign change, s:
        the offset leaves `side` ``T_x / 2`` before it and is mid-gap at it.

    Returns
    -------
    (float, float, float)
        ``psi, dpsi/dt, d2psi/dt2``.
    """
    if not changes or changes[0] >= 0.5 * duration:
        return side, 0.0, 0.0
    q, dq, ddq = _quintic(0.5 - changes[0] / duration, duration)
    # From `side` towards `-side`: psi = side (1 - 2 q).
    return side * (1.0 - 2.0 * q), -2.0 * side * dq, -2.0 * side * ddq
