"""The ``ctrl-lpv`` command: reproduce the paper, design, simulate.

Exit codes: 0 success, 1 failure while running (e.g. an integrator
failure), 2 bad command-line options, 3 the design problem is proven
infeasible (`ctrl_lpv.InfeasibleError`), 4 no certified design was found
(`ctrl_lpv.CertificationError`), 130 interrupted (Ctrl-C), 143 terminated
(SIGTERM).

Every output (``reproduce --out``, ``design --save``, ``simulate --out``)
is checked before the work starts and written through a temporary file or
folder beside it, moved into place at the end: an interrupted or failed run
leaves nothing half-written.

Parsing the options imports neither numpy, python-control, cvxpy nor
matplotlib; each command imports what it needs when it runs.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import signal
import sys
import threading
import time
from pathlib import Path

EXIT_FAILURE, EXIT_USAGE, EXIT_INFEASIBLE, EXIT_UNCERTIFIED = 1, 2, 3, 4
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + SIGINT, 128 + SIGTERM

#: Detail lines of a refusal printed without --verbose.
_DETAIL_LINES = 4

_EPILOG = """\
exit codes: 0 success, 1 failure while running, 2 bad options,
3 proven infeasible (InfeasibleError), 4 no certified design found
(CertificationError), 130 interrupted (Ctrl-C), 143 terminated (SIGTERM).
A negative value may follow its option (--p-min -0.5) or be attached
(--p-min=-0.5).

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


def _number_in(low: float, high: float, unit: str = ""):
    """An argparse type: a finite number in ``[low, high]``.

    The ranges keep every run meaningful and finite (a duration of 1e308 s
    would ask for 1e311 output points); the message states the range.
    """

    def convert(text: str) -> float:
        value = _number(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(
                f"must be between {low:g} and {high:g}{' ' + unit if unit else ''}, "
                f"got {text!r}"
            )
        return value

    return convert


# Ranges of the options (the paper's values: alpha 0.03 rad, Td 8 Nm,
# theta_r 0.5 rad, 5 s; output every millisecond).
_DURATION = _number_in(0.01, 100.0, "s")
_BACKLASH = _number_in(0.0, 1.0, "rad")
_LOAD_TORQUE = _number_in(-1e5, 1e5, "Nm")
_REFERENCE = _number_in(-100.0, 100.0, "rad")
_P_BOUND = _number_in(-1.0, 0.0)
_WEIGHT = _number_in(1e-6, 1e6)
_BACKOFF = _number_in(0.0, 10.0)


def _backoff(text: str) -> float | None:
    if text.lower() == "none":
        return None
    return _BACKOFF(text)


def _alpha_step(text: str) -> tuple[float, float]:
    after, sep, at = text.partition("@")
    if not sep:
        raise argparse.ArgumentTypeError(
            f"expected AFTER@TIME (e.g. 0.045@2.5), got {text!r}"
        )
    return _BACKLASH(after), _positive(at)


def _formats(text: str) -> tuple[str, ...]:
    formats = tuple(f.strip().lower() for f in text.split(",") if f.strip())
    unknown = [f for f in formats if f not in ("png", "svg", "pdf")]
    if not formats or unknown:
        raise argparse.ArgumentTypeError(
            f"choose from png, svg, pdf (comma-separated), got {text!r}"
        )
    return formats


class _Parser(argparse.ArgumentParser):
    """`argparse.ArgumentParser` that states the error before the usage."""

    def error(self, message: str):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}\n{self.format_usage()}")


