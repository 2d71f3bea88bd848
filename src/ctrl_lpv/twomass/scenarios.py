"""Closed-loop scenarios of the paper, built from python-control parts."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import control as ct
import numpy as np

from .._numba import numba_available, require_numba
from ..metrics import StepMetrics, step_metrics
from ..simulation import simulate as run
from .parameters import Parameters
from .plant import compiled_plant
from .plant import plant as make_plant

__all__ = ["closed_loop", "simulate", "metrics", "alpha_step", "AlphaStep"]

_ENGINES = ("control", "fast", "compiled", "auto")


def alpha_step(before: float = 0.03, after: float = 0.045, at: float = 2.5):
    """Backlash that steps from `before` to `after` at time `at`.

    The varying backlash of the paper's Figs. 6-7.

    Parameters
    ----------
    before, after : float, optional
        Half-gap before and from `at` on, rad (default 0.03 and 0.045).
    at : float, optional
        Time of the step, s (default 2.5).

    Returns
    -------
    callable
        ``alpha(t)``, for the ``alpha`` argument of `plant` or `simulate`;
        its fields ``before``, ``after`` and ``at`` let the compiled engine
        run it (and it pickles, for sweeps).
    """
    return AlphaStep(float(before), float(after), float(at))


@dataclass(frozen=True)
class AlphaStep:
    """``alpha(t) = before if t < at else after`` (see `alpha_step`).

    Attributes
    ----------
    before, after : float
        Half-gap before `at` and from `at` on, rad.
    at : float
        Time of the step, s.
    """

    before: float
    after: float
    at: float

    def __call__(self, t: float) -> float:
        return self.before if t < self.at else self.after


def closed_loop(controller, params=None, model="exact", alpha=None):
    """Interconnect the plant and a controller with `control.interconnect`.

    Parameters
    ----------
    controller : `control.NonlinearIOSystem`
        Inputs ``theta_m, omega_m, theta_l, omega_l, theta_r``, output
        ``Tm`` (as from `lpv_controller` or `backstepping_controller`).
    params : `Parameters`, optional
        Plant data.
    model : {"exact", "deadzone"}, optional
        Backlash model of the plant.
    alpha : float or callable, optional
        Backlash of the plant, default ``params.alpha``.

    Returns
    -------
    `control.InterconnectedSystem`
        Inputs ``["theta_r", "Td"]``, outputs ``["theta_l", "Tm", "theta_m",
        "omega_m", "omega_l", "Ts"]``.
    """
    drive = make_plant(params, model=model, alpha=alpha, name="plant")
    return ct.interconnect(
        [drive, controller],
        inplist=["theta_r", "Td"],
        inputs=["theta_r", "Td"],
        outlist=["plant.theta_l", "plant.Tm", "plant.theta_m", "plant.omega_m",
                 "plant.omega_l", "plant.Ts"],
        outputs=["theta_l", "Tm", "theta_m", "omega_m", "omega_l", "Ts"],
        name="loop",
    )  # fmt: skip


def simulate(
    controller,
    *,
    params: Parameters | None = None,
    model: str = "exact",
    alpha: float | Callable[[float], float] | None = None,
    theta_r: float = 0.5,
    Td: float = 8.0,
    T: float = 5.0,
    npoints: int = 5001,
    method: str | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-9,
    engine: str = "control",
) -> ct.TimeResponseData:
    """Step of the load reference with a constant load torque.

    The paper's scenario: ``theta_r = 0.5`` rad, ``Td = 8`` Nm, 5 s, from
    rest, at ``rtol=1e-6`` (python-control's default RK45 tolerance is far
    too loose here).

    Parameters
    ----------
    controller : `control.NonlinearIOSystem`
        The controller: inputs ``theta_m, omega_m, theta_l, omega_l,
        theta_r``, output ``Tm`` (as from `lpv_controller` or
        `backstepping_controller`), connected to the plant by name.
    params : `Parameters`, optional
        Plant data; default the paper's table.
    model : {"exact", "deadzone"}, optional
        Backlash model of the plant, default ``"exact"``.
    alpha : float or callable, optional
        Backlash half-gap of the plant (rad), or a function ``alpha(t)``
        (see `alpha_step`); default ``params.alpha``.
    theta_r, Td : float, optional
        Reference step (rad) and load torque (Nm).
    T : float, optional
        Duration, s.
    npoints : int, optional
        Number of time points, ``T`` included.
    method : str, optional
        `scipy.integrate.solve_ivp` method of the ``"control"`` and
        ``"fast"`` engines, default ``"LSODA"``.  The compiled engine
        integrates with Dormand-Prince 5(4) (scipy's ``"RK45"``, the only
        value it accepts).
    rtol, atol : float, optional
        Solver tolerances.
    engine : {"control", "fast", "compiled", "auto"}, optional
        ``"control"`` (default): `control.input_output_response` on the
        loop of `closed_loop`.  ``"fast"``: the fused right-hand side of
        `ctrl_lpv.simulate` on the same loop, about 100 times faster with
        LSODA and 10 times with RK45 (``benchmarks/bench_simulation.py``);
        results agree to the solver tolerance.  ``"compiled"``: the same
        loop compiled by numba (``pip install "ctrl_lpv[fast]"``) and
        integrated by a compiled Dormand-Prince 5(4) at a tenth of the
        tolerances, so that at the same `rtol` it is as accurate as the
        LSODA of ``"fast"`` (more on most sweep runs; with the dead-zone
        model, whose damper torque jumps at contact, 3 times less, within
        1e-6 rad), and 12 to 28 times faster than it in a sweep
        (``benchmarks/bench_compiled_sweep.py``); it runs
        `lpv_controller` (constant ``alpha_estimate``) and
        `backstepping_controller` on a constant or stepped (`alpha_step`)
        backlash.  The first call in a fresh installation compiles for
        15 to 30 s; the code is cached on disk for later processes (about
        0.5 s to load).
        ``"auto"``: ``"compiled"`` where numba is installed and the
        controller and `alpha` have a compiled form, else ``"fast"`` (the
        default of `sweep`).

    Returns
    -------
    `control.TimeResponseData`
        Outputs ``["theta_l", "Tm", "theta_m", "omega_m", "omega_l",
        "Ts"]`` (the loop of `closed_loop`) at `npoints` times from 0 to
        `T`.

    Raises
    ------
    ValueError
        For an unknown `engine`, a `method` other than ``"RK45"`` with the
        compiled engine, or a controller or `alpha` that the compiled
        engine does not run (with ``engine="compiled"``).
    ImportError
        For ``engine="compiled"`` without numba.
    """
    if engine not in _ENGINES:
        raise ValueError(f"engine: expected one of {_ENGINES}, got {engine!r}")
    t = np.linspace(0.0, T, npoints)
    if engine in ("compiled", "auto"):
        drive = compiled_plant(params, model, alpha)  # checked as by `plant`
        law = getattr(getattr(controller, "_kernel", None), "compiled", None)
        runs = numba_available() and drive is not None and law is not None
        if engine == "compiled" or runs:
            if method not in (None, "RK45"):
                raise ValueError(
                    "method: the compiled engine integrates with Dormand-Prince "
                    f"5(4), method='RK45'; got {method!r}"
                )
            require_numba("engine='compiled'")
            from .compiled import simulate_loop

            return simulate_loop(
                drive, controller, t, theta_r=theta_r, Td=Td, rtol=rtol, atol=atol
            )
        engine = "fast"
    loop = closed_loop(controller, params, model, alpha)
    U = np.vstack([np.full_like(t, theta_r), np.full_like(t, Td)])
    return run(
        loop, t, U, np.zeros(loop.nstates), engine=engine,
        method="LSODA" if method is None else method, rtol=rtol, atol=atol,
    )  # fmt: skip


def metrics(response: ct.TimeResponseData, theta_r: float = 0.5) -> StepMetrics:
    """Step metrics of the load angle and motor torque of a response.

    Parameters
    ----------
    response : `control.TimeResponseData`
        A response with outputs ``theta_l`` and ``Tm`` (as from `simulate`),
        starting from rest.
    theta_r : float, optional
        The reference step, rad (default 0.5).

    Returns
    -------
    `ctrl_lpv.metrics.StepMetrics`
        Rise and settling times, overshoot, steady-state error, IAE, ISE,
        peak torque and control energy.
    """
    out = response.outputs
    labels = response.output_labels
    return step_metrics(
        response.time,
        out[labels.index("theta_l")],
        theta_r,
        out[labels.index("Tm")],
        initial=0.0,
    )
