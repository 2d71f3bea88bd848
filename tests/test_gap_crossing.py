"""Gap crossings planned along a move (`ctrl_lpv.twomass.gap_crossing`).

The references are independent of the module's polynomial algebra: the
minimum-snap move sampled densely from `rest_to_rest` (the closed-form
polynomial), its shaft torque ``Jl a + cl v + Td`` computed with numpy and
its zeros located on a 1 us grid; the offset's derivatives by finite
differences.
"""

import numpy as np
import pytest

from ctrl_lpv.twomass.gap_crossing import (
    QUINTIC_PEAK_ACCEL,
    crossing_duration,
    crossing_offset,
    remaining_move,
    streamed_sign_changes,
    torque_sign_changes,
)
from ctrl_lpv.twomass.trajectory import rest_to_rest

JL, CL = 5.6, 1.0


def _zeros(distance, duration, Td, t0=0.0):
    """Zeros of the planned shaft torque after `t0`, on a 1 us grid."""
    t = np.linspace(0.0, duration, int(duration * 1e6) + 1)
    _, v, a, _, _ = rest_to_rest(t, distance, duration)
    F = JL * a + CL * v + Td
    z = np.flatnonzero(np.sign(F[1:]) != np.sign(F[:-1]))
    return [tz - t0 for tz in t[z] if tz > t0]


def _plan_at(distance, duration, t0):
    """The planner's state ``[r, v, a, j, g, h]`` at `t0` into the move."""
    r, v, a, j, _ = rest_to_rest([t0], distance, duration)[:, 0]
    return [r, v, a, j, distance, duration - t0]


@pytest.mark.parametrize(
    "distance, Td, count",
    [
        (0.05, 3.0, 2),  # against the load torque: braking, then holding
        (-0.05, 3.0, 2),  # with it: accelerating, then braking
        (0.05, 0.0, 1),  # braking only
        (0.05, -8.0, 2),  # helped by the load torque: accelerating, braking
    ],
)
def test_sign_changes_are_the_zeros_of_the_planned_torque(distance, Td, count):
    """From rest, the times where ``Jl a_r + cl v_r + Td`` changes sign."""
    D = 0.2
    side, changes = torque_sign_changes([0, 0, 0, 0, distance, D], JL, CL, Td, 1.5)
    want = _zeros(distance, D, Td)
    assert len(changes) == count
    # Td = 0: the torque ends at zero from the braking side, not a change.
    # Within a tenth of a 1 ms sample (linear interpolation on a 2 ms grid).
    np.testing.assert_allclose(changes, want[:count], atol=1e-4)
    first = JL * rest_to_rest([1e-3], distance, D)[2, 0] + Td
    assert side == np.sign(first)


def test_sign_changes_from_a_moving_plan():
    """Mid-move, the rest of the move is the same polynomial (the
    planner's principle of optimality): the same zeros, from now."""
    D, t0 = 0.2, 0.07
    plan = _plan_at(0.05, D, t0)
    side, changes = torque_sign_changes(plan, JL, CL, 3.0, 1.5)
    np.testing.assert_allclose(changes, _zeros(0.05, D, 3.0, t0), atol=1e-4)
    assert side == 1.0


@pytest.mark.parametrize(
    "Td, correction, kept",
    [
        (3.0, 0.0, 2),  # braking, then the hold's crossing
        (3.0, -1.0, 2),  # the load torque with the correction still asks it
        (3.0, -2.0, 1),  # it does not: a load running ahead stays braked
        (-3.0, 10.0, 1),  # the last change is the braking's, never dropped
    ],
)
def test_the_holds_crossing_follows_the_feedback(Td, correction, kept):
    """The last change into the rest's hold (after it the move asks no more
    than the load torque) is planned only where the load torque plus the
    feedback's correction now asks for the hold's flank; the changes kept
    are the planned torque's zeros."""
    plan = _plan_at(0.05, 0.2, 0.07)
    _, changes = torque_sign_changes(plan, JL, CL, Td, 1.5, correction=correction)
    assert len(changes) == kept
    np.testing.assert_allclose(changes, _zeros(0.05, 0.2, Td, 0.07)[:kept], atol=1e-4)


def test_remaining_move_meets_its_end_conditions():
    """The polynomial starts at the plan's state and ends at rest."""
    c = remaining_move(-0.03, 0.4, -2.0, 50.0, 0.15)
    p = np.polynomial.Polynomial(c)
    h = 0.15
    np.testing.assert_allclose(
        [p(0), p.deriv(1)(0) / h, p.deriv(2)(0) / h**2, p.deriv(3)(0) / h**3],
        [-0.03, 0.4, -2.0, 50.0],
    )
    np.testing.assert_allclose([p.deriv(k)(1.0) for k in range(4)], 0, atol=1e-12)


