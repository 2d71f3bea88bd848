"""LPV state feedback against backstepping on the exact two-mass plant.

Controllers (all with the interface of `lpv_controller`):

* ``paper K``: the published gain, error coordinates, no integral action;
* ``LPV robust``: a certified common gain (Lemma 2) on
  ``lpv_model(p_bounds=(-0.95, 0), formulation="tracking", integral=True)``;
* ``LPV scheduled``: Theorem 2 vertex gains on the same model, scheduled on
  ``p`` computed with the nominal backlash estimate 0.03 rad;
* ``backstepping``: `backstepping_controller` with its default gains and the
  nominal load torque ``Td_hat = 8`` Nm.

Scenarios (step of ``theta_r`` to 0.5 rad from rest, 5 s, exact backlash):

* ``paper``: alpha = 0.03, Td = 8, no torque limit (the paper's Fig. 8);
* ``paper alpha step``: alpha 0.03 -> 0.045 at 2.5 s (Figs. 6-7);
* ``Tmax=2000``, ``Tmax=500``: the alpha step under the same torque limit for
  every controller;
* robustness (optional): alpha in {0, 0.03, 0.045, 0.06}, Td in {0, 8}, Jl
  scaled by 0.8, 1 and 1.2, with the controllers designed on nominal data.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from ..synthesis import StateFeedbackDesign
from .backstepping import backstepping_controller
from .designs import design
from .feedback import lpv_controller
from .parameters import Parameters
from .scenarios import alpha_step, metrics, simulate

__all__ = [
    "Scenario",
    "comparison_designs",
    "comparison_controllers",
    "comparison_scenarios",
    "compare",
    "scenario_row",
    "markdown_table",
    "CONTROLLERS",
    "METRICS",
]

#: Controller names of the comparison, in the order of every table and figure.
CONTROLLERS = ("paper K", "LPV robust", "LPV scheduled", "backstepping")

#: Metric columns of a comparison row (see `ctrl_lpv.metrics.StepMetrics`).
METRICS = (
    "rise_time",
    "settling_time",
    "overshoot",
    "steady_state_error",
    "iae",
    "ise",
    "peak_input",
    "energy",
)

#: Backlash estimate used to schedule the vertex gains.
ALPHA_ESTIMATE = 0.03


@dataclass(frozen=True)
class Scenario:
    """One closed-loop experiment of the comparison.

    Attributes
    ----------
    name : str
        Row label.
    torque_limit : float or None
        ``|Tm|`` limit applied by every controller.
    simulate : dict
        Keyword arguments of `simulate` (``alpha``, ``Td``, ``params``).
    """

    name: str
    torque_limit: float | None = None
    simulate: dict = field(default_factory=dict)


def comparison_designs() -> dict[str, StateFeedbackDesign]:
    """The two certified designs of the comparison, on nominal data.

    Returns
    -------
    dict
        ``{"LPV robust": Lemma 2 design, "LPV scheduled": Theorem 2 design}``
        on the tracking model with integral action, ``p in [-0.95, 0]``.
    """
    return {
        "LPV robust": design(scheduled=False),
        "LPV scheduled": design(scheduled=True),
    }


def comparison_controllers(
    designs: dict[str, StateFeedbackDesign], torque_limit: float | None = None
) -> dict:
    """The four controllers of the comparison, in `CONTROLLERS` order.

    Parameters
    ----------
    designs : dict
        As returned by `comparison_designs`.
    torque_limit : float, optional
        ``|Tm|`` limit of every controller.

    Returns
    -------
    dict of str to `control.NonlinearIOSystem`
        Controllers by name.
    """
    limit = {"torque_limit": torque_limit}
    return {
        "paper K": lpv_controller(**limit),
        "LPV robust": lpv_controller(designs["LPV robust"], **limit),
        "LPV scheduled": lpv_controller(
            designs["LPV scheduled"], alpha_estimate=ALPHA_ESTIMATE, **limit
        ),
        "backstepping": backstepping_controller(Td_hat=8.0, **limit),
    }


def comparison_scenarios(robustness: bool = False) -> list[Scenario]:
    """The scenarios of the comparison.

    Parameters
    ----------
    robustness : bool, optional
        Append the 24 robustness scenarios (alpha, Td, load inertia).

    Returns
    -------
    list of `Scenario`
        The paper's scenarios first.
    """
    step = alpha_step(0.03, 0.045, at=2.5)
    out = [
        Scenario("paper", None, dict(alpha=0.03, Td=8.0)),
        Scenario("paper alpha step", None, dict(alpha=step, Td=8.0)),
        Scenario("Tmax=2000", 2000.0, dict(alpha=step, Td=8.0)),
        Scenario("Tmax=500", 500.0, dict(alpha=step, Td=8.0)),
    ]
    if robustness:
        nominal = Parameters()
        for alpha, Td, scale in itertools.product(
            (0.0, 0.03, 0.045, 0.06), (0.0, 8.0), (0.8, 1.0, 1.2)
        ):
            params = nominal.replace(Jl=nominal.Jl * scale)
            out.append(
                Scenario(
                    f"alpha={alpha:g} Td={Td:g} Jl x{scale:g}",
                    None,
                    dict(alpha=alpha, Td=Td, params=params),
                )
            )
    return out


def compare(
    designs: dict[str, StateFeedbackDesign] | None = None,
    scenarios: list[Scenario] | None = None,
    *,
    keep: Callable[[str], bool] = lambda name: False,
    progress: Callable[[int, int, str], None] | None = None,
    engine: str = "control",
) -> tuple[list[dict], dict]:
    """Simulate every controller in every scenario.

    Parameters
    ----------
    designs : dict, optional
        As from `comparison_designs` (computed when omitted).
    scenarios : list of `Scenario`, optional
        Default `comparison_scenarios()`.
    keep : callable, optional
        ``keep(scenario_name)``: whether to return the responses of a
        scenario (for figures).
    progress : callable, optional
        Called as ``progress(done, total, label)`` after each simulation.
    engine : {"control", "fast"}, optional
        Simulation engine of `simulate`: python-control's
        `control.input_output_response` (default, the reference) or the
        fused right-hand side, about 100 times faster.

    Returns
    -------
    rows : list of dict
        One per (scenario, controller): ``scenario``, ``controller``,
        ``torque_limit``, the `METRICS`, ``status`` (``"ok"``,
        ``"diverged"`` when ``theta_l(5 s)`` is more than 0.1 rad off, or
        ``"failed: ..."``) and ``seconds`` of wall time.
    responses : dict
        ``{(scenario, controller): control.TimeResponseData}`` for the kept
        scenarios.
    """
    designs = comparison_designs() if designs is None else designs
    scenarios = comparison_scenarios() if scenarios is None else scenarios
    rows, responses, controllers = [], {}, {}
    total, done = len(scenarios) * len(CONTROLLERS), 0
    for scenario in scenarios:
        limit = scenario.torque_limit
        if limit not in controllers:
            controllers[limit] = comparison_controllers(designs, limit)
        for name, controller in controllers[limit].items():
            row, response = scenario_row(scenario, name, controller, engine)
            rows.append(row)
            if keep(scenario.name) and response is not None:
                responses[scenario.name, name] = response
            done += 1
            if progress is not None:
                progress(done, total, f"{scenario.name}: {name}")
    return rows, responses


def scenario_row(
    scenario: Scenario, name: str, controller, engine: str = "control"
) -> tuple[dict, object]:
    """One row of the comparison: `controller` simulated in `scenario`.

    Parameters
    ----------
    scenario : `Scenario`
        The experiment (its torque limit is the controller's business).
    name : str
        Controller label of the row.
    controller : `control.NonlinearIOSystem`
        With the two-mass controller interface (see `simulate`).
    engine : {"control", "fast"}, optional
        Simulation engine of `simulate`.

    Returns
    -------
    row : dict
        As the rows of `compare`.
    response : `control.TimeResponseData` or None
        None when the simulation failed.
    """
    start = time.perf_counter()
    row = {"scenario": scenario.name, "controller": name,
           "torque_limit": scenario.torque_limit}  # fmt: skip
    response = None
    try:
        response = simulate(controller, engine=engine, **scenario.simulate)
        values = metrics(response).as_dict()
        final = response.outputs[response.output_labels.index("theta_l")][-1]
        row["status"] = "ok" if abs(final - 0.5) < 0.1 else "diverged"
    except (RuntimeError, ValueError) as exc:  # integrator failure
        values = dict.fromkeys(METRICS, math.nan)
        row["status"] = f"failed: {exc}"
        response = None
    row.update({k: values[k] for k in METRICS})
    row["seconds"] = time.perf_counter() - start
    return row, response


def markdown_table(rows: list[dict]) -> str:
    """The comparison rows as a Markdown table.

    Parameters
    ----------
    rows : list of dict
        As returned by `compare`.

    Returns
    -------
    str
        One line per row, with units in the header.
    """
    lines = [
        "| scenario | controller | rise (s) | settle (s) | overshoot (%) "
        "| error 5 s (rad) | IAE (rad s) | peak abs(Tm) (Nm) | energy (Nm^2 s) "
        "| status |",
        "|" + "---|" * 10,
    ]
    for r in rows:
        lines.append(
            f"| {r['scenario']} | {r['controller']} | {r['rise_time']:.3f} | "
            f"{r['settling_time']:.3f} | {r['overshoot']:.2f} | "
            f"{r['steady_state_error']:.2e} | {r['iae']:.4f} | "
            f"{r['peak_input']:.4g} | {r['energy']:.3g} | {r['status']} |"
        )
    return "\n".join(lines)
