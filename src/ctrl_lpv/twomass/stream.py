"""A streamed position set-point's derivatives, for the servo's feedforward.

A motion controller streams ``theta_r`` to the drive, one new position per
sample. The servo's feedforward needs the set-point's speed, acceleration
and jerk, and a drive cannot differentiate raw samples three times (each
difference multiplies the set-point's own quantization by ``1/dt``). The
standard answer is a tracking filter on the set-point: here the
alpha-beta-gamma-delta tracker of a constant-jerk model (Kalata's
alpha-beta(-gamma) tracker, one order higher; the discrete-time form of a
state-variable filter whose error dynamics is a chain of equal poles).

Per sample ``k`` the state ``z = [r, v, a, j]`` is predicted with the
constant-jerk model ``Phi(dt)`` and corrected with the set-point sample,
``z[k|k] = z[k|k-1] + L (theta_r[k] - r[k|k-1])``. ``L`` places the four
eigenvalues of the error dynamics ``(I - L C) Phi`` at
``exp(-bandwidth * dt)``. Two properties make it the right filter for a
feedforward:

* no lag on polynomials of degree <= 3: a ramp or a parabola is followed
  with zero error in steady state (the model is exact for them), and on a
  sine of frequency ``w`` the error is of order ``(w / bandwidth)^4``;
* its speed, acceleration and jerk are filtered: the gain from the
  set-point to ``a`` and ``j`` is bounded, of order ``bandwidth^2`` and
  ``bandwidth^3`` (not ``dt^-2``, ``dt^-3``).

The state can be extrapolated with ``Phi(tau)`` to the instant a command
computed now will act (one sample of computation delay, and half a sample
more for the zero-order hold of the torque).
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from .._checks import real_number

__all__ = ["jerk_model", "stream_gain"]


def jerk_model(tau: float) -> np.ndarray:
    """The constant-jerk transition over `tau` seconds (4 x 4)."""
    return np.array(
        [
            [1.0, tau, tau**2 / 2.0, tau**3 / 6.0],
            [0.0, 1.0, tau, tau**2 / 2.0],
            [0.0, 0.0, 1.0, tau],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def stream_gain(dt: float, bandwidth: float) -> np.ndarray:
    """The tracker's correction gain ``L`` (length 4).

    Parameters
    ----------
    dt : float
        Sample time, s.
    bandwidth : float
        The rate of the four equal poles of the error dynamics, rad/s; the
        discrete poles are ``exp(-bandwidth * dt)``, so ``bandwidth * dt``
        must be below about 1 for a filter that smooths.

    Returns
    -------
    ndarray
        ``L`` with ``(I - L C) Phi`` having the quadruple eigenvalue
        ``exp(-bandwidth dt)`` (``C = [1, 0, 0, 0]``, ``Phi = jerk_model(dt)``).
    """
    dt = real_number(dt, "dt", positive=True)
    bandwidth = real_number(bandwidth, "bandwidth", positive=True)
    if bandwidth * dt > 2.0:
        raise ValueError(
            f"bandwidth: {bandwidth:g} rad/s is more than 2 / dt = {2.0 / dt:g} "
            "rad/s: the tracker would not filter the set-point"
        )
    Phi = jerk_model(dt)
    C = np.array([[1.0, 0.0, 0.0, 0.0]])
    pole = math.exp(-bandwidth * dt)
    # (I - L C) Phi = Phi - L (C Phi): the observer form of pole placement
    # on the pair (Phi, C Phi).
    gain = ct.acker(Phi.T, (C @ Phi).T, [pole] * 4)
    return np.asarray(gain, float).reshape(-1)
