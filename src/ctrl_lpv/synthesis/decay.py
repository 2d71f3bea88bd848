"""The decay search of a `Peak` spec.

The invariance inequality of `~ctrl_lpv.synthesis.specs.Peak` is an LMI for
a fixed decay ``lambda`` (a cvxpy parameter of the job's problem) and is
bilinear otherwise; no ``lambda`` is best for every problem. Every
``lambda`` gives a valid certificate, so the search only decides how good
the design is, never whether it is certified.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
from scipy.optimize import minimize_scalar

from .. import budget
from ..lmi import default_solvers

# The decays tried: prescaled time units in continuous time, where the data
# are of order one; the contraction of V per sample in discrete time, up to
# 0.999 because with |w| <= 1 the bound tends to the exact one as lambda
# tends to 1 (for x+ = w it is 1 / sqrt(lambda)).
LAMBDAS = {
    True: tuple(10.0 ** np.arange(-3.0, 2.01, 0.5)),
    False: (0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9, 0.97, 0.99, 0.999),
}
# Grid decays, best first, at which the stages run after the refined one.
_TRIES = 2
# Evaluations of the bounded scalar minimisation between grid neighbours.
_REFINE_EVALUATIONS = 10


@contextmanager
def _first_solver(job):
    """The job's solves with its first solver only (the servo's search
    does the same): a fallback such as SCS may take a minute per solve where
    the first fails, and the search solves dozens of times."""
    chain, job.chain = job.chain, (job.chain or default_solvers())[:1]
    try:
        yield
    finally:
        job.chain = chain


def _set(job, lam) -> None:
    # Each decay is a solve or more: stop the search once the deadline
    # has passed (the stages would only refuse, one note per decay).
    budget.check(f"the Peak decay lambda = {lam * job.scaling.a:.3g}")
    budget.progress("Peak decay lambda = %.3g", lam * job.scaling.a)
    job.lam = lam  # kept on the job: a rebuild (the bound's rescaling) reads it
    job.lmi.set_parameter("lam", lam)


def _raw_optimum(job, lam) -> float:
    """The objective's raw optimum at the decay `lam` (inf if none)."""
    _set(job, lam)
    with _first_solver(job):
        raw = job.solve("optimal", lambda v: v.g0[0, 0], certify=False)
    value = np.inf if raw is None else float((raw.nominal or raw).g0[0, 0])
    return value if np.isfinite(value) and value > 0 else np.inf


def _refine(job, lo, hi, penalty) -> float:
    """The minimum of the raw optimum on ``[lo, hi]`` (``log lambda`` in
    continuous time), by `scipy.optimize.minimize_scalar` (bounded);
    `penalty` stands for an infeasible decay (the interpolation needs
    finite values)."""
    to, back = (np.log, np.exp) if job.continuous else (float, float)

    def value(x):
        raw = _raw_optimum(job, float(back(x)))
        return raw if np.isfinite(raw) else penalty

    result = minimize_scalar(
        value,
        bounds=(to(lo), to(hi)),
        method="bounded",
        options={"maxiter": _REFINE_EVALUATIONS, "xatol": 1e-3},
    )
    return float(back(result.x))


def search_decay(job):
    """The job's stages at the decays of its `Peak` spec; the first found.

    To minimise an objective, the raw optimum is evaluated on the grid and
    refined between the grid neighbours of the best; the stages (back-off,
    verification) then run at the refined decay, then at the best of the
    grid. For a given bound or stability alone, the grid is tried in turn
    until a point certifies. All with the first solver; then the first
    decay once more with the whole solver chain.
    """
    grid = LAMBDAS[job.continuous]
    order = list(grid)
    if job.objective is not None and job.objective.bound is None:
        start = len(job.notes)
        values = [_raw_optimum(job, lam) for lam in grid]
        failed = job.notes[start:]
        del job.notes[start:]  # one note for the grid, not one per decay
        if failed:
            job.notes.append(
                f"Peak decay search: {len(failed)} of {len(grid)} decays gave no "
                f"optimum (at lambda = {grid[0] * job.scaling.a:.3g}: {failed[0]})"
            )
        order = [grid[i] for i in np.argsort(values) if np.isfinite(values[i])]
        order = order[:_TRIES]
        if order:
            best = grid.index(order[0])
            lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
            penalty = 2 * max(v for v in values if np.isfinite(v))
            order.insert(0, _refine(job, lo, hi, penalty))
    for lam in order:
        _set(job, lam)
        with _first_solver(job):
            found = job.stages()
        if found is not None:
            return found
        job.notes.append(
            f"Peak decay lambda = {lam * job.scaling.a:.3g}: no certified point"
        )
    if not order or len(job.chain or default_solvers()) == 1:
        return None
    _set(job, order[0])
    return job.stages()
