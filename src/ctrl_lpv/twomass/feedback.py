"""State-feedback position controllers for the two-mass drive.

Every two-mass controller of this package has the same interface, so that
they are interchangeable in `control.interconnect`: inputs the measured
``theta_m, omega_m, theta_l, omega_l`` and the reference ``theta_r``, output
the motor torque ``Tm``.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import control as ct
import numpy as np

from ..interconnection import BlockKernel, kernel_nlsys
from ..polytope import box
from ..synthesis import StateFeedbackDesign
from .compiled_data import lpv_block
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
        For vertex gains: the backlash estimate (rad, finite and ``>= 0``)
        used to compute the scheduling parameter ``p`` from the measured
        ``theta_m - theta_l`` (`backlash_parameter`), projected onto the
        design's parameter box. A callable is evaluated as
        ``alpha_estimate(t)``; a negative or non-finite value it returns
        stops the simulation with a `ValueError`. Required for vertex
        gains; a common gain is not scheduled, and an estimate given with
        one is refused (`ValueError`), never silently ignored.
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

    Raises
    ------
    ValueError
        For a `design` of the wrong shape, a missing `alpha_estimate` with
        vertex gains or one given with a common gain, a negative or
        non-finite `alpha_estimate`, or a `torque_limit` that is not a
        positive number.
    TypeError
        For an `alpha_estimate` that is neither a number nor a callable.
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
        raise ValueError(
            "alpha_estimate: a common gain is not scheduled; an estimate "
            f"({alpha_estimate!r}) is only used with vertex gains"
        )
    if alpha_estimate is not None and not callable(alpha_estimate):
        if not _is_number(alpha_estimate):
            raise TypeError(
                "alpha_estimate: expected a number or a callable alpha(t), "
                f"got {alpha_estimate!r}"
            )
        if not (math.isfinite(alpha_estimate) and alpha_estimate >= 0):
            raise ValueError(
                "alpha_estimate: the backlash estimate must be a finite number "
                f">= 0 rad, got {alpha_estimate!r}"
            )
        alpha_estimate = float(alpha_estimate)
    if torque_limit is not None and not (
        _is_number(torque_limit) and math.isfinite(torque_limit) and torque_limit > 0
    ):
        raise ValueError(
            f"torque_limit: must be a positive number, got {torque_limit!r}"
        )
    kernel = _lpv_kernel(
        gains, domain, alpha_estimate, np.inf if torque_limit is None else torque_limit
    )
    return kernel_nlsys(
        kernel,
        inputs=MEASURED + ["theta_r"],
        outputs=["Tm"],
        states=["int_e_l"] if integral else None,
        feedthrough=True,
        name=name,
    )


def _lpv_kernel(gains: np.ndarray, domain, alpha_estimate, limit) -> BlockKernel:
    """Scalar and vectorized functions of `lpv_controller`.

    Error coordinates ``e = [theta_m - theta_r, omega_m, theta_l - theta_r,
    omega_l(, int_e_l)]``, ``Tm = clip(-K(p) e)``; the integral state stops
    while saturated in the direction of the error.
    """
    integral = gains.shape[1] == 5
    scheduled = gains.shape[0] > 1
    limit = float(limit)
    saturates = math.isfinite(limit)
    alpha_of_t = alpha_estimate if callable(alpha_estimate) else None
    alpha_const = None if callable(alpha_estimate) else alpha_estimate
    k_common = tuple(gains[0].tolist())

    # The gain at p: vertex gains combined with the convex coordinates of
    # the projected p.  On a one-parameter box these are affine in
    # lam = (p - lower) / (upper - lower), so K(p) = (1 - lam) K_lo + lam K_hi
    # with plain floats; other domains go through their `_weights`.
    interval = scheduled and domain.nparams == 1 and hasattr(domain, "lower")
    if interval:
        lo, hi = float(domain.lower[0]), float(domain.upper[0])
        k_lo = tuple((domain._weights(np.array([lo])) @ gains).tolist())
        k_hi = tuple((domain._weights(np.array([hi])) @ gains).tolist())
        width = hi - lo

    def gain(t, e_m, e_l):
        if not scheduled:
            return k_common
        a = alpha_const if alpha_of_t is None else _estimate(alpha_of_t, t)
        theta_d = abs(e_m - e_l)
        p = -a / (theta_d if theta_d > 1e-300 else 1e-300) if theta_d > a else -1.0
        if not interval:
            return tuple((domain._weights(np.array([p])) @ gains).tolist())
        lam = (p - lo) / width
        lam = 0.0 if lam < 0.0 else (1.0 if lam > 1.0 else lam)
        return tuple((1.0 - lam) * g + lam * h for g, h in zip(k_lo, k_hi))

    def raw_torque(t, x, u):
        theta_m, omega_m, theta_l, omega_l, theta_r = u
        e_m, e_l = theta_m - theta_r, theta_l - theta_r
        k = gain(t, e_m, e_l)
        raw = k[0] * e_m + k[1] * omega_m + k[2] * e_l + k[3] * omega_l
        if integral:
            raw += k[4] * x[0]
        return -raw, k, e_l

    def out(t, x, u):
        raw = raw_torque(t, x, u)[0]
        return (-limit if raw < -limit else (limit if raw > limit else raw),)

    if not (scheduled or integral):
        # The common case on one call: the paper's gain, robust designs.
        k0, k1, k2, k3 = k_common

        def out(t, x, u):
            theta_m, omega_m, theta_l, omega_l, theta_r = u
            raw = -(
                k0 * (theta_m - theta_r)
                + k1 * omega_m
                + k2 * (theta_l - theta_r)
                + k3 * omega_l
            )
            return (-limit if raw < -limit else (limit if raw > limit else raw),)

    def rhs(t, x, u):
        if saturates:
            raw, k, e_l = raw_torque(t, x, u)
            # Stop integrating when saturated and the error pushes further.
            if abs(raw) > limit and _sign(raw) == -_sign(k[4] * e_l):
                return (0.0,)
            return (e_l,)
        return (u[2] - u[4],)

    def out_many(t, x, u):
        theta_m, omega_m, theta_l, omega_l, theta_r = u
        e_m, e_l = theta_m - theta_r, theta_l - theta_r
        shape = np.broadcast(t, *x, *u).shape
        if scheduled:
            if alpha_of_t is None:
                a = alpha_const
            else:
                a = np.reshape(
                    [_estimate(alpha_of_t, ti) for ti in np.ravel(t)], np.shape(t)
                )
            p = np.broadcast_to(backlash_parameter(e_m - e_l, a), shape)
            if interval:
                lam = np.clip((p - lo) / width, 0.0, 1.0)[..., None]
                k = (1.0 - lam) * np.array(k_lo) + lam * np.array(k_hi)
            else:
                rows = [domain._weights(np.array([v])) @ gains for v in p.ravel()]
                k = np.reshape(rows, shape + (gains.shape[1],))
            k = np.moveaxis(k, -1, 0)
        else:
            k = k_common
        raw = k[0] * e_m + k[1] * omega_m + k[2] * e_l + k[3] * omega_l
        if integral:
            raw = raw + k[4] * x[0]
        return (np.clip(-raw, -limit, limit),)

    if not scheduled:
        compiled = lpv_block(k_common, k_common, integral, None, None, limit)
    elif interval:
        compiled = lpv_block(k_lo, k_hi, integral, (lo, hi), alpha_estimate, limit)
    else:
        compiled = None  # a general polytope of p: no compiled form
    return BlockKernel(
        out=out, rhs=rhs if integral else None, out_many=out_many, compiled=compiled
    )


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def _estimate(alpha_of_t, t) -> float:
    """``alpha_estimate(t)``, refused unless finite and ``>= 0``."""
    a = alpha_of_t(t)
    try:
        a = float(a)
    except (TypeError, ValueError):
        raise TypeError(
            f"alpha_estimate: the callable returned {a!r} at t = {t}, not a number"
        ) from None
    if not (a >= 0.0 and a < math.inf):
        raise ValueError(
            f"alpha_estimate: the callable returned {a} at t = {float(t):.6g}; "
            "the backlash estimate must be finite and >= 0"
        )
    return a


def _sign(v: float) -> int:
    return (v > 0.0) - (v < 0.0)
