"""The conic data of a stage solved by any solver cvxpy knows (MOSEK, CVXOPT).

Clarabel and SCS take the data directly (`ctrl_lpv.lmi.conic`); this
backend hands the very same problem, ``min c'x`` subject to ``b - A x`` in
the PSD cones, to cvxpy, the only module of the library that imports it.
"""

from __future__ import annotations

import functools
import importlib.util
import time
import warnings

import numpy as np
import scipy.sparse as sp

from .conic import SOLVED, ConicData, ConicResult, _layout

__all__ = ["available", "installed", "solve_cvxpy", "options_error"]


def available() -> bool:
    """Whether cvxpy is installed (the optional extra ``ctrl_lpv[cvxpy]``)."""
    return importlib.util.find_spec("cvxpy") is not None


@functools.cache
def installed() -> frozenset[str]:
    """Solvers cvxpy can call (empty without cvxpy); probed once."""
    if not available():
        return frozenset()
    import cvxpy as cp

    return frozenset(cp.installed_solvers())


def _unpack(d: int, upper: bool) -> sp.csr_array:
    """``vec S = U s``: the full matrix (row-major) from its scaled triangle."""
    where, scale = _layout(d, upper)
    i, j = np.divmod(where, d)
    rows = np.concatenate([where, j * d + i])
    cols = np.tile(np.arange(where.size), 2)
    values = np.tile(1.0 / scale, 2)
    off = i != j
    keep = np.concatenate([np.ones(where.size, bool), off])
    return sp.csr_array(
        (values[keep], (rows[keep], cols[keep])), shape=(d * d, where.size)
    )


def solve_cvxpy(solver: str, c, data: ConicData, margin: float, options) -> ConicResult:
    """Solve the conic problem with a solver through cvxpy."""
    import cvxpy as cp

    start = time.perf_counter()
    x = cp.Variable(data.A.shape[1])
    b = data.b(margin)
    constraints, offset = [], 0
    for d in data.sizes:
        k = d * (d + 1) // 2
        s = b[offset : offset + k] - data.A[offset : offset + k] @ x
        S = cp.reshape(_unpack(d, data.upper) @ s, (d, d), order="C")
        constraints.append(0.5 * (S + S.T) >> 0)
        offset += k
    problem = cp.Problem(cp.Minimize(np.asarray(c, float) @ x), constraints)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            problem.solve(solver=solver, **options)
        status = problem.status
    except cp.error.SolverError:
        status = "solver_error"
    seconds = time.perf_counter() - start
    setup = float(problem.compilation_time or 0.0)
    solved = status in SOLVED
    duals = [constraint.dual_value for constraint in constraints]
    if any(dual is None for dual in duals):
        duals = None
    return ConicResult(
        status,
        np.array(x.value, float) if solved and x.value is not None else None,
        duals,
        float(problem.value) if solved else None,
        seconds,
        setup,
        converged=status == "optimal",
    )


def options_error(solver: str, options: dict) -> str | None:
    """The message of a trial solve with `options` that fails by them."""
    import cvxpy as cp

    options = {k: v for k, v in options.items() if k != "verbose"}
    x = cp.Variable()
    problem = cp.Problem(cp.Minimize(x), [x >= 1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem.solve(solver=solver, **options)
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        return str(exc) or type(exc).__name__
    except cp.error.SolverError:
        return None  # a solve that fails for other reasons: not the options
    return None
