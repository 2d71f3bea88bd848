"""Scenario sweeps of the two-mass drive: picklable controllers, a runner.

python-control I/O systems built with closures (all controllers of this
package) do not pickle, so sweeps send small frozen specs to the workers
(`LPVSpec`, `BacksteppingSpec`) and build the controllers there, once per
process. `run_scenario` simulates one spec in one scenario and returns its
step metrics; `sweep` runs it over many scenarios with `ctrl_lpv.sweep`.
"""

from __future__ import annotations

import functools
import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING, Any

import control as ct
import numpy as np

from ..batch import _as_scenarios
from ..batch import sweep as _generic_sweep
from ..synthesis import StateFeedbackDesign
from .backstepping import DEFAULT_GAINS, backstepping_controller
from .comparison import ALPHA_ESTIMATE, CONTROLLERS, comparison_designs
from .feedback import lpv_controller
from .model import paper_gain
from .parameters import Parameters
from .scenarios import alpha_step, metrics
from .scenarios import simulate as default_simulate

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "LPVSpec",
    "BacksteppingSpec",
    "lpv_spec",
    "backstepping_spec",
    "comparison_specs",
    "run_scenario",
    "sweep",
]

_FIELDS = tuple(f.name for f in fields(Parameters) if f.name != "alpha")

#: Scenario keys of `run_scenario` besides the parameter changes.
SCENARIO_KEYS = (
    "alpha", "alpha_after", "alpha_at", "theta_r", "Td", "torque_limit",
    "model", "T", "npoints", "params",
)  # fmt: skip


@dataclass(frozen=True)
class LPVSpec:
    """Picklable recipe of an `lpv_controller`.

    Attributes
    ----------
    gains : tuple of tuple of float
        One row per vertex gain (a single row for a common gain), on the
        error coordinates ``[e_m, omega_m, e_l, omega_l]`` and, for integral
        designs, ``int_e_l`` (``u = -K x``).
    p_bounds : (float, float) or None
        Interval of ``p`` of vertex gains (the first row at the lower
        bound); None for a common gain.
    alpha_estimate : float or None
        Backlash estimate used to schedule vertex gains.
    """

    gains: tuple[tuple[float, ...], ...]
    p_bounds: tuple[float, float] | None = None
    alpha_estimate: float | None = None

    def build(self, torque_limit: float | None = None) -> ct.NonlinearIOSystem:
        """The controller I/O system (see `lpv_controller`)."""
        return lpv_controller(
            np.array(self.gains, dtype=float),
            p_bounds=self.p_bounds,
            alpha_estimate=self.alpha_estimate,
            torque_limit=torque_limit,
        )


@dataclass(frozen=True)
class BacksteppingSpec:
    """Picklable recipe of a `backstepping_controller`.

    Attributes
    ----------
    params : `Parameters` or None
        Design data (None: the paper's table).
    gains : (float, float, float, float)
        ``c1, c2, c3, c4``.
    alpha, sharpness, eps, Td_hat : float
        As in `backstepping_controller`; `torque_limit` is a scenario
        variable, given to `build`.
    """

    params: Parameters | None = None
    gains: tuple[float, float, float, float] = DEFAULT_GAINS
    alpha: float | None = None
    sharpness: float = 10.0
    eps: float = 1e-3
    Td_hat: float = 0.0

    def build(self, torque_limit: float | None = None) -> ct.NonlinearIOSystem:
        """The controller I/O system (see `backstepping_controller`)."""
        return backstepping_controller(
            self.params,
            self.gains,
            alpha=self.alpha,
            sharpness=self.sharpness,
            eps=self.eps,
            Td_hat=self.Td_hat,
            torque_limit=torque_limit,
        )


def lpv_spec(
    design: StateFeedbackDesign | np.ndarray | None = None,
    *,
    alpha_estimate: float | None = None,
) -> LPVSpec:
    """Picklable spec of an `lpv_controller`, for sweeps.

    Parameters
    ----------
    design : `StateFeedbackDesign` or array_like, optional
        As in `lpv_controller`: a design on ``lpv_model(formulation=
        "tracking")``, a ``1 x 4`` gain, or None for the paper's gain.
    alpha_estimate : float, optional
        Backlash estimate for vertex gains (a constant: a callable would
        have to pickle).

    Returns
    -------
    `LPVSpec`

    Raises
    ------
    ValueError
        If the controller cannot be built from these arguments (checked
        here, in the calling process, rather than in every worker).
    """
    if alpha_estimate is not None:
        if callable(alpha_estimate) or not np.isfinite(alpha_estimate):
            raise ValueError(
                f"alpha_estimate: expected a finite number, got {alpha_estimate!r}"
            )
        alpha_estimate = float(alpha_estimate)
    bounds = None
    if isinstance(design, StateFeedbackDesign):
        gains = np.stack(design.gains)[:, 0, :]
        domain = design.system.domain
        if design.scheduled:
            if tuple(domain.names) != ("p",):
                raise ValueError(
                    f"design: expected a design over the parameter 'p' of "
                    f"twomass.lpv_model, got parameters {list(domain.names)}"
                )
            # Vertex gains in the box's order: p = lower, then p = upper.
            bounds = (float(domain.lower[0]), float(domain.upper[0]))
    else:
        gains = paper_gain() if design is None else np.asarray(design, dtype=float)
    spec = LPVSpec(
        tuple(tuple(float(v) for v in row) for row in np.atleast_2d(gains)),
        bounds,
        alpha_estimate,
    )
    spec.build()  # validates here rather than in every worker
    return spec


