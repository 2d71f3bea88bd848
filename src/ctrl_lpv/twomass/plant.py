"""Nonlinear two-mass drive with backlash as a python-control system."""

from __future__ import annotations

import math
from collections.abc import Callable
from numbers import Real

import control as ct
import numpy as np

from ctrl_lpv.twomass.parameters import Parameters

__all__ = ["plant"]

_MODELS = ("exact", "deadzone")
_INPUTS = ["Tm", "Td"]
_OUTPUTS = ["theta_m", "omega_m", "theta_l", "omega_l", "Ts"]
_STATES = ["theta_m", "omega_m", "theta_l", "omega_l", "theta_b"]


def plant(
    params: Parameters | None = None,
    model: str = "exact",
    alpha: float | Callable[[float], float] | None = None,
    name: str = "plant",
) -> ct.NonlinearIOSystem:
    r"""Create a two-mass drive with backlash as an I/O system.

    The motor (inertia `Jm`, friction `cm`) drives the load (inertia `Jl`,
    friction `cl`) through an elastic, damped shaft (`ks`, `cs`) with a
    backlash of half-gap ``alpha``::

        Jm d(omega_m)/dt = Tm - cm omega_m - Ts
        Jl d(omega_l)/dt = Ts - cl omega_l - Td

    with ``theta_d = theta_m - theta_l`` and ``omega_d = omega_m -
    omega_l``.  The transmitted shaft torque `Ts` depends on `model`:

    * ``"exact"`` (Nordin, Galic and Gutman, 1997): the backlash angle
      ``theta_b`` is a state in ``[-alpha, alpha]``.  With ``s = omega_d +
      ks/cs (theta_d - theta_b)``, ``d(theta_b)/dt`` is ``s`` inside the gap,
      ``max(0, s)`` at ``-alpha`` and ``min(0, s)`` at ``+alpha``, and
      ``Ts = ks (theta_d - theta_b) + cs (omega_d - d(theta_b)/dt)``, which
      is zero inside the gap.
    * ``"deadzone"``: ``Ts = ks D(theta_d) + cs omega_d`` when
      ``|theta_d| >= alpha`` and 0 inside the gap, with ``D(theta_d) =
      theta_d - alpha sign(theta_d)``.  No backlash state.

    Parameters
    ----------
    params : Parameters, optional
        Physical data.  Default ``Parameters()`` (the paper's table).
    model : {"exact", "deadzone"}, optional
        Backlash model.  Default ``"exact"``.
    alpha : float or callable, optional
        Backlash half-gap in rad, overriding ``params.alpha``: a number
        >= 0 or a function ``alpha(t) -> float`` of time (e.g. a step from
        0.03 to 0.045 rad).  Default None (use ``params.alpha``).
    name : str, optional
        System name.  Default ``"plant"``.

    Returns
    -------
    sys : `control.NonlinearIOSystem`
        Continuous-time system with inputs ``["Tm", "Td"]`` (motor torque,
        load disturbance torque, Nm), outputs ``["theta_m", "omega_m",
        "theta_l", "omega_l", "Ts"]`` and states ``["theta_m", "omega_m",
        "theta_l", "omega_l", "theta_b"]`` (``"exact"``) or the first four
        (``"deadzone"``).  Angles in rad, speeds in rad/s, torque in Nm.

    Raises
    ------
    TypeError
        If `params` is not a `Parameters`, `alpha` is neither a real number
        nor a callable, or `name` is not a string.
    ValueError
        If `model` is unknown, or `alpha` (or ``alpha(0.0)`` for a callable)
        is negative or not finite.  A callable `alpha` that returns such a
        value during a simulation raises `ValueError` there.

    See Also
    --------
    ctrl_lpv.twomass.parameters.Parameters, control.input_output_response

    Notes
    -----
    The right-hand side of the exact model is continuous in the state
    except where the backlash closes (an impact, crossed transversally at
    an isolated instant; the jump of `Ts` there is the damper's response to
    the impact speed and is physical).  The physics uses the backlash angle
    ``clip(theta_b, -alpha(t), alpha(t))``: if `alpha` shrinks below
    ``|theta_b|`` the contact moves with it at once, and the state is drawn
    back onto the boundary at the shaft's own rate ``ks / cs`` (time
    constant 0.6 ms with the default data), so it may lie outside the new
    bound only during that transient.  A moving contact point is treated as
    quasi-static: the damper does not see ``d(alpha)/dt``.

    Simulate with tight tolerances (``rtol <= 1e-6``): the default RK45
    ``rtol = 1e-3`` of `control.input_output_response` is visibly
    inaccurate for this stiff shaft.

    With ``alpha = 0`` both models are the linear two-mass system with
    ``Ts = ks theta_d + cs omega_d``.

    Examples
    --------
    >>> import control as ct
    >>> import numpy as np
    >>> from ctrl_lpv.twomass.plant import plant
    >>> sys = plant(alpha=lambda t: 0.03 if t < 2.5 else 0.045)
    >>> sys.output_labels
    ['theta_m', 'omega_m', 'theta_l', 'omega_l', 'Ts']
    >>> T = np.linspace(0, 1, 101)
    >>> resp = ct.input_output_response(
    ...     sys, T, [10 * np.ones_like(T), 0 * T],
    ...     solve_ivp_kwargs=dict(rtol=1e-6, atol=1e-9))
    >>> bool(resp.outputs[4, -1] > 0)   # the drive is in contact at t = 1 s
    True

    """
    if params is None:
        params = Parameters()
    elif not isinstance(params, Parameters):
        raise TypeError(
            "plant: `params` must be a ctrl_lpv.twomass Parameters instance "
            f"or None, got {type(params).__name__}"
        )
    if not isinstance(model, str) or model not in _MODELS:
        raise ValueError(f"plant: `model` must be one of {_MODELS}, got {model!r}")
    if not isinstance(name, str):
        raise TypeError(f"plant: `name` must be a string, got {type(name).__name__}")

    alpha_fun = None
    if alpha is None:
        alpha0 = params.alpha
    elif callable(alpha):
        alpha_fun = alpha
        alpha0 = _checked_alpha(alpha(0.0), "alpha(0.0)")
    elif isinstance(alpha, Real) and not isinstance(alpha, bool):
        alpha0 = _checked_alpha(alpha, "alpha")
    else:
        raise TypeError(
            "plant: `alpha` must be a float >= 0 or a callable alpha(t), "
            f"got {type(alpha).__name__}"
        )

    if model == "exact":
        updfcn, outfcn = _exact_model(params, alpha0, alpha_fun)
        states = list(_STATES)
    else:
        updfcn, outfcn = _deadzone_model(params, alpha0, alpha_fun)
        states = list(_STATES[:4])
    return ct.nlsys(
        updfcn,
        outfcn,
        inputs=list(_INPUTS),
        outputs=list(_OUTPUTS),
        states=states,
        name=name,
    )


