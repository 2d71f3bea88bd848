"""The options of ``ctrl-lpv``: argument types, the parser, exit codes.

Parsing imports neither numpy, python-control, cvxpy nor matplotlib.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path

__all__ = ["build_parser", "attach_negative_values"]

EXIT_FAILURE, EXIT_USAGE, EXIT_INFEASIBLE, EXIT_UNCERTIFIED = 1, 2, 3, 4
EXIT_INTERRUPTED, EXIT_TERMINATED = 130, 143  # 128 + SIGINT, 128 + SIGTERM

#: Detail lines of a refusal printed without --verbose.
DETAIL_LINES = 4

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
_SAMPLE_TIME = _number_in(1e-5, 0.05, "s")


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
        f"message (default: the first {DETAIL_LINES})",
    )


def _engine_option(parser: argparse.ArgumentParser, compiled: bool = False) -> None:
    choices = ("control", "fast") + (("compiled", "auto") if compiled else ())
    extra = (
        "; compiled: numba-compiled, 10-30x faster still (needs the "
        "ctrl_lpv[fast] extra); auto: compiled where it can, else fast"
        if compiled
        else ""
    )
    parser.add_argument(
        "--engine",
        choices=choices,
        default="control",
        help="simulation engine: python-control's input_output_response "
        "(default, the reference) or ctrl_lpv's fused right-hand side "
        f"(fast: about 100x faster, same results to the solver tolerance){extra}",
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
        "(certified designs, computed now), backstepping, servo (the "
        "torque-limited position servo, designed now; --torque-limit is its "
        "limit, default 500 Nm), or a gain file from 'ctrl-lpv design --save' "
        "(default paper)",
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
    _engine_option(sim, compiled=True)
    sim.add_argument(
        "--torque-limit",
        metavar="NM",
        type=_positive,
        default=None,
        help="|Tm| limit of the controller, Nm",
    )
    sampled = sim.add_argument_group(
        "sampled servo",
        "with --dt the servo runs as a drive runs it: a discrete-time "
        "controller on the exact plant (zero-order hold), its angles read by "
        "a 20-bit motor and a 17-bit load encoder with half a count of noise "
        "(ctrl_lpv.sampled_response); --out then writes one row per sample",
    )
    sampled.add_argument(
        "--dt",
        metavar="S",
        type=_SAMPLE_TIME,
        default=None,
        help="sample time of the servo, 1e-5 to 0.05 s (--controller servo only)",
    )
    sampled.add_argument(
        "--delay",
        type=int,
        choices=(0, 1),
        default=None,
        help="samples of computation delay (default 1: the command computed "
        "at t_k acts from t_k+1)",
    )
    sampled.add_argument(
        "--sensors",
        choices=("states", "encoders", "motor"),
        default=None,
        help="what the servo reads: every state (exact), the motor and load "
        "encoders, or the motor encoder alone (default encoders)",
    )
    sampled.add_argument(
        "--seed",
        type=int,
        default=None,
        help="seed of the encoder noise (default 0)",
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


_NEGATIVE_VALUE = re.compile(r"-(\d|\.\d|inf|nan)", re.IGNORECASE)


def attach_negative_values(argv: list[str]) -> list[str]:
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
