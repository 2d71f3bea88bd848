"""numba kernels of the two-mass loop: plant, LPV and backstepping laws.

The same equations, branch by branch and in the same floating-point
order, as the Python kernels of `twomass.plant`, `lpv_controller` and
`backstepping_controller` (see there for why each is what it is); the data
come in one float64 vector laid out by `ctrl_lpv.twomass.compiled_data`.
`system_rhs` is the right-hand side that `ctrl_lpv.twomass.dopri5`
integrates: the plant alone under a held motor torque (controller kind 0),
or the closed loop.

Imported only by the compiled engine: it needs numba.
"""

from __future__ import annotations

import math

import numba as nb

from .compiled_data import (
    B_A,
    B_ALPHA,
    B_B,
    B_C1,
    B_C3,
    B_C4,
    B_CL,
    B_CM,
    B_JM,
    B_K,
    B_KS,
    B_TDHAT,
    C_KIND,
    C_LIMIT,
    D_BIJL,
    D_BIK,
    D_BIKEPS,
    D_BIKS,
    D_IJL,
    D_IJM,
    D_RATE,
    I_TD,
    I_TM,
    I_TR,
    L_AEST,
    L_HI,
    L_INTEGRAL,
    L_KHI,
    L_KLO,
    L_LO,
    L_SCHED,
    P_A0,
    P_A1,
    P_AT,
    P_CL,
    P_CM,
    P_CS,
    P_KS,
    P_MODEL,
)

# The exact plant's contact layer and rest band (twomass.plant).
from .plant import _CONTACT_LAYER as LAYER
from .plant import _REST_BAND as BAND

# error_model="numpy": a division by zero gives inf or nan (as IEEE) rather
# than a check and a ZeroDivisionError on every division.
#
# `inline`: numba inlines the parts (plant, laws) into `system_rhs` and
# `system_outputs` before LLVM sees them. Called out of line, the nested
# calls with array arguments took half of the time of a right-hand side
# (0.6 of a run); inlining the right-hand side itself into the integrator
# as well gains nothing more and takes two minutes to compile.
inline = nb.njit(cache=True, nogil=True, error_model="numpy", inline="always")
jit = nb.njit(cache=True, nogil=True, error_model="numpy")


@inline
def backlash(t, d):
    """Half-gap at time t (a constant or one step)."""
    return d[P_A0] if t < d[P_AT] else d[P_A1]


@inline
def shaft(t, x, d):
    """``(Ts, d theta_b/dt)`` of the plant at state x (see `twomass.plant`)."""
    a = backlash(t, d)
    ks, cs = d[P_KS], d[P_CS]
    tm, wm, tl, wl = x[0], x[1], x[2], x[3]
    wd = wm - wl
    if d[P_MODEL] != 0.0:  # dead zone, closed bounds
        td = tm - tl
        if td >= a:
            return ks * (td - a) + cs * wd, 0.0
        if td <= -a:
            return ks * (td + a) + cs * wd, 0.0
        return 0.0, 0.0
    tb = x[4]
    rate = d[D_RATE]
    if a == 0.0:
        return ks * (tm - tl) + cs * wd, -rate * tb
    if tb >= a:
        e = tb - a
        s = wd + rate * (tm - tl - a)
        v = s if s < 0.0 else 0.0
        if e > BAND:
            return cs * (s - v), v - rate * (e - BAND)
        return cs * (s - v), v
    if tb <= -a:
        e = -a - tb
        s = wd + rate * (tm - tl + a)
        v = s if s > 0.0 else 0.0
        if e > BAND:
            return cs * (s - v), v + rate * (e - BAND)
        return cs * (s - v), v
    s = wd + rate * (tm - tl - tb)
    depth = a - tb if s > 0.0 else a + tb
    lw = LAYER if LAYER < a else a
    if depth < lw:
        v = s * depth / lw
        return cs * (s - v), v
    return 0.0, s


@inline
def _clip(v, limit):
    return -limit if v < -limit else (limit if v > limit else v)


@inline
def _sign(v):
    return (v > 0.0) - (v < 0.0)


@inline
def lpv_law(x, n, d):
    """``(Tm, d int_e_l/dt)`` of `lpv_controller`; its state is ``x[n]``."""
    tr = d[I_TR]
    tm, wm, tl, wl = x[0], x[1], x[2], x[3]
    e_m, e_l = tm - tr, tl - tr
    integral = d[L_INTEGRAL] != 0.0
    lam = 0.0
    if d[L_SCHED] != 0.0:
        a = d[L_AEST]
        theta_d = abs(e_m - e_l)
        if theta_d > a:
            p = -a / (theta_d if theta_d > 1e-300 else 1e-300)
        else:
            p = -1.0
        lam = (p - d[L_LO]) / (d[L_HI] - d[L_LO])
        lam = 0.0 if lam < 0.0 else (1.0 if lam > 1.0 else lam)
    k0 = (1.0 - lam) * d[L_KLO] + lam * d[L_KHI]
    k1 = (1.0 - lam) * d[L_KLO + 1] + lam * d[L_KHI + 1]
    k2 = (1.0 - lam) * d[L_KLO + 2] + lam * d[L_KHI + 2]
    k3 = (1.0 - lam) * d[L_KLO + 3] + lam * d[L_KHI + 3]
    raw = k0 * e_m + k1 * wm + k2 * e_l + k3 * wl
    k4 = 0.0
    if integral:
        k4 = (1.0 - lam) * d[L_KLO + 4] + lam * d[L_KHI + 4]
        raw += k4 * x[n]
    raw = -raw
    limit = d[C_LIMIT]
    rate = 0.0
    if integral:
        # Conditional integration: stop while saturated and pushed further.
        if abs(raw) > limit and _sign(raw) == -_sign(k4 * e_l):
            rate = 0.0
        else:
            rate = e_l
    return _clip(raw, limit), rate