def _verbose_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="on a refusal or failure, print every detail line of the "
        f"message (default: the first {_DETAIL_LINES})",
    )


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

    parser = _Parser(
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
        "(a previous reproduction in DIR is replaced; on Ctrl-C, SIGTERM or "
        "an error nothing is left behind).",
    )
    rep.add_argument(
        "--out",
        required=True,
        type=Path,
        metavar="DIR",
        help="output folder (created in an existing folder; replaced if it "
        "holds a previous reproduction)",
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
    _verbose_option(rep)

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
        type=_P_BOUND,
        default=-0.95,
        help="lower bound of the backlash parameter p, in [-1, 0] (default "
        "-0.95; p = -1 is not stabilizable)",
    )
    des.add_argument(
        "--p-max",
        metavar="P",
        type=_P_BOUND,
        default=0.0,
        help="upper bound of p, in [-1, 0] (default 0)",
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
        type=_WEIGHT,
        default=2e-3,
        help="weight of Tm in z, 1e-6 to 1e6 (default 2e-3)",
    )
    des.add_argument(
        "--integral-weight",
        metavar="W",
        type=_WEIGHT,
        default=10.0,
        help="weight of the error integral in z, 1e-6 to 1e6 (default 10)",
    )
    des.add_argument(
        "--backoff",
        metavar="B",
        type=_backoff,
        default=0.2,
        help="relative back-off from the optimal gamma, 0 to 10, or 'none' "
        "(default 0.2: gamma 20 %% above the optimum)",
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
        help="write the gains and certificate data as JSON (the folder must "
        "exist; an existing file is replaced)",
    )
    des.add_argument(
        "--json",
        action="store_true",
        help="print the saved JSON document instead of the summary",
    )
    _verbose_option(des)

    sim = commands.add_parser(
        "simulate",
        help="simulate a step of the load reference with a controller",
        description="Step of theta_r from rest on the two-mass plant with "
        "backlash; prints the step metrics of the load angle (with units) and, "
        "with --out DIR, writes response.csv (time and every output, one row "
        "per millisecond), metrics.json (the metrics and their units) and the "
        "figure response.png/.svg (--formats).",
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
        type=_BACKLASH,
        default=0.03,
        help="backlash half-gap of the plant, 0 to 1 rad (default 0.03)",
    )
    sim.add_argument(
        "--alpha-step",
        type=_alpha_step,
        metavar="AFTER@TIME",
        help="step the backlash to AFTER rad (0 to 1) at TIME s (before --T)",
    )
    sim.add_argument(
        "--alpha-estimate",
        metavar="RAD",
        type=_BACKLASH,
        default=None,
        help="backlash estimate, 0 to 1 rad, of vertex gains (scheduled or a "
        "gain file with vertex gains; refused for a common gain; default: --alpha)",
    )
    sim.add_argument(
        "--Td",
        metavar="NM",
        type=_LOAD_TORQUE,
        default=8.0,
        help="load torque, -1e5 to 1e5 Nm (default 8)",
    )
    sim.add_argument(
        "--theta-r",
        metavar="RAD",
        type=_REFERENCE,
        default=0.5,
        help="load angle reference, -100 to 100 rad (default 0.5)",
    )
    sim.add_argument(
        "--T",
        metavar="S",
        type=_DURATION,
        default=5.0,
        help="duration, 0.01 to 100 s (default 5)",
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
        help="write response.csv, metrics.json and the figure here (created if "
        "missing, in an existing folder; other files in DIR are kept)",
    )
    sim.add_argument(
        "--formats",
        metavar="LIST",
        type=_formats,
        default=("png", "svg"),
        help="figure formats, comma-separated (default png,svg)",
    )
    _verbose_option(sim)
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
    if args.p_min >= args.p_max:
        return _usage(f"--p-min ({args.p_min}) must be below --p-max ({args.p_max})")
    from ._output import check_destination

    if args.save is not None:
        try:  # before the design, which takes seconds
            check_destination(args.save, "--save", folder=False)
        except ValueError as exc:
            return _usage(str(exc))
    from .twomass import designs

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
        # Atomic: written beside the file, then moved into place.
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
}


def _metric_text(value: float, unit: str) -> str:
    if math.isnan(value):
        return "undefined"
    if math.isinf(value) and unit == "s":
        return "never"
    return f"{value:.4g} {unit}"


