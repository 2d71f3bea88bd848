"""Step-response metrics of any simulated response."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

__all__ = ["StepMetrics", "step_metrics"]


@dataclass(frozen=True)
class StepMetrics:
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

    def as_dict(self) -> dict[str, float]:
        """The metrics as a plain dictionary (for tables and JSON)."""
        return {f.name: float(getattr(self, f.name)) for f in fields(self)}


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
    t = np.asarray(t, float).reshape(-1)
    y = np.asarray(y, float).reshape(-1)
    if t.shape != y.shape or t.size < 2:
        raise ValueError(f"t, y: expected equal lengths >= 2, got {t.size}, {y.size}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        raise ValueError("t: time points must be increasing")
    if not (np.all(np.isfinite(y)) and np.isfinite(reference)):
        raise ValueError("y, reference: values must be finite")
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
        u = np.asarray(u, float).reshape(-1)
        if u.shape != t.shape:
            raise ValueError(f"u: expected {t.size} samples, got {u.size}")
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
