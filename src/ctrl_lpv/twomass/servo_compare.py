"""Servo scenarios, metrics and the fair comparison under one torque limit.

Functions for the benchmark (``benchmarks/bench_servo.py``), the tests and
``ctrl-lpv reproduce``:

* `servo_loop`: exact plant, a saturation ``|Tm| <= limit`` at the plant
  input, and a controller with the servo interface, by `control.interconnect`;
* `run_servo_scenario`, `servo_metrics`: one scenario and its numbers;
* `servo_scenarios`: the issue's grid (paper scenario, alpha x Jl x Td);
* `comparison_controllers`, `servo_comparison`: the servo against the
  published gain and backstepping, each also with the servo's trajectory
  (and, for the state feedback, its feedforward), all under the same limit.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

import control as ct
import numpy as np

from ..interconnection import BlockKernel, kernel_nlsys
from ..simulation import simulate
from .backstepping import backstepping_controller
from .feedback import lpv_controller
from .model import paper_gain
from .parameters import Parameters
from .plant import plant
from .scenarios import alpha_step
from .servo import ServoDesign, servo_design
from .servo_config import ServoAntiHunting, ServoEstimator
from .trajectory import reference_generator

__all__ = [
    "servo_loop",
    "run_servo_scenario",
    "run_sampled_servo_scenario",
    "servo_metrics",
    "ServoMetrics",
    "servo_scenarios",
    "comparison_controllers",
    "servo_comparison",
    "torque_saturation",
]

CONTROLLER_INPUTS = ["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"]


def torque_saturation(limit: float, name: str = "saturation") -> ct.NonlinearIOSystem:
    """Static block ``y = clip(u, -limit, limit)`` (input ``u``, output ``y``)."""
    if not (np.isfinite(limit) and limit > 0):
        raise ValueError(f"limit: must be a positive number, got {limit!r}")
    lim = float(limit)

    def out(t, x, u):
        v = u[0]
        return (-lim if v < -lim else (lim if v > lim else v),)

    return kernel_nlsys(BlockKernel(out=out), inputs=["u"], outputs=["y"], name=name)


def servo_loop(
    controller: ct.NonlinearIOSystem,
    params: Parameters | None = None,
    alpha: float | Callable[[float], float] | None = None,
    torque_limit: float = 500.0,
) -> ct.InterconnectedSystem:
    """Exact plant, torque saturation and a controller, interconnected.

    Parameters
    ----------
    controller : `control.NonlinearIOSystem`
        Inputs ``theta_m, omega_m, theta_l, omega_l, theta_r``, output
        ``Tm``.
    params : `Parameters`, optional
        Plant data (e.g. another load inertia).
    alpha : float or callable, optional
        Half-gap of the plant (default ``params.alpha``).
    torque_limit : float, optional
        Saturation at the plant input, Nm.

    Returns
    -------
    `control.InterconnectedSystem`
        Inputs ``["theta_r", "Td"]``, outputs ``["theta_l", "Tm", "Tm_cmd",
        "theta_m", "omega_m", "omega_l", "Ts"]`` (``Tm`` at the plant,
        ``Tm_cmd`` from the controller).
    """
    drive = plant(params, model="exact", alpha=alpha, name="plant")
    sat = torque_saturation(torque_limit, name="saturation")
    c = controller.name
    return ct.interconnect(
        [drive, sat, controller],
        connections=[["plant.Tm", "saturation.y"], ["saturation.u", f"{c}.Tm"]]
        + [[f"{c}.{s}", f"plant.{s}"] for s in CONTROLLER_INPUTS[:4]],
        inplist=[f"{c}.theta_r", "plant.Td"],
        inputs=["theta_r", "Td"],
        outlist=["plant.theta_l", "saturation.y", f"{c}.Tm", "plant.theta_m",
                 "plant.omega_m", "plant.omega_l", "plant.Ts"],
        outputs=["theta_l", "Tm", "Tm_cmd", "theta_m", "omega_m", "omega_l", "Ts"],
        name="servo_loop",
    )  # fmt: skip


def _target(theta_r, t: np.ndarray) -> np.ndarray:
    """Target samples: a number, or ``[(time, value), ...]`` steps from 0."""
    if np.isscalar(theta_r):
        return np.full_like(t, float(theta_r))
    out = np.zeros_like(t)
    for at, value in theta_r:
        out[t >= at] = float(value)
    return out


def run_servo_scenario(
    controller: ct.NonlinearIOSystem,
    *,
    params: Parameters | None = None,
    alpha=0.03,
    Jl: float = 1.0,
    Td: float = 8.0,
    theta_r=0.5,
    T: float = 5.0,
    dt: float = 1e-3,
    torque_limit: float = 500.0,
    rtol: float = 1e-6,
    atol: float = 1e-9,
) -> ct.TimeResponseData:
    """Simulate one scenario (LSODA, fast engine) from rest at the origin.

    Parameters
    ----------
    controller : `control.NonlinearIOSystem`
        Position controller with inputs ``theta_m, omega_m, theta_l,
        omega_l, theta_r`` and output ``Tm`` (e.g. ``design.controller()``).
    params : `Parameters`, optional
        Nominal plant data; the load inertia is ``Jl * params.Jl``.
    alpha : float or callable, optional
        Plant half-gap.
    Jl : float, optional
        Load inertia multiple.
    Td : float, optional
        Load torque, Nm.
    theta_r : float or list of (float, float), optional
        Target: a constant from t = 0, or steps ``[(time, value), ...]``.
    T, dt : float, optional
        Duration and output step, s.
    torque_limit : float, optional
        Saturation at the plant input.
    rtol, atol : float, optional
        LSODA tolerances.

    Returns
    -------
    `control.TimeResponseData`
        Outputs of `servo_loop`, states included.
    """
    params = Parameters() if params is None else params
    loop = servo_loop(
        controller, params.replace(Jl=Jl * params.Jl), alpha, torque_limit
    )
    t = np.arange(0.0, T + 0.5 * dt, dt)
    U = np.vstack([_target(theta_r, t), np.full_like(t, float(Td))])
    return simulate(
        loop, t, U, 0.0, method="LSODA", rtol=rtol, atol=atol, return_states=True
    )


def run_sampled_servo_scenario(
    design: ServoDesign,
    *,
    params: Parameters | None = None,
    alpha=0.03,
    Jl: float = 1.0,
    Td: float = 8.0,
    theta_r: float = 0.5,
    T: float = 5.0,
    noise: float = 0.5,
    seed=0,
) -> ct.TimeResponseData:
    """Simulate a sampled servo on the exact plant read by its encoders.

    `ctrl_lpv.sampled_response` of ``design.controller()`` (a sampled
    design, ``dt`` set) on the exact plant, with the design's delay and
    encoders of its counts per revolution and `noise` counts of Gaussian
    noise.

    Parameters
    ----------
    design : `ServoDesign` or `ctrl_lpv.twomass.cascade.CascadeDesign`
        A sampled design (``servo_design(dt=..., sensors="encoders")``, or
        the cascade reference ``cascade_design(servo)``): anything with
        ``controller()``, ``dt``, ``delay`` and ``encoder_counts``.
    params, alpha, Jl, Td, theta_r, T
        As in `run_servo_scenario` (a constant target).
    noise : float, optional
        Encoder noise, counts (standard deviation).
    seed : int, optional
        Seed of the noise.

    Returns
    -------
    `control.TimeResponseData`
        At the sampling instants, with the outputs of `servo_loop`
        (``theta_l``, ``Tm``, ``Tm_cmd``, ``theta_m``, ``omega_m``,
        ``omega_l``, ``Ts``), so that `servo_metrics` reads it.
    """
    from ..sampled import sampled_response
    from ..sensors import Encoder

    if getattr(design, "dt", None) is None:
        raise ValueError("design: a continuous-time design; use run_servo_scenario")
    params = Parameters() if params is None else params
    loop_plant = plant(params.replace(Jl=Jl * params.Jl), alpha=alpha)
    controller = design.controller()
    sensors = {
        name: Encoder(c, noise)
        for name, c in zip(("theta_m", "theta_l"), design.encoder_counts)
        if name in controller.input_labels  # a motor-encoder design: theta_m
    }
    res = sampled_response(
        loop_plant, controller, T, inputs={"Td": Td, "theta_r": theta_r},
        delay=design.delay, sensors=sensors, seed=seed,
    )  # fmt: skip
    p = res.plant
    out = {name: p.outputs[p.output_labels.index(name)] for name in p.output_labels}
    torque = p.inputs[p.input_labels.index("Tm")]
    labels = ["theta_l", "Tm", "Tm_cmd", "theta_m", "omega_m", "omega_l", "Ts"]
    columns = [out["theta_l"], torque, torque] + [out[n] for n in labels[3:]]
    return ct.TimeResponseData(
        p.time,
        np.vstack(columns),
        output_labels=labels,
        issiso=False,
        sysname="sampled servo",
    )


@dataclass(frozen=True)
class ServoMetrics:
    """Numbers of one servo run (angles in rad, times in s, torques in Nm).

    Attributes
    ----------
    settling : float
        2 % settling time of the load about the final target (``inf`` if
        never settled).
    overshoot : float
        Overshoot, % of the step.
    error_5s : float
        ``|theta_l - theta_r|`` at t = 5 s.
    max_error_tail : float
        Largest ``|theta_l - theta_r|`` on ``[3 s, T]``.
    tail_ptp : float
        Peak-to-peak of the load error over the last 40 % of the run.
    tail_torque_ptp : float
        Peak-to-peak of the plant torque over the same window (a limit cycle
        shows up here).
    peak_torque : float
        Largest plant torque.
    peak_command : float
        Largest controller output (before the plant's saturation).
    """

    settling: float
    overshoot: float
    error_5s: float
    max_error_tail: float
    tail_ptp: float
    tail_torque_ptp: float
    peak_torque: float
    peak_command: float

    def as_dict(self) -> dict:
        """The fields as a dict of floats."""
        return {k: float(v) for k, v in asdict(self).items()}


def servo_metrics(response: ct.TimeResponseData, theta_r=0.5) -> ServoMetrics:
    """Metrics of a `run_servo_scenario` response.

    Parameters
    ----------
    response : `control.TimeResponseData`
        With outputs ``theta_l``, ``Tm`` and ``Tm_cmd``.
    theta_r : float or list of (float, float), optional
        The target as passed to the scenario; steps are measured from the
        last one.

    Returns
    -------
    `ServoMetrics`
    """
    t = response.time
    labels = response.output_labels
    y = response.outputs[labels.index("theta_l")]
    tm = response.outputs[labels.index("Tm")]
    cmd = response.outputs[labels.index("Tm_cmd")]
    target = _target(theta_r, t)
    final = target[-1]
    if np.isscalar(theta_r):
        start, t0, y0 = 0.0, 0.0, 0.0
    else:
        t0 = float(theta_r[-1][0])
        start = target[np.searchsorted(t, t0) - 1] if t0 > 0 else 0.0
        y0 = start
    step = final - start if final != start else 1.0
    e = y - target
    after = t >= t0
    out = np.abs(y[after] - final) > 0.02 * abs(step)
    ta = t[after]
    if not out.any():
        settling = 0.0
    elif out[-1]:
        settling = np.inf
    else:
        settling = float(ta[np.nonzero(out)[0][-1] + 1] - t0)
    overshoot = max(0.0, float(np.max((y[after] - final) * np.sign(step)))) / abs(step)
    del y0
    tail = t >= 3.0
    win = t >= t[-1] - 0.4 * (t[-1] - t[0])
    i5 = min(np.searchsorted(t, 5.0), t.size - 1)
    return ServoMetrics(
        settling=settling,
        overshoot=100.0 * overshoot,
        error_5s=float(abs(e[i5])),
        max_error_tail=float(np.max(np.abs(e[tail]))) if tail.any() else np.nan,
        tail_ptp=float(np.ptp(e[win])),
        tail_torque_ptp=float(np.ptp(tm[win])),
        peak_torque=float(np.max(np.abs(tm))),
        peak_command=float(np.max(np.abs(cmd))),
    )


def servo_scenarios() -> list[dict]:
    """The scenarios of issue 12 (keywords of `run_servo_scenario`).

    Returns
    -------
    list of dict
        The paper scenario (0.5 rad, alpha 0.03 -> 0.045 at 2.5 s, Td = 8,
        5 s), then alpha in {0, 0.03, 0.045, 0.06} x Jl in {0.8, 1, 1.2}
        with Td = 8 (5 s) and with Td = 0 (20 s).  Each dict has a
        ``"name"`` and a ``"group"`` besides the keywords.
    """
    rows = [
        dict(name="paper", group="paper", alpha=alpha_step(), Jl=1.0, Td=8.0, T=5.0)
    ]
    for Td, T in ((8.0, 5.0), (0.0, 20.0)):
        for a in (0.0, 0.03, 0.045, 0.06):
            for jl in (0.8, 1.0, 1.2):
                rows.append(
                    dict(name=f"a={a:g} Jl={jl:g} Td={Td:g}", group=f"Td={Td:g}",
                         alpha=a, Jl=jl, Td=Td, T=T)
                )  # fmt: skip
    return rows


def comparison_controllers(
    design: ServoDesign | None = None, torque_limit: float = 500.0
) -> dict[str, ct.NonlinearIOSystem]:
    """The controllers of the fair comparison, all with the servo interface.

    Parameters
    ----------
    design : `ServoDesign`, optional
        The servo (default ``servo_design(torque_limit=torque_limit)``).
    torque_limit : float, optional
        Limit of every controller's own output.

    Returns
    -------
    dict
        ``"servo"``; ``"servo, no anti-hunting"`` (the same trajectory,
        feedforward and gain without the anti-hunting parts: the issue's
        exploration); ``"published K + traj/ff"`` (the paper's gain on the
        error to the servo's trajectory, with its feedforward, fixed gap
        offset ``alpha_max / 2``); ``"published K"`` (as published, on the
        target); ``"backstepping + traj"`` (the target replaced by the
        servo's planned trajectory) and ``"backstepping"`` (as in the
        paper comparison, ``Td_hat = 0``).  Every output is clipped at
        `torque_limit`.
    """
    if design is None:
        design = servo_design(torque_limit=torque_limit)
    kw = dict(
        torque_limit=torque_limit, alpha_max=design.alpha_max,
        Jl_range=design.Jl_range, Td_max=design.Td_max, certify=False,
    )  # fmt: skip
    off = ServoAntiHunting(enabled=False)
    plain = servo_design(design.params, anti_hunting=off, **kw)
    paper_ff = servo_design(
        design.params, gain=paper_gain(), anti_hunting=off,
        estimator=ServoEstimator(gap_estimate=False), **kw,
    )  # fmt: skip
    planner = reference_generator(
        design.accel_limit, min_duration=design.tuning.min_duration,
        horizon_floor=design.tuning.horizon_floor, name="planner",
    )  # fmt: skip
    bs = backstepping_controller(design.params, torque_limit=torque_limit, name="bs")
    bs_traj = ct.interconnect(
        [planner, bs],
        connections=[["bs.theta_r", "planner.r"]],
        inplist=[["bs.theta_m"], ["bs.omega_m"], ["bs.theta_l"], ["bs.omega_l"],
                 ["planner.theta_r"]],
        inputs=CONTROLLER_INPUTS, outlist=["bs.Tm"], outputs=["Tm"],
        name="bs_traj", check_unused=False,
    )  # fmt: skip
    return {
        "servo": design.controller("servo"),
        "servo, no anti-hunting": plain.controller("servo_plain"),
        "published K + traj/ff": paper_ff.controller("paper_ff"),
        "published K": lpv_controller(
            paper_gain(), torque_limit=torque_limit, name="paper"
        ),
        "backstepping + traj": bs_traj,
        "backstepping": backstepping_controller(
            design.params, torque_limit=torque_limit, name="backstepping"
        ),
    }


def servo_comparison(
    controllers: dict | None = None,
    scenarios: list[dict] | None = None,
    *,
    torque_limit: float = 500.0,
    progress: Callable[[str], None] | None = None,
) -> list[dict]:
    """Run every controller on every scenario.

    Parameters
    ----------
    controllers : dict, optional
        Name -> controller (default `comparison_controllers`).
    scenarios : list of dict, optional
        Default `servo_scenarios`.
    torque_limit : float, optional
        Plant saturation.
    progress : callable, optional
        Called with a line per finished run.

    Returns
    -------
    list of dict
        One row per (controller, scenario): ``controller``, ``scenario``,
        ``group``, the `ServoMetrics` fields, ``success``.
    """
    if controllers is None:
        controllers = comparison_controllers(torque_limit=torque_limit)
    scenarios = servo_scenarios() if scenarios is None else scenarios
    rows = []
    for cname, ctrl in controllers.items():
        for sc in scenarios:
            kw = {k: v for k, v in sc.items() if k not in ("name", "group")}
            resp = run_servo_scenario(ctrl, torque_limit=torque_limit, **kw)
            m = servo_metrics(resp, kw.get("theta_r", 0.5))
            row = dict(controller=cname, scenario=sc["name"], group=sc["group"])
            row.update(m.as_dict())
            row["success"] = bool(resp.success)
            rows.append(row)
            if progress is not None:
                progress(f"{cname:24s} {sc['name']:22s} ts={m.settling:.3f}")
    return rows
