"""Simulation of I/O systems with a fused right-hand side.

`simulate` returns the same `control.TimeResponseData` as
`control.input_output_response`.  Its ``"fast"`` engine generates one
right-hand side for the whole block diagram (`ctrl_lpv.interconnection.plan`)
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

import contextlib
import itertools
import math
import threading
import time
import warnings
from bisect import bisect_left
from collections.abc import Callable, Mapping

import control as ct
import numpy as np
import scipy
from scipy.integrate import ODEintWarning, odeint, solve_ivp

from ._checks import flag, real_number
from .interconnection import _FastMixin, plan

__all__ = ["simulate", "SimulationError", "DivergenceError", "SimulationTimeout"]

_ENGINES = ("fast", "control")
# The fast engine checks the state bound and the wall time at every
# _EVERY-th right-hand-side call (a power of two).
_EVERY = 8

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


class SimulationError(RuntimeError):
    """A simulation stopped by one of `simulate`'s checks.

    Attributes
    ----------
    time : float
        Simulation time at which the check failed.
    """

    def __init__(self, message: str, time: float):
        super().__init__(message)
        self.time = float(time)


class DivergenceError(SimulationError):
    """A state left ``state_bound`` or a signal became NaN or infinite.

    Raised by `simulate` with both engines; the message names the state (or
    input) and the simulation time.

    Attributes
    ----------
    time : float
        Simulation time of the detection.
    signal : str
        Label of the state, state derivative (``d<label>/dt``) or input.
    value : float
        Its value there.
    """

    def __init__(self, message: str, time: float, signal: str, value: float):
        super().__init__(message, time)
        self.signal = signal
        self.value = float(value)


class SimulationTimeout(SimulationError, TimeoutError):
    """A simulation ran longer than its ``timeout`` (seconds of wall time).

    Attributes
    ----------
    time : float
        Simulation time reached.
    timeout : float
        The limit, s.
    """

    def __init__(self, message: str, time: float, timeout: float):
        super().__init__(message, time)
        self.timeout = float(timeout)


class _Guard:
    """Divergence, non-finite and wall-time checks around a right-hand side.

    A check costs a few list operations: sums propagate NaN and infinity,
    and ``max``/``min`` of the states find a bound violation; the labels
    are looked up only on failure (`check`).
    """

    def __init__(self, sys, state_bound, timeout, start, T):
        self.states = list(sys.state_labels)
        self.inputs = list(sys.input_labels)
        self.bound = math.inf if state_bound is None else float(state_bound)
        self.timeout, self.start = timeout, start
        self.deadline = math.inf if timeout is None else start + timeout
        self.span = (float(T[0]), float(T[-1]))
        self.clock = time.perf_counter

    def fast(self, rhs):
        """``f(t, x)`` with the checks, for solve_ivp and odeint.

        The derivative is checked at every call (a NaN or infinity makes
        the sum of its entries NaN), the state bound and the wall time at
        every `_EVERY`-th call: the right-hand side of a fused diagram
        costs about a microsecond, and the checks should not double it.
        """
        bound, clock, deadline = self.bound, self.clock, self.deadline
        check, every = self.check, _EVERY - 1
        calls = itertools.count()

        def guarded(t, x):
            try:
                dx = rhs(t, x)
            except RuntimeError as exc:
                self.algebraic_loop(exc, t, x, None)
                raise
            s = sum(dx)
            if s - s != 0.0:
                check(t, x.tolist(), dx)
            if not next(calls) & every:
                xs = x.tolist()
                s = sum(xs)
                if s - s != 0.0 or max(xs) > bound or min(xs) < -bound:
                    check(t, xs, dx)
                if clock() > deadline:
                    self.expired(t)
            return dx

        return guarded

    def control(self, sys):
        """``updfcn(t, x, u, params)`` for a wrapper of `sys`."""
        sys_rhs, bound, clock, deadline = (
            sys._rhs,
            self.bound,
            self.clock,
            self.deadline,
        )

        def updfcn(t, x, u, params=None):
            xs = np.asarray(x, dtype=float).reshape(-1).tolist()
            if xs:
                s = sum(xs)
                if s - s != 0.0 or max(xs) > bound or min(xs) < -bound:
                    self.check(t, xs, ())
            try:
                dx = sys_rhs(t, x, u)
            except RuntimeError as exc:
                self.algebraic_loop(exc, t, x, u, sys)
                raise
            dx = np.asarray(dx, dtype=float).reshape(-1)
            s = float(np.sum(dx))
            if s - s != 0.0:
                self.check(t, xs, dx.tolist())
            if clock() > deadline:
                self.expired(t)
            return dx

        return updfcn

    def check(self, t, xs, dx):
        """Raise `DivergenceError` for the first failing state, if any."""
        for label, v in zip(self.states, xs):
            if not math.isfinite(v):
                self.diverged(t, label, v, f"state {label!r} is {v} at t = {t:.6g}")
        for label, v in zip(self.states, dx):
            if not math.isfinite(v):
                self.diverged(
                    t, f"d{label}/dt", v,
                    f"the derivative of state {label!r} is {v} at t = {t:.6g} "
                    "(a NaN or infinite signal in the system, e.g. a scheduling "
                    "parameter or a controller output)",
                )  # fmt: skip
        for label, v in zip(self.states, xs):
            if abs(v) > self.bound:
                self.diverged(
                    t, label, v,
                    f"state {label!r} = {v:.4g} exceeds state_bound = "
                    f"{self.bound:g} at t = {t:.6g}: the simulation diverges "
                    "(an unstable closed loop?); pass state_bound=None to "
                    "integrate on",
                )  # fmt: skip

    def diverged(self, t, label, value, message):
        raise DivergenceError(message, t, label, value)

    def expired(self, t):
        raise SimulationTimeout(
            f"simulation exceeded timeout = {self.timeout:g} s of wall time "
            f"at t = {t:.6g} of [{self.span[0]:g}, {self.span[1]:g}]",
            t,
            self.timeout,
        )

    def algebraic_loop(self, exc, t, x, u, sys=None):
        """Explain python-control's "algebraic loop" from a NaN signal.

        python-control finds the signals of a diagram by fixed-point
        iteration, which never converges on a NaN; the one-pass plan (when
        the diagram has no structural algebraic loop) shows which state
        derivative is not finite.
        """
        if "algebraic loop" not in str(exc).lower():
            return
        xs = np.asarray(x, dtype=float).reshape(-1).tolist()
        self.check(t, xs, ())
        if u is not None:
            for label, v in zip(self.inputs, np.asarray(u, float).reshape(-1)):
                if not math.isfinite(v):
                    self.diverged(t, label, v, f"input {label!r} is {v} at t = {t:.6g}")
            evaluation = None
            if sys is not None:
                evaluation = sys._plan() if isinstance(sys, _FastMixin) else plan(sys)
            if evaluation is not None:
                with np.errstate(all="ignore"):
                    dx = np.asarray(evaluation.rhs(t, x, u), float).reshape(-1)
                self.check(t, xs, dx.tolist())


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
    method = _ode_method(method)
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
    T = _time_points(T)
    U = _inputs(U, sys.ninputs, T.size)
    X0 = _initial_state(X0, sys.nstates)
    kwargs = dict(solve_ivp_kwargs or {})
    for key in ("method", "rtol", "atol", "t_eval"):
        if key in kwargs:
            raise ValueError(
                f"solve_ivp_kwargs: pass {key!r} as an argument of simulate"
            )
    kwargs.update(method=method, rtol=rtol, atol=atol)

    guard = _Guard(sys, state_bound, timeout, start, T)
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
    evaluation = sys._plan() if isinstance(sys, _FastMixin) else plan(sys)
    if evaluation is None:
        rhs, out_many = _fallback(sys, T, U)
    else:
        rhs, out_many = evaluation.rhs_function(_input_source(T, U)), None

    message, success = None, True
    if sys.nstates == 0:
        t, X = T, np.zeros((0, T.size))
    else:
        try:
            t, X, success, message = _integrate(guard.fast(rhs), T, X0, kwargs)
        except DivergenceError as exc:
            if not ignore_errors:
                raise
            unbounded = _Guard(sys, None, timeout, start, T).fast(rhs)
            t, X, _, _ = _before(
                exc, T, lambda keep: _integrate(unbounded, T[keep], X0, kwargs)
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


def _ode_method(method) -> str:
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


def _before(exc, T, integrate):
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
        unbounded = _Guard(sys, None, guard.timeout, guard.start, T)
        resp = _before(
            exc, T, lambda keep: run(unbounded, T[keep], U[:, keep], ignore_errors=True)
        )
        resp.success, resp.message = False, str(exc)
        return resp


def _integrate(rhs, T, X0, kwargs) -> tuple[np.ndarray, np.ndarray, bool, str | None]:
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


def _time_points(T) -> np.ndarray:
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"T: expected an array of times, got {T!r}") from None
    if T.ndim != 1 or T.size < 2:
        raise ValueError(f"T: expected a 1-D array of at least 2 times, got {T.shape}")
    if not np.all(np.isfinite(T)) or not np.all(np.diff(T) > 0):
        raise ValueError("T: times must be finite and strictly increasing")
    return T


def _inputs(U, ninputs: int, npoints: int) -> np.ndarray:
    """Inputs as an (ninputs, npoints) array, python-control's rules."""
    if isinstance(U, (list, tuple)) and len(U) != npoints:
        rows = []
        for i, u in enumerate(U):
            u = np.asarray(u, dtype=float)
            if u.ndim == 0 or (u.ndim == 1 and u.shape[0] != npoints):
                u = np.outer(u, np.ones(npoints))
            elif not (u.ndim in (1, 2) and u.shape[-1] == npoints):
                raise ValueError(f"U[{i}]: shape {u.shape} does not match T")
            rows.append(u.reshape(-1, npoints))
        U = np.vstack(rows) if rows else np.zeros((0, npoints))
    try:
        U = np.asarray(U, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"U: expected numbers, got {U!r}") from None
    if U.ndim == 0:
        U = np.full((ninputs, npoints), float(U))
    elif U.ndim == 1 and ninputs == 1 and U.size == npoints:
        U = U.reshape(1, npoints)
    if U.shape != (ninputs, npoints):
        raise ValueError(
            f"U: expected shape ({ninputs}, {npoints}) for {ninputs} input(s) "
            f"at {npoints} times, got {U.shape}"
        )
    if not np.all(np.isfinite(U)):
        raise ValueError("U: inputs must be finite")
    return U


