"""The servo's controller as a block kernel (scalar functions of floats).

One function builds the right-hand side and the output of the
`ServoDesign` controller; `servo.py` documents the law.  States, in order:

``r, v_r, a_r, j_r``
    the reference chain of the online minimum-snap planner (load angle
    and its derivatives);
``goal``
    the target the current plan goes to (a fast copy of ``theta_r``);
``time_to_go``
    the planner's horizon ``h``;
``int_e_l``
    integral of the load-angle error (contact-aware, see below);
``alpha_hat_dev``
    gap estimate minus its initial value;
``omega_m_hat, Ts_hat``
    observer of the motor speed and of the shaft torque.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..interconnection import BlockKernel
from .rest_flank import RestFlank
from .trajectory import planner_functions

STATES = [
    "r", "v_r", "a_r", "j_r", "goal", "time_to_go", "int_e_l",
    "alpha_hat_dev", "omega_m_hat", "Ts_hat",
]  # fmt: skip
INPUTS = ["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"]


@dataclass(frozen=True)
class ServoTuning:
    """Every number of the servo law (see `servo_design` for meanings)."""

    Jm: float
    Jl: float
    cm: float
    cl: float
    ks: float
    cs: float
    gain: tuple[float, float, float, float, float]
    torque_limit: float
    accel_limit: float
    min_duration: float
    horizon_floor: float
    alpha_max: float
    alpha_initial: float
    flank_width: float
    contact_torque: float
    estimate_rate: float
    probe_rate: float
    integral_leak: float
    observer_bandwidth: float
    rest_speed: float = 0.01
    flank_lead: float = 0.0
    # Asked shaft torque, Nm, below which the sampled law asks for no flank
    # (the motor stays mid-gap): the motor-encoder design's quiet rest.
    flank_deadband: float = 0.0
    integral_hold: float = 0.0
    goal_rate: float = 2000.0
    replan_rate: float = 1e4
    goal_tolerance: float = 1e-6
    anti_hunting: bool = True
    gap_estimate: bool = True
    learn_torque: float = 0.0
    probe_error: float = 0.0
    # The sampled law's gap estimate (`ServoEstimator`).
    static_speed: float = 0.1
    narrowing_band: float = 2e-3
    rest_estimate_rate: float = 5.0
    rest_flank: RestFlank | None = None


def servo_kernel(c: ServoTuning) -> BlockKernel:
    """Kernel of the servo controller for `ServoTuning` `c`."""
    Jm, Jl, cm, cl, ks, cs = c.Jm, c.Jl, c.cm, c.cl, c.ks, c.cs
    k1, k2, k3, k4, k5 = c.gain
    limit = c.torque_limit
    plan_snap, plan_rates = planner_functions(
        c.accel_limit, c.min_duration, c.horizon_floor,
        c.goal_rate, c.replan_rate, c.goal_tolerance,
    )  # fmt: skip
    a0, amax = c.alpha_initial, c.alpha_max
    teps, tc = c.flank_width, c.contact_torque
    l1, l2 = 2.0 * c.observer_bandwidth, Jm * c.observer_bandwidth**2
    anti, estimate = c.anti_hunting, c.gap_estimate
    leak, gam, probe = c.integral_leak, c.estimate_rate, c.probe_rate
    ratio = ks / k1
    rest_speed, lead, hold = c.rest_speed, c.flank_lead, c.integral_hold

    def core(x, u):
        r, v, a, j, g, h, xi, dah = x[:8]
        tm, wm, tl, wl = u[:4]
        ah = a0 + dah
        snap = plan_snap(r, v, a, j, g, h)
        # Flat feedforward of the contact model (cs neglected): the shaft
        # torque that moves the load along r, the motor angle that gives it.
        F = Jl * a + cl * v
        F1 = Jl * j + cl * a
        F2 = Jl * snap + cl * j
        el, dl = tl - r, wl - v
        # The shaft torque asked for (feedforward and load feedback) picks
        # the flank: the backlash offset in the motor reference.
        # The planned torque is taken `lead` seconds ahead, so that the motor
        # crosses the gap before the load needs the other flank.
        fpred = F + lead * F1
        tstar = fpred - ratio * (k3 * el + k4 * dl + k5 * xi) if anti else fpred
        y = tstar / teps
        # psi: odd smoothstep, flat at 0 and at +-1 (C1).
        ya = y if y >= 0.0 else -y
        psi = 1.0 if ya >= 1.0 else ya * ya * (3.0 - 2.0 * ya)
        psi = psi if y >= 0.0 else -psi
        thm = r + F / ks + ah * psi
        wmf = v + F1 / ks
        tff = Jm * (a + F2 / ks) + cm * wmf + F
        raw = tff - (k1 * (tm - thm) + k2 * (wm - wmf) + k3 * el + k4 * dl + k5 * xi)
        sat = -limit if raw < -limit else (limit if raw > limit else raw)
        return snap, el, raw, sat, ah, tstar

    def out(t, x, u):
        return (core(x, u)[3],)

    def rhs(t, x, u):
        r, v, a, j, g, h, xi, dah, wh, tsh = x
        tm, wm, tl, wl, tr = u
        snap, el, raw, sat, ah, tstar = core(x, u)
        dg, dh = plan_rates(r, v, g, h, tr)
        # Shaft-torque observer on the motor side.
        ew = wm - wh
        dwh = (sat - cm * wm - tsh) / Jm + l1 * ew
        dtsh = -l2 * ew
        # Contact weight: 0 in the gap, 1 when clearly transmitting torque.
        wc = _smoothstep((abs(tsh) - tc) / tc)
        ddah = 0.0
        if estimate:
            # In contact the flank is at theta_d - (Ts - cs omega_d) / ks.
            flank = math.copysign(1.0, tsh) * ((tm - tl) - (tsh - cs * (wm - wl)) / ks)
            flank = 0.0 if flank < 0.0 else (amax if flank > amax else flank)
            ddah = gam * wc * (flank - ah)
            if anti:
                # Contact asked for (twice the contact torque) and not made:
                # the gap is wider than estimated.
                m = _smoothstep(abs(tstar) / (2.0 * tc) - 1.0)
                # Only with the move ended and the load nearly at rest.
                rest = _smoothstep(1.0 - (abs(v) + abs(wl)) / rest_speed)
                ddah += probe * (1.0 - wc) * m * rest * (1.0 if ah < amax else 0.0)
        # Integral action: conditional on saturation (anti-windup) and, with
        # anti-hunting, only in contact, fading out of contact.
        if (raw > limit and el < 0.0) or (raw < -limit and el > 0.0):
            dxi = 0.0
        elif anti:
            dxi = wc * el - (1.0 - wc) * leak * xi
        else:
            dxi = el
        if hold > 0.0:
            # The integral is for the load torque at rest, not for tracking
            # errors during the move (which would wind it up).
            dxi *= _smoothstep(1.0 - abs(v) / hold)
        return (v, a, j, snap, dg, dh, dxi, ddah, dwh, dtsh)

    return BlockKernel(out=out, rhs=rhs)


def _smoothstep(s: float) -> float:
    """0 below 0, 1 above 1, ``s^2 (3 - 2 s)`` between (C1: no kinks)."""
    if s <= 0.0:
        return 0.0
    if s >= 1.0:
        return 1.0
    return s * s * (3.0 - 2.0 * s)
