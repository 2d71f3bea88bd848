"""Dormand-Prince 5(4) on the two-mass loop, compiled by numba.

scipy's ``RK45`` step for step: the same Butcher tableau, error norm (RMS
of the error over ``atol + rtol max(|y|, |y_new|)``), step-size control
(safety 0.9, factors 0.2 to 10, no growth right after a rejection), initial
step selection and quartic dense output (Shampine's), so that its accuracy
at a tolerance is scipy's RK45 accuracy at that tolerance, without
solve_ivp's Python loop. The right-hand side is
`compiled_kernels.system_rhs`, called directly: numba caches only functions
whose callees are fixed (a right-hand side passed as an argument is
compiled again in every process), and the JIT warm-up then happens once
per installation rather than once per process.

Differences from solve_ivp: the integration restarts at the breakpoints
of the data (a step of the backlash ``alpha(t)``), where the right-hand
side jumps; and a state beyond ``state_bound`` stops it (status
`DIVERGED`), as the guard of `ctrl_lpv.simulate` does.

Imported only by the compiled engine: it needs numba.
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from .compiled_data import P_AT
from .compiled_kernels import jit, system_outputs, system_rhs

__all__ = ["solve", "advance", "outputs", "OK", "TOO_SMALL", "DIVERGED", "STEPS"]

# numba's on-disk cache keys a function on its own source file only: a
# change in a file it takes code or constants from (the kernels, the data
# layout, the plant's contact layer) would leave a stale compiled function
# in use. The fingerprint of all of them, compiled into `fingerprint`,
# tells `ctrl_lpv.twomass.compiled` when to throw the cache away.
SOURCES = ("compiled_data.py", "compiled_kernels.py", "dopri5.py", "plant.py")
FINGERPRINT = int(
    hashlib.sha256(
        b"".join((Path(__file__).parent / name).read_bytes() for name in SOURCES)
    ).hexdigest()[:15],
    16,
)

# Status codes.
OK, TOO_SMALL, DIVERGED, STEPS = 0, 1, 2, 3

C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0])
A = np.array([
    [0.0, 0.0, 0.0, 0.0, 0.0],
    [1 / 5, 0.0, 0.0, 0.0, 0.0],
    [3 / 40, 9 / 40, 0.0, 0.0, 0.0],
    [44 / 45, -56 / 15, 32 / 9, 0.0, 0.0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0.0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
])  # fmt: skip
B = np.array([35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84])
E = np.array([-71 / 57600, 0.0, 71 / 16695, -71 / 1920, 17253 / 339200,
              -22 / 525, 1 / 40])  # fmt: skip
P = np.array([
    [1.0, -8048581381 / 2820520608, 8663915743 / 2820520608,
     -12715105075 / 11282082432],
    [0.0, 0.0, 0.0, 0.0],
    [0.0, 131558114200 / 32700410799, -68118460800 / 10900136933,
     87487479700 / 32700410799],
    [0.0, -1754552775 / 470086768, 14199869525 / 1410260304,
     -10690763975 / 1880347072],
    [0.0, 127303824393 / 49829197408, -318862633887 / 49829197408,
     701980252875 / 199316789632],
    [0.0, -282668133 / 205662961, 2019193451 / 616988883,
     -1453857185 / 822651844],
    [0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
])  # fmt: skip
SAFETY, MIN_FACTOR, MAX_FACTOR = 0.9, 0.2, 10.0
EXPONENT = -1.0 / 5.0  # error estimator of order 4


@jit
def fingerprint():
    """`FINGERPRINT` as it was when this code was compiled."""
    return FINGERPRINT


@jit
def _initial_step(d, t0, y0, f0, t_bound, rtol, atol, y1, f1):
    """scipy's `select_initial_step` (Hairer, Norsett and Wanner II.4)."""
    n = y0.size
    interval = t_bound - t0
    if interval <= 0.0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        scale = atol + abs(y0[i]) * rtol
        d0 += (y0[i] / scale) ** 2
        d1 += (f0[i] / scale) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        y1[i] = y0[i] + h0 * f0[i]
    system_rhs(t0 + h0, y1, d, f1)
    d2 = 0.0
    for i in range(n):
        scale = atol + abs(y0[i]) * rtol
        d2 += ((f1[i] - f0[i]) / scale) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 5.0)
    return min(100.0 * h0, h1, interval)


