"""Time points, inputs and initial states of a simulation, checked.

python-control's conventions of `control.input_output_response`: inputs
given per time point (or as scalars and lists), linearly interpolated in
between; an initial state padded with zeros.
"""

from __future__ import annotations

import warnings
from bisect import bisect_left
from collections.abc import Callable

import numpy as np

__all__ = ["time_points", "input_array", "initial_state", "input_source", "fallback"]


def time_points(T) -> np.ndarray:
    try:
        T = np.asarray(T, dtype=float)
    except (TypeError, ValueError):
        raise TypeError(f"T: expected an array of times, got {T!r}") from None
    if T.ndim != 1 or T.size < 2:
        raise ValueError(f"T: expected a 1-D array of at least 2 times, got {T.shape}")
    if not np.all(np.isfinite(T)) or not np.all(np.diff(T) > 0):
        raise ValueError("T: times must be finite and strictly increasing")
    return T


def input_array(U, ninputs: int, npoints: int) -> np.ndarray:
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


def initial_state(X0, nstates: int) -> np.ndarray:
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


def input_source(T: np.ndarray, U: np.ndarray):
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


def fallback(sys, T, U) -> tuple[Callable, Callable]:
    """RHS and outputs through the system's own methods."""
    source = input_source(T, U)
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
