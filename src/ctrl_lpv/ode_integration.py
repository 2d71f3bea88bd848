"""ODE integration of a fused right-hand side at given output times.

`integrate` runs LSODA through `scipy.integrate.odeint` (the same solver as
``solve_ivp(method="LSODA")`` without solve_ivp's Python loop around every
step, which costs more than a fused right-hand side) and any other method
through `scipy.integrate.solve_ivp`; `before_divergence` recovers the
response up to a divergence the guard stopped.
"""

from __future__ import annotations

import contextlib
import math
import threading
import warnings

import numpy as np
import scipy
from scipy.integrate import ODEintWarning, odeint, solve_ivp

from .simulation_guard import DivergenceError

__all__ = ["ode_method", "integrate", "before_divergence"]

# solve_ivp keywords of LSODA under their odeint names; with any other
# keyword (events, dense_output, ...) the fast engine calls solve_ivp.
_ODEINT_NAMES = {"first_step": "h0", "max_step": "hmax", "min_step": "hmin"}
# odeint's limit of steps between two output times (default 500); solve_ivp
# has none, and a chattering loop can take thousands per output interval.
_ODEINT_MAX_STEPS = 10**9
# LSODA is thread-safe from scipy 1.17 (rewritten in C); before, two threads
# inside it at once (a threaded executor) corrupt each other's state.
_LSODA_GUARD = (
    contextlib.nullcontext()
    if tuple(int(v) for v in scipy.__version__.split(".")[:2]) >= (1, 17)
    else threading.Lock()
)


def ode_method(method) -> str:
    """`method` checked against `scipy.integrate`'s ODE solver classes.

    `solve_ivp` takes the name of any `scipy.integrate.OdeSolver` subclass
    it exports (``"RK45"``, ``"LSODA"``, ...): checked here, before the
    simulation is set up, so the message names the argument.
    """
    names = sorted(
        name
        for name, obj in vars(scipy.integrate).items()
        if isinstance(obj, type)
        and issubclass(obj, scipy.integrate.OdeSolver)
        and obj is not scipy.integrate.OdeSolver
    )
    if not isinstance(method, str):
        raise TypeError(f"method: expected a solve_ivp method name, got {method!r}")
    if method not in names:
        raise ValueError(
            f"method: unknown solve_ivp method {method!r}; use one of {names}"
        )
    return method


def before_divergence(exc, T, integrate):
    """The response before a divergence, by integrating again.

    The solvers lose their solution when the right-hand side raises, so the
    output times before the detection time ``exc.time`` are integrated
    again without the bound; a NaN found again (the solver evaluates a step
    ahead of its last accepted time) moves the end earlier. Raises `exc`
    when fewer than two output times remain.
    """
    stop = exc.time
    for _ in range(8):
        keep = T < stop
        if keep.sum() < 2:
            break
        try:
            with np.errstate(all="ignore"):
                return integrate(keep)
        except DivergenceError as again:
            stop = min(again.time, T[keep][-1])
    raise exc


def integrate(rhs, T, X0, kwargs) -> tuple[np.ndarray, np.ndarray, bool, str | None]:
    """Times reached, states (one column per time), success, message."""
    options = {k: v for k, v in kwargs.items() if k not in ("method", "rtol", "atol")}
    if kwargs["method"] != "LSODA" or not options.keys() <= _ODEINT_NAMES.keys():
        soln = solve_ivp(rhs, (T[0], T[-1]), X0, t_eval=T, **kwargs)
        message = None if soln.success else "solve_ivp failed: " + soln.message
        return soln.t, soln.y, bool(soln.success), message
    steps = {
        _ODEINT_NAMES[k]: v
        for k, v in options.items()
        if not (k == "max_step" and v == math.inf)  # odeint's default
    }
    with _LSODA_GUARD, warnings.catch_warnings():
        warnings.simplefilter("ignore", ODEintWarning)  # reported below
        X, info = odeint(
            rhs, X0, T, tfirst=True, rtol=kwargs["rtol"], atol=kwargs["atol"],
            full_output=True, mxstep=_ODEINT_MAX_STEPS, **steps,
        )  # fmt: skip
    if info["message"] == "Integration successful.":
        return T, X.T, True, None
    # Keep the output times that the solver reached before it stopped.
    reached = np.cumprod(np.asarray(info["tcur"]) >= T[1:])
    count = 1 + int(reached.sum())
    return T[:count], X[:count].T, False, "odeint (LSODA) failed: " + info["message"]
