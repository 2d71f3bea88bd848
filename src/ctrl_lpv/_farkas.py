"""The numerics of `ctrl_lpv.lmi.LMIProblem.farkas`, vectorised.

The active inequalities ``F_i(x) <= 0`` of a stage are affine in the free
entries ``x`` of the variables: ``F_i(x) = F_i(0) + sum_k x_k M_k^(i)``.
`AffineMap` stacks them: ``vec F_i(0)`` one after another in `base`, and
the columns ``vec M_k^(i)`` in one sparse matrix ``M`` (rows: the stacked
entries of every ``F_i``, columns: the free entries of the variables), read
off the block functions themselves one free entry at a time (`columns`).

A dual point ``Y = (Y_1, ..., Y_q)`` is a vector ``y`` of the same stacked
layout. `AffineMap.polish` alternates the projection on the PSD cone (one
batched ``eigh`` per LMI size) with the projection on the null space of the
adjoint ``y -> M' y``, whose pseudo-inverse Gram matrix is factored once;
`AffineMap.bound` evaluates the certificate with bounds on its rounding.
Nothing here decides what a certificate proves: `ctrl_lpv.lmi` does.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

EPS = np.finfo(float).eps
# Alternating projections per dual point (PSD cone, null space of M').
REFINEMENTS = 200


def _gamma(n):
    """Higham's ``gamma_n = n u / (1 - n u)`` (``u`` the unit roundoff)."""
    nu = np.asarray(n, float) * (EPS / 2)
    return nu / (1.0 - nu)


def columns(evaluate, F0, read, units) -> tuple:
    """The columns of one inequality, read off its block function.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(values)`` is the float64 matrix ``F_i`` with the variables
        of `values` set and every other variable zero.
    F0 : ndarray
        ``evaluate({})``.
    read : set of str
        The variables the block function reads; the others get no columns.
    units : dict of str to list of ndarray
        Per variable, in column order, its unit points (one per free
        entry).

    Returns
    -------
    tuple
        ``(rows, cols, data)`` of the nonzero entries of ``M_i``, column
        indices counted over all variables of `units` in their order.
    """
    rows, cols, data = [], [], []
    offset = 0
    for name, points in units.items():
        if name in read and points:
            dense = np.column_stack(
                [(evaluate({name: E}) - F0).ravel() for E in points]
            )
            r, c = np.nonzero(dense)
            rows.append(r)
            cols.append(c + offset)
            data.append(dense[r, c])
        offset += len(points)
    if not rows:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    return np.concatenate(rows), np.concatenate(cols), np.concatenate(data)


def stacked(pieces, nfree) -> AffineMap:
    """`AffineMap` of inequalities given as ``(F0, (rows, cols, data))``."""
    sizes, bases, rows, cols, data = [], [], [], [], []
    row0 = 0
    for F0, (r, c, x) in pieces:
        sizes.append(F0.shape[0])
        bases.append(F0.ravel())
        rows.append(r + row0)
        cols.append(c)
        data.append(x)
        row0 += F0.size
    if not pieces:
        return AffineMap(np.zeros(0, int), np.zeros(0), sp.csr_array((0, nfree)))
    M = sp.csr_array(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
        shape=(row0, nfree),
    )
    return AffineMap(np.asarray(sizes, int), np.concatenate(bases), M)


