"""Block matrices of LMIs in float64, and their affine maps.

An LMI is written once, as a block function of its variables that returns
the lower block triangle (`assemble`). The block functions are only ever
evaluated on float64 values: at the returned point (the certificate), and
at the unit points of the variables, which give the affine map ``x ->
F(x)`` that the conic backends pose (`columns`).

`columns` reads the map in one evaluation: the unit points of the
variables are stacked along a leading axis (`Batch`, whose ``.T``,
indexing and a few numpy functions act on the trailing axes), which numpy
broadcasts through the products and sums of a block function. A block
function written for one point may still not broadcast (an operation on
fixed axes, say): every batched map is therefore checked against a direct
evaluation at a random point, and read one unit point at a time when it
does not agree (logged at DEBUG on ``ctrl_lpv.lmi``). The check is not
skipped for a block function that passed it before: the same code with
other data may take another branch.
"""

from __future__ import annotations

import functools
import itertools
import logging
from types import SimpleNamespace

import numpy as np

logger = logging.getLogger("ctrl_lpv.lmi")

__all__ = [
    "Recording",
    "assemble",
    "columns",
    "diagonal",
    "normalized_max_eig",
    "normalized_max_eigs",
    "quadratic_rows",
    "size",
    "total",
    "unit_points",
]

# A batched map must reproduce a direct evaluation at a random point to
# this relative accuracy (rounding of a few products and sums).
_BATCH_TOLERANCE = 1e-10


def _shape(b):
    # An array's own shape (a `Batch`'s with its stack axis) without numpy's
    # dispatch: read for every block of every evaluation.
    return b.shape if isinstance(b, np.ndarray) else np.shape(b)


def _sizes(blocks):
    sizes = []
    for i, row in enumerate(blocks):
        shape = _shape(row[i])
        if len(shape) < 2 or shape[-1] != shape[-2]:
            raise ValueError(f"block ({i}, {i}) must be a square matrix, got {shape}")
        sizes.append(shape[-1])
    return sizes


def size(blocks) -> int:
    """The size of the matrix `assemble` makes of `blocks` (without making
    it)."""
    return sum(_sizes(blocks))


def assemble(blocks):
    """Symmetric matrix ``(M + M') / 2`` from the lower block triangle of ``M``.

    Only the symmetric part is ever used, so a diagonal block may be given
    as ``2 Q`` for ``Q + Q'``.

    Parameters
    ----------
    blocks : sequence of sequences
        Row ``i`` holds blocks ``(i, 0), ..., (i, i)``; entries above the
        diagonal may be omitted or ``None`` (symmetric completion). A scalar
        ``0`` is a zero block of the size implied by the diagonal blocks.
        Blocks may carry a leading stack axis (`Batch`).

    Returns
    -------
    ndarray
    """
    sizes = _sizes(blocks)
    stacks = [shape[0] for row in blocks for shape in map(_shape, row)
              if len(shape) > 2]  # fmt: skip
    lead = (max(stacks),) if stacks else ()
    ends = list(itertools.accumulate(sizes))
    starts = [0] + ends[:-1]
    # Each block written into its place (the zero blocks left as they are):
    # one array, no concatenation.
    full = np.zeros(lead + (ends[-1], ends[-1]))
    for i, row in enumerate(blocks):
        for j in range(i + 1):
            item = row[j]
            if isinstance(item, (int, float)) and item == 0:
                continue
            item = np.asarray(item, float)
            shape = (sizes[i], sizes[j])
            if (
                item.shape[-2:] != shape
                or item.ndim not in (2, 2 + len(lead))
                or (item.ndim == 3 and item.shape[0] != lead[0])
            ):
                raise ValueError(
                    f"block ({i}, {j}) must have shape {shape}, got {item.shape}"
                )
            full[..., starts[i] : ends[i], starts[j] : ends[j]] = item
            if j < i:
                full[..., starts[j] : ends[j], starts[i] : ends[i]] = item.swapaxes(
                    -1, -2
                )
    return 0.5 * (full + full.swapaxes(-1, -2))


