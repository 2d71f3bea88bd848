"""Reproduce the paper: errata findings, designs, figures and the comparison.

`reproduce` is what ``ctrl-lpv reproduce --out DIR`` runs. It writes into
one folder:

* ``report.md``: every finding below in one page, with the figures linked;
* ``errata.json``: closed-loop eigenvalues of the published gain at
  ``p = -1, -0.95, 0``, the `InfeasibleError` of the paper's interval
  ``[-1, 0]``, and the published gain in both readings of the first state;
* ``design_robust.json``, ``design_scheduled.json``: the certified gains
  (`save_gains`);
* ``comparison.md``, ``comparison.json``: the LPV vs backstepping table,
  with a row for the output-feedback design on the motor and load
  encoders (paper scenario);
* ``output_feedback.json``: the two encoder output-feedback designs
  (`output_feedback_design`), their certified gamma and frozen closed loops;
* figures (PNG and SVG): ``paper_gain`` (the paper's Figs. 4-5),
  ``coordinates`` (erratum on the first state), ``designs`` (published and
  certified gains, Fig. 8), ``alpha_step`` (Figs. 6-7), ``backstepping``
  and ``torque_limit`` (LPV vs backstepping, without and with a torque
  limit).

The folder is written atomically: everything goes to a temporary folder
beside it, moved into place when the run is complete, so that an interrupted
or failed run leaves no half-written folder.
"""

from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import control as ct
import numpy as np

from .. import __version__
from .._output import (
    check_destination,
    signals_deferred,
    temporary_beside,
    usual_mode,
)
from ..exceptions import InfeasibleError
from ..metrics import step_metrics
from ..plotting import controller_style, plot_responses, save_figure
from ..synthesis import gain_scheduled_hinf
from .comparison import (
    CONTROLLERS,
    compare,
    comparison_designs,
    comparison_scenarios,
    markdown_table,
    scenario_row,
)
from .designs import output_feedback_design
from .encoders import encoder_controller
from .gain_files import save_gains
from .model import PAPER_GAIN, lpv_model, paper_gain
from .scenarios import simulate
from .servo_figures import markdown_row, markdown_rule

__all__ = ["reproduce", "errata_findings"]

_UNITS = {"theta_l": "rad", "Tm": "Nm"}
_LABELS = {"theta_l": "load angle theta_l", "Tm": "motor torque Tm"}
_STYLES = {name: controller_style(i) for i, name in enumerate(CONTROLLERS)}


def _coordinate_controller(error_x1: bool) -> ct.NonlinearIOSystem:
    """``Tm = K_paper x`` with ``x1 = theta_m - theta_r`` or ``theta_m``."""
    K = paper_gain()[0]

    def output(t, x, u, params=None):
        theta_m, omega_m, theta_l, omega_l, theta_r = u
        x1 = theta_m - theta_r if error_x1 else theta_m
        return np.array([-K @ np.array([x1, omega_m, theta_l - theta_r, omega_l])])

    return ct.nlsys(
        None,
        output,
        name="paper_x1",
        inputs=["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"],
        outputs=["Tm"],
    )


