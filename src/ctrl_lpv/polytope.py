"""Parameter domains: boxes, simplices and general polytopes.

A domain maps a parameter value ``p`` to convex coordinates ``delta(p)``
over its vertices, so that a polytopic matrix is ``M(p) = sum_j delta_j M_j``.
The vertex order of a domain is the vertex order of the systems built on it.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

import numpy as np
from scipy.optimize import nnls

from ._checks import real_number

__all__ = ["ParameterBox", "Simplex", "Polytope", "box"]

# Tolerance (relative to the domain's extent) for accepting points on the
# boundary that numerical integration pushes slightly outside.
_INSIDE_RTOL = 1e-9


class _Domain:
    """Common interface of parameter domains (not public)."""

    names: tuple[str, ...]
    points: np.ndarray  # (N, k) vertex coordinates

    @property
    def nparams(self) -> int:
        """Number of parameters ``k``."""
        return len(self.names)

    @property
    def nvertices(self) -> int:
        """Number of vertices ``N``."""
        return self.points.shape[0]

    @property
    def center(self) -> np.ndarray:
        """Mean of the vertices, a point inside the domain."""
        return self.points.mean(axis=0)

    def _as_point(self, p) -> np.ndarray:
        if isinstance(p, Mapping):
            missing = [name for name in self.names if name not in p]
            extra = [name for name in p if name not in self.names]
            if missing or extra:
                raise ValueError(
                    f"p: expected values for parameters {list(self.names)}; "
                    f"missing {missing}, unknown {extra}"
                )
            p = [p[name] for name in self.names]
        raw = np.asarray(p)
        if raw.dtype.kind not in "iuf":  # strings, booleans, complex: refused
            for value in raw.reshape(-1):
                real_number(value, "p")
        point = np.asarray(p, dtype=float).reshape(-1)
        if point.shape != (self.nparams,):
            raise ValueError(
                f"p: expected {self.nparams} value(s) for parameters "
                f"{list(self.names)}, got shape {np.shape(p)}"
            )
        if not np.all(np.isfinite(point)):
            raise ValueError(f"p: values must be finite, got {point}")
        return point

    def __eq__(self, other) -> bool:
        return (
            type(self) is type(other)
            and self.names == other.names
            and self.points.shape == other.points.shape
            and np.array_equal(self.points, other.points)
        )

    def __hash__(self) -> int:
        return hash((type(self), self.names, self.points.tobytes()))


class ParameterBox(_Domain):
    """Box of named parameter bounds with its ``2**k`` vertices.

    Convex coordinates are multilinear: ``delta_j(p)`` is the product over the
    parameters of ``lambda_i`` or ``1 - lambda_i`` with ``lambda_i`` the
    relative position of ``p_i`` in its interval. They reproduce every affine
    function of ``p`` exactly, so an affine model ``M0 + sum p_i M_i`` equals
    ``sum_j delta_j(p) M(v_j)``.

    Parameters
    ----------
    bounds : mapping of str to (float, float)
        Lower and upper bound of each parameter, ``lower < upper``.

    Attributes
    ----------
    names : tuple of str
        Parameter names, in the order of `bounds`.
    lower, upper : ndarray
        Bounds, shape ``(k,)``.
    points : ndarray
        Vertices, shape ``(2**k, k)``; the first parameter varies slowest
        and each one takes its lower bound first.

    Examples
    --------
    >>> dom = ParameterBox({"p": (-0.95, 0.0)})
    >>> dom.weights(-0.475)
    array([0.5, 0.5])
    """

    def __init__(self, bounds: Mapping[str, tuple[float, float]]):
        if not isinstance(bounds, Mapping) or len(bounds) == 0:
            raise ValueError(
                "bounds: expected a non-empty mapping {name: (lower, upper)}"
            )
        names, lower, upper = [], [], []
        for name, pair in bounds.items():
            if not isinstance(name, str) or not name:
                raise TypeError(f"bounds: parameter names must be strings: {name!r}")
            try:
                lo, hi = pair
            except (TypeError, ValueError):
                raise ValueError(
                    f"bounds[{name!r}]: expected (lower, upper), got {pair!r}"
                ) from None
            lo, hi = (real_number(v, f"bounds[{name!r}]") for v in (lo, hi))
            if not lo < hi:
                raise ValueError(
                    f"bounds[{name!r}]: lower bound {lo} must be below upper {hi}"
                )
            names.append(name)
            lower.append(lo)
            upper.append(hi)
        self.names = tuple(names)
        self.lower = np.array(lower)
        self.upper = np.array(upper)
        corners = itertools.product((0, 1), repeat=len(names))
        self._bits = np.array(list(corners), dtype=bool)
        self.points = np.where(self._bits, self.upper, self.lower)

    def __repr__(self) -> str:
        items = ", ".join(
            f"{n!r}: ({lo:g}, {hi:g})"
            for n, lo, hi in zip(self.names, self.lower, self.upper)
        )
        return f"ParameterBox({{{items}}})"

    def contains(self, p) -> bool:
        """Whether `p` lies in the box (up to a relative 1e-9)."""
        point = self._as_point(p)
        slack = _INSIDE_RTOL * (self.upper - self.lower)
        return bool(
            np.all(point >= self.lower - slack) and np.all(point <= self.upper + slack)
        )

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Convex coordinates of `p` over the vertices.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value, shape ``(k,)`` or ``{name: value}``.
        clip : bool, optional
            Project `p` onto the box first instead of raising when it lies
            outside (used on simulation hot paths).

        Returns
        -------
        delta : ndarray
            Shape ``(N,)``, nonnegative, summing to one.

        Raises
        ------
        ValueError
            If `p` has the wrong size, is not finite, or is outside the box
            and `clip` is False.
        """
        point = self._as_point(p)
        if not clip and not self.contains(point):
            raise ValueError(
                f"p: {point} is outside the parameter box {self!r}; "
                "pass clip=True to project it onto the box"
            )
        return self._weights(point)

    def _weights(self, point: np.ndarray) -> np.ndarray:
        lam = np.clip((point - self.lower) / (self.upper - self.lower), 0.0, 1.0)
        return np.prod(np.where(self._bits, lam, 1.0 - lam), axis=1)

    def _weights_report(self, point: np.ndarray) -> tuple[np.ndarray, str | None]:
        """`_weights` and, if `point` is outside (or not finite), a report."""
        raw = (point - self.lower) / (self.upper - self.lower)
        lam = np.clip(raw, 0.0, 1.0)
        delta = np.prod(np.where(self._bits, lam, 1.0 - lam), axis=1)
        if not (lam != raw).any():  # inside (a NaN compares unequal)
            return delta, None
        bad = np.flatnonzero(~((raw >= -_INSIDE_RTOL) & (raw <= 1.0 + _INSIDE_RTOL)))
        if bad.size == 0:  # outside by less than the boundary tolerance
            return delta, None
        i = int(bad[0])
        return delta, (
            f"{self.names[i]} = {point[i]:.6g} (outside "
            f"[{self.lower[i]:g}, {self.upper[i]:g}])"
        )