def _like(v, out):
    """`out` as a `Batch` when `v` is one."""
    return out.view(Batch) if isinstance(v, Batch) else out


def diagonal(v):
    """``diag(v)`` of a vector (a column is read as a vector), stack-aware."""
    d = np.asarray(v, float)
    if not isinstance(v, Batch):
        d = d.reshape(-1)
    elif d.ndim == 3:  # a stack of columns
        d = d[:, :, 0]
    return _like(v, d[..., :, None] * np.eye(d.shape[-1]))


def total(v):
    """The sum of a vector's entries as a 1 x 1 matrix, stack-aware."""
    d = np.asarray(v, float)
    if isinstance(v, Batch):
        return _like(v, d.reshape(d.shape[0], -1).sum(axis=1)[:, None, None])
    return np.array([[d.sum()]])


def quadratic_rows(C, W):
    """``diag(C W C')`` as a diagonal matrix, stack-aware in ``W``."""
    rows = np.einsum("ij,...jk,ik->...i", C, np.asarray(W, float), C)
    return _like(W, rows[..., :, None] * np.eye(C.shape[0]))


def normalized_max_eig(M) -> float:
    """Largest ``lambda_max(D M D)`` over a stack, ``D = |diag M|^-1/2``.

    The Jacobi normalisation makes the test scale-free; a nonnegative
    diagonal entry (no strict inequality possible) gives ``inf``.
    """
    return float(normalized_max_eigs(M).max())


def normalized_max_eigs(M) -> np.ndarray:
    """`normalized_max_eig` of each matrix of a stack (``inf`` where a
    diagonal entry is nonnegative)."""
    diag = np.diagonal(M, axis1=1, axis2=2)
    out = np.full(len(M), np.inf)
    ok = np.all(diag < 0, axis=1)
    if ok.any():
        d = 1.0 / np.sqrt(-diag[ok])
        out[ok] = np.linalg.eigvalsh(M[ok] * d[:, :, None] * d[:, None, :])[:, -1]
    return out


def unit_points(shape, symmetric: bool) -> np.ndarray:
    """The unit points of a variable, stacked: one per free entry.

    A symmetric variable's free entries are its upper triangle, row by row
    (``np.triu_indices``); another variable's are its entries in C order.
    """
    if symmetric:
        n = shape[0]
        a, b = np.triu_indices(n)
        E = np.zeros((a.size, n, n))
        E[np.arange(a.size), a, b] = 1.0
        E[np.arange(a.size), b, a] = 1.0
        return E
    size = int(np.prod(shape))
    return np.eye(size).reshape((size,) + tuple(shape))


class Batch(np.ndarray):
    """Values of one variable stacked along a leading axis.

    Transposition, indexing and the numpy functions of `_BATCHED` act on
    the trailing axes (the value), so a block function written for one
    value evaluates the whole stack; an indexed scalar keeps two trailing
    axes of size 1, so that it scales the matrices it multiplies. Other
    numpy functions raise ``TypeError`` (and the map is read one unit
    point at a time).
    """

    @property
    def T(self):  # noqa: N802 (numpy's name)
        if self.ndim <= 2:
            return self
        return np.asarray(self).swapaxes(-1, -2).view(Batch)

    def trace(self, *args, **kwargs):
        if args or kwargs or self.ndim != 3:
            raise TypeError("trace: only the trace of matrices is batched")
        return _trace(self)

    def __getitem__(self, index):
        if not isinstance(index, tuple):
            index = (index,)
        if any(i is Ellipsis or i is None for i in index):
            raise IndexError("a Batch takes plain indices")
        out = np.asarray(self)[(slice(None),) + index]
        if out.ndim == 1:
            out = out[:, None, None]
        return out.view(Batch)

    def __array_function__(self, func, types, args, kwargs):
        if func in _QUERIES:  # of the array as it is, stack axis included
            return func(*(np.asarray(a) for a in args), **kwargs)
        batched = _BATCHED.get(func)
        if batched is None:
            raise TypeError(f"{func.__name__} is not batched")
        return batched(*args, **kwargs)