def errata_findings(engine: str = "control") -> tuple[dict, dict]:
    """Compute the paper's errata that are checkable by computation.

    Parameters
    ----------
    engine : {"control", "fast"}, optional
        Simulation engine of the two coordinate runs: python-control's
        `control.input_output_response` (the reference) or ctrl_lpv's fused
        right-hand side (same results to the solver tolerance, faster).

    Returns
    -------
    findings : dict
        ``published_gain`` (both signs), ``eigenvalues`` of the model (30)
        closed with the published gain at ``p = -1, -0.95, 0`` (as
        ``[real, imag]`` pairs), ``infeasible`` (the message of the
        `InfeasibleError` of Theorem 2 on ``[-1, 0]``, or None if it was
        feasible) and ``coordinates`` (load angle at 5 s and rise time of the
        published gain with ``x1 = theta_m - theta_r`` and ``x1 = theta_m``).
    responses : dict
        The two responses of ``coordinates``, for a figure.
    """
    model = lpv_model(p_bounds=(-1.0, 0.0))  # the paper's formulation
    iu = model.input_labels.index("Tm")
    eigenvalues = {}
    for p in (-1.0, -0.95, 0.0):
        frozen = model.at(p)
        poles = np.linalg.eigvals(frozen.A - frozen.B[:, [iu]] @ paper_gain())
        poles = poles[np.argsort(-poles.real)]
        eigenvalues[f"{p:g}"] = [[float(z.real), float(z.imag)] for z in poles]
    try:
        gain_scheduled_hinf(model, w=["Td", "theta_r"], u=["Tm"], z=["theta_l"])
        infeasible = None
    except InfeasibleError as exc:
        infeasible = str(exc)
    coordinates, responses = {}, {}
    for error_x1, label in ((True, "x1 = theta_m - theta_r"), (False, "x1 = theta_m")):
        response = simulate(_coordinate_controller(error_x1), alpha=0.03, engine=engine)
        labels = response.output_labels
        theta_l = response.outputs[labels.index("theta_l")]
        m = step_metrics(response.time, theta_l, 0.5, initial=0.0)
        coordinates[label] = {
            "theta_l_5s": float(theta_l[-1]),
            "rise_time": m.rise_time if math.isfinite(m.rise_time) else None,
        }
        responses[label] = response
    findings = {
        "published_gain": {
            "paper_sign_u_eq_Kx": PAPER_GAIN.tolist(),
            "python_control_sign_u_eq_minus_Kx": paper_gain().tolist(),
        },
        "eigenvalues": eigenvalues,
        "infeasible": infeasible,
        "coordinates": coordinates,
    }
    return findings, responses


def _format_poles(pairs) -> str:
    return ", ".join(
        f"{re:.4g}"
        if abs(im) < 1e-12
        else f"{re:.4g} {'+' if im > 0 else '-'} {abs(im):.4g}j"
        for re, im in pairs
    )


def _design_summary(name, design) -> dict:
    return {
        "controller": name,
        "method": design.method,
        "gamma": design.gamma,
        "gamma_opt": design.gamma_opt,
        "max_gain_norm": max(float(np.linalg.norm(K, 2)) for K in design.gains),
        "max_closed_loop_real": design.certificate.max_closed_loop_real,
        "verified": design.certificate.verified,
    }


#: Parameter values of the frozen closed loops of the encoder designs.
_FROZEN_P = tuple(np.linspace(-0.95, 0.0, 7))

#: The encoder designs of the report: label, sensors.
_ENCODER_DESIGNS = (("OF motor+load encoders", "both"), ("OF motor encoder", "motor"))


def _encoder_designs(scenario, engine) -> tuple[list[dict], list[dict]]:
    """Summaries of the encoder output-feedback designs, and the comparison
    row of the motor and load encoder design in `scenario`."""
    summaries, rows = [], []
    for label, sensors in _ENCODER_DESIGNS:
        design = output_feedback_design(sensors=sensors)
        controller = design.controller()
        plant = design.plant
        worst_real, worst_norm = -math.inf, 0.0
        for p in _FROZEN_P:
            loop = ct.interconnect(
                [plant.system.at({"p": p}), controller.at({"p": p})],
                inplist=plant.names("w"), outlist=plant.names("z"),
            )  # fmt: skip
            worst_real = max(worst_real, float(np.linalg.eigvals(loop.A).real.max()))
            worst_norm = max(worst_norm, float(ct.linfnorm(loop)[0]))
        summaries.append({
            "controller": label,
            "measured": [name.removeprefix("y_") for name in plant.names("y")],
            "gamma": design.gamma,
            "gamma_opt": design.gamma_opt,
            "controller_states": controller.nstates,
            "max_closed_loop_real": worst_real,
            "max_frozen_norm": worst_norm,
            "verified": design.certificate.verified,
        })  # fmt: skip
        if sensors == "both":
            row, _ = scenario_row(scenario, label, encoder_controller(design), engine)
            rows.append(row)
    return summaries, rows


