"""Compiled synthesis problems kept for re-solves (`synthesis_cache`).

The synthesis functions pose their LMIs with every number that changes
between calls as a parameter of `ctrl_lpv.lmi.LMIProblem`, so one problem
(its variables, its block functions and the affine maps read from them)
serves every call of the same structure; this module keeps them, in a
process-wide cache bounded in count and memory.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from contextlib import contextmanager

import numpy as np

__all__ = ["SynthesisCache", "synthesis_cache"]


class SynthesisCache:
    """Compiled synthesis problems, reused across calls of one process.

    The engine poses its LMIs with the vertex data, the margin and the
    stage bounds as parameters, so the problem depends only on the
    structure: the specs, the dimensions ``n, m, n_w, n_z``, the number of
    vertices, the Lyapunov structure and the pole-region shapes. A later
    call with the same structure (a gamma or back-off sweep, new
    performance weights, another plant of the same size) sets the
    parameter values and reads again only the LMIs whose data changed.
    Every result is still verified and certified from scratch; the cache
    holds no results, only problems.

    The cache is least-recently-used and thread-safe: a problem in use by
    one call is taken out, so concurrent calls with one structure compile
    their own. Two limits bound it: the number of structures and the total
    size of their LMIs, since a problem with its kept maps holds about
    0.4 kB per LMI matrix entry (measured: 12.5 MB for Theorem 2 with 32
    vertices and ``n = 4``, 528 LMIs of size 8). ``maxsize = 0`` disables the cache.

    Parameters
    ----------
    maxsize : int
        Largest number of compiled structures kept.
    max_entries : int
        Largest total number of LMI matrix entries (``sum size^2`` over
        the LMIs) of the structures kept; a larger structure is compiled
        for each call and not kept. The default is about 0.5 GB.

    Examples
    --------
    >>> synthesis_cache.info()["maxsize"]
    8
    """

    def __init__(self, maxsize: int = 8, max_entries: int = 250_000):
        self._entries: OrderedDict = OrderedDict()
        self._lock = threading.Lock()
        self._hits = 0
        self._misses = 0
        self._maxsize = self._count(maxsize, "maxsize")
        self._max_entries = self._count(max_entries, "max_entries")

    @staticmethod
    def _count(value, name: str) -> int:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise TypeError(f"{name}: expected an integer, got {value!r}")
        if value < 0:
            raise ValueError(f"{name}: must be nonnegative, got {value}")
        return int(value)

    @property
    def maxsize(self) -> int:
        """Largest number of compiled structures kept."""
        return self._maxsize

    @maxsize.setter
    def maxsize(self, value: int) -> None:
        self._maxsize = self._count(value, "maxsize")
        with self._lock:
            self._trim()

    @property
    def max_entries(self) -> int:
        """Largest total number of LMI matrix entries kept."""
        return self._max_entries

    @max_entries.setter
    def max_entries(self, value: int) -> None:
        self._max_entries = self._count(value, "max_entries")
        with self._lock:
            self._trim()

    def _total(self) -> int:
        return sum(s.entries for s in self._entries)

    def _trim(self):
        # Oldest first, until both limits hold.
        while self._entries and (
            len(self._entries) > self._maxsize or self._total() > self._max_entries
        ):
            self._entries.popitem(last=False)

    def __contains__(self, structure) -> bool:
        """Whether a compiled problem of `structure` is held."""
        with self._lock:
            return structure in self._entries

    def clear(self) -> None:
        """Drop every compiled problem and reset the counters."""
        with self._lock:
            self._entries.clear()
            self._hits = self._misses = 0

    def info(self) -> dict:
        """Hits, misses, size, LMI entries held, and the two limits."""
        with self._lock:
            return {
                "hits": self._hits,
                "misses": self._misses,
                "size": len(self._entries),
                "maxsize": self._maxsize,
                "entries": self._total(),
                "max_entries": self._max_entries,
            }

    @contextmanager
    def checkout(self, structure, build: Callable):
        """Yield ``(compiled, reused)``; the problem is put back afterwards.

        `structure` is the hashable key, with an ``entries`` attribute (the
        LMI matrix entries of its problem); ``build(structure)`` compiles
        the problem on a miss.
        """
        with self._lock:
            compiled = self._entries.pop(structure, None)
            if compiled is None:
                self._misses += 1
            else:
                self._hits += 1
        reused = compiled is not None
        if compiled is None:
            compiled = build(structure)
        try:
            yield compiled, reused
        finally:
            keep = self._maxsize > 0 and structure.entries <= self._max_entries
            with self._lock:
                if keep:  # a structure over the budget would flush the rest
                    self._entries[structure] = compiled
                    self._entries.move_to_end(structure)
                    self._trim()

    def __repr__(self) -> str:
        info = self.info()
        return (
            f"<SynthesisCache {info['size']}/{info['maxsize']} structures, "
            f"{info['entries']}/{info['max_entries']} LMI entries, "
            f"{info['hits']} hits, {info['misses']} misses>"
        )


#: The process-wide cache used by the synthesis functions.
synthesis_cache = SynthesisCache()
