"""The LMIs of a stage in sparse conic form, solved by Clarabel or SCS.

A stage is ``min c'x`` subject to ``F_i(x) <= -m_i I`` (``m_i`` the margin
of a strict inequality, 0 otherwise), with ``F_i(x) = F_i(0) + M_i x`` read
off the block functions (`ctrl_lpv.lmi.blocks.columns`). Both solvers take
``min c'x`` subject to ``s = b - A x`` in a product of cones; here each
``s_i = svec(-F_i(x) - m_i I)`` lies in a cone of PSD matrices stored as a
scaled triangle, off-diagonal entries times ``sqrt(2)`` (so that inner
products are preserved):

* Clarabel (``PSDTriangleConeT``): the upper triangle, column by column;
* SCS (cone ``"s"``): the lower triangle, column by column.

The data are assembled once per structure with numpy and scipy.sparse; a
re-solve with another margin changes ``b`` only, and another objective
``c`` only. Clarabel's solver is kept with the data (`_kept_clarabel`), so
that an identical re-solve (the same ``c`` and ``b``: a repeated design)
does not pay its setup (the KKT system's structure, equilibration,
symbolic factorisation) again. Other solvers take the same data through
cvxpy (`ctrl_lpv.lmi.cvxpy_backend`).
"""

from __future__ import annotations

import collections
import functools
import threading
import time
import weakref
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

__all__ = ["ConicData", "ConicResult", "conic_data", "solve_direct", "DIRECT"]

# Solver statuses, as cvxpy names them (the engine's vocabulary).
OPTIMAL = "optimal"
OPTIMAL_INACCURATE = "optimal_inaccurate"
INFEASIBLE = "infeasible"
INFEASIBLE_INACCURATE = "infeasible_inaccurate"
SOLVED = (OPTIMAL, OPTIMAL_INACCURATE)
PROVED_INFEASIBLE = (INFEASIBLE, INFEASIBLE_INACCURATE)


@functools.cache
def _layout(d: int, upper: bool) -> tuple[np.ndarray, np.ndarray]:
    """Row-major positions in ``vec F`` of a triangle's entries, and scales."""
    if upper:  # (i, j), i <= j, column by column
        i, j = np.triu_indices(d)
        order = np.lexsort((i, j))
    else:  # (i, j), i >= j, column by column
        i, j = np.tril_indices(d)
        order = np.lexsort((i, j))
    i, j = i[order], j[order]
    scale = np.where(i == j, 1.0, np.sqrt(2.0))
    return i * d + j, scale


@functools.cache
def _positions(d: int, upper: bool) -> tuple[np.ndarray, np.ndarray]:
    """Per entry of ``vec F``, its position in the triangle (-1: not
    stored), and ``svec(I)``; kept, as `_layout`."""
    where, _ = _layout(d, upper)
    position = np.full(d * d, -1)
    position[where] = np.arange(where.size)
    eye = np.eye(d).ravel()[where]
    position.flags.writeable = eye.flags.writeable = False
    return position, eye


@dataclass(frozen=True)
class ConicData:
    """``min c'x`` s.t. ``b - A x`` in PSD triangle cones of `sizes`.

    Attributes
    ----------
    A : scipy.sparse.csc_array
    b0 : ndarray
        ``b`` without the margins: ``svec(-F_i(0))``.
    b_margin : ndarray
        ``svec(I)`` for the strict inequalities, 0 elsewhere: ``b = b0 -
        margin * b_margin``.
    sizes : tuple of int
        Size of each inequality.
    upper : bool
        The triangle stored (Clarabel: upper; SCS: lower).
    solvers : dict
        Solvers set up for these data, kept for re-solves (Clarabel's;
        bounded in the process by `KEPT_BYTES` and `KEPT_COSTLY`).
    """

    A: sp.csc_array
    b0: np.ndarray
    b_margin: np.ndarray
    sizes: tuple[int, ...]
    upper: bool
    solvers: dict = field(default_factory=dict, compare=False, repr=False)

    def b(self, margin: float) -> np.ndarray:
        return self.b0 - margin * self.b_margin

    def matrices(self, z) -> list[np.ndarray]:
        """Symmetric matrices from a vector of the cones' layout (duals)."""
        out, start = [], 0
        for d in self.sizes:
            where, scale = _layout(d, self.upper)
            Y = np.zeros(d * d)
            Y[where] = np.asarray(z[start : start + where.size]) / scale
            Y = Y.reshape(d, d)
            out.append(Y + np.triu(Y, 1).T + np.tril(Y, -1).T)
            start += where.size
        return out


