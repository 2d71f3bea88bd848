"""The commands of ``ctrl-lpv``: reproduce, design, simulate.

Each command checks its outputs before the work starts and imports what it
needs when it runs (see `ctrl_lpv.cli`).
"""

from __future__ import annotations

import csv
import json
import math
import sys
import time
from pathlib import Path

from ._cli_parser import EXIT_USAGE

__all__ = ["COMMANDS", "METRIC_UNITS", "usage"]


def _progress(start: float, quiet: bool):
    def say(message: str) -> None:
        if not quiet:
            print(
                f"[{time.perf_counter() - start:6.1f} s] {message}",
                file=sys.stderr,
                flush=True,
            )

    return say


def _run_reproduce(args) -> int:
    from .twomass.reproduce import _check_target, reproduce

    try:
        _check_target(args.out)
    except ValueError as exc:
        return usage(f"--{exc}")
    result = reproduce(
        args.out,
        robustness=args.robustness,
        formats=args.formats,
        progress=_progress(time.perf_counter(), args.quiet),
        engine=args.engine,
    )
    if not args.quiet:
        print((args.out / "comparison.md").read_text(), end="")
        print(
            f"\nwrote {len(result['files'])} files to {args.out} "
            f"(report: {args.out / 'report.md'})"
        )
    return 0


def _run_design(args) -> int:
    if args.p_min >= args.p_max:
        return usage(f"--p-min ({args.p_min}) must be below --p-max ({args.p_max})")
    from ._output import check_destination

    if args.save is not None:
        try:  # before the design, which takes seconds
            check_destination(args.save, "--save", folder=False)
        except ValueError as exc:
            return usage(str(exc))
    from .twomass import designs
    from .twomass.gain_files import gains_document, save_gains

    options = {} if args.gain_bound is None else {"gain_bound": args.gain_bound}
    model_options = {
        "p_bounds": [args.p_min, args.p_max],
        "formulation": args.formulation,
        "integral": args.integral and args.formulation == "tracking",
        "torque_weight": args.torque_weight,
        "integral_weight": args.integral_weight,
    }
    try:
        design = designs.design(
            p_bounds=(args.p_min, args.p_max),
            formulation=args.formulation,
            integral=model_options["integral"],
            scheduled=args.scheduled,
            torque_weight=args.torque_weight,
            integral_weight=args.integral_weight,
            backoff=args.backoff,
            **options,
        )
    except ValueError as exc:
        return usage(str(exc))
    if args.save:
        # Atomic: written beside the file, then moved into place.
        save_gains(design, args.save, model=model_options)
    if args.json:
        document = gains_document(design, model=model_options)
        print(json.dumps(document, indent=2))
    else:
        print(design)
        if args.save:
            print(f"gains saved to {args.save}")
    return 0


def _controller(args):
    from .twomass import backstepping_controller, designs, load_gains, lpv_controller

    name = args.controller
    estimate = args.alpha if args.alpha_estimate is None else args.alpha_estimate
    limit = {"torque_limit": args.torque_limit}

    def common(what: str) -> None:
        if args.alpha_estimate is not None:
            raise ValueError(
                f"--alpha-estimate: {what} is a common gain, not scheduled by "
                "the backlash; drop the option or use vertex gains"
            )

    if name in ("paper", "robust", "backstepping", "servo"):
        common(
            {"paper": "the published gain", "robust": "the robust design"}.get(
                name, name
            )
        )
    if name == "servo":
        from .twomass import servo_design

        limit = {} if args.torque_limit is None else limit
        return servo_design(certify=False, **limit).controller()
    if name == "paper":
        return lpv_controller(**limit)
    if name == "backstepping":
        return backstepping_controller(Td_hat=args.Td, **limit)
    if name in ("robust", "scheduled"):
        design = designs.design(scheduled=name == "scheduled")
        extra = {"alpha_estimate": estimate} if design.scheduled else {}
        return lpv_controller(design, **extra, **limit)
    path = Path(name)
    if not path.is_file():
        raise ValueError(
            f"--controller: {name!r} is neither paper, robust, scheduled, "
            "backstepping, servo nor an existing gain file"
        )
    try:
        gains = load_gains(path)
    except ValueError as exc:
        raise ValueError(f"--controller: {exc}") from None
    if not gains.scheduled:
        common(f"the gain file {path}")
    extra = {"alpha_estimate": estimate} if gains.scheduled else {}
    try:
        return gains.controller(**extra, **limit)
    except ValueError as exc:
        raise ValueError(f"--controller: {path}: {exc}") from None


#: Step metrics as printed and their units (`ctrl_lpv.metrics.StepMetrics`).
METRIC_UNITS = {
    "rise_time": ("rise time 10-90 %", "s"),
    "settling_time": ("settling time 2 %", "s"),
    "overshoot": ("overshoot", "%"),
    "steady_state_error": ("final error theta_r - theta_l", "rad"),
    "iae": ("IAE of the error", "rad s"),
    "ise": ("ISE of the error", "rad^2 s"),
    "peak_input": ("peak |Tm|", "Nm"),
    "energy": ("energy, integral of Tm^2", "Nm^2 s"),
    "rest_error_peak_to_peak": ("at rest: error peak-to-peak", "rad"),
    "rest_max_error": ("at rest: largest |error|", "rad"),
    "rest_torque_std": ("at rest: Tm standard deviation", "Nm"),
}


def _rest_window(T: float) -> float:
    """The end of a run measured as its rest: the last second, or the last
    half of a run shorter than two."""
    return min(1.0, T / 2)


