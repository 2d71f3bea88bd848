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

import signal
import sys
import threading

from ._cli_commands import COMMANDS
from ._cli_parser import (
    DETAIL_LINES,
    EXIT_FAILURE,
    EXIT_INFEASIBLE,
    EXIT_INTERRUPTED,
    EXIT_TERMINATED,
    EXIT_UNCERTIFIED,
    EXIT_USAGE,
    attach_negative_values,
    build_parser,
)

__all__ = [
    "main",
    "build_parser",
    "EXIT_FAILURE",
    "EXIT_USAGE",
    "EXIT_INFEASIBLE",
    "EXIT_UNCERTIFIED",
    "EXIT_INTERRUPTED",
    "EXIT_TERMINATED",
]


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
    shown = details if verbose else details[:DETAIL_LINES]
    lines += [f"  {line}" for line in shown]
    if len(details) > len(shown):
        hidden = len(details) - len(shown)
        lines.append(f"  ... {hidden} more detail lines (--verbose prints them)")
    print("\n".join(lines), file=sys.stderr)


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
        return _main(attach_negative_values(given), given)
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
        import matplotlib

        matplotlib.use("Agg")  # files only, also on machines without a display
        return COMMANDS[args.command](args)
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