def reproduce(
    out: str | Path,
    *,
    robustness: bool = False,
    formats: tuple[str, ...] = ("png", "svg"),
    progress: Callable[[str], None] | None = None,
    engine: str = "control",
) -> dict:
    """Run the whole reproduction of the paper and write it to `out`.

    The files are written to a temporary folder beside `out` (same file
    system), which replaces `out` when everything is written; on any error
    or interruption (`KeyboardInterrupt`) it is removed and `out` is left as
    it was.

    Parameters
    ----------
    out : str or path
        Output folder: created, or replaced if it is empty or holds a
        previous reproduction (a ``report.md`` or ``errata.json``). Its
        parent folder must exist (it is not created).
    robustness : bool, optional
        Also run the 24 robustness scenarios of the comparison (about 4
        times longer).
    formats : tuple of str, optional
        Figure file formats.
    progress : callable, optional
        Called with a one-line message at each step and simulation.
    engine : {"control", "fast"}, optional
        Simulation engine of every run: python-control's
        `control.input_output_response` (the reference) or ctrl_lpv's fused
        right-hand side (same results to the solver tolerance, faster).

    Returns
    -------
    dict
        ``files`` (paths written, in `out`), ``errata``, ``designs``
        (summaries), ``rows`` (the comparison table) and ``seconds``.

    Raises
    ------
    ValueError
        If the parent of `out` does not exist or is not writable, or `out`
        exists and is neither a folder that is empty or holds a previous
        reproduction.
    """
    out = Path(out)
    _check_target(out)
    with temporary_beside(out, folder=True) as work:
        result = _reproduce_into(work, robustness, formats, progress, engine)
        usual_mode(work)
        with signals_deferred():  # the two renames are not cut apart
            _replace(work, out)
    result["files"] = [out / path.relative_to(work) for path in result["files"]]
    (progress or (lambda message: None))(
        f"done in {result['seconds']:.0f} s: {len(result['files'])} files in {out}"
    )
    return result


#: Files whose presence marks a folder as a previous reproduction.
_MARKERS = ("report.md", "errata.json")


def _check_target(out: Path) -> None:
    check_destination(out, "out", folder=True)
    if not out.exists():
        return
    if any(out.iterdir()) and not any((out / m).is_file() for m in _MARKERS):
        raise ValueError(
            f"out: {out} is not empty and holds no previous reproduction "
            f"({' or '.join(_MARKERS)}); choose a new or empty folder"
        )


