"""How `LMIProblem` reads its inequalities into conic data, and back.

Each inequality's affine map is read off its block function
(`ctrl_lpv.lmi.blocks.columns`) and kept for its last few sets of values of
the parameters it reads; a stage's conic data (`ctrl_lpv.lmi.conic`) are
rebuilt only when a map changed. Objectives are linear and read the same
way; a solver's point is turned back into the variables' values.
"""

from __future__ import annotations

import functools
import time
from types import SimpleNamespace

import numpy as np

from .. import budget
from . import blocks as _blocks
from .conic import conic_data
from .dual import id_equal

__all__ = ["ConicReading"]

# Maps of one inequality kept for as many sets of the parameter values it
# reads: stages and prescalings that alternate (a bound set per stage) then
# read each inequality once.
_KEPT_MAPS = 4


class ConicReading:
    """The reading methods of `ctrl_lpv.lmi.LMIProblem`."""

    def _units(self) -> dict[str, np.ndarray]:
        # Kept until a variable is declared (`_forget`): a re-read with new
        # numbers needs the same unit points.
        if self._unit_points is None:
            self._unit_points = {
                name: _blocks.unit_points(var.shape, var.symmetric)
                for name, var in self._vars.items()
            }
        return self._unit_points

    def _nfree(self) -> int:
        return sum(var.free for var in self._vars.values())

    def _base(self) -> dict[str, np.ndarray]:
        """The parameters' values and the variables at zero."""
        zero = {k: np.zeros(v.shape) for k, v in self._vars.items()}
        return {**self._numeric(), **zero}

    def _pieces(self, active, exact: bool = False):
        """Per inequality, ``(F(0), columns of M)`` (`ctrl_lpv.lmi.blocks`).

        An inequality's map is kept for its last few sets of values of the
        parameters it reads (which it was first seen to read), and reused
        for the same values; a block function that reads other constants
        that change needs `invalidate`. `exact` reads the maps one unit
        point at a time (for dual certificates, whose rounding bounds
        assume exact columns); otherwise in one batched evaluation per
        variable, checked at a random point the first time an inequality
        is read that way (`ctrl_lpv.lmi.blocks.columns`, ``trusted``).
        """
        units = self._units()
        numeric = self._numeric()
        # The parameters' bytes once per reading, not once per inequality.
        encoded = {p: value.tobytes() for p, value in numeric.items()}
        base = self._base()
        # One namespace for every evaluation of this reading: only the
        # variables an evaluation sets are put back to zero after it (a new
        # namespace of every name per evaluation costs more than the map).
        namespace = SimpleNamespace(**base)
        cache = self._exact if exact else self._columns
        pieces = []
        for name, blocks, _, _ in active:
            kept = cache.setdefault(name, {})
            read = self._reads.get(name)
            key = None if read is None else _key(read, encoded)
            if key in kept:
                kept[key] = kept.pop(key)  # the most recent last
                pieces.append(kept[key])
                continue
            budget.check(f"reading the LMI {name}")
            F0 = None  # read with the columns, once the names read are known
            if read is None and name in self._given_reads:
                self._reads[name] = read = self._given_reads[name] & set(base)
            if read is None:
                read = set()
                F0 = _blocks.assemble(blocks(_blocks.Recording(base, read)))
                if "__dict__" in read:  # the namespace was read as a whole
                    read = set(base)
                self._reads[name] = read = frozenset(read & set(base))

            def evaluate(values, blocks=blocks):
                for key, value in values.items():
                    setattr(namespace, key, value)
                try:
                    return _blocks.assemble(blocks(namespace))
                finally:
                    for key in values:
                        setattr(namespace, key, base[key])

            start = time.perf_counter()
            F0, part = _blocks.columns(
                evaluate, F0, read, units, not exact,
                trusted=name in self._trusted,
                on_checked=lambda name=name: self._trusted.add(name),
            )  # fmt: skip
            kept[_key(read, encoded)] = piece = (F0, part)
            self._reading += time.perf_counter() - start
            if len(kept) > _KEPT_MAPS:
                del kept[next(iter(kept))]
            pieces.append(piece)
        return pieces

    def _conic_data(self, stage: str, upper: bool):
        """The stage's conic data (`ctrl_lpv.lmi.conic`) and whether it was
        rebuilt (only when an inequality's map changed)."""
        active = self._active(stage)
        pieces = self._pieces(active)
        parts = tuple(part for _, part in pieces)
        last = self._conic.get((stage, upper))
        if last and len(last[0]) == len(parts) and all(map(id_equal, last[0], parts)):
            return last[1], False
        strict = [is_strict for _, _, is_strict, _ in active]
        start = time.perf_counter()
        data = conic_data(pieces, strict, self._nfree(), upper)
        self._reading += time.perf_counter() - start
        self._conic[(stage, upper)] = (parts, data)
        return data, True

    def _objective_vector(self, objective) -> np.ndarray:
        """``c`` of a linear objective ``objective(v) = c'x + c0``."""
        c = np.zeros(self._nfree())
        if objective is None:
            return c

        # One namespace for every evaluation (as `_pieces`): a unit point is
        # set, evaluated and put back to zero.
        base = self._base()
        namespace = SimpleNamespace(**base)

        def value(name=None, E=None):
            if name is not None:
                setattr(namespace, name, E)
            try:
                return float(np.asarray(objective(namespace)).reshape(()))
            finally:
                if name is not None:
                    setattr(namespace, name, base[name])

        zero = value()
        offset = 0
        for name, points in self._units().items():
            for k, E in enumerate(points):
                c[offset + k] = value(name, E) - zero
            offset += len(points)
        return c

    def _values(self, x) -> dict[str, np.ndarray]:
        """The variables' values from the vector of free entries."""
        values, offset = {}, 0
        for name, points in self._units().items():
            k = len(points)
            values[name] = np.tensordot(x[offset : offset + k], points, axes=1)
            offset += k
        return values


def _key(read, encoded) -> tuple:
    """The values of the parameters among `read` (`encoded`: each
    parameter's bytes), as a dictionary key."""
    return tuple((p, encoded[p]) for p in _sorted(read) if p in encoded)


@functools.lru_cache(maxsize=4096)
def _sorted(read: frozenset) -> tuple:
    # Kept: every reading asks again for each inequality's key.
    return tuple(sorted(read))