def _lead(arrays):
    """The stack size of the Batch arrays among `arrays`."""
    return next(a.shape[0] for a in arrays if isinstance(a, Batch))


def _stacked(arrays, ndim=2):
    """Every array with the leading stack axis (constants broadcast)."""
    k = _lead(arrays)
    out = []
    for a in arrays:
        if isinstance(a, Batch):
            out.append(np.asarray(a))
        else:
            a = np.asarray(a, float)
            out.append(np.broadcast_to(a, (k,) + a.shape))
    return out


def _concatenate(arrays, axis=0):
    if axis is None or not -2 <= axis < 2:
        raise TypeError("concatenate: only axes of a matrix are batched")
    if any(np.ndim(a) != 2 + isinstance(a, Batch) for a in arrays):
        raise TypeError("concatenate: only matrices are batched")
    axis = axis + 1 if axis >= 0 else axis
    return np.concatenate(_stacked(arrays), axis=axis).view(Batch)


def _kron(a, b):
    a, b = _stacked([a, b])
    k = a.shape[0]
    out = np.einsum("kij,kab->kiajb", a, b)
    return out.reshape(k, a.shape[1] * b.shape[1], a.shape[2] * b.shape[2]).view(Batch)


def _diag(v, k=0):
    if k != 0 or np.ndim(v) != 3:
        raise TypeError("diag: only the diagonal of matrices is batched")
    return np.diagonal(np.asarray(v), axis1=1, axis2=2).view(Batch)


def _trace(a):
    if np.ndim(a) != 3:
        raise TypeError("trace: only matrices are batched")
    return np.trace(np.asarray(a), axis1=1, axis2=2)[:, None, None].view(Batch)


_QUERIES = frozenset({np.shape, np.ndim, np.size})
_BATCHED = {
    np.concatenate: _concatenate,
    np.hstack: lambda arrays: _concatenate(arrays, axis=1),
    np.vstack: lambda arrays: _concatenate(arrays, axis=0),
    np.kron: _kron,
    np.diag: _diag,
    np.trace: _trace,
}


def columns(
    evaluate, F0, read, units, batched=True, trusted=False, on_checked=None
) -> tuple:
    """The columns of one inequality ``F(x) = F0 + sum_k x_k M_k``.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(values)`` is the float64 matrix ``F`` with the variables
        of `values` set and every other variable zero.
    F0 : ndarray or None
        ``evaluate({})``; None: read it too, as one more (zero) point of
        the batched evaluation (one evaluation less per inequality; the
        random-point check covers it).
    read : set of str
        The variables the block function reads; the others get no columns.
    units : dict of str to ndarray
        Per variable, in column order, its stacked unit points
        (`unit_points`).
    batched : bool, optional
        Read in one batched evaluation, checked at a random point (True),
        or one unit point at a time.
    trusted : bool, optional
        Skip the random-point check of a batched reading: for a block
        function whose batched reading passed it before (the check is of
        the function's code path, which does not depend on the numbers;
        the point the solver returns is checked in float64 anyway).
    on_checked : callable, optional
        Called without arguments when a batched reading passed its
        random-point check.

    Returns
    -------
    F0 : ndarray
    tuple
        ``(rows, cols, data)`` of the nonzero entries of ``M`` (rows: the
        entries of ``vec F`` in C order), column indices counted over all
        variables of `units` in their order.
    """
    pieces = _batched(evaluate, F0, read, units) if batched else None
    if pieces is not None and trusted:
        return pieces
    if pieces is not None:
        F0, pieces = pieces
        # Every variable at one random point (those not read change nothing
        # of a function that reads only `read`; one that reads more fails).
        x, values = _probe(units)
        rows, cols, data = pieces
        expected = F0.ravel().copy()
        np.add.at(expected, rows, data * x[cols])
        actual = np.asarray(evaluate(values)).ravel()
        # Relative to the size of the terms: a map of small entries gets no
        # absolute allowance.
        scale = np.abs(F0).sum() + np.abs(data * x[cols]).sum()
        if np.abs(actual - expected).max() <= _BATCH_TOLERANCE * scale:
            if on_checked is not None:
                on_checked()
            return F0, pieces
        logger.debug("batched map of an LMI rejected at a random point")
        F0 = None  # perhaps read wrongly with the rest
    elif batched:
        logger.debug("an LMI does not evaluate batched: read point by point")
    if F0 is None:
        F0 = evaluate({})
    return F0, _one_by_one(evaluate, F0, read, units)