def backstepping_spec(
    params: Parameters | None = None,
    gains: tuple[float, float, float, float] = DEFAULT_GAINS,
    **kwargs: float,
) -> BacksteppingSpec:
    """Picklable spec of a `backstepping_controller`, for sweeps.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data of the controller's design model; default (None) the
        paper's table.
    gains : (c1, c2, c3, c4), optional
        Positive backstepping gains, default ``(10, 20, 100, 200)``.
    **kwargs : float
        Only these keywords of `backstepping_controller`: ``alpha``
        (backlash half-gap assumed by the controller, rad; default
        ``params.alpha``), ``sharpness`` (``k alpha`` of the smooth dead
        zone, default 10), ``eps`` (width of the smoothed inverse, rad,
        default 1e-3) and ``Td_hat`` (known load torque, Nm, default 0).
        The torque limit is a scenario variable, given to
        `BacksteppingSpec.build`.

    Returns
    -------
    `BacksteppingSpec`
        Validated: its controller was built once in the calling process.

    Raises
    ------
    TypeError
        For a keyword other than those above, or `params` that is not a
        `Parameters`.
    ValueError
        For gains that are not four positive numbers, a negative `alpha`,
        a nonpositive `sharpness` or `eps`, or non-finite values.
    """
    allowed = {"alpha", "sharpness", "eps", "Td_hat"}
    unknown = sorted(set(kwargs) - allowed)
    if unknown:
        raise TypeError(
            f"backstepping_spec: unknown argument(s) {unknown}; "
            f"expected {sorted(allowed)}"
        )
    spec = BacksteppingSpec(params, tuple(float(c) for c in gains), **kwargs)
    spec.build()  # validates in the calling process
    return spec


def comparison_specs(
    designs: Mapping[str, StateFeedbackDesign] | None = None,
) -> dict[str, LPVSpec | BacksteppingSpec]:
    """Specs of the four controllers of `compare`, for `sweep`.

    The picklable counterpart of `comparison_controllers`: ``"paper K"``,
    ``"LPV robust"``, ``"LPV scheduled"`` (scheduled with the backlash
    estimate 0.03 rad) and ``"backstepping"`` (``Td_hat = 8`` Nm).

    Parameters
    ----------
    designs : dict, optional
        As from `comparison_designs` (computed when omitted).

    Returns
    -------
    dict
        Name -> spec, in `CONTROLLERS` order.
    """
    designs = comparison_designs() if designs is None else designs
    specs = {
        "paper K": lpv_spec(),
        "LPV robust": lpv_spec(designs["LPV robust"]),
        "LPV scheduled": lpv_spec(
            designs["LPV scheduled"], alpha_estimate=ALPHA_ESTIMATE
        ),
        "backstepping": backstepping_spec(Td_hat=8.0),
    }
    return {name: specs[name] for name in CONTROLLERS}


@functools.lru_cache(maxsize=64)
def _built(spec, torque_limit):
    # One controller per (spec, limit) and process: building costs more
    # than a fast simulation.
    return spec.build(torque_limit=torque_limit)


def _controller(spec, torque_limit):
    if isinstance(spec, ct.InputOutputSystem):
        if torque_limit is not None:
            raise ValueError(
                "torque_limit: needs a controller spec (LPVSpec, BacksteppingSpec),"
                " not a built I/O system"
            )
        return spec
    if not callable(getattr(spec, "build", None)):
        raise TypeError(
            "controller: expected a spec with a build(torque_limit) method "
            f"(lpv_spec, backstepping_spec), got {type(spec).__name__}"
        )
    try:
        return _built(spec, torque_limit)
    except TypeError:  # unhashable spec: build without the cache
        return spec.build(torque_limit=torque_limit)