class AffineMap:
    """Stacked inequalities ``vec F_i(x) = base_i + M_i x`` (module doc).

    Parameters
    ----------
    sizes : ndarray of int
        Size of each ``F_i``.
    base : ndarray
        ``vec F_i(0)`` (row-major), stacked.
    M : scipy.sparse array
        ``vec(F_i(x) - F_i(0)) = M_i x``, stacked by rows.
    """

    def __init__(self, sizes, base, M):
        self.sizes = np.asarray(sizes, int)
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes**2)]).astype(int)
        self.base = np.asarray(base, float)
        self.M = sp.csr_array(M)
        self.MT = self.M.T.tocsr()
        self.nfree = self.M.shape[1]
        self._restricted: dict[bytes, AffineMap] = {}
        owner = np.repeat(np.arange(self.sizes.size), self.sizes**2)
        self._owner = owner
        nlmi = self.sizes.size
        absM = abs(self.M)
        # Per inequality: sum |F_i(0)| and sum |M_i| (the rounding bounds).
        self.abs_base_sums = np.bincount(owner, np.abs(self.base), minlength=nlmi)
        row_sums = np.asarray(absM.sum(axis=1)).ravel()
        self.abs_M_sums = np.bincount(owner, row_sums, minlength=nlmi)
        self._absMT = absM.T.tocsr()
        self._column_terms = np.diff(self._absMT.indptr)  # terms of each g_j
        # Index arrays of the stacked layout: transposition, diagonals, and
        # the entries of the inequalities of each size (batched eigh).
        transpose, diagonal = [], []
        groups: dict[int, list] = {}
        for i, d in enumerate(self.sizes):
            start = self.offsets[i]
            local = np.arange(d * d).reshape(d, d)
            transpose.append(start + local.T.ravel())
            diagonal.append(start + np.diag(local))
            groups.setdefault(int(d), []).append(i)
        self._transpose = np.concatenate(transpose) if transpose else np.zeros(0, int)
        self._diagonal = np.concatenate(diagonal) if diagonal else np.zeros(0, int)
        self._groups = [
            (
                d,
                np.array(members),
                np.concatenate(
                    [np.arange(self.offsets[i], self.offsets[i + 1]) for i in members]
                ),
            )
            for d, members in groups.items()
            if d > 0
        ]
        # c = gram^+ g, as numpy's lstsq on the Gram matrix M'M would give
        # (singular values below eps * nfree * the largest dropped).
        if self.nfree:
            gram = (self.MT @ self.M).toarray()
            s, U = np.linalg.eigh(gram)
            keep = s > EPS * self.nfree * max(float(s.max()), 0.0)
            self._pinv = (U[:, keep] / s[keep]) @ U[:, keep].T
        else:
            self._pinv = np.zeros((0, 0))

    @property
    def count(self) -> int:
        """Number of inequalities."""
        return int(self.sizes.size)

    def restrict(self, keep) -> AffineMap:
        """The map of the inequalities where `keep` (a boolean mask) is set."""
        keep = np.asarray(keep, bool)
        key = keep.tobytes()
        if key not in self._restricted:
            rows = np.flatnonzero(keep[self._owner])
            self._restricted[key] = AffineMap(
                self.sizes[keep], self.base[rows], self.M[rows]
            )
        return self._restricted[key]

    def stack(self, matrices) -> np.ndarray:
        """Stacked vector of one symmetric matrix per inequality."""
        parts = []
        for Y, d in zip(matrices, self.sizes):
            Y = np.asarray(Y, float).reshape(d, d)
            parts.append((0.5 * (Y + Y.T)).ravel())
        return np.concatenate(parts) if parts else np.zeros(0)

    def nonzero(self, y) -> np.ndarray:
        """Whether each inequality's block of `y` has a nonzero entry."""
        return np.bincount(self._owner, y != 0, minlength=self.count) > 0

    def psd_part(self, y) -> np.ndarray:
        """Projection of every block of `y` on the PSD cone."""
        out = np.zeros_like(y)
        for d, _, index in self._groups:
            lam, V = np.linalg.eigh(y[index].reshape(-1, d, d))
            lam = np.clip(lam, 0.0, None)
            out[index] = ((V * lam[:, None, :]) @ V.transpose(0, 2, 1)).ravel()
        return out

    def trace(self, y) -> float:
        """``sum_i tr Y_i``."""
        return float(y[self._diagonal].sum())

    def slope(self, y) -> np.ndarray:
        """``g = M' y``: the gradient of ``sum_i <F_i(x), Y_i>``."""
        return self.MT @ y

    def polish(self, y) -> np.ndarray | None:
        """Alternating projections from `y`; None if the trace vanishes.

        Each round projects every block on the PSD cone, scales to
        ``sum tr Y_i = 1``, then takes the smallest change of ``y`` that
        zeroes ``g = M' y`` (``y - M (M'M)^+ g``, symmetrised). The
        projections converge linearly: they stop when ``||g||`` falls by
        less than 0.1 % or reaches ``1e3 eps``, after at most `REFINEMENTS`
        rounds. The result is PSD-projected and scaled once more.
        """
        slope_before = np.inf
        for _ in range(REFINEMENTS):
            y = self.psd_part(y)
            total = self.trace(y)
            if not total > 0:
                break
            y = y / total
            g = self.slope(y)
            slope = float(np.linalg.norm(g))
            if slope > 0.999 * slope_before or slope < 1e3 * EPS:
                break
            slope_before = slope
            y = y - self.M @ (self._pinv @ g)
            y = 0.5 * (y + y[self._transpose])
        y = self.psd_part(y)
        total = self.trace(y)
        if not total > 0:
            return None
        return y / total

    def bound(self, y) -> tuple[float, float]:
        """``(b - b_err, ||g|| + g_err)`` of ``sum_i <F_i(x), Y_i> = b + g'x``.

        The rounding bounds are those of the entry-by-entry evaluation:
        per inequality, ``10 d_i eps max|Y_i|`` times ``sum |F_i(0)|`` (for
        ``b``) and times ``sum |M_i|`` (for ``g``); to them are added the
        worst-case bounds ``gamma_n sum |a_k| |y_k|`` of the float64 sums
        that compute ``b`` and every entry of ``g`` (``n`` their number of
        terms), and of the norm.
        """
        abs_y = np.abs(y)
        largest = np.zeros(self.count)
        for d, members, index in self._groups:
            largest[members] = abs_y[index].reshape(-1, d * d).max(axis=1)
        scale = 10 * self.sizes * EPS * largest
        b = float(self.base @ y)
        b_err = float(scale @ self.abs_base_sums)
        b_err += 1.01 * float(_gamma(y.size) * (np.abs(self.base) @ abs_y))
        g = self.slope(y)
        g_err = float(scale @ self.abs_M_sums)
        sums = _gamma(self._column_terms) * (self._absMT @ abs_y)
        g_err += 1.01 * float(np.linalg.norm(sums))
        norm = float(np.linalg.norm(g)) * (1 + 1.01 * float(_gamma(g.size + 2)))
        return b - b_err, norm + g_err

    def block_slopes(self, y, groups) -> list[float | None]:
        """Bounds on ``||g_v||_2`` for column groups ``v`` of ``g = M' y``.

        `groups` are slices of the columns (one per variable). Each bound
        carries the whole rounding bound of `bound` (the evaluation's and
        the sums' of every entry of ``g``), so it holds whatever part of
        the error falls in the group. A group that no inequality with a
        nonzero block of `y` reads (no nonzero entry of ``M`` in its rows)
        gets None: such a variable does not enter those ``F_i`` at all.
        """
        abs_y = np.abs(y)
        largest = np.zeros(self.count)
        for d, members, index in self._groups:
            largest[members] = abs_y[index].reshape(-1, d * d).max(axis=1)
        scale = 10 * self.sizes * EPS * largest
        g = self.slope(y)
        sums = _gamma(self._column_terms) * (self._absMT @ abs_y)
        rows = self.nonzero(y)[self._owner].astype(float)
        read = (self._absMT @ rows) > 0
        evaluation = float(scale @ self.abs_M_sums)
        out: list[float | None] = []
        for group in groups:
            if not np.any(read[group]):
                out.append(None)
                continue
            norm = float(np.linalg.norm(g[group]))
            norm *= 1 + 1.01 * float(_gamma(g[group].size + 2))
            out.append(norm + evaluation + 1.01 * float(np.linalg.norm(sums[group])))
        return out

    def evaluation_bounds(self, y) -> tuple[int, float, float]:
        """Size and entry sums of the inequalities that `y` weighs.

        ``(d, base, spread)``: the largest size, ``max sum |F_i(0)|`` and
        ``max sum |M_i|`` over the inequalities with a nonzero block of `y`,
        so that ``||F_i(x)||_2 <= base + spread ||x||_2`` for each of them
        (the rounding of a float64 check of ``F_i`` scales with it).
        """
        used = self.nonzero(y)
        if not used.any():
            return 0, 0.0, 0.0
        return (
            int(self.sizes[used].max()),
            float(self.abs_base_sums[used].max()),
            float(self.abs_M_sums[used].max()),
        )