# The tableau as scalars: the stages below are written out (numba then
# keeps every coefficient in a register; loops over the tableau cost a third
# of a step).
A21 = A[1, 0]
A31, A32 = A[2, 0], A[2, 1]
A41, A42, A43 = A[3, 0], A[3, 1], A[3, 2]
A51, A52, A53, A54 = A[4, 0], A[4, 1], A[4, 2], A[4, 3]
A61, A62, A63, A64, A65 = A[5, 0], A[5, 1], A[5, 2], A[5, 3], A[5, 4]
B1, B3, B4, B5, B6 = B[0], B[2], B[3], B[4], B[5]
E1, E3, E4, E5, E6, E7 = E[0], E[2], E[3], E[4], E[5], E[6]
C2, C3, C4, C5 = C[1], C[2], C[3], C[4]


@jit
def _segment(d, y, t, t_end, h_abs, rtol, atol, bound, t_eval, X, i, K, work,
             max_steps):  # fmt: skip
    """Integrate y (in place) from t to t_end; fill X at t_eval[i:] <= t_end.

    Returns (status, t reached, next step size, next index of t_eval,
    steps taken).  ``K[0]`` holds f(t, y) on entry.
    """
    n = y.size
    y_new = work[0]
    y_tmp = work[1]
    Q = np.empty((n, 4))
    k1, k2, k3, k4, k5, k6, k7 = K[0], K[1], K[2], K[3], K[4], K[5], K[6]
    steps = 0
    while t < t_end:
        if steps >= max_steps:
            return STEPS, t, h_abs, i, steps
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if h_abs < min_step:
                return TOO_SMALL, t, h_abs, i, steps
            t_new = t + h_abs
            if t_new > t_end:
                t_new = t_end
            h = t_new - t
            for m in range(n):
                y_tmp[m] = y[m] + h * (A21 * k1[m])
            system_rhs(t + C2 * h, y_tmp, d, k2)
            for m in range(n):
                y_tmp[m] = y[m] + h * (A31 * k1[m] + A32 * k2[m])
            system_rhs(t + C3 * h, y_tmp, d, k3)
            for m in range(n):
                y_tmp[m] = y[m] + h * (A41 * k1[m] + A42 * k2[m] + A43 * k3[m])
            system_rhs(t + C4 * h, y_tmp, d, k4)
            for m in range(n):
                y_tmp[m] = y[m] + h * (
                    A51 * k1[m] + A52 * k2[m] + A53 * k3[m] + A54 * k4[m]
                )
            system_rhs(t + C5 * h, y_tmp, d, k5)
            for m in range(n):
                y_tmp[m] = y[m] + h * (
                    A61 * k1[m] + A62 * k2[m] + A63 * k3[m] + A64 * k4[m]
                    + A65 * k5[m]
                )  # fmt: skip
            system_rhs(t + h, y_tmp, d, k6)
            for m in range(n):
                y_new[m] = y[m] + h * (
                    B1 * k1[m] + B3 * k3[m] + B4 * k4[m] + B5 * k5[m] + B6 * k6[m]
                )
            system_rhs(t_new, y_new, d, k7)
            err = 0.0
            for m in range(n):
                e = (E1 * k1[m] + E3 * k3[m] + E4 * k4[m] + E5 * k5[m]
                     + E6 * k6[m] + E7 * k7[m])  # fmt: skip
                scale = atol + max(abs(y[m]), abs(y_new[m])) * rtol
                err += (h * e / scale) ** 2
            err = math.sqrt(err / n)
            if err < 1.0:
                if err == 0.0:
                    factor = MAX_FACTOR
                else:
                    factor = min(MAX_FACTOR, SAFETY * err**EXPONENT)
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            if math.isfinite(err):
                h_abs *= max(MIN_FACTOR, SAFETY * err**EXPONENT)
            else:
                h_abs *= MIN_FACTOR
            rejected = True
        steps += 1
        # Dense output at the requested times in (t, t_new]: the quartic
        # y + h (Q0 s + Q1 s^2 + Q2 s^3 + Q3 s^4), Q = K^T P, s = (t' - t)/h.
        if i < t_eval.size and t_eval[i] <= t_new:
            for m in range(n):
                for c in range(4):
                    acc = 0.0
                    for j in range(7):
                        acc += K[j, m] * P[j, c]
                    Q[m, c] = acc
        while i < t_eval.size and t_eval[i] <= t_new:
            if t_eval[i] == t_new:
                for m in range(n):
                    X[m, i] = y_new[m]
            else:
                sigma = (t_eval[i] - t) / h
                for m in range(n):
                    q = Q[m, 2] + sigma * Q[m, 3]
                    q = Q[m, 0] + sigma * (Q[m, 1] + sigma * q)
                    X[m, i] = y[m] + h * sigma * q
            i += 1
        for m in range(n):
            y[m] = y_new[m]
            k1[m] = k7[m]
        t = t_new
        for m in range(n):
            if not abs(y[m]) <= bound:
                return DIVERGED, t, h_abs, i, steps
    return OK, t, h_abs, i, steps


