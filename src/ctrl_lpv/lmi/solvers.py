"""Which solvers run, with which options and time limits, and what they did."""

from __future__ import annotations

import functools
import importlib.util
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .. import budget
from . import cvxpy_backend
from .conic import CHORDAL, DIRECT, LIFTED, ConicResult, conic_data, solve_direct

__all__ = ["SolveAttempt", "default_solvers", "solver_chain", "run"]


@dataclass(frozen=True)
class SolveAttempt:
    """One solver attempt: solver, status, time and whether it certified.

    Attributes
    ----------
    solver : str
        Solver name (cvxpy's spelling).
    status : str
        Status the solver reported (not trusted: see `certified`).
    seconds : float
        Wall time of the attempt.
    certified : bool
        Whether the returned point passed its float64 certificate.
    message : str
        Why it did not certify, or which retry it was.
    compile_seconds : float
        Part of `seconds` spent before the solver iterated: assembling the
        conic data and handing it over (cvxpy's compilation, for solvers
        called through cvxpy).
    converged : bool
        Whether the solver reached its full accuracy
        (`ctrl_lpv.lmi.conic.ConicResult.converged`).
    """

    solver: str
    status: str
    seconds: float
    certified: bool
    message: str = ""
    compile_seconds: float = 0.0
    converged: bool = False


@functools.cache
def _installed_solvers() -> frozenset[str]:
    direct = {
        name for name in DIRECT if importlib.util.find_spec(name.lower()) is not None
    }
    return frozenset(direct) | cvxpy_backend.installed()


# The default chain's solvers that only cvxpy calls, by their modules.
_THROUGH_CVXPY = {"CVXOPT": "cvxopt", "MOSEK": "mosek"}


@functools.cache
def _default_installed() -> frozenset[str]:
    """The default chain's installed solvers.

    Imports cvxpy (about 0.3 s, more than a small design's solve) only when
    a module of a solver it would call is present: cvxpy lists a solver
    only if its module imports, so the set is `_installed_solvers`'s.
    """
    direct = {
        name for name in DIRECT if importlib.util.find_spec(name.lower()) is not None
    }
    through = {
        name
        for name, module in _THROUGH_CVXPY.items()
        if importlib.util.find_spec(module) is not None
        and name in cvxpy_backend.installed()
    }
    return frozenset(direct | through)


def default_solvers() -> list[tuple[str, dict]]:
    """Solver chain: Clarabel, SCS with tight tolerances, then CVXOPT, MOSEK.

    Only installed solvers are listed (probed once per process); Clarabel
    and SCS are called directly, the others through cvxpy if it is
    installed. Clarabel runs without its chordal decomposition: the LMIs
    here are small dense blocks that it would only split at the zeros of
    their identity blocks, and with it the gain stage of the two-mass
    design stalled in a numerical error (measured on the two-mass model
    and random polytopes: no such failure without it, and less time).
    """
    installed = _default_installed()
    chain = [
        ("CLARABEL", {"chordal_decomposition_enable": False}),
        ("SCS", {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 20_000}),
        ("CVXOPT", {}),
        ("MOSEK", {}),
    ]
    return [(name, opts) for name, opts in chain if name in installed]


# Solver options that bound a solve's wall time, in seconds.
_TIME_LIMIT_OPTIONS = {"CLARABEL": "time_limit", "SCS": "time_limit_secs"}


def with_time_limit(solver, options, deadline):
    """`options` with the solver's own limit set to the time left.

    The time left is that of `deadline` or of the call's budget
    (`ctrl_lpv.budget`), whichever ends first.
    """
    # Clarabel's lifted and chordal forms ("CLARABEL (...)") take its limit.
    key = _TIME_LIMIT_OPTIONS.get(solver.upper().split(" (")[0])
    ends = [d for d in (deadline, budget.deadline()) if d is not None]
    if not ends or key is None:
        return options
    left = max(min(ends) - time.perf_counter(), 1e-3)
    return {**options, key: min(float(options.get(key, np.inf)), left)}