def _checked_alpha(value, what: str) -> float:
    """Return `value` as a float if it is a valid half-gap, else raise."""
    if isinstance(value, bool) or not isinstance(value, Real | np.number):
        raise TypeError(
            f"plant: `{what}` must be a real number, got {type(value).__name__}"
        )
    value = float(value)
    if not (0.0 <= value < math.inf):
        raise ValueError(f"plant: `{what}` must be finite and >= 0, got {value}")
    return value


def _bad_alpha(t: float, value: float) -> ValueError:
    return ValueError(
        f"plant: `alpha(t)` must be finite and >= 0, got {value} at t = {t}"
    )


def _exact_model(params: Parameters, alpha0: float, alpha_fun):
    """Update and output functions of the exact backlash model."""
    inv_jm, inv_jl = 1.0 / params.Jm, 1.0 / params.Jl
    cm, cl, cs = params.cm, params.cl, params.cs
    rate = params.ks / params.cs
    import os; RELAX = float(os.environ.get("RELAX", "1")) * rate; ETA1 = float(os.environ.get("ETA1", "1e-9")); ETA2 = float(os.environ.get("ETA2", "1e-8")); INV1 = 1/ETA1
    inf = math.inf

    # Why this formulation.  The exact model is a projected ODE: theta_b
    # follows s = omega_d + rate * (theta_d - theta_b) and is stopped at the
    # bounds.  Written naively (test |theta_b| < alpha on the raw state, use
    # the raw state in s and Ts), integration error leaves theta_b a hair
    # inside or outside the bound while the drive is in contact; a point just
    # inside sees the full gap dynamics (Ts = 0, d(theta_b)/dt = s = Ts/cs,
    # up to 1e4 rad/s under high-gain control), a point just outside sees a
    # clamped one, so every Runge-Kutta stage lands on either side and the
    # step-size control chatters for minutes at rtol = 1e-6.
    #
    # Here the physics only ever sees the projection theta_c = clip(theta_b,
    # -alpha, alpha), and the contact test is on theta_c.  Then:
    # - in contact (theta_c = +-alpha, s pushing outward) the derivative is 0
    #   for every state on or beyond the bound, so RK stages stay there
    #   exactly: the contact set is invariant, no chattering;
    # - separation is continuous (min(0, s) and s agree at s = 0);
    # - the only discontinuity left is the impact, crossed transversally
    #   once (s > 0 inside, 0 on the bound); the jump of Ts there is the
    #   damper's reaction to the impact speed, physical and isolated, which
    #   adaptive solvers resolve with a few rejected steps;
    # - Ts = cs * (s - v) is the model's Ts, and is exactly 0.0 in the gap.
    # A state outside the bound (alpha(t) shrank below it, or a solver step
    # overshot an impact) is drawn back by rate * (theta_c - theta_b): this
    # term is 0 inside, continuous across the bound, carries no torque, and
    # uses the gap's own eigenvalue, so it adds no new stiffness.
    def backlash(t, tm, wm, tl, wl, tb):
        # Returns (Ts, d(theta_b)/dt).
        if alpha_fun is None:
            a = alpha0
        else:
            a = float(alpha_fun(t))
            if not (0.0 <= a < inf):
                raise _bad_alpha(t, a)
        wd = wm - wl
        if tb > a:
            e = tb - a
            s = wd + rate * (tm - tl - a)
            if a == 0.0:
                return cs * s, -RELAX * tb
            if s > 0.0:
                v = s * (1.0 - e * INV1) if e < ETA1 else 0.0
            else:
                v = s
            if e > ETA2:
                return cs * (s - v), v - RELAX * (e - ETA2)
            return cs * (s - v), v
        if tb < -a:
            e = -a - tb
            s = wd + rate * (tm - tl + a)
            if a == 0.0:
                return cs * s, -RELAX * tb
            if s < 0.0:
                v = s * (1.0 - e * INV1) if e < ETA1 else 0.0
            else:
                v = s
            if e > ETA2:
                return cs * (s - v), v + RELAX * (e - ETA2)
            return cs * (s - v), v
        if a == 0.0:
            return cs * (wd + rate * (tm - tl)), 0.0
        return 0.0, wd + rate * (tm - tl - tb)

    def updfcn(t, x, u, params=None):
        tm, wm, tl, wl, tb = x.tolist()
        tq_m, tq_d = u.tolist()
        ts, dtb = backlash(t, tm, wm, tl, wl, tb)
        return np.array(
            (
                wm,
                (tq_m - cm * wm - ts) * inv_jm,
                wl,
                (ts - cl * wl - tq_d) * inv_jl,
                dtb,
            )
        )

    def outfcn(t, x, u, params=None):
        tm, wm, tl, wl, tb = x.tolist()
        return np.array((tm, wm, tl, wl, backlash(t, tm, wm, tl, wl, tb)[0]))

    return updfcn, outfcn


