"""Rectangular grids of named parameters, with multilinear interpolation.

A `ParameterGrid` is the domain of a `GriddedStateSpace`: the product of one
strictly increasing axis per parameter. Its points (the data points) are
ordered as the vertices of a `ctrl_lpv.ParameterBox` are, the first
parameter varying slowest. Between points it interpolates multilinearly: the
weight of a point is the product over the parameters of the 1-D hat
functions of its axes, so on a grid cell (the box between two consecutive
values of every axis) the weights are exactly the box's convex coordinates
of its ``2**k`` corners. The weights are nonnegative and sum to one: every
interpolated matrix lies in the convex hull of its cell's corner matrices.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from .._checks import real_number
from ..polytope import _INSIDE_RTOL, ParameterBox, _Domain

__all__ = ["ParameterGrid"]


class ParameterGrid(_Domain):
    """Rectangular grid of named parameters.

    Parameters
    ----------
    axes : mapping of str to array_like
        ``{name: values}``, each a strictly increasing sequence of at least
        two finite numbers.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in the order of `axes`.
    axes : tuple of ndarray
        The grid values of each parameter.
    shape : tuple of int
        Number of values on each axis.
    lower, upper : ndarray
        The first and last value of each axis.
    points : ndarray
        ``(N, k)`` grid points, ``N = prod(shape)``, the first parameter
        varying slowest (C order of `shape`).

    Examples
    --------
    >>> g = ParameterGrid({"v": [1.0, 2.0, 4.0]})
    >>> g.weights(3.0)
    array([0. , 0.5, 0.5])
    """

    def __init__(self, axes: Mapping):
        if not isinstance(axes, Mapping) or len(axes) == 0:
            raise ValueError("grid: expected a non-empty mapping {name: values}")
        names, values = [], []
        for name, axis in axes.items():
            if not isinstance(name, str) or not name:
                raise TypeError(f"grid: parameter names must be strings: {name!r}")
            if np.ndim(axis) != 1:
                raise ValueError(
                    f"grid[{name!r}]: expected a 1-D sequence of values, got "
                    f"shape {np.shape(axis)}"
                )
            arr = np.array([real_number(v, f"grid[{name!r}]") for v in axis])
            if arr.size < 2:
                raise ValueError(
                    f"grid[{name!r}]: expected at least two values, got {arr.tolist()}"
                )
            if not np.all(np.diff(arr) > 0):
                i = int(np.flatnonzero(np.diff(arr) <= 0)[0])
                raise ValueError(
                    f"grid[{name!r}]: values must be strictly increasing; "
                    f"{arr[i]:g} is followed by {arr[i + 1]:g}"
                )
            names.append(name)
            values.append(arr)
        self.names = tuple(names)
        self.axes = tuple(values)
        self.shape = tuple(a.size for a in values)
        self.lower = np.array([a[0] for a in values])
        self.upper = np.array([a[-1] for a in values])
        self.points = np.array(list(itertools.product(*values)), dtype=float)
        corners = itertools.product((0, 1), repeat=len(names))
        self._bits = np.array(list(corners), dtype=int)

    def __repr__(self) -> str:
        items = ", ".join(
            f"{n!r}: {len(a)} values in [{a[0]:g}, {a[-1]:g}]"
            for n, a in zip(self.names, self.axes)
        )
        return f"ParameterGrid({{{items}}})"

    @property
    def center(self) -> np.ndarray:
        """The middle of the grid's box."""
        return 0.5 * (self.lower + self.upper)

    # ------------------------------------------------------------------
    # Cells
    # ------------------------------------------------------------------
    @property
    def ncells(self) -> int:
        """Number of grid cells, ``prod(shape[i] - 1)``."""
        return int(np.prod([s - 1 for s in self.shape]))

    def cells(self):
        """The cells' multi-indices (lower corner on each axis), in C order."""
        return itertools.product(*(range(s - 1) for s in self.shape))

    def corners(self, cell) -> np.ndarray:
        """Flat indices of the ``2**k`` corners of `cell`, in box order.

        The order is the vertex order of the cell's `box` (first parameter
        slowest, lower value first).
        """
        idx = np.asarray(cell, int)[None, :] + self._bits
        return np.ravel_multi_index(idx.T, self.shape)

    def box(self, cell) -> ParameterBox:
        """The cell as a `ctrl_lpv.ParameterBox`."""
        return ParameterBox(
            {
                n: (float(a[i]), float(a[i + 1]))
                for n, a, i in zip(self.names, self.axes, cell)
            }
        )

    def cell_of(self, point) -> tuple:
        """The cell containing `point` (projected onto the grid's box)."""
        point = np.clip(np.asarray(point, float), self.lower, self.upper)
        return tuple(
            int(min(max(np.searchsorted(a, x, side="right") - 1, 0), a.size - 2))
            for a, x in zip(self.axes, point)
        )

    def local(self, cell, point) -> np.ndarray:
        """Relative position of `point` in `cell` on each axis (0 to 1)."""
        lo = np.array([a[i] for a, i in zip(self.axes, cell)])
        hi = np.array([a[i + 1] for a, i in zip(self.axes, cell)])
        return np.clip((np.asarray(point, float) - lo) / (hi - lo), 0.0, 1.0)

    def corner_weights(self, point) -> tuple[np.ndarray, np.ndarray]:
        """``(indices, weights)`` of the ``2**k`` corners interpolating `point`."""
        cell = self.cell_of(point)
        lam = self.local(cell, point)
        weights = np.prod(np.where(self._bits, lam, 1.0 - lam), axis=1)
        return self.corners(cell), weights

    # ------------------------------------------------------------------
    # The domain interface of a polytopic system
    # ------------------------------------------------------------------
    def contains(self, p) -> bool:
        """Whether `p` lies in the grid's box (up to a relative 1e-9)."""
        point = self._as_point(p)
        slack = _INSIDE_RTOL * (self.upper - self.lower)
        return bool(
            np.all(point >= self.lower - slack) and np.all(point <= self.upper + slack)
        )

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Interpolation weights of `p` over the grid points, shape ``(N,)``.

        Nonnegative, summing to one, nonzero only at the corners of the
        cell containing `p`.

        Raises
        ------
        ValueError
            If `p` has the wrong size, is not finite, or is outside the
            grid and `clip` is False.
        """
        point = self._as_point(p)
        if not clip and not self.contains(point):
            raise ValueError(
                f"p: {point} is outside the grid {self!r}; pass clip=True to "
                "project it onto the grid"
            )
        return self._weights(point)

    def _weights(self, point: np.ndarray) -> np.ndarray:
        idx, w = self.corner_weights(point)
        out = np.zeros(len(self.points))
        out[idx] = w
        return out

    def _weights_report(self, point: np.ndarray) -> tuple[np.ndarray, str | None]:
        """`_weights` and, if `point` is outside (or not finite), a report."""
        raw = (point - self.lower) / (self.upper - self.lower)
        ok = (raw >= -_INSIDE_RTOL) & (raw <= 1.0 + _INSIDE_RTOL)
        if np.all(ok):
            return self._weights(point), None
        i = int(np.flatnonzero(~ok)[0])
        safe = np.where(np.isfinite(point), point, self.lower)
        return self._weights(safe), (
            f"{self.names[i]} = {point[i]:.6g} (outside "
            f"[{self.lower[i]:g}, {self.upper[i]:g}])"
        )