def run(solver: str, c, data_of, margin: float, options) -> ConicResult:
    """Solve with `solver`; ``data_of(upper)`` gives the conic data."""
    if solver in (LIFTED, CHORDAL):
        return solve_direct(solver, c, data_of(True), margin, options)
    solver = solver.upper()
    if solver in DIRECT:
        return solve_direct(solver, c, data_of(DIRECT[solver][1]), margin, options)
    return cvxpy_backend.solve_cvxpy(solver, c, data_of(True), margin, options)


def summary(attempts) -> str:
    """The attempts of a solve, one clause each, repeats counted."""
    return budget.digest(
        "; ".join(
            f"{a.solver}: {a.status}" + (f" ({a.message})" if a.message else "")
            for a in attempts
        )
    )


def solver_chain(solvers) -> list[tuple[str, dict]] | None:
    """Validate a `solvers` argument: None, a name, or names/(name, options).

    Returns
    -------
    list of (str, dict) or None
        None for the default chain (`default_solvers`).

    Raises
    ------
    ValueError
        For an empty chain, a solver that is not installed (the message
        lists the installed ones), or options the solver rejects (judged by
        the solver on a tiny problem, before any real solve).
    TypeError
        For anything else.
    """
    if solvers is None:
        return None
    if isinstance(solvers, str):
        solvers = [solvers]
    try:
        items = list(solvers)
    except TypeError:
        raise TypeError(
            f"solvers: expected a solver name or a list of names or (name, "
            f"options) pairs, got {solvers!r}"
        ) from None
    if not items:
        raise ValueError("solvers: the list is empty; pass None for the default")
    chain = []
    for item in items:
        if isinstance(item, str):
            name, options = item, {}
        elif (
            isinstance(item, Sequence)
            and len(item) == 2
            and isinstance(item[0], str)
            and isinstance(item[1], dict)
        ):
            name, options = item
        else:
            raise TypeError(
                f"solvers: expected a name or a (name, options) pair, got {item!r}"
            )
        if name.upper() not in _installed_solvers():
            hint = ""
            if name.upper() not in DIRECT and not cvxpy_backend.available():
                hint = (" (solvers other than Clarabel and SCS are called "
                        "through cvxpy: pip install 'ctrl_lpv[cvxpy]')")  # fmt: skip
            raise ValueError(
                f"solvers: {name!r} is not installed; installed: "
                f"{sorted(_installed_solvers())}{hint}"
            )
        _check_options(name.upper(), options)
        chain.append((name.upper(), dict(options)))
    return chain


def _check_options(solver: str, options: dict) -> None:
    """Refuse options `solver` does not accept, before any real solve.

    The solver itself is the judge (no list of names kept here): a tiny
    problem is solved once with the options, as the real solves pass them;
    a `ValueError` names the option(s) that alone fail.
    """
    if options and _options_error(solver, options) is not None:
        bad = [k for k in options if _options_error(solver, {k: options[k]})]
        bad = bad or sorted(options)
        raise ValueError(
            f"solvers: {solver} rejects the option(s) {', '.join(map(repr, bad))} "
            f"(unknown name or wrong value): "
            f"{_options_error(solver, {k: options[k] for k in bad})}"
        )


def _options_error(solver: str, options: dict) -> str | None:
    """The message of a trial solve with `options` that fails by them."""
    if solver not in DIRECT:
        return cvxpy_backend.options_error(solver, options)
    # min x subject to 1 - x <= 0, as a 1 x 1 inequality.
    piece = (np.ones((1, 1)), (np.zeros(1, int), np.zeros(1, int), -np.ones(1)))
    data = conic_data([piece], [False], 1, DIRECT[solver][1])
    try:
        solve_direct(solver, np.ones(1), data, 0.0, options)
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        return str(exc) or type(exc).__name__
    except Exception:  # noqa: BLE001 - a solve failing otherwise: not the options
        return None
    return None