def _print_metrics(args, values: dict[str, float]) -> None:
    print(
        f"controller {args.controller}, theta_r = {args.theta_r:g} rad, "
        f"Td = {args.Td:g} Nm, {args.T:g} s:"
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
        return _usage(
            f"--alpha-step: the step time {args.alpha_step[1]:g} s is not "
            f"before the end of the run, --T {args.T:g} s"
        )
    from ._output import check_destination

    if args.out is not None:
        try:  # before the simulation, which takes seconds
            check_destination(args.out, "--out", folder=True)
        except ValueError as exc:
            return _usage(str(exc))
    from .twomass import metrics, simulate
    from .twomass.scenarios import alpha_step

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
    values = metrics(response, args.theta_r).as_dict()
    _print_metrics(args, values)
    if args.out:
        written = _write_response(args, response, values)
        print(f"wrote {', '.join(written)} to {args.out}")
    return 0


def _usage(message: str) -> int:
    print(f"ctrl-lpv: error: {message}", file=sys.stderr)
    return EXIT_USAGE


def _clauses(message: str) -> list[str]:
    """`message` cut at "; " and ". " outside brackets (its clauses)."""
    clauses, depth, start = [], 0, 0
    for i, char in enumerate(message):
        if char in "([{":
            depth += 1
        elif char in ")]}":
            depth = max(depth - 1, 0)
        elif depth == 0 and char in ";." and message.startswith(" ", i + 1):
            clauses.append(message[start : i + (char == ".")])
            start = i + 2
    clauses.append(message[start:])
    return [c.strip() for c in clauses if c.strip()]


def _headline(message: str) -> tuple[str, list[str]]:
    """The first clause of `message` (without a long final parenthesis) and the rest."""
    first, *details = _clauses(message) or [""]
    if len(first) > 100 and first.endswith(")"):
        depth = 0
        for i in range(len(first) - 1, -1, -1):
            depth += {")": 1, "(": -1}.get(first[i], 0)
            if depth == 0:
                if first[:i].strip():
                    details.insert(0, first[i:])
                    first = first[:i].strip()
                break
    return first, details


def _refusal(what: str, exc: BaseException, argv: list[str], verbose: bool) -> None:
    """Print a refusal or failure: one line saying what failed, then details.

    The first line names the command and options run and what failed; the
    details follow, one clause a line, the first few only unless `verbose`.
    """
    import shlex

    first, details = _headline(str(exc))
    command = shlex.join(argv)
    lines = [f"ctrl-lpv: {what} ({command}): {first}"]
    shown = details if verbose else details[:_DETAIL_LINES]
    lines += [f"  {line}" for line in shown]
    if len(details) > len(shown):
        hidden = len(details) - len(shown)
        lines.append(f"  ... {hidden} more detail lines (--verbose prints them)")
    print("\n".join(lines), file=sys.stderr)


_NEGATIVE_VALUE = re.compile(r"-(\d|\.\d|inf|nan)", re.IGNORECASE)


def _attach_negative_values(argv: list[str]) -> list[str]:
    """``--p-min -1e-12`` -> ``--p-min=-1e-12``.

    argparse takes an argument that starts with "-" for an option unless it
    looks like a plain negative number ("-1", "-0.5"): "-1e-12", "-.5",
    "-inf" or "-0.01@2" after an option would be refused as a missing value.
    Attached with "=", they reach the option's own check.
    """
    joined: list[str] = []
    for i, arg in enumerate(argv):
        if arg == "--":
            return joined + argv[i:]
        previous = joined[-1] if joined else ""
        if (
            previous.startswith("--")
            and "=" not in previous
            and _NEGATIVE_VALUE.match(arg)
        ):
            joined[-1] = f"{previous}={arg}"
        else:
            joined.append(arg)
    return joined


class _Terminated(KeyboardInterrupt):
    """SIGTERM, raised like Ctrl-C so that every cleanup of an interrupted run runs.

    A `KeyboardInterrupt` (not an `Exception`): no ``except Exception`` of a
    solver fallback swallows it.
    """


def _raise_terminated(signum, frame):
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # one cleanup, not two
    raise _Terminated


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
        certified design found, 130 interrupted (Ctrl-C), 143 terminated
        (SIGTERM); on 130 and 143, one line on stderr, no traceback, and no
        output file or temporary folder left behind.
    """
    given = list(sys.argv[1:] if argv is None else argv)
    previous = None
    if threading.current_thread() is threading.main_thread():  # signal's rule
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        return _main(_attach_negative_values(given), given)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _main(argv: list[str], given: list[str]) -> int:
    """`main` after the signal handler: `argv` parsed, `given` quoted in refusals."""
    from .exceptions import CertificationError, InfeasibleError

    verbose = False
    try:
        args = build_parser().parse_args(argv)
        verbose = args.verbose
        runners = {
            "reproduce": _run_reproduce,
            "design": _run_design,
            "simulate": _run_simulate,
        }
        import matplotlib

        matplotlib.use("Agg")  # files only, also on machines without a display
        return runners[args.command](args)
    except _Terminated:
        print("ctrl-lpv: terminated (SIGTERM)", file=sys.stderr)
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        print("ctrl-lpv: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except InfeasibleError as exc:
        _refusal("infeasible", exc, given, verbose)
        return EXIT_INFEASIBLE
    except CertificationError as exc:
        _refusal("no certified design found", exc, given, verbose)
        return EXIT_UNCERTIFIED
    except (RuntimeError, OSError) as exc:
        _refusal("failed", exc, given, verbose)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