def _initial_state(X0, nstates: int) -> np.ndarray:
    if isinstance(X0, (list, tuple)):
        X0 = [v for x in X0 for v in np.asarray(x, dtype=float).reshape(-1)]
    try:
        X0 = np.asarray(X0, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"X0: expected numbers, got {X0!r}") from None
    if X0.ndim == 0:
        X0 = np.full(nstates, float(X0))
    X0 = X0.reshape(-1)
    if X0.size < nstates:
        if X0.size and X0[-1] != 0:
            warnings.warn("X0 too short; padding with zeros", stacklevel=3)
        X0 = np.concatenate([X0, np.zeros(nstates - X0.size)])
    if X0.size != nstates:
        raise ValueError(f"X0: expected {nstates} initial states, got {X0.size}")
    if not np.all(np.isfinite(X0)):
        raise ValueError("X0: initial state must be finite")
    return X0


def _input_source(T: np.ndarray, U: np.ndarray):
    """Constant inputs as a tuple, else an interpolating function.

    The interpolation is python-control's (``ufun`` in
    `control.input_output_response`): linear between the samples,
    extrapolated linearly beyond them, written on Python floats.
    """
    if U.shape[0] == 0 or np.all(U == U[:, :1]):
        return tuple(U[:, 0].tolist())
    times, rows, last = T.tolist(), U.T.tolist(), T.size - 1

    def inputs(t):
        i = bisect_left(times, t)
        i = 1 if i < 1 else (last if i > last else i)
        t0 = times[i - 1]
        w = (t - t0) / (times[i] - t0)
        return [a * (1.0 - w) + b * w for a, b in zip(rows[i - 1], rows[i])]

    return inputs


def _fallback(sys, T, U) -> tuple[Callable, Callable]:
    """RHS and outputs through the system's own methods."""
    source = _input_source(T, U)
    if callable(source):

        def u_at(t):
            return np.array(source(t), dtype=float)

    else:
        constant = np.array(source, dtype=float)

        def u_at(t):
            return constant

    sys_rhs, sys_out = sys._rhs, sys._out

    def rhs(t, x):
        return sys_rhs(t, x, u_at(t))

    def out_many(t, X, U):
        Y = np.zeros((sys.noutputs, t.size))
        for i in range(t.size):
            Y[:, i] = sys_out(t[i], X[:, i], U[:, i])
        return Y

    return rhs, out_many
