"""How `LMIProblem` reads its inequalities into conic data, and back.

Each inequality's affine map is read off its block function
(`ctrl_lpv.lmi.blocks.columns`) and kept for its last few sets of values of
the parameters it reads; a stage's conic data (`ctrl_lpv.lmi.conic`) are
rebuilt only when a map changed. Objectives are linear and read the same
way; a solver's point is turned back into the variables' values.
"""

from __future__ import annotations

import functools
import logging
import time
from types import SimpleNamespace

import numpy as np

from .. import budget
from . import blocks as _blocks
from .conic import conic_data
from .dual import id_equal

__all__ = ["ConicReading"]

logger = logging.getLogger("ctrl_lpv.lmi")

# Maps of one inequality kept for as many sets of the parameter values it
# reads: stages and prescalings that alternate (a bound set per stage) then
# read each inequality once.
_KEPT_MAPS = 4

# A stacked matrix at a point must agree with its map to this relative
# accuracy (the rounding of a few products and sums, as a batched reading).
_STACK_TOLERANCE = 1e-10

# Largest matrix read a group at a time. A row of the stack repeats its
# coefficient's data, which costs more than a block function's Python for
# large matrices (measured, warm reading of Theorem 2 with N = 16: 8 x 8,
# n = 4, 16 -> 11 ms; 19 x 19, n = 8, 31 -> 33 ms; 27 x 27, n = 12, 68 ->
# 87 ms).
_GROUP_MAX_SIZE = 12