def test_small_torque_stretches_keep_the_flank():
    """A load torque below the threshold (0.5 Nm helping the move): the
    shaft torque starts at -0.5 Nm and turns positive after 2.7 ms; that
    first stretch does not ask for the other flank, the braking does."""
    side, changes = torque_sign_changes([0, 0, 0, 0, 0.05, 0.2], JL, CL, -0.5, 1.5)
    zeros = _zeros(0.05, 0.2, -0.5)
    assert len(zeros) == 2 and zeros[0] < 3e-3
    assert side == 1.0
    np.testing.assert_allclose(changes, zeros[1:], atol=1e-4)


def test_crossing_offset_starts_half_a_crossing_early():
    """psi leaves +1 half a crossing before the sign change along the
    quintic of a crossing centred on it: mid-gap at the sign change, at the
    quintic's peak speed; then the new flank. Derivatives by finite
    differences."""
    T, change = 0.03, 0.05  # sign change 50 ms from now
    now = np.linspace(0.0, 0.1, 10001)

    def at(t):
        if t >= change:  # past the sign change: the new side, no change ahead
            return crossing_offset(-1.0, [], T)
        return crossing_offset(1.0, [change - t], T)

    psi, dpsi, ddpsi = np.array([at(t) for t in now]).T
    before, after = now <= change - T / 2, now >= change
    assert np.all(psi[before] == 1.0) and np.all(psi[after] == -1.0)
    crossing = ~before & ~after
    assert np.all(np.diff(psi[crossing]) < 0)
    h = now[1] - now[0]
    inner = crossing & np.roll(crossing, 1) & np.roll(crossing, -1)
    np.testing.assert_allclose(
        np.gradient(psi, h)[inner], dpsi[inner], rtol=0, atol=2e-3 * np.max(-dpsi)
    )
    np.testing.assert_allclose(
        np.gradient(dpsi, h)[inner], ddpsi[inner], atol=5e-3 * np.max(np.abs(ddpsi))
    )
    # Just before the sign change: mid-gap at the quintic's peak speed.
    last = np.flatnonzero(crossing)[-1]
    assert psi[last] == pytest.approx(0.0, abs=2e-3)  # 10 us before it
    assert -dpsi[last] == pytest.approx(2 * 1.875 / T, rel=1e-3)
    # The offset's acceleration peaks at the quintic's.
    assert np.max(np.abs(ddpsi)) == pytest.approx(2 * QUINTIC_PEAK_ACCEL / T**2, 1e-3)


def test_crossing_duration_meets_its_acceleration():
    """A 2 alpha = 0.12 rad crossing at 625 rad/s^2: the motor offset
    ``alpha psi`` peaks at 625 rad/s^2 in its first half."""
    T = crossing_duration(0.12, 625.0)
    assert T == pytest.approx(np.sqrt(10 / np.sqrt(3) * 0.12 / 625.0))
    x = np.linspace(0, T / 2, 2001)
    ddpsi = np.array([crossing_offset(1.0, [c], T)[2] for c in x])
    assert 0.06 * np.max(np.abs(ddpsi)) == pytest.approx(625.0, rel=1e-3)


@pytest.mark.parametrize(
    "v, a, j, Td",
    [(1.2, 0.5, -20.0, 0.0), (1.2, -0.2, -20.0, 0.0), (-0.8, 2.0, 30.0, -8.0),
     (0.6, 0.1, 5.0, 0.0)],
)  # fmt: skip
def test_streamed_sign_changes_on_the_constant_jerk_extrapolation(v, a, j, Td):
    """The torque ``Jl (a + j t) + cl (v + a t + j t^2 / 2) + Td`` of the
    tracker's extrapolation, its zero found by numpy's roots, from half a
    crossing back to half a crossing ahead; `side` is the flank before it."""
    duration = 0.08
    found_side, changes = streamed_sign_changes(v, a, j, duration, JL, CL, Td, 1e-9)
    roots = np.roots([0.5 * CL * j, JL * j + CL * a, JL * a + CL * v + Td])
    roots = sorted(r.real for r in roots
                   if abs(r.imag) < 1e-12 and abs(r.real) < 0.5 * duration)  # fmt: skip
    assert len(changes) == len(roots)
    np.testing.assert_allclose(changes, roots, atol=duration / 95)
    start = -0.5 * duration
    F0 = JL * (a + j * start) + CL * (v + a * start + 0.5 * j * start**2) + Td
    assert found_side == np.sign(F0)
