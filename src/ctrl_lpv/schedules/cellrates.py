"""Lyapunov matrices multilinear on grid cells, and their rate terms.

A matrix ``P(p)`` with values ``P_g`` at the points of a
`ctrl_lpv.systems.grid.ParameterGrid`, multilinear on each cell, is
continuous across cells. On a cell of widths ``h``, ``dw_a/dp_d`` is
``+-(w_a + w_a')/h_d`` (``a'`` the corner across axis ``d``), so ``dP/dt
= sum_a w_a D_a`` with ``D_a = sum_d (dp_d/dt) (P_a+ - P_a-) / h_d``, the
difference of ``P`` along the cell's edge through corner ``a``: linear in
the multilinear weights ``w`` and affine in the rates, so conditions affine
in ``dP/dt`` hold on the rate box when they hold at its vertices.

A parameter whose rate is unbounded gets no dependence: the ``P_g`` of the
points that differ only in it are one variable (`lyapunov_index`), its
edges' differences vanish and its rate drops out.

Both `certify` (``P`` in the primal inequalities) and the rate-bounded
synthesis on grids (``X = P^-1`` in the dual ones) use this module.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["CellRates", "lyapunov_index"]


def lyapunov_index(grid, unbounded=()) -> np.ndarray:
    """Index of the Lyapunov matrix at each grid point, ``(N,)``.

    Points that differ only along the axes in `unbounded` share one index
    (the matrix does not depend on those parameters).
    """
    multi = np.array(np.unravel_index(np.arange(len(grid.points)), grid.shape))
    multi[list(unbounded)] = 0
    return np.ravel_multi_index(multi, grid.shape)


@dataclass(frozen=True)
class CellRates:
    """The rate term of a cell: ``D_a`` at the vertices of the rate box.

    Attributes
    ----------
    corners : ndarray
        The cell's grid point indices, in box order.
    widths : ndarray
        ``h``, the cell's width on each axis.
    active : tuple of int
        The axes whose rate enters (the others are unbounded: ``P`` does
        not depend on them).
    """

    corners: np.ndarray
    widths: np.ndarray
    active: tuple
    _across: tuple
    _bits: np.ndarray

    @classmethod
    def of(cls, grid, corners, unbounded=()) -> CellRates:
        k = grid.nparams
        bits = grid._bits
        weights = 2 ** np.arange(k - 1, -1, -1)
        across = tuple(
            tuple(int((bits[a] ^ np.eye(k, dtype=int)[d]) @ weights) for d in range(k))
            for a in range(len(bits))
        )
        corners = np.asarray(corners)
        widths = grid.points[corners[-1]] - grid.points[corners[0]]
        active = tuple(d for d in range(k) if d not in set(unbounded))
        return cls(corners, widths, active, across, bits)

    def vertices(self):
        """Sign vectors of the rate box's vertices (0 on inactive axes)."""
        k = len(self.widths)
        for signs in itertools.product((-1.0, 1.0), repeat=len(self.active)):
            out = np.zeros(k)
            out[list(self.active)] = signs
            yield tuple(out.tolist())

    def derivative(self, P, a, signs, nu):
        """``D_a``: ``dP/dt`` at corner position `a`, rates ``signs * nu``.

        `P` maps a corner position to its matrix; `nu` the rates (entries
        of an LMI parameter).
        """
        total = 0.0
        for d in self.active:
            b = self._across[a][d]
            up, down = (a, b) if self._bits[a][d] else (b, a)
            total = total + signs[d] * nu[d] * (P(up) - P(down)) / self.widths[d]
        return total
