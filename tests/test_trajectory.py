"""The rest-to-rest planner (`ctrl_lpv.twomass.trajectory`) on analytic cases.

The references here are independent of the planner's feedback law: the
minimum-snap move between two states is the seventh-order polynomial
solved from its eight boundary conditions with numpy.
"""

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrl_lpv.twomass.gap_crossing import no_reversal_duration, one_flank_duration
from ctrl_lpv.twomass.trajectory import (
    PEAK_ACCEL,
    move_duration,
    planner_functions,
    replan_duration,
    rest_to_rest,
)


def _min_snap(start, end, h):
    """Coefficients of the seventh-order polynomial from state `start` to
    `end` (position, speed, acceleration, jerk) in time `h`."""
    rows, rhs = [], []
    for t, state in ((0.0, start), (h, end)):
        for k, value in enumerate(state):
            row = [
                math.factorial(n) / math.factorial(n - k) * t ** (n - k)
                if n >= k
                else 0.0
                for n in range(8)
            ]
            rows.append(row)
            rhs.append(value)
    return np.linalg.solve(np.array(rows), np.array(rhs))


def _run_law(state, goal, h, hmin=1e-9):
    """The online minimum-snap law with ``dh/dt = -1`` from `state`."""
    snap, _ = planner_functions(60.0, 0.0, hmin)

    def rhs(t, x):
        r, v, a, j = x
        return [v, a, j, snap(r, v, a, j, goal, h - t)]

    t = np.linspace(0.0, 0.98 * h, 981)
    sol = solve_ivp(rhs, (0.0, t[-1]), state, t_eval=t, rtol=1e-10, atol=1e-12)
    return t, sol.y


@pytest.mark.parametrize(
    "state, goal",
    [
        ((0.0, 0.0, 0.0, 0.0), 0.05),
        ((0.0, 0.6, 0.0, 0.0), -0.05),
        ((0.02, 0.3, -5.0, 40.0), 0.05),
    ],
)
def test_online_law_is_the_minimum_snap_polynomial(state, goal):
    """From rest or from a moving state (a re-plan), the feedback law
    follows the polynomial that solves the boundary conditions."""
    h = 0.2
    t, y = _run_law(list(state), goal, h)
    coef = _min_snap(state, (goal, 0.0, 0.0, 0.0), h)
    poly = np.polynomial.Polynomial(coef)
    for k in range(3):
        ref = poly.deriv(k)(t) if k else poly(t)
        scale = max(1e-3, np.max(np.abs(ref)))
        np.testing.assert_allclose(y[k], ref, atol=1e-6 * scale)


def test_stopping_a_speed_in_place_peaks_at_five_times_v_over_h():
    """The constant quoted by `replan_duration`: 5.03 |v| / h."""
    h, v = 0.3, 0.8
    poly = np.polynomial.Polynomial(_min_snap((0.0, v, 0.0, 0.0), (0.0,) * 4, h))
    t = np.linspace(0.0, h, 30001)
    peak = np.max(np.abs(poly.deriv(2)(t)))
    assert abs(peak * h / v - 5.03) < 5e-3
    _, y = _run_law([0.0, v, 0.0, 0.0], 0.0, h)
    assert abs(np.max(np.abs(y[2])) - peak) < 1e-3 * peak


def test_replan_duration_terms():
    """Each term of the re-plan duration wins in its own case."""
    alim, dmin = 60.0, 0.2
    # A small distance from rest: the floor.
    assert replan_duration(0.05, 0.0, alim, dmin) == dmin
    # A long one from rest: the move of `move_duration`, peak at the limit.
    D = replan_duration(1.0, 0.0, alim, dmin)
    assert D == pytest.approx(move_duration(1.0, alim, dmin))
    acc = rest_to_rest(np.linspace(0.0, D, 20001), 1.0, D)[2]
    assert np.max(np.abs(acc)) == pytest.approx(alim, rel=1e-5)
    # A fast plan re-planned to where it is: the speed term, either sign.
    assert replan_duration(0.0, -9.0, alim, dmin) == pytest.approx(3 * 9.0 / alim)
    assert replan_duration(0.0, 9.0, alim, dmin) == replan_duration(
        0.0, -9.0, alim, dmin
    )