def _metric_text(value: float, unit: str) -> str:
    if math.isnan(value):
        return "undefined"
    if math.isinf(value) and unit == "s":
        return "never"
    return f"{value:.4g} {unit}"


def _print_metrics(args, values: dict[str, float]) -> None:
    print(
        f"controller {args.controller}, theta_r = {args.theta_r:g} rad, "
        f"Td = {args.Td:g} Nm, {args.T:g} s (at rest: the last "
        f"{_rest_window(args.T):g} s):"
    )
    width = max(len(label) for label, _ in METRIC_UNITS.values())
    for key, (label, unit) in METRIC_UNITS.items():
        print(f"  {label:<{width}}  {_metric_text(values[key], unit)}")


def _write_response(args, response, values: dict[str, float]) -> list[str]:
    """Write response.csv, metrics.json and the figure into ``args.out``."""
    import numpy as np

    from ._output import staged_folder
    from .plotting import plot_responses, save_figure

    with staged_folder(args.out) as work:
        labels = list(response.output_labels)
        with open(work / "response.csv", "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(["time"] + labels)
            writer.writerows(
                np.column_stack([response.time, np.asarray(response.outputs).T])
            )
        document = {k: v if math.isfinite(v) else None for k, v in values.items()}
        document["units"] = {key: unit for key, (_, unit) in METRIC_UNITS.items()}
        (work / "metrics.json").write_text(json.dumps(document, indent=2) + "\n")
        fig = plot_responses(
            {args.controller: response},
            ["theta_l", "Tm"],
            units={"theta_l": "rad", "Tm": "Nm"},
            reference={"theta_l": args.theta_r},
            limits={} if args.torque_limit is None else {"Tm": args.torque_limit},
            title=f"{args.controller}, Td = {args.Td:g} Nm",
        )
        figures = save_figure(fig, work / "response", args.formats)
    return ["response.csv", "metrics.json"] + [p.name for p in figures]


def _run_simulate(args) -> int:
    if args.alpha_step is not None and args.alpha_step[1] >= args.T:
        return usage(
            f"--alpha-step: the step time {args.alpha_step[1]:g} s is not "
            f"before the end of the run, --T {args.T:g} s"
        )
    from ._output import check_destination

    if args.out is not None:
        try:  # before the simulation, which takes seconds
            check_destination(args.out, "--out", folder=True)
        except ValueError as exc:
            return usage(str(exc))
    given = [
        f"--{k}" for k in ("delay", "sensors", "seed") if getattr(args, k) is not None
    ]
    if args.dt is None and given:
        return usage(f"{', '.join(given)}: only with --dt (the sampled servo)")
    if args.dt is not None:
        if args.controller != "servo":
            return usage(
                f"--dt: only --controller servo has a sampled mode, not "
                f"{args.controller!r}"
            )
        if args.model != "exact":
            return usage("--dt: the sampled servo runs on the exact plant only")
    from ._numba import INSTALL, numba_available
    from .twomass import metrics, simulate
    from .twomass.scenarios import alpha_step

    if args.engine == "compiled" and not numba_available():
        return usage(f"--engine compiled needs numba (not installed): {INSTALL}")
    alpha = args.alpha
    if args.alpha_step is not None:
        after, at = args.alpha_step
        alpha = alpha_step(args.alpha, after, at)
    if args.dt is not None:
        response = _sampled_servo_response(args, alpha)
    else:
        try:
            controller = _controller(args)
        except ValueError as exc:
            return usage(str(exc))
        response = simulate(
            controller,
            model=args.model,
            alpha=alpha,
            theta_r=args.theta_r,
            Td=args.Td,
            T=args.T,
            npoints=int(round(1000 * args.T)) + 1,
            engine=args.engine,
        )
    values = metrics(response, args.theta_r).as_dict()
    values.update(_rest_values(response, args.theta_r, _rest_window(args.T)))
    _print_metrics(args, values)
    if args.out:
        written = _write_response(args, response, values)
        print(f"wrote {', '.join(written)} to {args.out}")
    return 0


def _rest_values(response, theta_r: float, window: float) -> dict[str, float]:
    """The rest metrics of the load angle and motor torque (`METRIC_UNITS`)."""
    from .metrics import rest_metrics

    labels = list(response.output_labels)
    out = response.outputs
    rest = rest_metrics(
        response.time, out[labels.index("theta_l")], theta_r,
        out[labels.index("Tm")], window=window,
    )  # fmt: skip
    return {
        "rest_error_peak_to_peak": rest.error_peak_to_peak,
        "rest_max_error": rest.max_error,
        "rest_torque_std": rest.input_std,
    }


def _sampled_servo_response(args, alpha):
    """The servo designed for ``args.dt`` run on its encoders."""
    from .twomass import servo_design
    from .twomass.servo_compare import run_sampled_servo_scenario

    limit = {} if args.torque_limit is None else {"torque_limit": args.torque_limit}
    design = servo_design(
        dt=args.dt,
        delay=1 if args.delay is None else args.delay,
        sensors=args.sensors or "encoders",
        certify=False,
        **limit,
    )
    return run_sampled_servo_scenario(
        design, alpha=alpha, Td=args.Td, theta_r=args.theta_r, T=args.T,
        seed=args.seed or 0,
    )  # fmt: skip


def usage(message: str) -> int:
    print(f"ctrl-lpv: error: {message}", file=sys.stderr)
    return EXIT_USAGE


#: The runner of each command: ``runner(args) -> exit code``.
COMMANDS = {
    "reproduce": _run_reproduce,
    "design": _run_design,
    "simulate": _run_simulate,
}