def conic_data(pieces, strict, nfree: int, upper: bool) -> ConicData:
    """Conic form of inequalities given as ``(F0, (rows, cols, data))``.

    Parameters
    ----------
    pieces : sequence
        Per inequality, ``F_i(0)`` and the entries of ``M_i`` (rows in
        ``vec F_i``, row-major).
    strict : sequence of bool
        Which inequalities carry the margin.
    nfree : int
        Number of free entries ``x``.
    upper : bool
        Clarabel's layout (True) or SCS's.
    """
    rows, cols, data, b0, b_margin, sizes = [], [], [], [], [], []
    offset = 0
    for (F0, (r, c, x)), is_strict in zip(pieces, strict):
        d = F0.shape[0]
        where, scale = _layout(d, upper)
        position, eye = _positions(d, upper)
        keep = position[r] >= 0
        svec_rows = position[r[keep]]
        rows.append(svec_rows + offset)
        cols.append(c[keep])
        data.append(x[keep] * scale[svec_rows])
        b0.append(-F0.ravel()[where] * scale)
        b_margin.append(eye * (1.0 if is_strict else 0.0))
        sizes.append(d)
        offset += where.size
    A = sp.csc_array(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
        shape=(offset, nfree),
    )
    return ConicData(
        A, np.concatenate(b0), np.concatenate(b_margin), tuple(sizes), upper
    )


@dataclass(frozen=True)
class ConicResult:
    """What a solver returned (nothing in it is trusted).

    Attributes
    ----------
    status : str
        cvxpy's name for the solver's status.
    x : ndarray or None
        The point, when the solver reported one.
    duals : list of ndarray or None
        After a solve that found no point, one symmetric matrix per
        inequality: the dual point (a Farkas point after an infeasible
        solve); None with a point (nothing reads the duals then).
    objective : float or None
    seconds : float
        Wall time.
    setup_seconds : float
        The part spent posing the data in another form (cvxpy's
        compilation); 0 for the solvers called directly.
    converged : bool
        Whether the solver's own optimality measures reached full accuracy:
        an "optimal" status, or an "optimal_inaccurate" one whose duality
        gap and residuals are within `NEAR_OPTIMAL` (Clarabel's
        "AlmostSolved" ends so when only its last step fell short).
    iterate : ndarray or None
        The point a solver stopped at without converging (Clarabel's
        `UNCONVERGED` statuses: its last interior iterate), for a caller
        that only wants a point to check in float64 (see
        `ctrl_lpv.lmi.LMIProblem.solve`, ``unconverged``); None otherwise.
    """

    status: str
    x: np.ndarray | None
    duals: list | None
    objective: float | None
    seconds: float
    setup_seconds: float = 0.0
    converged: bool = False
    iterate: np.ndarray | None = None


# Relative duality gap and residuals of an "optimal_inaccurate" point that
# count as converged (Clarabel's full accuracy is 1e-8, its reduced one
# 5e-5). Measured on random Theorem 2 polytopes (n = 8, N = 32): an
# "AlmostSolved" point with gap 4e-8 and residuals 2e-8, whose re-solve
# from another prescaling found nothing better.
NEAR_OPTIMAL = 1e-6

_CLARABEL_STATUS = {
    "Solved": OPTIMAL,
    "AlmostSolved": OPTIMAL_INACCURATE,
    "PrimalInfeasible": INFEASIBLE,
    "AlmostPrimalInfeasible": INFEASIBLE_INACCURATE,
    "DualInfeasible": "unbounded",
    "AlmostDualInfeasible": "unbounded_inaccurate",
    "MaxIterations": "user_limit",
    "MaxTime": "user_limit",
}