@jit
def solve(d, x0, t_eval, rtol, atol, bound, max_steps):
    """States at the increasing times `t_eval`, from `x0` at ``t_eval[0]``.

    Restarts at the backlash step ``d[P_AT]`` if it lies inside.  Returns
    (X of shape ``(n, len(t_eval))``, status, time reached, steps).
    """
    n = x0.size
    npts = t_eval.size
    X = np.empty((n, npts))
    K = np.empty((7, n))
    work = np.empty((2, n))
    y = x0.copy()
    t = t_eval[0]
    for m in range(n):
        X[m, 0] = y[m]
    i = 1
    t_final = t_eval[npts - 1]
    steps = 0
    at = d[P_AT]
    ends = (at, t_final) if t < at < t_final else (t_final, t_final)
    for end in ends:
        if t >= end:
            continue
        system_rhs(t, y, d, K[0])
        h_abs = _initial_step(d, t, y, K[0], end, rtol, atol, work[0], work[1])
        status, t, _, i, taken = _segment(
            d,
            y,
            t,
            end,
            h_abs,
            rtol,
            atol,
            bound,
            t_eval,
            X,
            i,
            K,
            work,
            max_steps - steps,
        )
        steps += taken
        if status != OK:
            X[:, i:] = np.nan  # not reached
            return X, status, t, steps
    return X, OK, t, steps


@jit
def advance(d, x0, t0, t1, rtol, atol, h_abs, max_steps):
    """The state at `t1` from `x0` at `t0` (inputs held in `d`).

    `h_abs` is the first step (0: select one, as `solve` does); returns
    (state, status, time reached, the step size to start the next interval
    with).
    """
    n = x0.size
    K = np.empty((7, n))
    work = np.empty((2, n))
    y = x0.copy()
    X = np.empty((n, 0))
    t_eval = np.empty(0)
    system_rhs(t0, y, d, K[0])
    if h_abs <= 0.0:
        h_abs = _initial_step(d, t0, y, K[0], t1, rtol, atol, work[0], work[1])
    status, t, h_abs, _, _ = _segment(
        d, y, t0, t1, h_abs, rtol, atol, np.inf, t_eval, X, 0, K, work, max_steps
    )
    return y, status, t, h_abs


@jit
def outputs(d, t_eval, X):
    """Loop outputs (`system_outputs`) at each time, one column per time."""
    Y = np.empty((6, t_eval.size))
    y = np.empty(6)
    x = np.empty(X.shape[0])
    for i in range(t_eval.size):
        for m in range(x.size):
            x[m] = X[m, i]
        system_outputs(t_eval[i], x, d, y)
        for m in range(6):
            Y[m, i] = y[m]
    return Y