def _replace(work: Path, out: Path) -> None:
    """Move the finished folder `work` to `out`, replacing an old one."""
    if not out.exists():
        work.rename(out)
        return
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
    old.rmdir()
    out.rename(old)
    try:
        work.rename(out)
    except BaseException:
        old.rename(out)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _reproduce_into(out: Path, robustness, formats, progress, engine) -> dict:
    """The steps of `reproduce`, writing into the (temporary) folder `out`."""
    start = time.perf_counter()
    say = progress or (lambda message: None)
    files: list[Path] = []

    def figure(stem, responses, title, signals=("theta_l", "Tm"), **kwargs):
        fig = plot_responses(
            responses,
            signals,
            units=_UNITS,
            labels=_LABELS,
            reference={"theta_l": 0.5},
            title=title,
            **kwargs,
        )
        files.extend(save_figure(fig, out / stem, formats))

    say(
        "errata: eigenvalues of the published gain, Theorem 2 on p in [-1, 0], "
        "first-state coordinates"
    )
    errata, coordinate_responses = errata_findings(engine)
    (out / "errata.json").write_text(json.dumps(errata, indent=2) + "\n")
    files.append(out / "errata.json")
    figure(
        "coordinates",
        coordinate_responses,
        "Published gain: two readings of the first state",
    )

    say("designs: Lemma 2 (common gain) and Theorem 2 (vertex gains)")
    designs = comparison_designs()
    summaries = []
    for name, design in designs.items():
        stem = "design_robust" if name == "LPV robust" else "design_scheduled"
        files.append(
            save_gains(
                design,
                out / f"{stem}.json",
                model={
                    "p_bounds": [-0.95, 0.0],
                    "formulation": "tracking",
                    "integral": True,
                },
            )
        )
        summaries.append(_design_summary(name, design))

    scenarios = comparison_scenarios(robustness)
    figure_scenarios = {"paper", "paper alpha step", "Tmax=500"}

    def report(done, total, label):
        say(f"simulation {done}/{total}: {label}")

    rows, responses = compare(
        designs,
        scenarios,
        keep=figure_scenarios.__contains__,
        progress=report,
        engine=engine,
    )
    say("output feedback on encoders: designs, frozen loops, paper scenario")
    encoder_summaries, encoder_rows = _encoder_designs(scenarios[0], engine)
    rows += encoder_rows
    (out / "output_feedback.json").write_text(
        json.dumps(encoder_summaries, indent=2) + "\n"
    )
    files.append(out / "output_feedback.json")
    table = markdown_table(rows)
    (out / "comparison.md").write_text(table + "\n")
    (out / "comparison.json").write_text(
        json.dumps(rows, indent=2, default=lambda v: None) + "\n"
    )
    files += [out / "comparison.md", out / "comparison.json"]

    say("figures")

    def pick(scenario, names=CONTROLLERS):
        return {n: responses[scenario, n] for n in names if (scenario, n) in responses}

    lpv = ("paper K", "LPV robust", "LPV scheduled")
    figure(
        "paper_gain",
        pick("paper", ["paper K"]),
        "Published gain, alpha = 0.03 rad, Td = 8 Nm (Figs. 4-5)",
        styles=_STYLES,
        symlog=("Tm",),
    )
    figure(
        "designs",
        pick("paper", lpv),
        "Published and certified gains, alpha = 0.03 rad (Fig. 8)",
        styles=_STYLES,
        symlog=("Tm",),
    )
    figure(
        "alpha_step",
        pick("paper alpha step", lpv),
        "Backlash step 0.03 -> 0.045 rad at 2.5 s (Figs. 6-7)",
        styles=_STYLES,
        symlog=("Tm",),
    )
    figure(
        "backstepping",
        pick("paper alpha step"),
        "LPV vs backstepping, backlash step at 2.5 s",
        styles=_STYLES,
        symlog=("Tm",),
    )
    figure(
        "torque_limit",
        pick("Tmax=500"),
        "LPV vs backstepping, |Tm| <= 500 Nm, backlash step at 2.5 s",
        styles=_STYLES,
        limits={"Tm": 500.0},
    )

    say("servo comparison: servo, published K and backstepping at 500 and 2000 Nm")
    from .servo_figures import write_servo

    servo_rows, servo_files = write_servo(out, formats, say)
    files += servo_files

    seconds = time.perf_counter() - start
    result = {
        "servo_rows": servo_rows,
        "files": files,
        "errata": errata,
        "designs": summaries,
        "output_feedback": encoder_summaries,
        "rows": rows,
        "seconds": seconds,
    }
    report_path = out / "report.md"
    report_path.write_text(_report(result, formats))
    files.append(report_path)
    return result


