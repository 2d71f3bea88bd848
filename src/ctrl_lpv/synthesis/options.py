"""Keyword options of the synthesis functions, and the size guard."""

from __future__ import annotations

import os
import warnings

from .. import budget
from .._checks import real_number
from ..exceptions import ProblemSizeWarning
from ..lmi import solver_chain
from ..problem_cache import synthesis_cache
from ..regions import LMIRegion

# Compile-time and memory estimates of a problem (see `guard_size`): a
# warning above _WARN_COMPILE_SECONDS, a refusal above the time left or
# half the memory. The stages after the first compile about as much again
# (`ctrl_lpv.budget.compile_seconds` is the estimate of one).
_WARN_COMPILE_SECONDS = 30.0
# A kept problem and its maps (measured: 370 B per LMI entry, Theorem 2 at
# n = 4 with 32 vertices, 12.5 MB).
_BYTES_PER_ENTRY = 400


def validated_regions(regions) -> tuple:
    """`regions` as a tuple of `LMIRegion` (a single one accepted)."""
    if isinstance(regions, LMIRegion):
        regions = (regions,)
    try:
        regions = tuple(regions)
    except TypeError:
        raise TypeError(
            f"regions: expected an LMIRegion or a sequence of them, got {regions!r}"
        ) from None
    for region in regions:
        if not isinstance(region, LMIRegion):
            raise TypeError(f"regions: expected LMIRegion objects, got {region!r}")
    return regions


def validated_options(regions, backoff, gamma, gain_bound, margin, solvers, time_limit):
    """Check the keyword options of the four functions at their boundary."""
    regions = validated_regions(regions)
    backoff = real_number(backoff, "backoff", allow_none=True, minimum=0.0)
    # gamma^2 and gain_bound^2 must stay finite in float64.
    gamma = real_number(gamma, "gamma", allow_none=True, positive=True, below=1e150)
    gain_bound = real_number(gain_bound, "gain_bound", allow_none=True, positive=True)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    time_limit = real_number(time_limit, "time_limit", allow_none=True, positive=True)
    return (
        regions,
        backoff,
        gamma,
        gain_bound,
        margin,
        solver_chain(solvers),
        time_limit,
    )


def guard_size(structure, time_limit=None) -> None:
    """`guard_estimate` for a `~ctrl_lpv.synthesis.problem.Structure`."""
    guard_estimate(
        structure.nlmis, structure.entries, structure.largest, time_limit,
        cached=structure in synthesis_cache,
    )  # fmt: skip


def guard_estimate(nlmis, entries, largest, time_limit=None, cached=False) -> None:
    """Warn about, or refuse, a problem too large for this machine or time.

    Each LMI is read from its block function in Python
    (`ctrl_lpv.budget.compile_seconds`), so a scheduled design on 200
    vertices (20,100 LMIs) takes a minute before any solver runs. The
    time is that of the call's budget, or `time_limit` if shorter. A
    `cached` problem is read already: only the memory is checked.

    Raises
    ------
    ValueError
        If the compiled problem would not fit in half the memory.
    `ctrl_lpv.budget.TimeLimitReached`
        If its first stage would not compile in the time left.
    """
    estimate = entries * _BYTES_PER_ENTRY
    seconds = budget.compile_seconds(nlmis, entries)
    text = (
        f"{nlmis} LMIs of size up to {largest}, about {entries:,} "
        f"matrix entries, estimated {estimate / 2**30:.2g} GiB and "
        f"{seconds:.3g} s to compile"
    )
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover
        memory = None
    if memory is not None and estimate > 0.5 * memory:
        raise ValueError(
            f"sys: the problem is too large for this machine ({text}, more than "
            f"half of its {memory / 2**30:.3g} GiB); use fewer vertices or a "
            "common gain"
        )
    if cached:
        return
    left = min(budget.remaining(), float("inf") if time_limit is None else time_limit)
    if seconds > left:
        raise budget.TimeLimitReached(
            f"time_limit: no design tried, the problem would not compile within "
            f"the {left:.3g} s left ({text})",
            time_limit=time_limit,
        )
    if seconds > _WARN_COMPILE_SECONDS:
        warnings.warn(
            f"large LMI problem: {text}; time_limit= bounds the whole call",
            ProblemSizeWarning,
            stacklevel=5,
        )