def _deadzone_model(params: Parameters, alpha0: float, alpha_fun):
    """Update and output functions of the dead-zone backlash model."""
    inv_jm, inv_jl = 1.0 / params.Jm, 1.0 / params.Jl
    cm, cl, ks, cs = params.cm, params.cl, params.ks, params.cs
    inf = math.inf

    def shaft(t, tm, wm, tl, wl):
        if alpha_fun is None:
            a = alpha0
        else:
            a = float(alpha_fun(t))
            if not (0.0 <= a < inf):
                raise _bad_alpha(t, a)
        td = tm - tl
        # Closed bounds, so that alpha = 0 is the linear model everywhere.
        if td >= a:
            return ks * (td - a) + cs * (wm - wl)
        if td <= -a:
            return ks * (td + a) + cs * (wm - wl)
        return 0.0

    def updfcn(t, x, u, params=None):
        tm, wm, tl, wl = x.tolist()
        tq_m, tq_d = u.tolist()
        ts = shaft(t, tm, wm, tl, wl)
        return np.array(
            (wm, (tq_m - cm * wm - ts) * inv_jm, wl, (ts - cl * wl - tq_d) * inv_jl)
        )

    def outfcn(t, x, u, params=None):
        tm, wm, tl, wl = x.tolist()
        return np.array((tm, wm, tl, wl, shaft(t, tm, wm, tl, wl)))

    return updfcn, outfcn