def test_the_planner_replans_with_replan_duration():
    """The planner's time-to-go moves to `replan_duration` on a new target
    (the rate law of `planner_functions`)."""
    alim, dmin, hmin = 60.0, 0.2, 0.04
    _, rates = planner_functions(alim, dmin, hmin)
    r, v, g, h = 0.1, 2.0, 0.1, hmin
    target = -0.4
    dg, dh = rates(r, v, g, h, target)
    assert dg > 0 or dg < 0
    want = replan_duration(target - r, v, alim, dmin)
    assert want == pytest.approx(math.sqrt(PEAK_ACCEL * 0.5 / alim))
    assert dh == pytest.approx(1e4 * (want - h), rel=1e-6)


@pytest.mark.parametrize(
    "start, goal",
    [
        # From rest: the peak deceleration PEAK_ACCEL d / D**2 is the bound.
        ((0.0, 0.0, 0.0, 0.0), 0.02),
        # From a load still falling away from the goal (the landing of
        # `gap_fall`), and the mirror image on the other flank.
        ((-0.014, -0.19, 0.0, 0.0), 0.0),
        ((0.014, 0.19, 0.0, 0.0), 0.0),
    ],
)
def test_one_flank_duration_is_the_shortest_on_its_grid(start, goal):
    """Along the online law's move of the returned duration the shaft
    torque ``Jl a + cl v`` stays above ``-spare`` on the flank of the push;
    one grid step (5 %) shorter, it does not."""
    Jl, cl, spare = 5.6, 1.0, 6.0
    side = 1.0 if goal >= start[0] else -1.0
    D = one_flank_duration(start, goal, 0.2, Jl, cl, side, spare)
    assert 0.2 <= D < 1.0

    def lowest(h):
        _, y = _run_law(list(start), goal, h)
        return np.min(side * (Jl * y[2] + cl * y[1]))

    assert lowest(D) >= -spare * (1 + 1e-3)
    if D > 0.2:
        assert lowest(D / 1.05) < -spare
    if start[1] == 0.0:
        assert D == pytest.approx(math.sqrt(PEAK_ACCEL * goal * Jl / spare), rel=0.06)


def _path(start, goal, h, n=2001):
    """Position and acceleration of the minimum-snap move from `start` to
    rest at `goal` in `h` s (`_min_snap`), on `n` points."""
    c = _min_snap(start, (goal, 0.0, 0.0, 0.0), h)
    t = np.linspace(0.0, h, n)
    pos = np.polynomial.polynomial.polyval(t, c)
    acc = np.polynomial.polynomial.polyval(t, np.polynomial.polynomial.polyder(c, 2))
    return pos, acc


@pytest.mark.parametrize(
    "start, goal",
    [
        # A target moved back to 47 mrad ahead of a move at 1.2 rad/s.
        ((0.0, 1.2, 0.0, 0.0), 0.047),
        # Mid-acceleration, and the mirror image.
        ((0.0, 1.2, 30.0, 500.0), 0.047),
        ((0.0, -2.0, -20.0, 0.0), -0.12),
    ],
)
def test_no_reversal_duration_stops_at_the_goal(start, goal):
    """The move of the returned duration reaches the goal without passing
    it, within the acceleration limit; the re-plan's usual duration (0.2 s
    here) passes it, and so does one grid step (5 %) longer."""
    limit, usual = 60.0, 0.2
    D = no_reversal_duration(start, goal, usual, limit, 0.04)
    ahead = math.copysign(1.0, goal - start[0])
    pos, acc = _path(start, goal, D)
    assert np.max(ahead * (pos - goal)) <= 1e-9
    assert np.max(np.abs(acc)) <= limit
    assert np.max(ahead * (_path(start, goal, usual)[0] - goal)) > 1e-3
    longer, acc_longer = _path(start, goal, D / 0.95)
    assert np.max(ahead * (longer - goal)) > 1e-9 or np.max(np.abs(acc_longer)) > limit


def test_no_reversal_duration_keeps_the_usual_one_where_it_cannot():
    """Moving away from the goal, at rest, or too fast to stop short of it
    within the limit: the usual duration."""
    assert no_reversal_duration((0.0, -1.2, 0.0, 0.0), 0.047, 0.2, 60.0, 0.04) == 0.2
    assert no_reversal_duration((0.0, 0.0, 0.0, 0.0), 0.047, 0.2, 60.0, 0.04) == 0.2
    # 3.2 rad/s needs 85 mrad at 60 rad/s^2: 43 mrad is too short.
    assert no_reversal_duration((0.0, 3.2, 0.0, 0.0), 0.043, 0.2, 60.0, 0.04) == 0.2