# Entries of the row-stacked variables and matrices of one chunk of a
# group's reading (`ConicReading._read_group`): 2e6 float64, 16 MB; the
# peak memory of a reading stays that of the conic data.
_GROUP_ENTRIES = 2_000_000


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
        if not exact:
            self._read_groups(active, units, encoded, base)
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

    def _read_groups(self, active, units, encoded, base) -> None:
        """The maps of grouped inequalities (`LMIProblem.add`, ``stacked``)
        not kept for these parameter values, read a group at a time.

        Into the maps `_pieces` keeps, the same as its batched reading
        (`ctrl_lpv.lmi.blocks.columns`); each member's checked at a random
        point against its own block function the first time its group is
        read. A group that does not read stacked is left to `_pieces`.
        """
        groups: dict = {}
        for name, blocks, _, _ in active:
            member = self._stacked.get(name)
            if member is None:
                continue
            read = self._reads.get(name)
            if read is None and name in self._given_reads:
                self._reads[name] = read = self._given_reads[name] & set(base)
            if read is None or "__dict__" in read:
                continue
            key = _key(read, encoded)
            if key in self._columns.get(name, {}):
                continue
            groups.setdefault(id(member[0]), (member[0], []))[1].append(
                (name, member[1], read, key, blocks)
            )
        for group, members in groups.values():
            if len(members) < 2:
                continue
            budget.check("reading a group of LMIs")
            start = time.perf_counter()
            try:
                found = self._read_group(group, members, units, base)
            except (ValueError, TypeError, IndexError):
                logger.debug("a group of LMIs does not read stacked")
                found = None
            if found is None:
                continue
            for (name, _, _, key, _), piece in zip(members, found):
                kept = self._columns.setdefault(name, {})
                kept[key] = piece
                if len(kept) > _KEPT_MAPS:
                    del kept[next(iter(kept))]
            self._reading += time.perf_counter() - start

    def _read_group(self, group, members, units, base):
        """Per member, ``(F0, columns)`` of a group read stacked (None if
        a member's map fails its random-point check)."""
        spans = _blocks._spans(units)
        positions = [k for _, k, _, _, _ in members]
        F0s = _blocks.assemble(group(SimpleNamespace(**base), positions, None))
        if F0s.ndim != 3 or F0s.shape[0] != len(members):
            return None
        if F0s.shape[1] > _GROUP_MAX_SIZE:
            return None  # read one by one: cheaper for larger matrices
        F0s = np.ascontiguousarray(F0s)
        read_spans = [
            tuple((v, span) for v, span in spans.items()
                  if v in read and span[1] > span[0])
            for _, _, read, _, _ in members
        ]  # fmt: skip
        repeats = [sum(b - a for _, (a, b) in sp) for sp in read_spans]
        # Members in chunks: a chunk's variables hold one value per row, and
        # its stack (and assembly's few copies) one matrix per row.
        width = sum(int(np.prod(points.shape[1:])) for points in units.values())
        most = max(1, _GROUP_ENTRIES // (width + 4 * F0s[0].size))
        found, first = [], 0
        while first < len(members):
            last, rows = first, 0
            while last < len(members) and (
                last == first or rows + repeats[last] <= most
            ):
                rows += repeats[last]
                last += 1
            found += self._read_chunk(group, range(first, last), positions, read_spans,
                                      repeats, F0s, units, base)  # fmt: skip
            first = last
        trusted = all(name in self._trusted_groups for name, *_ in members)
        if not trusted:
            x, values = _blocks._probe(units)
            namespace = SimpleNamespace(**{**base, **values})
            for member, (F0, (rows, cols, data)) in zip(members, found):
                blocks = member[4]
                expected = F0.ravel().copy()
                np.add.at(expected, rows, data * x[cols])
                actual = np.asarray(_blocks.assemble(blocks(namespace))).ravel()
                scale = np.abs(F0).sum() + np.abs(data * x[cols]).sum()
                if not np.abs(actual - expected).max() <= _STACK_TOLERANCE * scale:
                    logger.debug("a group's map differs from its LMI at a random point")
                    return None
            self._trusted_groups.update(name for name, *_ in members)
        return found

    def _read_chunk(self, group, chunk, positions, read_spans, repeats, F0s, units,
                    base):  # fmt: skip
        counts = [repeats[i] for i in chunk]
        total = sum(counts)
        variables: dict = {}
        offset = 0
        for i in chunk:
            slot = offset
            for v, (a, b) in read_spans[i]:
                if v not in variables:
                    variables[v] = np.zeros((total,) + units[v].shape[1:])
                variables[v][slot : slot + b - a] = units[v]
                slot += b - a
            offset += repeats[i]
        stacks = {v: value.view(_blocks.Batch) for v, value in variables.items()}
        namespace = SimpleNamespace(**{**base, **stacks})
        stack = np.asarray(
            _blocks.assemble(group(namespace, [positions[i] for i in chunk], counts))
        )
        if stack.shape != (total,) + F0s.shape[1:]:
            raise ValueError("a stacked group read to another shape")
        found, offset = [], 0
        for i in chunk:
            F0, count = F0s[i], repeats[i]
            if not count:
                found.append((F0, (np.zeros(0, int), np.zeros(0, int), np.zeros(0))))
                continue
            dense = (stack[offset : offset + count] - F0).reshape(count, -1).T
            where = _blocks._columns_of(tuple(span for _, span in read_spans[i]))
            rows, slots = np.nonzero(dense)
            found.append((F0, (rows, where[slots], dense[rows, slots])))
            offset += count
        return found

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

    def _stacked_values(self, v, values, active) -> list:
        """Per active inequality, its matrix at the point from its group's
        stacked evaluation (`LMIProblem.add`, ``stacked``), or None (to be
        evaluated alone).

        A group's stacked matrices are kept only where every member's
        agrees with its map at the point, ``F0 + M x`` (read at these
        parameter values): a block function that broadcasts wrongly over
        the stack is caught by a reading of another kind, and evaluated
        alone.
        """
        found: list = [None] * len(active)
        groups: dict = {}
        for i, (name, _, _, _) in enumerate(active):
            member = self._stacked.get(name)
            if member is not None:
                groups.setdefault(id(member[0]), (member[0], []))[1].append(
                    (i, name, member[1])
                )
        if not groups:
            return found
        x = self._point_vector(values)
        if x is None:
            return found
        encoded = {p: value.tobytes() for p, value in self._numeric().items()}
        for group, members in groups.values():
            try:
                stack = _blocks.assemble(group(v))
            except (ValueError, TypeError, IndexError):
                logger.debug("a stacked group of LMIs does not evaluate stacked")
                continue
            if stack.ndim != 3 or stack.shape[0] <= max(k for *_, k in members):
                continue
            ks = [k for *_, k in members]
            maps = [self._kept_map(name, encoded) for _, name, _ in members]
            if any(piece is None or piece[0].shape != stack.shape[1:]
                   for piece in maps):  # fmt: skip
                continue
            expected, scale = _mapped(maps, x)
            matrices = stack[ks]
            error = np.abs(matrices - expected).max(axis=(1, 2))
            if not np.all(error <= _STACK_TOLERANCE * scale):
                logger.debug("stacked values of LMIs differ from their maps")
                continue
            for (i, _, _), F in zip(members, matrices):
                found[i] = F
        return found

    def _point_vector(self, values):
        """The vector of free entries of `values` (None if one is missing)."""
        parts = []
        for name, var in self._vars.items():
            if name not in values:
                return None
            value = np.asarray(values[name], float)
            if var.symmetric:
                parts.append(value[np.triu_indices(var.shape[0])])
            else:
                parts.append(value.ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def _kept_map(self, name, encoded):
        """An inequality's map kept for the current parameter values, or
        None."""
        read = self._reads.get(name)
        if read is None:
            return None
        return self._columns.get(name, {}).get(_key(read, encoded))

    def _values(self, x) -> dict[str, np.ndarray]:
        """The variables' values from the vector of free entries."""
        values, offset = {}, 0
        for name, points in self._units().items():
            k = len(points)
            values[name] = np.tensordot(x[offset : offset + k], points, axes=1)
            offset += k
        return values


def _mapped(maps, x):
    """``F0 + M x`` of each of a list of maps (`_pieces`) of matrices of one
    size, stacked, and each one's scale ``sum |F0| + sum |M_k x_k|``."""
    size = maps[0][0].size
    F0 = np.stack([F0 for F0, _ in maps])
    rows = np.concatenate([rows + k * size for k, (_, (rows, _, _)) in enumerate(maps)])
    cols = np.concatenate([cols for _, (_, cols, _) in maps])
    data = np.concatenate([data for _, (_, _, data) in maps])
    terms = data * x[cols]
    total = len(maps) * size
    mapped = F0.reshape(-1) + np.bincount(rows, terms, minlength=total)
    scale = np.abs(F0).reshape(len(maps), -1).sum(axis=1) + np.bincount(
        rows // size, np.abs(terms), minlength=len(maps)
    )
    return mapped.reshape(F0.shape), scale


def _key(read, encoded) -> tuple:
    """The values of the parameters among `read` (`encoded`: each
    parameter's bytes), as a dictionary key."""
    return tuple((p, encoded[p]) for p in _sorted(read) if p in encoded)


@functools.lru_cache(maxsize=4096)
def _sorted(read: frozenset) -> tuple:
    # Kept: every reading asks again for each inequality's key.
    return tuple(sorted(read))
