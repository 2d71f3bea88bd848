"""The ``ctrl-lpv`` command: reproduce the paper, design, simulate.

Exit codes: 0 success, 1 failure while running (e.g. an integrator
failure), 2 bad command-line options, 3 the design problem is proven
infeasible (`ctrl_lpv.InfeasibleError`), 4 no certified design was found
(`ctrl_lpv.CertificationError`), 130 interrupted (Ctrl-C).

Parsing the options imports neither python-control, cvxpy nor matplotlib
(``--help`` and ``--version`` answer at once); each command imports what it
needs when it runs.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

EXIT_FAILURE, EXIT_USAGE, EXIT_INFEASIBLE, EXIT_UNCERTIFIED = 1, 2, 3, 4
EXIT_INTERRUPTED = 130

_EPILOG = """\
exit codes: 0 success, 1 failure while running, 2 bad options,
3 proven infeasible (InfeasibleError), 4 no certified design found
(CertificationError), 130 interrupted.

examples:
  ctrl-lpv reproduce --out results
  ctrl-lpv design --scheduled --save gains.json
  ctrl-lpv simulate --controller gains.json --alpha-estimate 0.03 --out run
  ctrl-lpv simulate --controller backstepping --alpha-step 0.045@2.5 --out run
"""


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def _positive(text: str) -> float:
    value = _number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be positive: {text!r}")
    return value


def _nonnegative(text: str) -> float:
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0: {text!r}")
    return value


def _backoff(text: str) -> float | None:
    if text.lower() == "none":
        return None
    value = _number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0 or 'none': {text!r}")
    return value


def _alpha_step(text: str) -> tuple[float, float]:
    after, sep, at = text.partition("@")
    if not sep:
        raise argparse.ArgumentTypeError(
            f"expected AFTER@TIME (e.g. 0.045@2.5), got {text!r}"
        )
    return _number(after), _positive(at)


def _formats(text: str) -> tuple[str, ...]:
    formats = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    unknown = [f for f in formats if f not in ("png", "svg", "pdf")]
    if not formats or unknown:
        raise argparse.ArgumentTypeError(
            f"formats: choose from png, svg, pdf (comma-separated), got {text!r}"
        )
    return formats


def _engine_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--engine",
        choices=("control", "fast"),
        default="control",
        help="simulation engine: python-control's input_output_response "
        "(default, the reference) or ctrl_lpv's fused right-hand side "
        "(about 100x faster, same results to the solver tolerance)",
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``ctrl-lpv`` (for the docs and tests)."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog="ctrl-lpv",
        description="Certified LPV gain scheduling for python-control: "
        "reproduce the two-mass backlash paper, design and simulate.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--version", action="version", version=f"%(prog)s {__version__}"
    )
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    rep = commands.add_parser(
        "reproduce",
        help="errata findings, certified designs, figures and the "
        "LPV vs backstepping table, written to a folder",
        description="Reproduce the paper: errata findings, the certified "
        "designs, every figure and the LPV vs backstepping comparison "
        "(Markdown and JSON). The folder is written atomically: the files "
        "go to a temporary folder beside DIR, moved into place at the end "
        "(a previous reproduction in DIR is replaced; on Ctrl-C or an error "
        "nothing is left behind).",
    )
    rep.add_argument(
        "--out",
        required=True,
        type=Path,
        metavar="DIR",
        help="output folder (created; replaced if it holds a previous reproduction)",
    )
    rep.add_argument(
        "--robustness",
        action="store_true",
        help="add the 24 robustness scenarios to the comparison "
        "(alpha, Td and load inertia mismatch)",
    )
    rep.add_argument(
        "--formats",
        metavar="LIST",
        type=_formats,
        default=("png", "svg"),
        help="figure formats, comma-separated (default png,svg)",
    )
    _engine_option(rep)
    rep.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="print nothing (no progress, no table); errors still go to stderr",
    )

    des = commands.add_parser(
        "design",
        help="certified H-infinity design for the two-mass LPV model",
        description="Certified H-infinity state feedback (Lemma 2, or Theorem 2 "
        "with --scheduled) for the two-mass LPV model; prints the design and "
        "its certificate and optionally saves the gains as JSON. Gains are "
        "in python-control's sign, u = -K x.",
    )
    des.add_argument(
        "--p-min",
        metavar="P",
        type=_number,
        default=-0.95,
        help="lower bound of the backlash parameter p (default "
        "-0.95; p = -1 is not stabilizable)",
    )
    des.add_argument(
        "--p-max",
        metavar="P",
        type=_number,
        default=0.0,
        help="upper bound of p (default 0)",
    )
    des.add_argument(
        "--formulation",
        choices=("tracking", "paper"),
        default="tracking",
        help="model formulation (default tracking: error "
        "coordinates, weighted torque in z)",
    )
    des.add_argument(
        "--no-integral",
        dest="integral",
        action="store_false",
        help="no integral of the load-angle error (tracking)",
    )
    des.add_argument(
        "--scheduled",
        action="store_true",
        help="one gain per vertex (Theorem 2) instead of one common gain (Lemma 2)",
    )
    des.add_argument(
        "--torque-weight",
        metavar="W",
        type=_positive,
        default=2e-3,
        help="weight of Tm in z (default 2e-3)",
    )
    des.add_argument(
        "--integral-weight",
        metavar="W",
        type=_positive,
        default=10.0,
        help="weight of the error integral in z (default 10)",
    )
    des.add_argument(
        "--backoff",
        metavar="B",
        type=_backoff,
        default=0.2,
        help="relative back-off from the optimal gamma, or 'none' (default 0.2)",
    )
    des.add_argument(
        "--gain-bound",
        metavar="K",
        type=_positive,
        default=None,
        help="bound on the norm of every gain (Nm per state unit)",
    )
    des.add_argument(
        "--save",
        type=Path,
        metavar="FILE",
        help="write the gains and certificate summary as JSON",
    )
    des.add_argument(
        "--json",
        action="store_true",
        help="print the saved JSON document instead of the summary",
    )

    sim = commands.add_parser(
        "simulate",
        help="simulate a step of the load reference with a controller",
        description="Step of theta_r from rest on the two-mass plant with "
        "backlash; writes the response as CSV and a figure, prints its metrics.",
    )
    sim.add_argument(
        "--controller",
        default="paper",
        metavar="NAME|FILE",
        help="paper (published gain), robust, scheduled "
        "(certified designs, computed now), backstepping, or a gain "
        "file from 'ctrl-lpv design --save' (default paper)",
    )
    sim.add_argument(
        "--alpha",
        metavar="RAD",
        type=_number,
        default=0.03,
        help="backlash half-gap of the plant, rad (default 0.03)",
    )
    sim.add_argument(
        "--alpha-step",
        type=_alpha_step,
        metavar="AFTER@TIME",
        help="step the backlash to AFTER rad at TIME s",
    )
    sim.add_argument(
        "--alpha-estimate",
        metavar="RAD",
        type=_nonnegative,
        default=None,
        help="backlash estimate, rad, of vertex gains (scheduled or a "
        "gain file with vertex gains; refused for a common gain; default: --alpha)",
    )
    sim.add_argument(
        "--Td",
        metavar="NM",
        type=_number,
        default=8.0,
        help="load torque, Nm (default 8)",
    )
    sim.add_argument(
        "--theta-r",
        metavar="RAD",
        type=_number,
        default=0.5,
        help="load angle reference, rad (default 0.5)",
    )
    sim.add_argument(
        "--T", metavar="S", type=_positive, default=5.0, help="duration, s (default 5)"
    )
    sim.add_argument(
        "--model",
        choices=("exact", "deadzone"),
        default="exact",
        help="backlash model of the plant (default exact)",
    )
    _engine_option(sim)
    sim.add_argument(
        "--torque-limit",
        metavar="NM",
        type=_positive,
        default=None,
        help="|Tm| limit of the controller, Nm",
    )
    sim.add_argument(
        "--out",
        type=Path,
        metavar="DIR",
        help="write response.csv and response.png/.svg here",
    )
    sim.add_argument(
        "--formats",
        metavar="LIST",
        type=_formats,
        default=("png", "svg"),
        help="figure formats, comma-separated (default png,svg)",
    )
    return parser


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
        return _usage(f"--{exc}")
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
    from .twomass import designs

    if args.p_min >= args.p_max:
        return _usage(f"--p-min ({args.p_min}) must be below --p-max ({args.p_max})")
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
        return _usage(str(exc))
    if args.save:
        designs.save_gains(design, args.save, model=model_options)
    if args.json:
        document = designs.gains_document(design, model=model_options)
        print(json.dumps(document, indent=2))
    else:
        print(design)
        if args.save:
            print(f"gains saved to {args.save}")
    return 0


def _controller(args):
    from .twomass import backstepping_controller, designs, lpv_controller

    name = args.controller
    estimate = args.alpha if args.alpha_estimate is None else args.alpha_estimate
    limit = {"torque_limit": args.torque_limit}

    def common(what: str) -> None:
        if args.alpha_estimate is not None:
            raise ValueError(
                f"--alpha-estimate: {what} is a common gain, not scheduled by "
                "the backlash; drop the option or use vertex gains"
            )

    if name in ("paper", "robust", "backstepping"):
        common(
            {"paper": "the published gain", "robust": "the robust design"}.get(
                name, "backstepping"
            )
        )
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
            "backstepping nor an existing gain file"
        )
    try:
        gains = designs.load_gains(path)
    except ValueError as exc:
        raise ValueError(f"--controller: {exc}") from None
    if not gains.scheduled:
        common(f"the gain file {path}")
    extra = {"alpha_estimate": estimate} if gains.scheduled else {}
    try:
        return gains.controller(**extra, **limit)
    except ValueError as exc:
        raise ValueError(f"--controller: {path}: {exc}") from None


def _run_simulate(args) -> int:
    from .twomass import metrics, simulate
    from .twomass.scenarios import alpha_step

    if args.alpha < 0 or (args.alpha_step and args.alpha_step[0] < 0):
        return _usage("--alpha/--alpha-step: the backlash must be >= 0")
    if args.alpha_step is not None and args.alpha_step[1] >= args.T:
        return _usage(
            f"--alpha-step: the step time {args.alpha_step[1]:g} s is not "
            f"before the end of the run, --T {args.T:g} s"
        )
    try:
        controller = _controller(args)
    except ValueError as exc:
        return _usage(str(exc))
    alpha = args.alpha
    if args.alpha_step is not None:
        after, at = args.alpha_step
        alpha = alpha_step(args.alpha, after, at)
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
    import numpy as np

    m = metrics(response, args.theta_r)
    print(
        f"controller {args.controller}: "
        + ", ".join(f"{k} = {v:.4g}" for k, v in m.as_dict().items())
    )
    if args.out:
        from .plotting import plot_responses, save_figure

        args.out.mkdir(parents=True, exist_ok=True)
        labels = list(response.output_labels)
        with open(args.out / "response.csv", "w", newline="") as fh:
            writer = csv.writer(fh)
            writer.writerow(["time"] + labels)
            writer.writerows(
                np.column_stack([response.time, np.asarray(response.outputs).T])
            )
        fig = plot_responses(
            {args.controller: response},
            ["theta_l", "Tm"],
            units={"theta_l": "rad", "Tm": "Nm"},
            reference={"theta_l": args.theta_r},
            limits={} if args.torque_limit is None else {"Tm": args.torque_limit},
            title=f"{args.controller}, Td = {args.Td:g} Nm",
        )
        paths = save_figure(fig, args.out / "response", args.formats)
        (args.out / "metrics.json").write_text(
            json.dumps(m.as_dict(), indent=2, default=lambda v: None) + "\n"
        )
        print(
            f"wrote response.csv, metrics.json and "
            f"{', '.join(p.name for p in paths)} to {args.out}"
        )
    return 0


def _usage(message: str) -> int:
    print(f"ctrl-lpv: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``ctrl-lpv``; returns the exit code.

    Parameters
    ----------
    argv : list of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        0 success, 1 failure, 2 bad options, 3 proven infeasible, 4 no
        certified design found, 130 interrupted (Ctrl-C: one line on
        stderr, no traceback).
    """
    from .exceptions import CertificationError, InfeasibleError

    try:
        args = build_parser().parse_args(argv)
        runners = {
            "reproduce": _run_reproduce,
            "design": _run_design,
            "simulate": _run_simulate,
        }
        import matplotlib

        matplotlib.use("Agg")  # files only, also on machines without a display
        return runners[args.command](args)
    except KeyboardInterrupt:
        print("ctrl-lpv: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except InfeasibleError as exc:
        print(f"ctrl-lpv: infeasible: {exc}", file=sys.stderr)
        return EXIT_INFEASIBLE
    except CertificationError as exc:
        print(f"ctrl-lpv: no certified design found: {exc}", file=sys.stderr)
        return EXIT_UNCERTIFIED
    except (RuntimeError, OSError) as exc:
        print(f"ctrl-lpv: failed: {exc}", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
