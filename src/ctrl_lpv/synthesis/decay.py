"""The search of a spec's decay (a `Peak` spec's ``lambda``).

The invariance inequality of `~ctrl_lpv.synthesis.specs.Peak` is an LMI for
a fixed decay ``lambda`` (a parameter of the rung's problem) and is
bilinear otherwise; no ``lambda`` is best for every problem. Every
``lambda`` gives a valid certificate, so the search only decides how good
the design is, never whether it is certified.

The flow is one way: `search_decay` gets an immutable `DecaySearch` and two
functions of the decay (the raw optimum, the stages), and returns what it
found with its notes; it holds no state of the rung.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from .. import budget

# Grid decays, best first, at which the stages run after the refined one.
_TRIES = 2
# Evaluations of the bounded scalar minimisation between grid neighbours.
_REFINE_EVALUATIONS = 10


@dataclass(frozen=True)
class DecaySearch:
    """What the search needs to know.

    Attributes
    ----------
    grid : tuple of float
        The decays tried (prescaled units).
    continuous : bool
        Refine in ``log lambda`` (continuous time) or ``lambda``.
    minimise : bool
        Whether there is an objective to minimise (else the first decay
        that certifies wins).
    a : float
        The time scaling, for messages in the model's units.
    whole_chain : bool
        Whether a solver chain beyond the first solver exists (tried once,
        at the best decay, after the first solver failed at every decay).
    """

    grid: tuple
    continuous: bool
    minimise: bool
    a: float
    whole_chain: bool


def _announce(search, lam) -> None:
    # Each decay is a solve or more: stop the search once the deadline
    # has passed (the stages would only refuse, one note per decay).
    budget.check(f"the Peak decay lambda = {lam * search.a:.3g}")
    budget.progress("Peak decay lambda = %.3g", lam * search.a)


def search_decay(
    search: DecaySearch,
    raw_optimum: Callable[[float], tuple[float, list]],
    stages: Callable[[float, bool], tuple[object, list]],
):
    """The stages at the decays of the search; the first found.

    `raw_optimum(lam)` is the objective's raw optimum at a decay with the
    first solver (``inf`` if none) and its notes; `stages(lam, first)` the
    rung's stages at a decay (with the first solver only, or the whole
    chain) and their notes.

    To minimise an objective, the raw optimum is evaluated on the grid and
    refined between the grid neighbours of the best (scipy's bounded
    scalar minimisation); the stages then run at the refined decay, then at
    the best of the grid. For a given bound or stability alone, the grid
    is tried in turn until a point certifies. All with the first solver (a
    fallback such as SCS may take a minute per solve where the first
    fails, and the search solves dozens of times); then the first decay
    once more with the whole chain.

    Returns
    -------
    found, list of str
        The stages' result (None if nothing certified) and the notes.
    """
    grid = search.grid
    order = list(grid)
    notes: list[str] = []

    def raw(lam):
        _announce(search, lam)
        value, failed = raw_optimum(lam)
        return (value if np.isfinite(value) and value > 0 else np.inf), failed

    if search.minimise:
        evaluated = [raw(lam) for lam in grid]
        values = [value for value, _ in evaluated]
        failed = [note for _, some in evaluated for note in some[:1]]
        if failed:  # one note for the grid, not one per decay
            notes.append(
                f"Peak decay search: {len(failed)} of {len(grid)} decays gave no "
                f"optimum (at lambda = {grid[0] * search.a:.3g}: {failed[0]})"
            )
        order = [grid[i] for i in np.argsort(values) if np.isfinite(values[i])]
        order = order[:_TRIES]
        if order:
            best = grid.index(order[0])
            lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
            penalty = 2 * max(v for v in values if np.isfinite(v))
            if lo < hi:  # (not for a grid of one decay: nothing to refine)
                order.insert(0, _refine(search, raw, lo, hi, penalty))
    for lam in order:
        _announce(search, lam)
        found, more = stages(lam, True)
        notes.extend(more)
        if found is not None:
            return found, notes
        notes.append(f"Peak decay lambda = {lam * search.a:.3g}: no certified point")
    if not order or not search.whole_chain:
        return None, notes
    _announce(search, order[0])
    found, more = stages(order[0], False)
    return found, notes + more


def _refine(search, raw, lo, hi, penalty) -> float:
    """The minimum of the raw optimum on ``[lo, hi]`` (``log lambda`` in
    continuous time); `penalty` stands for an infeasible decay (the
    interpolation needs finite values)."""
    to, back = (np.log, np.exp) if search.continuous else (float, float)

    def value(x):
        found, _ = raw(float(back(x)))
        return found if np.isfinite(found) else penalty

    result = minimize_scalar(
        value,
        bounds=(to(lo), to(hi)),
        method="bounded",
        options={"maxiter": _REFINE_EVALUATIONS, "xatol": 1e-3},
    )
    return float(back(result.x))
