"""Block matrices of LMIs in float64, and their affine maps.

An LMI is written once, as a block function of its variables that returns
the lower block triangle (`assemble`). The block functions are only ever
evaluated on float64 values: at the returned point (the certificate), and
at the unit points of the variables, which give the affine map ``x ->
F(x)`` that the conic backends pose (`columns`).

`columns` reads the map in one evaluation per variable: a variable's unit
points are stacked along a leading axis (`Batch`, whose ``.T`` and
indexing act on the trailing axes), which numpy broadcasts through the
products and sums of a block function. A block function written for one
point may still not broadcast (a concatenation along a fixed axis, say):
the batched map is therefore checked against a direct evaluation at a
random point, and read one unit point at a time when it does not agree.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

__all__ = ["Recording", "assemble", "columns", "normalized_max_eig", "unit_points"]

# A batched map must reproduce a direct evaluation at a random point to
# this relative accuracy (rounding of a few products and sums).
_BATCH_TOLERANCE = 1e-10


def _sizes(blocks):
    sizes = []
    for i, row in enumerate(blocks):
        shape = np.shape(row[i])
        if len(shape) < 2 or shape[-1] != shape[-2]:
            raise ValueError(f"block ({i}, {i}) must be a square matrix, got {shape}")
        sizes.append(shape[-1])
    return sizes


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
        Blocks may carry leading (stack) axes, broadcast together.

    Returns
    -------
    ndarray
    """
    sizes = _sizes(blocks)
    lead = np.broadcast_shapes(
        *(np.shape(b)[:-2] for row in blocks for b in row if np.ndim(b) > 2)
    )

    def block(i, j):
        item = blocks[i][j] if j <= i else blocks[j][i]
        if isinstance(item, (int, float)) and item == 0:
            return np.zeros(lead + (sizes[i], sizes[j]))
        item = np.asarray(item, float)
        if j > i:
            item = np.swapaxes(item, -1, -2)
        return np.broadcast_to(item, lead + (sizes[i], sizes[j]))

    if len(blocks) == 1:
        full = block(0, 0)
    else:
        full = np.concatenate(
            [
                np.concatenate([block(i, j) for j in range(len(blocks))], axis=-1)
                for i in range(len(blocks))
            ],
            axis=-2,
        )
    return 0.5 * (full + np.swapaxes(full, -1, -2))


def normalized_max_eig(M) -> float:
    """Largest ``lambda_max(D M D)`` over a stack, ``D = |diag M|^-1/2``.

    The Jacobi normalisation makes the test scale-free; a nonnegative
    diagonal entry (no strict inequality possible) gives ``inf``.
    """
    diag = np.diagonal(M, axis1=1, axis2=2)
    if not np.all(diag < 0):
        return float("inf")
    d = 1.0 / np.sqrt(-diag)
    return float(np.linalg.eigvalsh(M * d[:, :, None] * d[:, None, :])[:, -1].max())


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

    Transposition and indexing act on the trailing axes (the value), so a
    block function written for one value evaluates the whole stack; an
    indexed scalar keeps two trailing axes of size 1, so that it scales the
    matrices it multiplies.
    """

    @property
    def T(self):  # noqa: N802 (numpy's name)
        if self.ndim <= 2:
            return self
        return np.swapaxes(self, -1, -2)

    def __getitem__(self, index):
        if not isinstance(index, tuple):
            index = (index,)
        if any(i is Ellipsis or i is None for i in index):
            raise IndexError("a Batch takes plain indices")
        out = np.asarray(self)[(slice(None),) + index]
        if out.ndim == 1:
            out = out[:, None, None]
        return out.view(Batch)


def _direct(evaluate, read, units, x):
    values, offset = {}, 0
    for name, points in units.items():
        if name in read and len(points):
            k = len(points)
            values[name] = np.tensordot(x[offset : offset + k], points, axes=1)
        offset += len(points)
    return evaluate(values)


def columns(evaluate, F0, read, units, rng=None) -> tuple:
    """The columns of one inequality ``F(x) = F0 + sum_k x_k M_k``.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(values)`` is the float64 matrix ``F`` with the variables
        of `values` set and every other variable zero.
    F0 : ndarray
        ``evaluate({})``.
    read : set of str
        The variables the block function reads; the others get no columns.
    units : dict of str to ndarray
        Per variable, in column order, its stacked unit points
        (`unit_points`).
    rng : numpy.random.Generator, optional
        For the point that checks a batched evaluation; ``None`` reads the
        map one unit point at a time, without batching.

    Returns
    -------
    tuple
        ``(rows, cols, data)`` of the nonzero entries of ``M`` (rows: the
        entries of ``vec F`` in C order), column indices counted over all
        variables of `units` in their order.
    """
    pieces = _batched(evaluate, F0, read, units) if rng is not None else None
    if pieces is not None:
        x = np.zeros(sum(len(p) for p in units.values()))
        for name, (start, stop) in _spans(units).items():
            if name in read:
                x[start:stop] = rng.standard_normal(stop - start)
        rows, cols, data = pieces
        expected = F0.ravel().copy()
        np.add.at(expected, rows, data * x[cols])
        actual = _direct(evaluate, read, units, x).ravel()
        scale = np.abs(F0).sum() + np.abs(data * x[cols]).sum() + 1.0
        if np.abs(actual - expected).max() <= _BATCH_TOLERANCE * scale:
            return pieces
    return _one_by_one(evaluate, F0, read, units)


def _spans(units):
    spans, offset = {}, 0
    for name, points in units.items():
        spans[name] = (offset, offset + len(points))
        offset += len(points)
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
    found = []
    try:
        for name, (start, stop) in _spans(units).items():
            if name not in read or stop == start:
                continue
            stack = evaluate({name: units[name].view(Batch)})
            if np.shape(stack) != (stop - start,) + F0.shape:
                return None
            dense = (np.asarray(stack) - F0).reshape(stop - start, -1).T
            found.append((start, dense))
    except (ValueError, TypeError, IndexError):
        return None
    return _collect(found)


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