def _plant_params(params, changes) -> Parameters:
    base = Parameters() if params is None else params
    if not isinstance(base, Parameters):
        raise TypeError(f"params: expected twomass.Parameters, got {type(base)!r}")
    new = {}
    for key, value in changes.items():
        name = key.removesuffix("_scale")
        if name not in _FIELDS:
            raise TypeError(
                f"run_scenario: unknown scenario key {key!r}; expected "
                f"{list(SCENARIO_KEYS)} or a parameter {list(_FIELDS)} "
                "(absolute) or '<parameter>_scale' (relative to nominal)"
            )
        new[name] = getattr(base, name) * value if key.endswith("_scale") else value
    return base.replace(**new) if new else base


def _accepts(function, keyword: str) -> bool:
    try:
        return _accepts_cached(function, keyword)
    except TypeError:  # an unhashable callable
        return _signature_accepts(function, keyword)


@functools.lru_cache(maxsize=64)
def _accepts_cached(function, keyword: str) -> bool:
    # inspect.signature costs as much as a compiled simulation.
    return _signature_accepts(function, keyword)


def _signature_accepts(function, keyword: str) -> bool:
    try:
        signature = inspect.signature(function)
    except (TypeError, ValueError):
        return False
    return keyword in signature.parameters or any(
        p.kind is inspect.Parameter.VAR_KEYWORD for p in signature.parameters.values()
    )


def run_scenario(
    controller,
    *,
    alpha: float | Callable[[float], float] | None = None,
    alpha_after: float | None = None,
    alpha_at: float = 2.5,
    theta_r: float = 0.5,
    Td: float = 8.0,
    torque_limit: float | None = None,
    model: str = "exact",
    T: float = 5.0,
    npoints: int | None = None,
    params: Parameters | None = None,
    engine: str | None = None,
    simulate: Callable[..., Any] | None = None,
    **changes: float,
) -> dict[str, float]:
    """Simulate one controller in one two-mass scenario; its metrics.

    The controller is designed beforehand (on nominal data); the scenario
    sets the plant: backlash, load torque, reference and parameter
    mismatch.

    Parameters
    ----------
    controller : spec or `control.NonlinearIOSystem`
        A spec with ``build(torque_limit)`` (`lpv_spec`,
        `backstepping_spec`), built once per process and cached; or a built
        controller (serial sweeps only: it does not pickle).
    alpha : float or callable, optional
        Plant backlash, default ``params.alpha``. A callable ``alpha(t)``
        must pickle to go to workers; prefer `alpha_after`.
    alpha_after, alpha_at : float, optional
        With `alpha_after`, the backlash steps from `alpha` to
        `alpha_after` at `alpha_at` seconds (`alpha_step`).
    theta_r, Td : float, optional
        Reference step (rad) and constant load torque (Nm).
    torque_limit : float, optional
        ``|Tm| <= torque_limit``, applied to any controller; None or
        ``inf`` for no limit.
    model : {"exact", "deadzone"}, optional
        Backlash model of the plant.
    T : float, optional
        Horizon, s.
    npoints : int, optional
        Output samples, default one per millisecond.
    params : `Parameters`, optional
        Nominal plant data that the changes apply to.
    engine : str, optional
        Passed to the simulation function as ``engine=`` (e.g. ``"fast"``
        where it exists).
    simulate : callable, optional
        Simulation function with the signature of `twomass.simulate`
        (default), returning a response that `twomass.metrics` reads.
    **changes : float
        Plant parameter mismatch: ``Jl=6.0`` sets a value, ``Jl_scale=1.2``
        scales the nominal one (any field of `Parameters` but ``alpha``).

    Returns
    -------
    dict
        The `StepMetrics` fields and ``"status"``: ``"ok"``, or
        ``"diverged"`` when the final load-angle error exceeds 20 % of the
        step (or is not finite).

    Raises
    ------
    TypeError, ValueError
        For unknown scenario keys, bad values, or an `engine` that the
        simulation function does not accept.
    """
    simulate = default_simulate if simulate is None else simulate
    if torque_limit is not None and torque_limit == math.inf:
        torque_limit = None  # inf keeps a table's torque_limit column numeric
    plant_params = _plant_params(params, changes)
    if alpha_after is not None:
        before = plant_params.alpha if alpha is None else alpha
        if callable(before):
            raise ValueError("alpha: must be a number when alpha_after is given")
        alpha = alpha_step(float(before), float(alpha_after), at=float(alpha_at))
    if npoints is None:
        npoints = int(round(T * 1000)) + 1
    kwargs = dict(
        params=plant_params, model=model, alpha=alpha, theta_r=theta_r, Td=Td,
        T=T, npoints=npoints,
    )  # fmt: skip
    if engine is not None:
        if not _accepts(simulate, "engine"):
            raise TypeError(
                f"engine: the simulation function {simulate.__name__} has no "
                f"'engine' keyword (requested engine={engine!r})"
            )
        kwargs["engine"] = engine
    response = simulate(_controller(controller, torque_limit), **kwargs)
    result: dict[str, Any] = metrics(response, theta_r).as_dict()
    error = result["steady_state_error"]
    diverged = not math.isfinite(error) or abs(error) > 0.2 * abs(theta_r)
    result["status"] = "diverged" if diverged else "ok"
    return result


