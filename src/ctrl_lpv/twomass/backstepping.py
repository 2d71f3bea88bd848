r"""Backstepping position controller for the two-mass drive with backlash.

The paper's reference [19] could not be found; this is a standard recursive
backstepping design (Krstic, Kanellakopoulos and Kokotovic, 1995) on a
smooth dead-zone model of the backlash, with a smoothed inverse.

Design model
------------
States ``x1 = theta_l``, ``x2 = omega_l``, ``x3 = theta_m``, ``x4 = omega_m``,
shaft angle ``d = x3 - x1``; the shaft damping ``cs`` is neglected::

    Jl x2' = ks D(d) - cl x2 - Td,        Jm x4' = u - cm x4 - ks D(d),

with the smooth dead zone (``k`` sets the corner sharpness)::

    D(d) = [softplus(k (d - alpha)) - softplus(-k (d + alpha))] / k

and its smoothed inverse ``I(T) = T / ks + alpha tanh(T / (ks eps))``, so
that ``ks D(I(T)) ~ T`` for ``|T| >> ks eps``.

Recursion
---------
1. ``z1 = x1 - theta_r``; virtual ``x2 = -c1 z1``; ``z2 = x2 + c1 z1``.
2. Shaft-torque demand ``T* = Jl (-z1 - c2 z2 - c1 x2) + cl x2 + Td_hat``,
   which gives ``z2' = -z1 - c2 z2`` when ``ks D(d) = T*``.
3. Motor-angle demand ``alpha2 = x1 + I(T*)``; ``z3 = x3 - alpha2``;
   virtual ``x4 = alpha3 = alpha2' - c3 z3 - z2``; ``z4 = x4 - alpha3``.
4. ``u = cm x4 + ks D(d) + Jm (alpha3' - c4 z4 - z3)``.

``T*`` is affine in ``(z1, x2)``, so ``alpha2'`` and ``alpha3'`` follow by
the chain rule along the design model without dividing by ``D'(d)``, which
vanishes in the gap. With ``V = (z1^2 + z2^2) / 2 + ks / (2 Jl) (z3^2 +
z4^2)``::

    V' = -c1 z1^2 - c2 z2^2 - ks / Jl (c3 z3^2 + c4 z4^2)
         + z2 / Jl (ks D(d) - T* - ks z3),

and the last term vanishes where the dead zone is in contact (``D' = 1``)
and the inverse is exact: there ``V`` decreases. In the gap (``D' ~ 0``)
the cross term is not cancelled; the gap is crossed in a transient that
the negative terms dominate once contact is regained. Assumptions: ``Td``
known (``Td_hat``), ``alpha`` known, ``cs`` neglected.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from ..interconnection import BlockKernel, kernel_nlsys
from .compiled_data import backstepping_block
from .parameters import Parameters

__all__ = ["backstepping_controller", "BacksteppingLaw"]

DEFAULT_GAINS = (10.0, 20.0, 100.0, 200.0)


def _softplus(z):
    return np.maximum(z, 0.0) + np.log1p(np.exp(-np.abs(z)))


def _sigmoid(z):
    return 0.5 * (1.0 + np.tanh(0.5 * z))


class _ArrayOps:
    """The law's elementary functions on arrays (numpy)."""

    softplus = staticmethod(_softplus)
    sigmoid = staticmethod(_sigmoid)
    tanh = staticmethod(np.tanh)


class _FloatOps:
    """The same functions on Python floats (math): 5-10x faster per call."""

    @staticmethod
    def softplus(z):
        return (z if z > 0.0 else 0.0) + math.log1p(math.exp(-abs(z)))

    @staticmethod
    def sigmoid(z):
        return 0.5 * (1.0 + math.tanh(0.5 * z))

    tanh = staticmethod(math.tanh)


