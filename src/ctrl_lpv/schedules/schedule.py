"""Gain schedules as tables of gains at points, with their interpolation cells.

A `GainSchedule` is what a scheduled state feedback ``u = -K(p) x`` is made
of: gains ``K_i`` at points ``p_i`` of the scheduling variables, and the
cells on which ``K(p)`` is affine. python-control's
`control.create_statefbk_iosystem` with ``gainsched_method="linear"``
interpolates with `scipy.interpolate.interp1d` (one variable: the cells are
the intervals between sorted points) or `scipy.interpolate.LinearNDInterpolator`
(the cells are the simplices of its Delaunay triangulation); `schedule_of`
reads these back from the controller object itself, and builds the same
cells for a table ``(gains, points)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["GainSchedule", "schedule_of"]


@dataclass(frozen=True, eq=False)
class GainSchedule:
    """Gains at points and the cells of their piecewise-affine interpolation.

    Attributes
    ----------
    points : ndarray
        ``(M, k)`` values of the ``k`` scheduling variables.
    gains : ndarray
        ``(M, m, n)``: ``u = -K_i x`` at ``points[i]``.
    cells : ndarray
        ``(ncells, k + 1)`` indices of the points spanning each cell (a
        simplex; an interval for one variable); ``K(p)`` is affine on each.
    names : tuple of str
        The scheduling variables (as the controller names them).
    """

    points: np.ndarray
    gains: np.ndarray
    cells: np.ndarray
    names: tuple[str, ...]

    @property
    def nvars(self) -> int:
        return self.points.shape[1]

    def barycentric(self, cell: int, p) -> np.ndarray:
        """Convex coordinates of `p` in `cell` (may be negative outside)."""
        V = self.points[self.cells[cell]]
        M = np.vstack([(V[1:] - V[0]).T])
        lam = np.linalg.solve(M, np.asarray(p, float) - V[0]) if M.size else []
        return np.concatenate([[1.0 - np.sum(lam)], lam])

    def cell_of(self, p) -> int | None:
        """The cell containing `p` (None outside the convex hull)."""
        for c in range(len(self.cells)):
            if np.all(self.barycentric(c, p) >= -1e-12):
                return c
        return None

    def gain(self, p) -> np.ndarray:
        """``K(p)`` by the piecewise-affine interpolation."""
        c = self.cell_of(p)
        if c is None:
            raise ValueError(f"p: {p} is outside the schedule's points")
        lam = self.barycentric(c, p)
        return np.tensordot(lam, self.gains[self.cells[c]], axes=1)


def schedule_of(controller, names=None) -> GainSchedule:
    """The `GainSchedule` of a controller or a table.

    Parameters
    ----------
    controller : NonlinearIOSystem, tuple or `ctrl_lpv.StateFeedbackDesign`
        A gain-scheduled controller from `control.create_statefbk_iosystem`
        (``gain=(gains, points)``, ``gainsched_method="linear"``, without
        integral action), a table ``(gains, points)`` as passed to it, or
        a design: a common gain (at the corners of its domain), vertex
        gains over one parameter (interpolated linearly, as the design's
        controller does), or a `ctrl_lpv.synthesis.gridded.GriddedDesign`
        (gains at the grid points, interpolated as python-control does).
    names : sequence of str, optional
        Names of the scheduling variables of a table (default ``p[i]``).

    Returns
    -------
    `GainSchedule`

    Raises
    ------
    ValueError, TypeError
        A controller that is not a linear gain schedule of
        `create_statefbk_iosystem` (named), a malformed table, or a design
        whose gain is not piecewise affine (vertex gains over several
        parameters interpolate multilinearly; a parameter-dependent
        Lyapunov design's gain is rational).
    """
    if hasattr(controller, "gains") and hasattr(controller, "system"):
        return _from_design(controller)
    if isinstance(controller, tuple):
        gains, points = controller
        return _table(np.asarray(gains, float), np.asarray(points, float), names)
    return _from_control(controller)


def _table(gains, points, names):
    if points.ndim == 1:
        points = points.reshape(-1, 1)
    if gains.ndim != 3 or gains.shape[0] != points.shape[0]:
        raise ValueError(
            f"controller: expected (gains, points) with one m x n gain per point, "
            f"got gains of shape {gains.shape} and {points.shape[0]} points"
        )
    k = points.shape[1]
    names = tuple(names) if names is not None else tuple(f"p[{i}]" for i in range(k))
    if len(names) != k:
        raise ValueError(f"names: expected {k} names, got {list(names)}")
    if k == 1:
        order = np.argsort(points[:, 0])
        cells = np.stack([order[:-1], order[1:]], axis=1)
    else:
        from scipy.spatial import Delaunay

        cells = Delaunay(points).simplices
    return GainSchedule(points, gains, np.asarray(cells, int), names)


def _from_design(design):
    domain = design.system.domain
    if hasattr(design, "points"):  # a GriddedDesign: gains at the grid points
        gains = np.asarray(design.gains, float)
        return _table(gains, np.asarray(design.points, float), domain.names)
    if not hasattr(domain, "lower"):
        raise TypeError("controller: a design over a box of named parameters")
    points = np.asarray(domain.points, float)
    gains = np.asarray(design.gains, float)
    if len(gains) == 1:
        gains = np.repeat(gains, len(points), axis=0)
    elif getattr(design, "rational", None) is not None or points.shape[1] > 1:
        raise ValueError(
            "controller: vertex gains over several parameters (multilinear) or "
            "of a parameter-dependent Lyapunov design (rational) are not "
            "piecewise affine; certify a table of gains at points instead"
        )
    return _table(gains, points, domain.names)


def _from_control(ctrl):
    try:
        cells = _closure(ctrl.outfcn)
        if not cells["gainsched"]:
            raise KeyError
        inner = _closure(cells["_compute_gain"])
        interp = inner["_interp"]
        indices = list(cells["gainsched_indices"])
        nintegrators = cells["nintegrators"]
        m, n = cells["sys_ninputs"], cells["sys_nstates"]
    except (AttributeError, KeyError, TypeError, ValueError):
        raise TypeError(
            "controller: expected a gain-scheduled controller of "
            "control.create_statefbk_iosystem(sys, (gains, points), ...), or a "
            "table (gains, points)"
        ) from None
    if nintegrators:
        raise ValueError(
            "controller: gain schedules with integral action are not supported"
        )
    names = [ctrl.input_labels[i] for i in indices]
    kind = type(interp).__name__
    if kind == "interp1d" and getattr(interp, "_kind", "linear") == "linear":
        gains = np.moveaxis(np.asarray(interp.y, float), interp.axis, 0)
        return _table(gains.reshape(-1, m, n), np.asarray(interp.x, float), names)
    if kind == "LinearNDInterpolator":
        points = np.asarray(interp.points, float)
        gains = np.asarray(interp.values, float).reshape(len(points), m, n)
        return GainSchedule(points, gains, np.asarray(interp.tri.simplices, int),
                            tuple(names))  # fmt: skip
    raise ValueError(
        f"controller: gainsched_method must be 'linear' (piecewise affine, "
        f"certifiable cell by cell); this controller interpolates with {kind}"
    )


def _closure(function):
    return {
        name: cell.cell_contents
        for name, cell in zip(function.__code__.co_freevars, function.__closure__)
    }