def _report(result: dict, formats) -> str:
    """Markdown page of the whole reproduction."""
    errata = result["errata"]
    ext = "png" if "png" in formats else formats[0]
    lines = [
        "# ctrl_lpv: reproduction of the LPV two-mass backlash paper",
        "",
        f"ctrl_lpv {__version__}, python-control {ct.__version__}; "
        f"{result['seconds']:.0f} s.",
        "",
        "## Errata",
        "",
        "Gains are in python-control's sign, `u = -K x` (`K = -K_paper`).",
        "",
        "Closed-loop eigenvalues of the model (30) with the published gain:",
        "",
    ]
    for p, pairs in errata["eigenvalues"].items():
        lines.append(f"- p = {p}: {_format_poles(pairs)}")
    lines += ["", "Theorem 2 on the paper's interval p in [-1, 0]:", ""]
    lines.append(
        f"> InfeasibleError: {errata['infeasible']}"
        if errata["infeasible"]
        else "> feasible (unexpected: the vertex p = -1 should not be stabilizable)"
    )
    lines += ["", "Published gain, two readings of the first state x1:", ""]
    for label, values in errata["coordinates"].items():
        rise = values["rise_time"]
        lines.append(
            f"- {label}: theta_l(5 s) = {values['theta_l_5s']:.4f} rad, "
            f"rise 10-90 % = {'never' if rise is None else f'{rise:.4f} s'}"
        )
    lines += ["", f"![coordinates](coordinates.{ext})", "", "## Certified designs", ""]
    columns = ("controller", "method", "gamma", "gamma*", "max norm K",
               "max Re(closed loop)", "verified")  # fmt: skip
    lines += [markdown_row(columns), markdown_rule(len(columns))]
    for s in result["designs"]:
        lines.append(
            markdown_row(
                [
                    s["controller"],
                    s["method"],
                    f"{s['gamma']:.4g}",
                    f"{s['gamma_opt']:.4g}",
                    f"{s['max_gain_norm']:.4g}",
                    f"{s['max_closed_loop_real']:.4g}",
                    s["verified"],
                ]
            )  # fmt: skip
        )
    lines += ["", "## Output feedback on encoders (no speeds measured)", ""]
    columns = ("controller", "measured", "gamma", "gamma*", "controller states",
               "max Re(frozen loops)", "max frozen norm", "verified")  # fmt: skip
    lines += [markdown_row(columns), markdown_rule(len(columns))]
    for s in result["output_feedback"]:
        lines.append(
            markdown_row(
                [
                    s["controller"],
                    ", ".join(s["measured"]),
                    f"{s['gamma']:.4g}",
                    f"{s['gamma_opt']:.4g}",
                    s["controller_states"],
                    f"{s['max_closed_loop_real']:.4g}",
                    f"{s['max_frozen_norm']:.4g}",
                    s["verified"],
                ]
            )  # fmt: skip
        )
    lines += [
        "",
        "Frozen loops: the LPV model with the controller at "
        f"{len(_FROZEN_P)} values of p in [-0.95, 0], built by "
        "`control.interconnect`; their H-infinity norms (`control.linfnorm`) "
        "are below gamma. The motor and load encoder design runs in the "
        "comparison (paper scenario); the motor-encoder design is not "
        "simulated: it is scheduled with p, which needs the shaft twist and "
        "so the load encoder it does not have.",
    ]
    lines += ["", "## Comparison", "", markdown_table(result["rows"]), ""]
    for stem in ("paper_gain", "designs", "alpha_step", "backstepping", "torque_limit"):
        lines += [f"![{stem}]({stem}.{ext})", ""]
    from .servo_figures import servo_markdown_table

    lines += ["## Servo (ours) under a torque limit, paper scenario", ""]
    lines += [servo_markdown_table(result["servo_rows"]), ""]
    for stem in ("servo_500", "servo_2000"):
        lines += [f"![{stem}]({stem}.{ext})", ""]
    lines += [
        "The row 'servo, 1 ms on encoders' is the same servo sampled as a drive "
        "runs it (`servo_design(dt=1e-3, delay=1, sensors='encoders')`: the "
        "encoder angles only, a drive observer, one sample of delay), simulated "
        "on the exact plant read by 20- and 17-bit encoders with half a count "
        "of noise. The row 'cascade P/PI, 1 ms on encoders' is the industrial "
        "reference on the same terms (`twomass.cascade_design`: load-position P, "
        "motor-speed PI on a filtered difference of the motor encoder, the "
        "servo's trajectory and feedforward, the same sampling, delay and "
        "encoders; tuned by the symmetric optimum and bandwidth separation, "
        "see docs/servo.rst). At rest:",
        "",
    ]
    for stem in ("servo_rest_500", "servo_rest_2000"):
        lines += [f"![{stem}]({stem}.{ext})", ""]
    return "\n".join(lines)