# Clarabel's statuses that end a solve without converging, at an interior
# iterate (its primal residual often far below its tolerance, its gap
# not): a stiff problem (the LPVTools spinning disks' back-off stage, a
# weight's pole at -0.04 beside ones at -4e4) stops so after 15-21
# iterations, with a point as good as a converged one for a stage that
# only chooses a point.
UNCONVERGED = ("NumericalError", "InsufficientProgress", "MaxIterations", "MaxTime")

# SCS's status_val.
_SCS_STATUS = {
    1: OPTIMAL,
    2: OPTIMAL_INACCURATE,
    -2: INFEASIBLE,
    -7: INFEASIBLE_INACCURATE,
    -1: "unbounded",
    -6: "unbounded_inaccurate",
}


def clarabel_settings(options: dict):
    """Clarabel's settings with `options` (AttributeError for an unknown one)."""
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    for key, value in options.items():
        if not hasattr(settings, key):
            raise AttributeError(f"Clarabel has no setting {key!r}")
        setattr(settings, key, value)
    return settings


# Clarabel solvers kept in the process, idle between solves. Each holds its
# KKT matrix and factorisation, measured at 60-65 bytes per entry of ``A``
# and of the cones' dense Hessian blocks (``t^2`` for a cone of ``t``
# triangle entries; Theorem 2 LMIs, n = 4 and 8, N = 16 and 32: 13-55 MB),
# and its setup cost 2-8 % of its solve there, but 18 % for the many small
# cones of an affine-Lyapunov H2 design (n = 4, N = 16). After each solve
# and before each setup, the least recently used ones are freed down to
# `KEPT_BYTES`, except those whose setup cost `COSTLY_SETUP` of their solve
# or more: up to `KEPT_COSTLY` of these stay whatever their size (a
# ladder's stages each have their own data, and so their own solver).
KEPT_BYTES = 16 * 2**20
COSTLY_SETUP = 0.12
KEPT_COSTLY = 3
_BYTES_PER_ENTRY = 64
_kept: collections.OrderedDict = collections.OrderedDict()  # id -> weakref
# The records of data no longer alive, dropped under the lock: a weakref
# callback may run in any thread, even amid the bookkeeping.
_dead: list = []
_lock = threading.Lock()