class Simplex(_Domain):
    """Domain whose parameters are the convex coordinates themselves.

    This is the domain of a polytopic system given only by its vertices:
    ``p = delta``, one parameter per vertex.

    Parameters
    ----------
    nvertices : int
        Number of vertices ``N >= 1``.
    names : sequence of str, optional
        Parameter names, default ``delta[0]``, ..., ``delta[N-1]``.
    """

    def __init__(self, nvertices: int, names: Sequence[str] | None = None):
        if int(nvertices) != nvertices or nvertices < 1:
            raise ValueError(f"nvertices: expected a positive integer, got {nvertices}")
        nvertices = int(nvertices)
        if names is None:
            names = [f"delta[{j}]" for j in range(nvertices)]
        if len(names) != nvertices:
            raise ValueError(f"names: expected {nvertices} names, got {len(names)}")
        self.names = tuple(names)
        self.points = np.eye(nvertices)

    def __repr__(self) -> str:
        return f"Simplex({self.nvertices})"

    def contains(self, p) -> bool:
        """Whether `p` is a vector of convex coordinates (up to 1e-9)."""
        delta = self._as_point(p)
        return bool(
            np.all(delta >= -_INSIDE_RTOL) and abs(delta.sum() - 1) <= _INSIDE_RTOL
        )

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Return `p` itself after checking it is convex coordinates.

        With ``clip=True`` negative entries are set to zero and the vector is
        normalised to sum to one.
        """
        delta = self._as_point(p)
        if not clip and not self.contains(delta):
            raise ValueError(
                f"p: convex coordinates must be >= 0 and sum to 1, got {delta}"
            )
        return self._weights(delta)

    def _weights(self, delta: np.ndarray) -> np.ndarray:
        delta = np.maximum(delta, 0.0)
        total = delta.sum()
        return delta / total if total > 0 else np.full(delta.size, 1.0 / delta.size)

    def _weights_report(self, delta: np.ndarray) -> tuple[np.ndarray, str | None]:
        """`_weights` and, if `delta` is not convex (or finite), a report."""
        total = delta.sum()
        if delta.min() >= -_INSIDE_RTOL and abs(total - 1.0) <= _INSIDE_RTOL:
            return self._weights(delta), None
        neg = np.flatnonzero(~(delta >= -_INSIDE_RTOL))
        if neg.size:
            i = int(neg[0])
            report = f"{self.names[i]} = {delta[i]:.6g} (negative)"
        else:
            report = f"coordinates summing to {total:.6g} (not 1)"
        return self._weights(delta), report


class Polytope(_Domain):
    """Convex hull of given parameter points.

    Convex coordinates of a point are not unique unless the polytope is a
    simplex; `weights` returns the nonnegative combination found by
    nonnegative least squares.

    Parameters
    ----------
    points : array_like
        Vertices, shape ``(N, k)``.
    names : sequence of str
        Parameter names, length ``k``.
    """

    def __init__(self, points, names: Sequence[str]):
        pts = np.asarray(points, dtype=float)
        if pts.ndim != 2 or pts.shape[0] == 0:
            raise ValueError(
                f"points: expected shape (N, k) with N >= 1, got {pts.shape}"
            )
        if not np.all(np.isfinite(pts)):
            raise ValueError("points: coordinates must be finite")
        if len(names) != pts.shape[1]:
            raise ValueError(
                f"names: expected {pts.shape[1]} names for points of shape {pts.shape}"
            )
        self.names = tuple(names)
        self.points = pts
        self._scale = max(1.0, float(np.ptp(pts, axis=0).max(initial=0.0)))

    def __repr__(self) -> str:
        return f"Polytope({self.nvertices} vertices, names={list(self.names)})"

    def _solve(self, point: np.ndarray) -> tuple[np.ndarray, float]:
        # Row of ones weighted heavily enforces sum(delta) = 1 in the NNLS.
        heavy = 1e3 * self._scale
        matrix = np.vstack([self.points.T, heavy * np.ones(self.nvertices)])
        delta, residual = nnls(matrix, np.append(point, heavy))
        return delta / delta.sum(), residual

    def contains(self, p) -> bool:
        """Whether `p` lies in the convex hull (up to a relative 1e-7)."""
        _, residual = self._solve(self._as_point(p))
        return residual <= 1e-7 * self._scale

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Nonnegative convex coordinates of `p` (see `ParameterBox.weights`)."""
        point = self._as_point(p)
        delta, residual = self._solve(point)
        if not clip and residual > 1e-7 * self._scale:
            raise ValueError(f"p: {point} is outside the polytope {self!r}")
        return delta

    def _weights(self, point: np.ndarray) -> np.ndarray:
        return self._solve(point)[0]

    def _weights_report(self, point: np.ndarray) -> tuple[np.ndarray, str | None]:
        """`_weights` and, if `point` is outside the hull, a description."""
        if not np.all(np.isfinite(point)):
            return np.full(self.nvertices, np.nan), "a non-finite value"
        delta, residual = self._solve(point)
        if residual <= 1e-7 * self._scale:
            return delta, None
        values = ", ".join(f"{n} = {v:.6g}" for n, v in zip(self.names, point))
        return delta, f"({values}) (outside the polytope)"


def box(**bounds: tuple[float, float]) -> ParameterBox:
    """Create a parameter box from keyword bounds.

    Parameters
    ----------
    **bounds : (float, float)
        ``name=(lower, upper)`` for each parameter, in order.

    Returns
    -------
    `ParameterBox`
        The box ``ParameterBox(bounds)``.

    Examples
    --------
    >>> box(p=(-0.95, 0.0)).nvertices
    2
    """
    return ParameterBox(bounds)