def sweep(
    scenarios,
    controllers: Mapping[str, Any] | None = None,
    *,
    engine: str | None = None,
    simulate: Callable[..., Any] | None = None,
    executor=None,
    max_workers: int | None = None,
    progress: bool = True,
    chunksize: int | None = None,
    timeout: float | None = None,
) -> pd.DataFrame:
    """Sweep two-mass scenarios for several controllers.

    `ctrl_lpv.sweep` with `run_scenario` as the runner.

    Parameters
    ----------
    scenarios : list of dict, dict of lists, or DataFrame
        Keyword arguments of `run_scenario`: ``alpha``, ``alpha_after``,
        ``alpha_at``, ``theta_r``, ``Td``, ``torque_limit``, ``model``,
        ``T``, ``npoints``, ``params`` and parameter changes such as
        ``Jl_scale``. A dict of lists is a Cartesian grid.
    controllers : dict, optional
        Name -> spec (`lpv_spec`, `backstepping_spec`); default
        `comparison_specs` (designs computed here, on nominal data).
    engine : str, optional
        Simulation engine passed to `simulate`. With the default
        `simulate`: ``"auto"`` (default), the compiled engine where numba
        is installed (``pip install "ctrl_lpv[fast]"``) and the controller
        has a compiled form (`lpv_spec`, `backstepping_spec`), else
        ``"fast"``; ``"compiled"`` insists on it (`ImportError` without
        numba); ``"fast"`` is the scipy path (LSODA), about 20 times
        slower; ``"control"`` python-control's reference path, about 100
        times slower still (see `twomass.simulate`).
    simulate : callable, optional
        Simulation function, default `twomass.simulate`; must pickle
        (module level) for process and cluster executors.
    executor : `concurrent.futures.Executor`, "processes" or "serial", optional
        Where to run. Default (None or "processes"): a
        `~concurrent.futures.ProcessPoolExecutor` with `max_workers`
        processes, shut down at the end. "serial": in this process, no
        pickling. Any other executor (e.g. a Dask cluster's
        ``Client.get_executor()``, see `ctrl_lpv.sweep`) is used as given
        and left open.
    max_workers : int, optional
        Processes of the default executor, default ``os.cpu_count()``; 1
        runs serially.
    progress : bool, optional
        Show a progress bar (tqdm if installed, else a counter on stderr);
        default True.
    chunksize : int, optional
        Runs per task; default about 16 tasks per worker.
    timeout : float, optional
        Wall-time limit of one run, s (default none): a run that exceeds it
        is stopped and gets status ``"timeout: ..."`` and NaN metrics. It
        interrupts Python code (the simulation's right-hand side), not a
        long call into compiled code.

    Returns
    -------
    `pandas.DataFrame`
        Scenario columns, ``controller``, the step metrics and ``status``.

    Raises
    ------
    TypeError, ValueError
        For unknown scenario keys, an `engine` that `simulate` does not
        accept, or bad sweep arguments.

    Examples
    --------
    >>> table = sweep({"alpha": [0.0, 0.03], "Jl_scale": [0.8, 1.2]})  # doctest: +SKIP
    >>> table.pivot_table("iae", "controller", "alpha")    # doctest: +SKIP
    """
    if simulate is None and engine is None:
        engine = "auto"
    simulate_fn = default_simulate if simulate is None else simulate
    if engine is not None and not _accepts(simulate_fn, "engine"):
        raise TypeError(
            f"engine: the simulation function {simulate_fn.__name__} has no "
            f"'engine' keyword (requested engine={engine!r})"
        )
    scenarios = _as_scenarios(scenarios)
    for key in sorted({k for s in scenarios for k in s}):
        if key not in SCENARIO_KEYS and key.removesuffix("_scale") not in _FIELDS:
            raise TypeError(
                f"scenarios: unknown key {key!r}; expected {list(SCENARIO_KEYS)}, "
                f"a parameter {list(_FIELDS)} or '<parameter>_scale'"
            )
    if controllers is None:
        controllers = comparison_specs()
    run = functools.partial(run_scenario, engine=engine, simulate=simulate)
    return _generic_sweep(
        run,
        scenarios,
        controllers=controllers,
        executor=executor,
        max_workers=max_workers,
        progress=progress,
        chunksize=chunksize,
        timeout=timeout,
    )
