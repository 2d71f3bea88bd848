"""Step-response and rest metrics of any simulated response."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

__all__ = ["RestMetrics", "StepMetrics", "rest_metrics", "step_metrics"]


class _Metrics:
    """`as_dict` of the metrics dataclasses."""

    def as_dict(self) -> dict[str, float]:
        """The metrics as a plain dictionary (for tables and JSON)."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


@dataclass(frozen=True)
class StepMetrics(_Metrics):
    """Metrics of a step response towards a constant reference.

    Attributes
    ----------
    rise_time : float
        10-90 % rise time, s (``inf`` if 90 % is never reached).
    settling_time : float
        Time after which ``|r - y|`` stays within `settling_band` of the step
        size, s (``inf`` if it is outside at the end).
    overshoot : float
        Largest excursion past the reference, percent of the step size.
    steady_state_error : float
        ``r - y`` at the final time.
    iae, ise : float
        Integral of ``|r - y|`` and of ``(r - y)^2`` over the response.
    peak_input : float
        Largest ``|u|`` (nan without an input signal).
    energy : float
        Integral of ``u^2`` (nan without an input signal).
    """

    rise_time: float
    settling_time: float
    overshoot: float
    steady_state_error: float
    iae: float
    ise: float
    peak_input: float
    energy: float


def _crossing(t, y, level, rising):
    """First time `y` reaches `level` (linear interpolation), or inf."""
    above = y >= level if rising else y <= level
    if not above.any():
        return np.inf
    i = int(np.argmax(above))
    if i == 0:
        return float(t[0])
    frac = (level - y[i - 1]) / (y[i] - y[i - 1])
    return float(t[i - 1] + frac * (t[i] - t[i - 1]))


def _integral(dt, values):
    """Trapezoidal integral of `values` over the steps `dt` of the times."""
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * dt))


