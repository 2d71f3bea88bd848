"""Timebases of polytopic systems: python-control's ``dt``, checked.

A polytopic system is either continuous (``dt = 0``) or discrete (``dt =
True`` or a sampling period), the same at every vertex.
"""

from __future__ import annotations

import numpy as np
from control import StateSpace

__all__ = ["UNSET", "as_dt", "same_dt", "common_dt"]

#: Marks a ``dt`` keyword that was not given (None is python-control's
#: unspecified timebase, which is refused).
UNSET = object()


def as_dt(value, name: str = "dt"):
    """A python-control timebase: 0 (continuous), True or a period > 0.

    ``False`` is 0; ``True`` (discrete, unspecified period) is kept as is;
    numbers become floats. None (python-control's unspecified timebase) is
    refused: a polytopic system is either continuous or discrete.
    """
    if value is True or (isinstance(value, np.bool_) and bool(value)):
        return True
    if value is False or (isinstance(value, np.bool_) and not bool(value)):
        return 0
    if value is None:
        raise ValueError(
            f"{name}: None (an unspecified timebase) is not supported; use 0 "
            "(continuous time), True or a positive sampling period (discrete time)"
        )
    if isinstance(value, (str, bytes, complex)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise TypeError(
            f"{name}: expected 0, True or a positive sampling period, got {value!r}"
        )
    number = float(value)
    if not np.isfinite(number) or number < 0:
        raise ValueError(
            f"{name}: expected 0, True or a positive sampling period, got {value!r}"
        )
    return 0 if number == 0 else number


def same_dt(a, b) -> bool:
    """Equal timebases (``True`` differs from ``1.0``)."""
    return (a is True) == (b is True) and a == b


def common_dt(vertices, given):
    """The timebase of the vertices, checked against a given ``dt``.

    Every `control.StateSpace` vertex must have the same ``dt`` (a vertex
    with ``dt=None`` takes the common one); tuples take `given`, or 0.
    """
    found, first = None, None
    for j, vertex in enumerate(vertices):
        own = getattr(vertex, "dt", None) if isinstance(vertex, StateSpace) else None
        if own is None:
            continue
        own = as_dt(own, f"vertices[{j}].dt")
        if found is None:
            found, first = own, j
        elif not same_dt(own, found):
            raise ValueError(
                f"vertices: vertices[{j}] has dt = {own!r} but vertices[{first}] "
                f"has dt = {found!r}; every vertex must have the same timebase"
            )
    if given is UNSET:
        return 0 if found is None else found
    given = as_dt(given, "dt")
    if found is not None and not same_dt(given, found):
        raise ValueError(
            f"dt: {given!r} differs from the timebase of the vertex systems "
            f"(dt = {found!r})"
        )
    return given