def _size(data: ConicData) -> int:
    """A Clarabel solver's estimated memory for `data`."""
    hessian = sum((d * (d + 1) // 2) ** 2 for d in data.sizes)
    return _BYTES_PER_ENTRY * (data.A.nnz + hessian)


def _costly(data: ConicData) -> bool:
    """Whether the setup of the solver kept for `data` cost `COSTLY_SETUP`
    of its (first) solve or more, in CPU time."""
    kept = data.solvers["CLARABEL"]
    return kept.setup >= COSTLY_SETUP * kept.solve


def _make_room() -> None:
    """Free the least recently used idle solvers down to `KEPT_BYTES` of
    cheaply set up ones and `KEPT_COSTLY` costly ones."""
    alive = [(key, ref()) for key, ref in _kept.items()]
    alive = [(key, data) for key, data in alive if data is not None]
    cheap = sum(_size(data) for _, data in alive if not _costly(data))
    costly = sum(_costly(data) for _, data in alive)
    for key, data in alive:
        if _costly(data):
            if costly <= KEPT_COSTLY:
                continue
            costly -= 1
        else:
            if cheap <= KEPT_BYTES:
                continue
            cheap -= _size(data)
        del _kept[key]
        data.solvers.pop("CLARABEL", None)


@dataclass
class _Kept:
    """A solver kept with its data, the ``c`` and ``b`` it was set up with,
    and what it cost (CPU seconds)."""

    settings: str
    solver: object
    c: bytes
    b: bytes
    setup: float
    solve: float = np.inf


def _forget(key: int, ref) -> None:
    """Note data no longer alive (their solver went with them)."""
    _dead.append((key, ref))


def _sweep() -> None:
    """Drop the records of data no longer alive (under the lock)."""
    while _dead:
        key, ref = _dead.pop()
        if _kept.get(key) is ref:
            del _kept[key]


def _settings_key(options: dict) -> str:
    """What a kept solver must share with a re-solve's options: all but the
    time limit (Clarabel refuses to change the others after setup)."""
    return repr(sorted((k, v) for k, v in options.items() if k != "time_limit"))


def _clarabel_cones(data: ConicData) -> list:
    """Clarabel's cones of `data`: a scalar as a nonnegative cone, a matrix
    as a PSD triangle."""
    import clarabel

    return [
        clarabel.NonnegativeConeT(1) if d == 1 else clarabel.PSDTriangleConeT(d)
        for d in data.sizes
    ]


def _kept_clarabel(c, data: ConicData, b, options):
    """Clarabel's solver for `data` (`_Kept`): the one kept from a solve
    with the same ``c``, ``b`` and options (the time limit may differ: it
    is updated), else one set up anew.

    Only identical data are re-solved on a kept solver: Clarabel scales
    data given through `update` with rounding that differs from its setup's,
    which a degenerate optimum amplifies (measured: points 1e-4 apart, and a
    solver error on the spinning-disk output-feedback design), so a solve
    with other numbers must not depend on what the solver did before.
    Clarabel starts every solve from its own initial point: an identical
    re-solve gives the first solve's point.
    """
    import clarabel

    settings = clarabel_settings(options)
    same = _settings_key(options)
    c_bytes, b_bytes = np.asarray(c, float).tobytes(), np.asarray(b, float).tobytes()
    with _lock:
        _sweep()
        kept = data.solvers.get("CLARABEL")
        if kept is not None and (kept.settings, kept.c, kept.b) == (
            same,
            c_bytes,
            b_bytes,
        ):
            _kept.move_to_end(id(data))
        else:
            data.solvers.pop("CLARABEL", None)
            _kept.pop(id(data), None)
            _make_room()
            kept = None
    if kept is not None:
        kept.solver.update(settings=settings)  # the time limit left
        return kept
    setup = time.process_time()
    cones = _clarabel_cones(data)
    n = data.A.shape[1]
    P = sp.csc_matrix((n, n))
    solver = clarabel.DefaultSolver(P, c, sp.csc_matrix(data.A), b, cones, settings)
    kept = _Kept(same, solver, c_bytes, b_bytes, time.process_time() - setup)
    key = id(data)
    with _lock:
        data.solvers["CLARABEL"] = kept
        _kept[key] = weakref.ref(data, lambda ref: _forget(key, ref))
        _kept.move_to_end(key)
    return kept


def _clarabel(c, data: ConicData, b, options) -> ConicResult:
    start = time.perf_counter()
    kept = _kept_clarabel(c, data, b, options)
    cpu = time.process_time()
    solution = kept.solver.solve()
    kept.solve = min(kept.solve, time.process_time() - cpu)
    with _lock:  # not beside the next stage's reading either
        _sweep()
        _make_room()
    return _result(solution, data, start)


def _result(solution, data: ConicData, start: float, lifted: int = 0) -> ConicResult:
    """A Clarabel solution as a `ConicResult`; `lifted` slack variables
    after ``x`` and equality rows before the cones' (`_clarabel_lifted`)."""
    n = data.A.shape[1]
    status = _CLARABEL_STATUS.get(str(solution.status), "solver_error")
    x = np.array(solution.x, float)[:n] if status in SOLVED else None
    z = np.array(solution.z, float)[lifted:]
    duals = None if status in SOLVED else data.matrices(z)
    objective = float(solution.obj_val) if status in SOLVED else None
    primal, dual = solution.obj_val, solution.obj_val_dual
    gap = abs(primal - dual) / max(1.0, abs(primal))
    converged = status == OPTIMAL or (
        status == OPTIMAL_INACCURATE
        and max(gap, solution.r_prim, solution.r_dual) <= NEAR_OPTIMAL
    )
    iterate = None
    if str(solution.status) in UNCONVERGED:
        iterate = np.array(solution.x, float)[:n]
        if not np.all(np.isfinite(iterate)):
            iterate = None
    seconds = time.perf_counter() - start
    return ConicResult(
        status, x, duals, objective, seconds, converged=converged, iterate=iterate
    )


def _clarabel_lifted(c, data: ConicData, b, options) -> ConicResult:
    """Clarabel on the same problem with the slack a variable of its own.

    ``b - A x = s`` become equality rows and the cones hold ``s``: Clarabel
    equilibrates a PSD cone's rows by one common factor, equality rows each
    by its own. An LMI whose entries span many orders of magnitude (a mode
    at 1e9 beside one at 1e-9, in coordinates where neither is hidden by a
    time scaling) stops the direct form in a numerical error; lifted, it
    solves (fuzz cases 4242:47 and 6161:12). The problem is larger: the
    engine's ladder calls it (as the solver `LIFTED`) only in its last
    rungs, after every other rung failed.
    """
    import clarabel

    start = time.perf_counter()
    m, n = data.A.shape
    A = sp.vstack([
        sp.hstack([data.A, sp.identity(m)]),
        sp.hstack([sp.csc_matrix((m, n)), -sp.identity(m)]),
    ]).tocsc()  # fmt: skip
    cones = [clarabel.ZeroConeT(m), *_clarabel_cones(data)]
    solver = clarabel.DefaultSolver(
        sp.csc_matrix((n + m, n + m)), np.concatenate([c, np.zeros(m)]), A,
        np.concatenate([b, np.zeros(m)]), cones, clarabel_settings(options),
    )  # fmt: skip
    return _result(solver.solve(), data, start, lifted=m)


#: The name of Clarabel's lifted form in a solve's attempts.
LIFTED = "CLARABEL (lifted)"


def _clarabel_chordal(c, data: ConicData, b, options) -> ConicResult:
    """Clarabel on the same problem with its chordal decomposition on.

    An LMI whose rows touch few of the others (a weakly controllable mode
    1e16 slower than a fast one, in the model's units, beside the zeros of
    its identity blocks) is split into cones on its cliques, each
    equilibrated by a factor of its own: where one factor for the whole
    cone leaves the slow mode's entries below the fast one's rounding (a
    numerical error at the first iteration, fuzz case 9595:21), the split
    solves. The lifted form (`_clarabel_lifted`) does not solve that case,
    nor this form the lifted one's (4242:47): the engine's ladder calls
    both (this as the solver `CHORDAL`), last, after every other rung
    failed. Not kept with the data (`_kept_clarabel`): it is a last resort.
    """
    import clarabel

    start = time.perf_counter()
    cones = _clarabel_cones(data)
    n = data.A.shape[1]
    settings = clarabel_settings({**options, "chordal_decomposition_enable": True})
    solver = clarabel.DefaultSolver(
        sp.csc_matrix((n, n)), c, sp.csc_matrix(data.A), b, cones, settings
    )
    return _result(solver.solve(), data, start)


#: The name of Clarabel's chordal form in a solve's attempts.
CHORDAL = "CLARABEL (chordal)"


def _scs(c, data: ConicData, b, options) -> ConicResult:
    import scs

    start = time.perf_counter()
    solver = scs.SCS(
        {"A": sp.csc_matrix(data.A), "b": b, "c": c},
        {"s": list(data.sizes)},
        **{"verbose": False, **options},
    )
    solution = solver.solve()
    status = _SCS_STATUS.get(int(solution["info"]["status_val"]), "solver_error")
    x = np.array(solution["x"], float) if status in SOLVED else None
    duals = None if status in SOLVED else data.matrices(np.array(solution["y"], float))
    objective = float(solution["info"]["pobj"]) if status in SOLVED else None
    seconds = time.perf_counter() - start
    return ConicResult(
        status, x, duals, objective, seconds, converged=status == OPTIMAL
    )


#: The solvers this module calls directly, and their layout (upper triangle).
DIRECT = {"CLARABEL": (_clarabel, True), "SCS": (_scs, False)}
_FORMS = {
    **DIRECT,
    LIFTED: (_clarabel_lifted, True),
    CHORDAL: (_clarabel_chordal, True),
}


def solve_direct(
    solver: str, c, data: ConicData, margin: float, options
) -> ConicResult:
    """Solve with `solver` (a key of `DIRECT`, `LIFTED` or `CHORDAL`);
    `data` in its layout."""
    call, upper = _FORMS[solver]
    if data.upper != upper:
        raise ValueError(f"data: not in {solver}'s layout")
    return call(np.asarray(c, float), data, data.b(margin), options)