def _signals(t, y, reference, u):
    """`t`, `y` and `u` (or None) as checked float arrays of one length."""
    t = np.asarray(t, float).reshape(-1)
    y = np.asarray(y, float).reshape(-1)
    if t.shape != y.shape or t.size < 2:
        raise ValueError(f"t, y: expected equal lengths >= 2, got {t.size}, {y.size}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("t: time points must be increasing")
    if not (np.all(np.isfinite(y)) and np.isfinite(reference)):
        raise ValueError("y, reference: values must be finite")
    if u is not None:
        u = np.asarray(u, float).reshape(-1)
        if u.shape != t.shape:
            raise ValueError(f"u: expected {t.size} samples, got {u.size}")
    return t, y, u


def step_metrics(
    t,
    y,
    reference: float,
    u=None,
    *,
    initial: float | None = None,
    settling_band: float = 0.02,
) -> StepMetrics:
    """Compute the step metrics of a response.

    Parameters
    ----------
    t : array_like
        Time points, increasing (use a dense grid: metrics interpolate
        linearly between samples).
    y : array_like
        Controlled output at `t`.
    reference : float
        Constant reference the output should reach.
    u : array_like, optional
        Control input at `t`, for the peak and the energy.
    initial : float, optional
        Output before the step; default ``y[0]``.
    settling_band : float, optional
        Relative band of the settling time, default 0.02 (2 %).

    Returns
    -------
    `StepMetrics`

    Raises
    ------
    ValueError
        If the arrays do not match, `t` is not increasing, or the reference
        equals the initial value (no step).

    Examples
    --------
    >>> t = np.linspace(0, 10, 10001)
    >>> m = step_metrics(t, 1 - np.exp(-t), 1.0)
    >>> round(m.rise_time, 3)   # ln 9
    2.197
    """
    t, y, u = _signals(t, y, reference, u)
    dt = np.diff(t)
    y0 = float(y[0]) if initial is None else float(initial)
    step = float(reference) - y0
    if step == 0:
        raise ValueError("reference: equals the initial value, there is no step")
    rising = step > 0
    error = reference - y

    rise = _crossing(t, y, y0 + 0.9 * step, rising) - _crossing(
        t, y, y0 + 0.1 * step, rising
    )
    outside = np.abs(error) > settling_band * abs(step)
    if not outside.any():
        settling = float(t[0])
    elif outside[-1]:
        settling = np.inf
    else:
        last = int(np.nonzero(outside)[0][-1])
        # Interpolate where |error| re-enters the band after the last exit.
        e0, e1 = abs(error[last]), abs(error[last + 1])
        band = settling_band * abs(step)
        frac = (e0 - band) / (e0 - e1) if e0 != e1 else 1.0
        settling = float(t[last] + frac * (t[last + 1] - t[last]))
    past = (y - reference) / step
    overshoot = max(0.0, float(past.max()) * 100.0)

    if u is None:
        peak, energy = np.nan, np.nan
    else:
        peak, energy = float(np.abs(u).max()), _integral(dt, u**2)
    return StepMetrics(
        rise_time=float(rise),
        settling_time=settling,
        overshoot=overshoot,
        steady_state_error=float(error[-1]),
        iae=_integral(dt, np.abs(error)),
        ise=_integral(dt, error**2),
        peak_input=peak,
        energy=energy,
    )


@dataclass(frozen=True)
class RestMetrics(_Metrics):
    """Metrics of the rest at the end of a response (its last `window` s).

    Attributes
    ----------
    window : float
        Length of the end of the response measured, s.
    error_peak_to_peak : float
        Peak-to-peak of ``r - y`` over the window (a limit cycle's size).
    max_error : float
        Largest ``|r - y|`` over the window.
    input_std : float
        Standard deviation of ``u`` over the window (the torque chatter of
        a drive at rest; nan without an input signal).
    input_ripple : float
        Largest ``|u - mean(u)|`` over the window (nan without an input).
    """

    window: float
    error_peak_to_peak: float
    max_error: float
    input_std: float
    input_ripple: float


def rest_metrics(t, y, reference: float, u=None, *, window: float = 1.0) -> RestMetrics:
    """Compute the metrics of the rest over the last `window` s of a response.

    What a drive engineer reads off a servo at rest: whether the output
    still moves (a limit cycle, hunting) and how much the input chatters.
    The samples at or after ``t[-1] - window`` are measured, as given (a
    sampled controller's response: its samples; no interpolation).

    Parameters
    ----------
    t : array_like
        Time points, increasing.
    y : array_like
        Controlled output at `t`.
    reference : float
        The reference the output rests at.
    u : array_like, optional
        Control input at `t`.
    window : float, optional
        Length of the end of the response measured, s (default 1).

    Returns
    -------
    `RestMetrics`

    Raises
    ------
    ValueError
        If the arrays do not match, `t` is not increasing, a value is not
        finite, or `window` is not positive or longer than the response.

    Examples
    --------
    >>> t = np.linspace(0, 2, 2001)
    >>> m = rest_metrics(t, 1 + 1e-3 * np.sin(2 * np.pi * 5 * t), 1.0)
    >>> round(m.error_peak_to_peak, 6)
    0.002
    """
    t, y, u = _signals(t, y, reference, u)
    window = float(window)
    if not 0.0 < window <= t[-1] - t[0]:
        raise ValueError(
            f"window: expected a length in (0, {t[-1] - t[0]:g}] s, got {window:g}"
        )
    last = t >= t[-1] - window
    error = float(reference) - y[last]
    if u is None:
        std, ripple = np.nan, np.nan
    else:
        rest = u[last]
        std, ripple = float(np.std(rest)), float(np.abs(rest - rest.mean()).max())
    return RestMetrics(
        window=window,
        error_peak_to_peak=float(np.ptp(error)),
        max_error=float(np.abs(error).max()),
        input_std=std,
        input_ripple=ripple,
    )
