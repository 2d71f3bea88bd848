"""The checks around a running simulation, and the errors they raise.

`Guard` wraps a right-hand side (the fused one of the fast engine, or
python-control's through a wrapper system): a state beyond ``state_bound``,
a NaN or infinite state, derivative or input raises `DivergenceError`
naming the signal and the time, and a wall-time limit raises
`SimulationTimeout`.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np

from .interconnection import system_plan

__all__ = ["SimulationError", "DivergenceError", "SimulationTimeout", "Guard"]

# The fast engine checks the state bound and the wall time at every
# _EVERY-th right-hand-side call (a power of two).
_EVERY = 8


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


class Guard:
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
            evaluation = None if sys is None else system_plan(sys)
            if evaluation is not None:
                with np.errstate(all="ignore"):
                    dx = np.asarray(evaluation.rhs(t, x, u), float).reshape(-1)
                self.check(t, xs, dx.tolist())