# The spans of the last `units` seen: a reading passes the same dict for
# every inequality (`ctrl_lpv.lmi.reading`), so they are counted once.
_last_spans: list = [None, None]


# The random point of the last `units` seen (`_probe`), for the same reason.
_last_probe: list = [None, None]


def _probe(units):
    """A random value of every variable of `units`: the vector of its free
    entries and the variables' values."""
    if _last_probe[0] is not units:
        rng = np.random.default_rng(20261202)
        x = rng.standard_normal(sum(len(p) for p in units.values()))
        values, offset = {}, 0
        for name, points in units.items():
            k = len(points)
            if k:
                values[name] = (x[offset : offset + k] @ points.reshape(k, -1)).reshape(
                    points.shape[1:]
                )
            offset += k
        _last_probe[:] = [units, (x, values)]
    return _last_probe[1]


def _spans(units):
    if _last_spans[0] is units:
        return _last_spans[1]
    spans, offset = {}, 0
    for name, points in units.items():
        spans[name] = (offset, offset + len(points))
        offset += len(points)
    _last_spans[:] = [units, spans]
    return spans


def _collect(blocks_of):
    rows, cols, data = [], [], []
    for offset, dense in blocks_of:
        r, c = np.nonzero(dense)
        rows.append(r)
        cols.append(c + offset)
        data.append(dense[r, c])
    if not rows:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(data)


def _batched(evaluate, F0, read, units):
    """``(F0, columns)`` in one evaluation: the stack holds every unit point
    of every variable read, each variable zero outside its own slots (and,
    when `F0` is None, first the zero point, which gives ``F0``)."""
    spans = [(name, span) for name, span in _spans(units).items()
             if name in read and span[1] > span[0]]  # fmt: skip
    total = sum(stop - start for _, (start, stop) in spans)
    if not total:
        return (evaluate({}) if F0 is None else F0), _collect([])
    first = int(F0 is None)
    values, slot = {}, first
    for name, _ in spans:
        points = units[name]
        stack = np.zeros((first + total,) + points.shape[1:])
        stack[slot : slot + len(points)] = points
        values[name] = stack.view(Batch)
        slot += len(points)
    try:
        stack = np.asarray(evaluate(values))
    except (ValueError, TypeError, IndexError):
        return None
    if stack.ndim != 3 or stack.shape[0] != first + total:
        return None
    if F0 is None:
        F0 = stack[0].copy()
    elif stack.shape[1:] != F0.shape:
        return None
    dense = (stack[first:] - F0).reshape(total, -1).T
    # Slot of the stack -> column of the map, for one nonzero() of it all.
    where = _columns_of(tuple(span for _, span in spans))
    rows, slots = np.nonzero(dense)
    return F0, (rows, where[slots], dense[rows, slots])


@functools.lru_cache(maxsize=256)
def _columns_of(spans):
    """The columns of the map of the stack's slots (`_batched`), kept: the
    same few sets of spans recur for every inequality of a problem."""
    where = np.concatenate([np.arange(start, stop) for start, stop in spans])
    where.flags.writeable = False
    return where


def _one_by_one(evaluate, F0, read, units):
    found = []
    for name, (start, stop) in _spans(units).items():
        if name in read and stop > start:
            dense = np.column_stack(
                [(evaluate({name: E}) - F0).ravel() for E in units[name]]
            )
            found.append((start, dense))
    return _collect(found)


class Recording(SimpleNamespace):
    """A namespace that adds to ``_read`` the names looked up in it."""

    def __init__(self, values, read: set):
        super().__init__(**values)
        object.__setattr__(self, "_read", read)

    def __getattribute__(self, name):
        if name == "__dict__" or not name.startswith("_"):
            object.__getattribute__(self, "_read").add(name)
        return object.__getattribute__(self, name)
