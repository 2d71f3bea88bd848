"""Parameter trajectories that destabilise a frozen-stable schedule.

Above the certified rate `ctrl_lpv.certify` claims nothing; this module
looks for evidence that the loop is in fact unstable there: a periodic
triangle wave of the parameter between two points of one cell, at a given
rate, whose monodromy matrix (the state transition over one period,
integrated along the ramp) has a spectral radius above 1. The state then
grows by that factor every period, as a simulation shows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

__all__ = ["ParameterTrajectory", "destabilising_trajectory"]


@dataclass(frozen=True)
class ParameterTrajectory:
    """A periodic parameter trajectory along which the closed loop grows.

    Attributes
    ----------
    start, end : dict
        The two parameter values the triangle wave moves between (linearly,
        at `rate`), starting at `start`.
    rate : float
        ``max_k |dp_k/dt|`` along the wave.
    period : float
        Its period.
    growth : float
        Spectral radius of the state transition over one period (> 1).
    """

    start: dict
    end: dict
    rate: float
    period: float
    growth: float

    def __call__(self, t):
        """The parameter values at times `t` (one row per parameter)."""
        t = np.asarray(t, float)
        phase = np.mod(t, self.period) / (0.5 * self.period)
        s = np.where(phase <= 1.0, phase, 2.0 - phase)
        a = np.array(list(self.start.values()))
        b = np.array(list(self.end.values()))
        return a[:, None] + (b - a)[:, None] * s[None, :]

    def __str__(self) -> str:
        return (f"triangle wave between {self.start} and {self.end} at rate "
                f"{self.rate:.4g} (period {self.period:.4g}): the state grows by "
                f"{self.growth:.4g} per period")  # fmt: skip


def destabilising_trajectory(loops, certified_rate, span=1e3, count=80):
    """The most destabilising trajectory found above `certified_rate`.

    Scans rates from 1.05 to `span` times the certified one (`count` on a
    log grid; a resonance can sit anywhere in between) for every segment
    of `loops.segments()` (two parameter values, and the closed loop
    between them, piecewise affine: its values at nodes), and returns the
    largest growth per period, or None.
    """
    best = None
    segments = loops.segments()
    for rate in certified_rate * np.geomspace(1.05, span, count):
        for start, end, nodes, loops_at in segments:
            growth, period = _growth(start, end, nodes, loops_at, rate)
            if growth > 1.0 + 1e-9 and (best is None or growth > best[0]):
                best = (growth, period, start, end, rate)
    if best is None:
        return None
    growth, period, start, end, rate = best
    return ParameterTrajectory(
        dict(zip(loops.names, np.asarray(start).tolist())),
        dict(zip(loops.names, np.asarray(end).tolist())),
        float(rate), float(period), float(growth),
    )  # fmt: skip


def _growth(start, end, nodes, loops_at, rate):
    """Spectral radius of the monodromy of the triangle wave start-end.

    The closed loop at ``start + s (end - start)`` interpolates `loops_at`
    (its values at the positions `nodes`, from 0 to 1) linearly.
    """
    distance = float(np.max(np.abs(np.asarray(end) - np.asarray(start))))
    half = distance / rate
    n = loops_at[0].shape[0]
    nodes = np.asarray(nodes, float)

    def rhs(t, y, sign):
        s = t / half if sign > 0 else 1.0 - t / half
        k = int(np.clip(np.searchsorted(nodes, s, side="right") - 1, 0,
                        len(nodes) - 2))  # fmt: skip
        f = (s - nodes[k]) / (nodes[k + 1] - nodes[k])
        A = (1 - f) * loops_at[k] + f * loops_at[k + 1]
        return (A @ y.reshape(n, n)).ravel()

    Phi = np.eye(n)
    for sign in (1, -1):
        sol = solve_ivp(rhs, (0.0, half), Phi.ravel(), args=(sign,), rtol=1e-10,
                        atol=1e-12, method="DOP853")  # fmt: skip
        Phi = sol.y[:, -1].reshape(n, n)
    return float(np.abs(np.linalg.eigvals(Phi)).max()), 2.0 * half
