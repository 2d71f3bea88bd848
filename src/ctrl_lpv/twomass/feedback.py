"""State-feedback position controllers for the two-mass drive.

Every two-mass controller of this package has the same interface, so that
they are interchangeable in `control.interconnect`: inputs the measured
``theta_m, omega_m, theta_l, omega_l`` and the reference ``theta_r``, output
the motor torque ``Tm``.
"""

from __future__ import annotations

from collections.abc import Callable

import control as ct
import numpy as np

from ..polytope import box
from ..synthesis import StateFeedbackDesign
from .model import paper_gain

__all__ = ["lpv_controller", "backlash_parameter"]

MEASURED = ["theta_m", "omega_m", "theta_l", "omega_l"]


def backlash_parameter(theta_d, alpha: float) -> np.ndarray:
    """The LPV parameter ``p`` of (27) for a shaft angle and a backlash.

    ``p = -alpha / |theta_d|`` outside the gap and ``-1`` inside, so that
    ``(1 + p) theta_d`` is the dead-zone characteristic.

    Parameters
    ----------
    theta_d : float or array_like
        ``theta_m - theta_l``, rad.
    alpha : float
        Backlash half-gap, rad (an estimate when used for scheduling).

    Returns
    -------
    ndarray
        Values in ``[-1, 0]``.
    """
    theta_d = np.abs(np.asarray(theta_d, dtype=float))
    with np.errstate(divide="ignore"):
        return np.where(theta_d > alpha, -alpha / np.maximum(theta_d, 1e-300), -1.0)


def lpv_controller(
    design: StateFeedbackDesign | np.ndarray | None = None,
    *,
    alpha_estimate: float | Callable[[float], float] | None = None,
    torque_limit: float | None = None,
    p_bounds: tuple[float, float] | None = None,
    name: str = "lpv",
) -> ct.NonlinearIOSystem:
    """Two-mass position controller from a state-feedback design.

    Computes the error coordinates ``[theta_m - theta_r, omega_m,
    theta_l - theta_r, omega_l]`` (and the integral of the load-angle error
    when the design has the state ``int_e_l``) and applies
    ``Tm = -K(p) x``.

    Parameters
    ----------
    design : `StateFeedbackDesign` or array_like, optional
        A design on `lpv_model` with the tracking formulation; or a ``1 x 4``
        (``1 x 5`` with the integral state) gain on the error coordinates
        (``u = -K x``); or, with `p_bounds`, two such gains, at
        ``p = p_bounds[0]`` and ``p = p_bounds[1]`` (as read from a gain
        file by `load_gains`). Default: the paper's published gain
        (`paper_gain`).
    alpha_estimate : float or callable, optional
        For vertex gains: the backlash estimate used to compute the
        scheduling parameter ``p`` from the measured ``theta_m - theta_l``
        (`backlash_parameter`), projected onto the design's parameter box. A
        callable is evaluated as ``alpha_estimate(t)``. Required for vertex
        gains, ignored (must be None) for a common gain.
    torque_limit : float, optional
        Saturate ``|Tm| <= torque_limit``; the integral state then stops
        integrating while the torque is saturated in the direction of the
        error (conditional-integration anti-windup).
    p_bounds : (float, float), optional
        Interval of ``p`` of vertex gains given as an array.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        Inputs ``["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"]``,
        output ``["Tm"]``, state ``["int_e_l"]`` for integral designs.
    """
    if design is None:
        design = paper_gain()
    if isinstance(design, StateFeedbackDesign):
        labels = list(design.states)
        if labels[:4] != ["e_m", "omega_m", "e_l", "omega_l"] or len(labels) > 5:
            raise ValueError(
                "design: expected a design on twomass.lpv_model(formulation="
                f"'tracking'), whose states are e_m, omega_m, e_l, omega_l[, int_e_l]; "
                f"got states {labels}"
            )
        gains = np.stack(design.gains)[:, 0, :]
        domain = design.system.domain
    else:
        rows = 1 if p_bounds is None else 2
        gains = np.atleast_2d(np.asarray(design, dtype=float))
        if (
            gains.ndim != 2
            or gains.shape[0] != rows
            or gains.shape[1] not in (4, 5)
            or not np.all(np.isfinite(gains))
        ):
            raise ValueError(
                f"design: expected {rows} finite gain(s) of 4 or 5 states, "
                f"got shape {np.shape(design)}"
            )
        domain = None if p_bounds is None else box(p=p_bounds)
    integral = gains.shape[1] == 5
    scheduled = gains.shape[0] > 1
    if scheduled and alpha_estimate is None:
        raise ValueError("alpha_estimate: vertex gains need a backlash estimate")
    if not scheduled and alpha_estimate is not None:
        raise ValueError("alpha_estimate: a common gain is not scheduled")
    if torque_limit is not None and not (
        np.isfinite(torque_limit) and torque_limit > 0
    ):
        raise ValueError(f"torque_limit: must be a positive number, got {torque_limit}")
    alpha_of_t = (
        alpha_estimate if callable(alpha_estimate) else (lambda t, a=alpha_estimate: a)
    )
    limit = np.inf if torque_limit is None else float(torque_limit)

    def gain(t, x):
        if not scheduled:
            return gains[0]
        p = float(backlash_parameter(x[0] - x[2], alpha_of_t(t)))
        return domain._weights(np.array([p])) @ gains

    def error_state(x, u):
        e = np.array([u[0] - u[4], u[1], u[2] - u[4], u[3]])
        return np.concatenate([e, x]) if integral else e

    def torque(t, x, u, params=None):
        e = error_state(x, u)
        return np.array([np.clip(-gain(t, e) @ e, -limit, limit)])

    def integrate(t, x, u, params=None):
        e_l = u[2] - u[4]
        if np.isfinite(limit):
            e = error_state(x, u)
            raw = -gain(t, e) @ e
            # Stop integrating when saturated and the error pushes further.
            if abs(raw) > limit and np.sign(raw) == -np.sign(gain(t, e)[4] * e_l):
                return np.zeros(1)
        return np.array([e_l])

    return ct.nlsys(
        integrate if integral else None,
        torque,
        inputs=MEASURED + ["theta_r"],
        outputs=["Tm"],
        states=["int_e_l"] if integral else None,
        name=name,
    )