class BacksteppingLaw:
    """The control law and its Lyapunov function (see the module doc).

    Parameters
    ----------
    params : `Parameters`
        Drive data of the design model.
    gains : (float, float, float, float)
        ``c1, c2, c3, c4 > 0``.
    alpha : float
        Backlash half-gap assumed by the controller, rad.
    sharpness : float
        ``k alpha``, the dead-zone corner sharpness (``k = sharpness / alpha``).
    eps : float
        Width of the smoothed inverse, rad of shaft twist.
    Td_hat : float
        Load-torque estimate, Nm.
    """

    def __init__(self, params, gains, alpha, sharpness, eps, Td_hat):
        self.p = params
        self.c1, self.c2, self.c3, self.c4 = (float(c) for c in gains)
        self.alpha = float(alpha)
        self.k = float(sharpness) / self.alpha if self.alpha > 0 else np.inf
        self.eps = float(eps)
        self.Td_hat = float(Td_hat)
        Jl, cl = params.Jl, params.cl
        # T* = a z1 + b x2 + Td_hat.
        self.a = -Jl * (1.0 + self.c1 * self.c2)
        self.b = cl - Jl * (self.c1 + self.c2)

    def D(self, d, ops=_ArrayOps):
        """Smooth dead zone and its slope."""
        if not math.isfinite(self.k):
            return d, 1.0
        k, a = self.k, self.alpha
        value = (ops.softplus(k * (d - a)) - ops.softplus(-k * (d + a))) / k
        slope = ops.sigmoid(k * (d - a)) + ops.sigmoid(-k * (d + a))
        return value, slope

    def inverse(self, T, ops=_ArrayOps):
        """Smoothed inverse ``I(T)`` and its first two derivatives."""
        ks, a, eps = self.p.ks, self.alpha, self.eps
        th = ops.tanh(T / (ks * eps))
        sech2 = 1.0 - th**2
        value = T / ks + a * th
        first = 1.0 / ks + a * sech2 / (ks * eps)
        second = -2.0 * a * sech2 * th / (ks * eps) ** 2
        return value, first, second

    def errors(self, x, theta_r, ops=_ArrayOps):
        """``(z1, z2, z3, z4)`` and the terms of ``u`` at state ``x``.

        `ops` holds the elementary functions: numpy's (default, arrays) or
        math's (`_FloatOps`, Python floats, used on the simulation path).
        """
        p = self.p
        x1, x2, x3, x4 = x
        d = x3 - x1
        Dd, Dslope = self.D(d, ops)
        a2 = (p.ks * Dd - p.cl * x2 - self.Td_hat) / p.Jl  # model x2'
        a2dot = (p.ks * Dslope * (x4 - x2) - p.cl * a2) / p.Jl
        z1 = x1 - theta_r
        z2 = x2 + self.c1 * z1
        T = self.a * z1 + self.b * x2 + self.Td_hat
        Tdot = self.a * x2 + self.b * a2
        inv, inv1, inv2 = self.inverse(T, ops)
        z3 = d - inv
        alpha3 = x2 + inv1 * Tdot - self.c3 * z3 - z2
        z4 = x4 - alpha3
        alpha3dot = (
            inv2 * Tdot**2
            + inv1 * (self.a * a2 + self.b * a2dot)
            - self.c3 * (x4 - x2 - inv1 * Tdot)
            - self.c1 * x2
        )
        return (z1, z2, z3, z4), Dd, alpha3dot

    def torque(self, x, theta_r, ops=_ArrayOps):
        """Motor torque ``u``."""
        (_, _, z3, z4), Dd, alpha3dot = self.errors(x, theta_r, ops)
        p = self.p
        return p.cm * x[3] + p.ks * Dd + p.Jm * (alpha3dot - self.c4 * z4 - z3)

    def lyapunov(self, x, theta_r):
        """``V = (z1^2 + z2^2) / 2 + ks / (2 Jl) (z3^2 + z4^2)``."""
        (z1, z2, z3, z4), _, _ = self.errors(x, theta_r)
        return 0.5 * (z1**2 + z2**2) + self.p.ks / (2 * self.p.Jl) * (z3**2 + z4**2)


def backstepping_controller(
    params: Parameters | None = None,
    gains: tuple[float, float, float, float] = DEFAULT_GAINS,
    *,
    alpha: float | None = None,
    sharpness: float = 10.0,
    eps: float = 1e-3,
    Td_hat: float = 0.0,
    torque_limit: float | None = None,
    name: str = "backstepping",
) -> ct.NonlinearIOSystem:
    """Backstepping position controller as a python-control I/O system.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data of the design model; default the paper's table.
    gains : (c1, c2, c3, c4), optional
        Positive backstepping gains, default ``(10, 20, 100, 200)``.
    alpha : float, optional
        Backlash half-gap assumed by the controller; default
        ``params.alpha``.
    sharpness : float, optional
        ``k alpha`` of the smooth dead zone, default 10.
    eps : float, optional
        Width of the smoothed inverse (rad), default ``1e-3``.
    Td_hat : float, optional
        Known load torque (Nm), default 0. There is no integral action: an
        error in `Td_hat` leaves a steady-state error.
    torque_limit : float, optional
        Saturate ``|Tm| <= torque_limit``.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        Static: inputs ``["theta_m", "omega_m", "theta_l", "omega_l",
        "theta_r"]``, output ``["Tm"]``.

    Raises
    ------
    ValueError
        For nonpositive gains, `sharpness`, `eps` or `torque_limit`, a
        negative `alpha`, or non-finite values.
    """
    params = Parameters() if params is None else params
    if not isinstance(params, Parameters):
        raise TypeError(f"params: expected twomass.Parameters, got {type(params)!r}")
    gains = tuple(gains)
    if len(gains) != 4 or not all(np.isfinite(c) and c > 0 for c in gains):
        raise ValueError(f"gains: expected four positive numbers, got {gains!r}")
    alpha = params.alpha if alpha is None else alpha
    if not (np.isfinite(alpha) and alpha >= 0):
        raise ValueError(f"alpha: must be a nonnegative number, got {alpha}")
    for label, value in (("sharpness", sharpness), ("eps", eps)):
        if not (np.isfinite(value) and value > 0):
            raise ValueError(f"{label}: must be a positive number, got {value}")
    if not np.isfinite(Td_hat):
        raise ValueError(f"Td_hat: must be finite, got {Td_hat}")
    if torque_limit is not None and not (
        np.isfinite(torque_limit) and torque_limit > 0
    ):
        raise ValueError(f"torque_limit: must be a positive number, got {torque_limit}")
    law = BacksteppingLaw(params, gains, alpha, sharpness, eps, Td_hat)
    limit = math.inf if torque_limit is None else float(torque_limit)

    ops = _FloatOps

    def out(t, x, u):
        theta_m, omega_m, theta_l, omega_l, theta_r = u
        tq = law.torque((theta_l, omega_l, theta_m, omega_m), theta_r, ops)
        return (-limit if tq < -limit else (limit if tq > limit else tq),)

    def out_many(t, x, u):
        theta_m, omega_m, theta_l, omega_l, theta_r = (np.asarray(v) for v in u)
        tq = law.torque((theta_l, omega_l, theta_m, omega_m), theta_r)
        return (np.clip(tq, -limit, limit),)

    return kernel_nlsys(
        BlockKernel(
            out=out, out_many=out_many, compiled=backstepping_block(law, limit)
        ),
        inputs=["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"],
        outputs=["Tm"],
        feedthrough=True,
        name=name,
    )