@inline
def _dead_zone_side(z):
    """``(softplus(z), sigmoid(z))`` from one exponential.

    ``softplus(z) = max(z, 0) + log1p(exp(-|z|))`` as in
    `BacksteppingLaw.D`; the sigmoid ``1 / (1 + exp(-z))`` from the same
    ``exp(-|z|)`` equals the law's ``(1 + tanh(z / 2)) / 2`` to rounding
    and saves two of the law's seven transcendental calls.
    """
    e = math.exp(-abs(z))
    if z > 0.0:
        return z + math.log1p(e), 1.0 / (1.0 + e)
    return math.log1p(e), e / (1.0 + e)


@inline
def backstepping_law(x, d):
    """Motor torque of `backstepping_controller` (`BacksteppingLaw.torque`).

    The same expressions, with the divisions by constants as
    multiplications by their reciprocals (agreement to rounding).
    """
    x1, x2, x3, x4 = x[2], x[3], x[0], x[1]
    ks, cl, inv_jl = d[B_KS], d[B_CL], d[D_BIJL]
    c1, c3 = d[B_C1], d[B_C3]
    A, B = d[B_A], d[B_B]
    td_hat, alpha, k = d[B_TDHAT], d[B_ALPHA], d[B_K]
    dd = x3 - x1
    if math.isfinite(k):
        plus, plus_slope = _dead_zone_side(k * (dd - alpha))
        minus, minus_slope = _dead_zone_side(-k * (dd + alpha))
        value = (plus - minus) * d[D_BIK]
        slope = plus_slope + minus_slope
    else:
        value, slope = dd, 1.0
    a2 = (ks * value - cl * x2 - td_hat) * inv_jl
    a2dot = (ks * slope * (x4 - x2) - cl * a2) * inv_jl
    z1 = x1 - d[I_TR]
    z2 = x2 + c1 * z1
    T = A * z1 + B * x2 + td_hat
    Tdot = A * x2 + B * a2
    inv_keps = d[D_BIKEPS]
    th = math.tanh(T * inv_keps)
    sech2 = 1.0 - th * th
    inv = T * d[D_BIKS] + alpha * th
    inv1 = d[D_BIKS] + alpha * sech2 * inv_keps
    inv2 = -2.0 * alpha * sech2 * th * (inv_keps * inv_keps)
    z3 = dd - inv
    alpha3 = x2 + inv1 * Tdot - c3 * z3 - z2
    z4 = x4 - alpha3
    alpha3dot = (
        inv2 * Tdot * Tdot
        + inv1 * (A * a2 + B * a2dot)
        - c3 * (x4 - x2 - inv1 * Tdot)
        - c1 * x2
    )
    tq = d[B_CM] * x4 + ks * value + d[B_JM] * (alpha3dot - d[B_C4] * z4 - z3)
    return _clip(tq, d[C_LIMIT])


@inline
def nplant(d):
    """States of the plant: 5 (exact model) or 4 (dead zone)."""
    return 5 if d[P_MODEL] == 0.0 else 4


@inline
def torque(x, d):
    """``(Tm, d(controller state)/dt)``: the controller, or the held torque."""
    kind = d[C_KIND]
    if kind == 1.0:
        return lpv_law(x, nplant(d), d)
    if kind == 2.0:
        return backstepping_law(x, d), 0.0
    return d[I_TM], 0.0


@jit
def system_rhs(t, x, d, dx):
    """``dx/dt`` of the plant under the controller of `d`, written to dx."""
    tq_m, dxc = torque(x, d)
    ts, dtb = shaft(t, x, d)
    dx[0] = x[1]
    dx[1] = (tq_m - d[P_CM] * x[1] - ts) * d[D_IJM]
    dx[2] = x[3]
    dx[3] = (ts - d[P_CL] * x[3] - d[I_TD]) * d[D_IJL]
    n = nplant(d)
    if n == 5:
        dx[4] = dtb
    if x.size > n:
        dx[n] = dxc


@jit
def system_outputs(t, x, d, y):
    """Loop outputs ``theta_l, Tm, theta_m, omega_m, omega_l, Ts``."""
    y[0] = x[2]
    y[1] = torque(x, d)[0]
    y[2] = x[0]
    y[3] = x[1]
    y[4] = x[3]
    y[5] = shaft(t, x, d)[0]
