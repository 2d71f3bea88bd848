"""Gridded LPV systems: `GriddedStateSpace` and `gss`.

The systems of many LPV models are known at the points of a rectangular
grid of the parameters (the linearizations of a nonlinear model at trim
points, say). `GriddedStateSpace` interpolates them multilinearly, so it is
a union of polytopic cells: on each grid cell it is exactly the
`PolytopicStateSpace` of the cell's ``2**k`` corner systems over the cell's
box (`GriddedStateSpace.cell`). It shares the polytopic class's signal
conventions and its frozen and scheduled behaviour (`.nominal`,
`.scheduling`); only the domain differs (a `ParameterGrid`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from control import StateSpace

from .frozen import FrozenDataMixin, signal_names
from .grid import ParameterGrid
from .nominal import NominalPointMixin
from .polytopic import PolytopicStateSpace
from .scheduling import Scheduling, SchedulingMixin
from .timebase import UNSET
from .vertices import checked_vertex_data

__all__ = ["GriddedStateSpace", "gss"]


class GriddedStateSpace(
    FrozenDataMixin, NominalPointMixin, SchedulingMixin, StateSpace
):
    r"""LPV state-space system given at the points of a parameter grid.

    .. math::

        (A, B, C, D)(p) = \sum_{i} w_i(p) (A_i, B_i, C_i, D_i),

    with ``(A_i, B_i, C_i, D_i)`` the system at grid point ``p_i`` and
    ``w_i`` the multilinear interpolation weights of the grid (the product
    of the 1-D hat functions of each axis). On each grid cell the weights
    are the convex coordinates of the cell's box over its ``2**k`` corners,
    so the cell is the `PolytopicStateSpace` `cell` returns, and the system
    is the union of these polytopic cells, continuous across them.

    The signal conventions are those of `PolytopicStateSpace`: ``A, B, C,
    D`` are the frozen system at the `nominal` point (default the middle of
    the grid's box), read with a `NominalPointWarning`; ``sys.at(p)`` is the
    frozen system at `p`; in simulation (`control.input_output_response`)
    the parameters come from `scheduling`: ``None`` (the ``params`` dict,
    frozen), ``"inputs"`` (one extra input per parameter, named after it,
    after the physical inputs) or a callable ``p = f(t, x, u)``; scheduled
    values outside the grid are projected onto it with a
    `ParameterClipWarning`.

    Block-diagram operations (sums, products, feedback, ...) and `sample`
    are not defined on a gridded system (they are refused with a
    `TypeError`): apply them to the systems at the grid points and build a
    new grid with `gss`.

    Parameters
    ----------
    systems : sequence or mapping of `control.StateSpace` or (A, B, C, D)
        The systems at the grid points: a nested sequence of the grid's
        shape (``systems[i][j]`` at ``(axis0[i], axis1[j])``), a flat
        sequence in the order of ``grid.points`` (first parameter slowest),
        or a mapping ``{point: system}`` (a number for one parameter, else
        a tuple). Same dimensions and timebase everywhere; systems that are
        `control.StateSpace` must have the same signal names.
    grid : `ParameterGrid` or mapping of str to array_like
        ``{name: values}``, each axis strictly increasing (at least two
        values).
    scheduling : None, "inputs" or callable, optional
        Source of the parameters in simulation (see above).
    nominal : array_like or mapping, optional
        Parameter value of the frozen ``A, B, C, D``.
    inputs, outputs, states : int, str or list of str, optional
        Signal names (physical inputs only); default those of the first
        `control.StateSpace` system.
    name : str, optional
        System name.
    dt : 0, True or float, optional
        Timebase (default that of the systems).

    Raises
    ------
    ValueError
        A bad grid (naming the axis), systems that do not match it in
        number or shape, systems of different dimensions, timebases or
        signal names (naming the grid point), or a `nominal` outside the
        grid.
    TypeError
        `systems` or `grid` of the wrong type.

    Attributes
    ----------
    domain : `ParameterGrid`
        The grid (also `grid`).
    vertices : tuple of `control.StateSpace`
        The systems at the grid points, in the order of ``grid.points``.
    nominal : ndarray
        Parameter value of the frozen ``A, B, C, D``.

    See Also
    --------
    gss, PolytopicStateSpace

    Examples
    --------
    >>> import control as ct
    >>> sys = GriddedStateSpace(
    ...     [ct.ss([[-v]], [[1.0]], [[1.0]], 0) for v in (1.0, 2.0, 4.0)],
    ...     {"v": [1.0, 2.0, 4.0]})
    >>> sys.at(3.0).A
    array([[-3.]])
    """

    _kind = "gridded"

    def __init__(
        self,
        systems,
        grid,
        *,
        scheduling: Scheduling = None,
        nominal=None,
        **kwargs,
    ):
        if isinstance(grid, Mapping):
            grid = ParameterGrid(grid)
        if not isinstance(grid, ParameterGrid):
            raise TypeError(
                "grid: expected a ParameterGrid or a mapping {name: values}, got "
                f"{type(grid).__name__}"
            )
        flat = _grid_ordered(systems, grid)
        labels = [f"systems at {_point_text(grid, q)}" for q in grid.points]
        try:
            data, dt = checked_vertex_data(flat, kwargs.pop("dt", UNSET))
        except ValueError as err:
            raise ValueError(_relabel(str(err), labels)) from None
        _check_signal_names(flat, grid)
        self._data = data
        self.domain = grid
        self.nominal = (
            grid.center.copy() if nominal is None else grid._as_point(nominal)
        )
        self._nominal_source = (
            "the grid's center"
            if np.allclose(self.nominal, grid.center, rtol=1e-12, atol=0.0)
            else "nominal="
        )
        self._clip_warned = False
        if not grid.contains(self.nominal):
            raise ValueError(f"nominal: {self.nominal} is outside {grid!r}")
        self._set_scheduling(scheduling)

        labels = signal_names(flat, data, kwargs)
        frozen = self._name_points(data, labels, grid._weights(self.nominal), dt)
        args, kwargs = self._system_arguments(frozen, dt)
        super().__init__(*args, **kwargs)
        self._update_params(None)

    # ------------------------------------------------------------------
    # Grid data
    # ------------------------------------------------------------------
    @property
    def grid(self) -> ParameterGrid:
        """The parameter grid (the `domain`)."""
        return self.domain

    def cell(self, index) -> PolytopicStateSpace:
        """The grid cell `index` as a `PolytopicStateSpace`.

        Parameters
        ----------
        index : tuple of int
            The cell's lower corner on each axis (``0 <= index[i] <
            shape[i] - 1``).

        Returns
        -------
        `PolytopicStateSpace`
            Over the cell's box, with the corner systems as vertices: on
            the cell it equals this system.
        """
        index = tuple(int(i) for i in np.atleast_1d(index))
        if len(index) != self.nparams or any(
            not 0 <= i < s - 1 for i, s in zip(index, self.domain.shape)
        ):
            raise ValueError(
                f"index: expected one cell index per parameter in "
                f"{[range(s - 1) for s in self.domain.shape]}, got {index}"
            )
        return PolytopicStateSpace(
            [self.vertices[i] for i in self.domain.corners(index)],
            self.domain.box(index),
            name=f"{self.name}{list(index)}",
        )

    def scheduled(self, by: Scheduling):
        """Return a copy with another scheduling source.

        Parameters
        ----------
        by : None, "inputs" or callable
            Where the parameters come from in simulation: the ``params``
            dict (None), one extra input per parameter (``"inputs"``), or a
            callable ``p = f(t, x, u)``.

        Returns
        -------
        `GriddedStateSpace`
            The same grid, systems, nominal point and name.
        """
        return type(self)(self.vertices, self.domain, scheduling=by,
                          nominal=self.nominal, name=self.name)  # fmt: skip

    # ------------------------------------------------------------------
    # Operations python-control would apply to the nominal frozen system
    # ------------------------------------------------------------------
    def _refuse(self, *args, **kwargs):
        raise TypeError(
            "GriddedStateSpace: block-diagram operations and sampling are not "
            "defined on a gridded system; apply them to the systems at the grid "
            "points (sys.vertices, or sys.at(p)) and build a new grid with gss"
        )

    __neg__ = __add__ = __radd__ = __sub__ = __rsub__ = _refuse
    __mul__ = __rmul__ = __truediv__ = __rtruediv__ = __pow__ = _refuse
    __getitem__ = feedback = append = lft = minreal = sample = _refuse

    def _points_text(self) -> str:
        return f"{len(self.vertices)} grid points"

    def _points_repr(self) -> str:
        return f"grid {self.domain.shape} of {list(self.domain.names)}"


def gss(systems, grid, **kwargs) -> GriddedStateSpace:
    """Create a gridded LPV system, from systems or from a function.

    Parameters
    ----------
    systems : callable, sequence or mapping
        A function ``f(**p)`` of the parameters (keyword arguments named
        after them) returning a `control.StateSpace` or ``(A, B, C, D)``,
        e.g. ``control.linearize`` of a nonlinear system at the trim point
        of ``p``, called at every grid point; or the systems themselves
        (see `GriddedStateSpace`).
    grid : `ParameterGrid` or mapping of str to array_like
        ``{name: values}``, each axis strictly increasing.
    **kwargs
        ``scheduling``, ``nominal``, ``inputs``, ``outputs``, ``states``,
        ``name``, ``dt`` (see `GriddedStateSpace`).

    Returns
    -------
    `GriddedStateSpace`

    Raises
    ------
    ValueError, TypeError
        As `GriddedStateSpace`; a function that fails at a grid point is
        reported with the point.

    Examples
    --------
    >>> import control as ct
    >>> sys = gss(lambda v: ct.ss([[-v]], [[1.0]], [[1.0]], 0),
    ...           {"v": [1.0, 2.0, 4.0]})
    >>> sys.at(1.5).A
    array([[-1.5]])
    """
    if isinstance(grid, Mapping):
        grid = ParameterGrid(grid)
    if callable(systems) and not isinstance(systems, StateSpace):
        fun, systems = systems, []
        for q in getattr(grid, "points", ()):
            point = dict(zip(grid.names, q.tolist()))
            try:
                systems.append(fun(**point))
            except Exception as err:
                raise type(err)(
                    f"systems: the function failed at {point}: {err}"
                ) from err
    return GriddedStateSpace(systems, grid, **kwargs)


def _point_text(grid, q) -> str:
    return "{" + ", ".join(f"{n!r}: {v:g}" for n, v in zip(grid.names, q)) + "}"


def _relabel(message: str, labels) -> str:
    """A vertex message of `checked_vertex_data` in terms of grid points."""
    import re

    return re.sub(r"vertices\[(\d+)\]", lambda m: labels[int(m.group(1))], message)


def _grid_ordered(systems, grid) -> list:
    """The systems in the order of ``grid.points``, checked against the grid."""
    N = len(grid.points)
    if isinstance(systems, Mapping):
        ordered = [None] * N
        for key, system in systems.items():
            q = np.atleast_1d(np.asarray(key, dtype=float)).reshape(-1)
            if q.size != grid.nparams:
                raise ValueError(
                    f"systems: key {key!r} is not a point of the grid's "
                    f"{grid.nparams} parameters {list(grid.names)}"
                )
            match = np.flatnonzero(np.all(np.isclose(grid.points, q, rtol=1e-12,
                                                      atol=1e-12), axis=1))  # fmt: skip
            if match.size == 0:
                raise ValueError(f"systems: key {key!r} is not a point of {grid!r}")
            ordered[match[0]] = system
        missing = [_point_text(grid, grid.points[i]) for i, s in enumerate(ordered)
                   if s is None]  # fmt: skip
        if missing:
            raise ValueError(f"systems: no system at the grid points {missing}")
        return ordered
    if isinstance(systems, (StateSpace, str)) or not isinstance(
        systems, (Sequence, np.ndarray)
    ):
        raise TypeError(
            "systems: expected a sequence (nested to the grid's shape, or flat) "
            "or a mapping {point: system}, or for gss a function of the "
            f"parameters; got {type(systems).__name__}"
        )
    flat = _flatten(systems, grid.shape, "systems")
    if flat is None:
        flat = list(systems)
        if len(flat) != N:
            raise ValueError(
                f"systems: expected {N} systems (the grid's shape {grid.shape}, "
                f"nested or flat), got {len(flat)}"
            )
    return flat


def _is_system(item) -> bool:
    """A system, not a row of systems: a StateSpace or an (A, B, C, D) tuple."""
    if isinstance(item, StateSpace):
        return True
    return (isinstance(item, tuple) and len(item) == 4
            and not any(isinstance(e, (StateSpace, tuple)) for e in item))  # fmt: skip


def _flatten(items, shape, label):
    """Flatten a nested sequence of `shape` (None when it is flat)."""
    if len(shape) == 1 or (len(items) and _is_system(items[0])):
        if len(shape) > 1 and len(items) == int(np.prod(shape)):
            return None  # flat, checked by the caller
        if len(items) != shape[0]:
            raise ValueError(
                f"{label}: expected {shape[0]} entries on this axis of the grid "
                f"(shape {shape}), got {len(items)}"
            )
        if len(shape) > 1:
            raise ValueError(
                f"{label}: expected a nested sequence of shape {shape}, got "
                "systems one level too early"
            )
        return list(items)
    if len(items) != shape[0]:
        raise ValueError(
            f"{label}: expected {shape[0]} entries on this axis of the grid "
            f"(shape {shape}), got {len(items)}"
        )
    out = []
    for i, sub in enumerate(items):
        if isinstance(sub, (StateSpace, str)) or not isinstance(
            sub, (Sequence, np.ndarray)
        ):
            raise ValueError(
                f"{label}[{i}]: expected a sequence of {shape[1]} systems (the "
                f"grid's shape is {shape})"
            )
        inner = _flatten(sub, shape[1:], f"{label}[{i}]")
        if inner is None:
            raise ValueError(
                f"{label}[{i}]: expected a nested sequence of shape {shape[1:]}"
            )
        out += inner
    return out


def _check_signal_names(flat, grid) -> None:
    """Systems given as `control.StateSpace` must name their signals alike."""
    named = [(q, s) for q, s in zip(grid.points, flat) if isinstance(s, StateSpace)]
    if not named:
        return
    q0, s0 = named[0]
    for q, s in named[1:]:
        for what in ("input", "output", "state"):
            a, b = getattr(s0, f"{what}_labels"), getattr(s, f"{what}_labels")
            if list(a) != list(b):
                raise ValueError(
                    f"systems: the system at {_point_text(grid, q)} has {what}s "
                    f"{list(b)}, the one at {_point_text(grid, q0)} {list(a)}; "
                    "every grid point must name its signals alike"
                )
