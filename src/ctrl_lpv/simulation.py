"""Simulation of I/O systems with a fused right-hand side.

`simulate` returns the same `control.TimeResponseData` as
`control.input_output_response`.  Its ``"fast"`` engine generates one
right-hand side for the whole block diagram (`ctrl_lpv.evaluation_plan.plan`)
and integrates it directly: no fixed-point iteration over the subsystems,
no per-call input interpolation through numpy, and outputs computed
vectorized over the time points afterwards.  LSODA runs through
`scipy.integrate.odeint`, the same solver as ``solve_ivp(method="LSODA")``
without solve_ivp's Python loop around every step, which costs more than
the right-hand side itself.

Both engines watch the integration: a state beyond ``state_bound``, a NaN
or infinite state, derivative or input raises `DivergenceError` (naming the
signal and the time) instead of letting the solver grind on or
python-control report an "algebraic loop", and ``timeout=`` bounds the
wall time (`SimulationTimeout`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping

import control as ct
import numpy as np

from ._checks import flag, real_number
from .interconnection import system_plan
from .ode_integration import before_divergence, integrate, ode_method
from .simulation_guard import (
    DivergenceError,
    Guard,
    SimulationError,
    SimulationTimeout,
)
from .simulation_inputs import (
    fallback,
    initial_state,
    input_array,
    input_source,
    time_points,
)

__all__ = ["simulate", "SimulationError", "DivergenceError", "SimulationTimeout"]

_ENGINES = ("fast", "control")


def simulate(
    sys: ct.NonlinearIOSystem,
    T,
    U=0.0,
    X0=0.0,
    *,
    engine: str = "fast",
    method: str = "RK45",
    rtol: float = 1e-6,
    atol: float = 1e-9,
    params: Mapping | None = None,
    return_states: bool = False,
    squeeze: bool | None = None,
    transpose: bool = False,
    ignore_errors: bool = False,
    solve_ivp_kwargs: Mapping | None = None,
    state_bound: float | None = 1e12,
    timeout: float | None = None,
) -> ct.TimeResponseData:
    """Simulate an I/O system, with tighter tolerances than python-control.

    Parameters
    ----------
    sys : `control.NonlinearIOSystem`
        Continuous-time system, typically from `ctrl_lpv.interconnect` or
        `control.interconnect` (a `control.StateSpace` is one too).
    T : array_like
        Increasing time points; the response is returned at these times.
    U : float, array_like or list, optional
        Inputs at the times `T`, linearly interpolated in between, as in
        `control.input_output_response`: a scalar for every input, an
        array of shape ``(ninputs, len(T))`` (or ``(len(T),)`` for one
        input), or a list with one element (scalar, vector or time series)
        per input or group of inputs.  Default 0.
    X0 : float, array_like or list, optional
        Initial state; a scalar for every state, or a vector (a list is
        concatenated) padded with zeros as in python-control.  Default 0.
    engine : {"fast", "control"}, optional
        ``"fast"`` (default): one generated right-hand side for the whole
        diagram, integrated with `scipy.integrate.solve_ivp`, or with
        `scipy.integrate.odeint` for ``method="LSODA"`` (the same solver,
        three to four times less overhead per step).  Blocks
        without an algebraic loop are evaluated once per call in
        dependency order; with an algebraic loop the system's own
        (python-control's) evaluation is used.  ``"control"``: call
        `control.input_output_response` with the same solver settings.
    method : str, optional
        `scipy.integrate.solve_ivp` method, default ``"RK45"`` (as
        python-control); ``"LSODA"`` is usually several times faster on
        stiff drives.
    rtol, atol : float, optional
        Solver tolerances, default 1e-6 and 1e-9 (python-control's
        default ``rtol = 1e-3`` is too loose for most closed loops).
    params : dict, optional
        System parameters ``{name: value}``, set on `sys` (and its
        subsystems) for the whole simulation, as in
        `control.input_output_response`; for a `PolytopicStateSpace` with
        ``scheduling=None`` they are the frozen parameter values.
    return_states : bool, optional
        If True, unpacking the response as a tuple gives ``(time, outputs,
        states)`` instead of ``(time, outputs)``. Default False. The states
        are in ``response.states`` either way.
    squeeze : bool, optional
        If True, a single output (and input) is returned as a 1-D array;
        if False, always as 2-D arrays. Default None:
        ``control.config.defaults["control.squeeze_time_response"]``
        (1-D for a SISO system).
    transpose : bool, optional
        If True, the arrays are indexed by time first (as in
        `scipy.signal.lsim` and MATLAB). Default False.
    ignore_errors : bool, optional
        If False (default) a solver failure or a divergence raises;
        otherwise the response has ``success = False``, a message, and the
        solution up to the failure (a `SimulationTimeout` always raises).
    solve_ivp_kwargs : dict, optional
        Other `scipy.integrate.solve_ivp` keywords (``max_step``,
        ``first_step``, ...).
    state_bound : float or None, optional
        Divergence threshold: a state with ``|x_i| > state_bound`` stops the
        simulation with `DivergenceError` (default 1e12, in the states' own
        units; None disables it). A NaN or infinite state, state derivative
        or input always stops it with `DivergenceError`, with both engines
        (python-control itself reports a NaN signal in a diagram as an
        "algebraic loop").
    timeout : float or None, optional
        Wall-time limit in seconds (default None: none); beyond it the
        simulation stops with `SimulationTimeout`. Checked at every
        right-hand-side evaluation, with both engines.

    Returns
    -------
    `control.TimeResponseData`
        With the labels, shapes and fields of
        `control.input_output_response`.

    Raises
    ------
    TypeError
        If `sys` is not a `control.NonlinearIOSystem`, or `rtol`, `atol`,
        `method` or a flag has the wrong type (``rtol="1e-6"``,
        ``transpose="no"``).
    ValueError
        For an unknown `engine` or `method`, a discrete-time `sys` with the
        fast engine, a time vector that is not increasing and finite, inputs
        or initial state of the wrong size or not finite, or nonpositive
        tolerances.
    DivergenceError
        If a state exceeds `state_bound` or a signal is not finite (and
        `ignore_errors` is False); the message names the state and time.
    SimulationTimeout
        If the simulation takes longer than `timeout`.
    RuntimeError
        If the solver fails and `ignore_errors` is False.

    See Also
    --------
    ctrl_lpv.interconnect, control.input_output_response

    Examples
    --------
    >>> import control as ct
    >>> import numpy as np
    >>> from ctrl_lpv.simulation import simulate
    >>> sys = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0)
    >>> T = np.linspace(0.0, 1.0, 11)
    >>> resp = simulate(sys, T, 1.0)
    >>> bool(abs(resp.outputs[-1] - (1 - np.exp(-1.0))) < 1e-6)
    True
    """
    if not isinstance(sys, ct.NonlinearIOSystem):
        raise TypeError(
            f"sys: expected a control.NonlinearIOSystem, got {type(sys).__name__}"
        )
    if not isinstance(engine, str) or engine not in _ENGINES:
        raise ValueError(f"engine: expected one of {_ENGINES}, got {engine!r}")
    rtol = real_number(rtol, "rtol", positive=True)
    atol = real_number(atol, "atol", positive=True)
    method = ode_method(method)
    return_states = flag(return_states, "return_states")
    transpose = flag(transpose, "transpose")
    ignore_errors = flag(ignore_errors, "ignore_errors")
    if squeeze is not None:
        squeeze = flag(squeeze, "squeeze")
    start = time.perf_counter()
    for label, value in (("state_bound", state_bound), ("timeout", timeout)):
        if value is not None and not (
            isinstance(value, (int, float, np.floating, np.integer))
            and not isinstance(value, bool)
            and value > 0
            and (label == "state_bound" or value < math.inf)
        ):
            raise ValueError(
                f"{label}: expected None or a positive number, got {value!r}"
            )
    T = time_points(T)
    U = input_array(U, sys.ninputs, T.size)
    X0 = initial_state(X0, sys.nstates)
    kwargs = dict(solve_ivp_kwargs or {})
    for key in ("method", "rtol", "atol", "t_eval"):
        if key in kwargs:
            raise ValueError(
                f"solve_ivp_kwargs: pass {key!r} as an argument of simulate"
            )
    kwargs.update(method=method, rtol=rtol, atol=atol)

    guard = Guard(sys, state_bound, timeout, start, T)
    if engine == "control":
        return _control_engine(
            sys, guard, T, U, X0, kwargs, params=params,
            return_states=return_states, squeeze=squeeze, transpose=transpose,
            ignore_errors=ignore_errors,
        )  # fmt: skip
    if sys.isdtime(strict=True):
        raise ValueError(
            "sys: the fast engine simulates continuous-time systems; use "
            "engine='control' for discrete time"
        )

    sys._update_params(params)
    evaluation = system_plan(sys)
    if evaluation is None:
        rhs, out_many = fallback(sys, T, U)
    else:
        rhs, out_many = evaluation.rhs_function(input_source(T, U)), None

    message, success = None, True
    if sys.nstates == 0:
        t, X = T, np.zeros((0, T.size))
    else:
        try:
            t, X, success, message = integrate(guard.fast(rhs), T, X0, kwargs)
        except DivergenceError as exc:
            if not ignore_errors:
                raise
            unbounded = Guard(sys, None, timeout, start, T).fast(rhs)
            t, X, _, _ = before_divergence(
                exc, T, lambda keep: integrate(unbounded, T[keep], X0, kwargs)
            )
            success, message = False, str(exc)
        if not success and not ignore_errors:
            raise RuntimeError(message)
    Ut = U[:, : t.size]
    if out_many is not None:
        Y = out_many(t, X, Ut)
    else:
        Y = np.asarray(evaluation.out_many(t, list(X), list(Ut)), dtype=float)
        Y = Y.reshape(sys.noutputs, t.size)
    return ct.TimeResponseData(
        t, Y, X, Ut, params=params, issiso=sys.issiso(),
        output_labels=sys.output_labels, input_labels=sys.input_labels,
        state_labels=sys.state_labels, sysname=sys.name,
        title="Input/output response for " + sys.name, transpose=transpose,
        return_x=return_states, squeeze=squeeze, success=success,
        message=message,
    )  # fmt: skip


def _control_engine(sys, guard, T, U, X0, kwargs, *, params, ignore_errors,
                    **options):  # fmt: skip
    """`control.input_output_response` on `sys` with the checks.

    python-control evaluates a wrapper system whose update function calls
    ``sys._rhs`` after the checks and whose output function is
    ``sys._out``; the parameters go to `sys` as python-control would pass
    them.
    """
    sys._update_params(params)
    sys_out = sys._out

    def run(guard, T_, U_, **extra):
        wrapper = ct.nlsys(
            guard.control(sys), lambda t, x, u, params=None: sys_out(t, x, u),
            inputs=sys.input_labels, outputs=sys.output_labels,
            states=sys.state_labels, name=sys.name, dt=sys.dt,
        )  # fmt: skip
        return ct.input_output_response(
            wrapper, T_, U_, X0, params=params, solve_ivp_kwargs=kwargs,
            **extra, **options,
        )  # fmt: skip

    try:
        return run(guard, T, U, ignore_errors=ignore_errors)
    except DivergenceError as exc:
        if not ignore_errors:
            raise
        unbounded = Guard(sys, None, guard.timeout, guard.start, T)
        resp = before_divergence(
            exc, T, lambda keep: run(unbounded, T[keep], U[:, keep], ignore_errors=True)
        )
        resp.success, resp.message = False, str(exc)
        return resp
