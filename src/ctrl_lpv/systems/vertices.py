"""Vertex data of polytopic systems: checked, ordered, combined.

The vertex systems correspond one to one, in order, to the vertices of the
parameter domain; this module checks the matrices, puts vertices given as
``{vertex point: system}`` in the domain's order, checks vertices that
state their own point, builds the vertices of an affine dependence, and
combines vertex data with convex coordinates.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from control import StateSpace

from .._checks import as_ss_data
from ..polytope import ParameterBox, Polytope, Simplex
from .timebase import as_dt, common_dt, same_dt

__all__ = [
    "MAX_AFFINE_PARAMETERS",
    "ss_data",
    "checked_vertex_data",
    "combine_data",
    "as_domain",
    "ordered_vertices",
    "check_vertex_order",
    "affine_vertices",
]

#: Most parameters `PolytopicStateSpace.from_affine` accepts: a box of
#: ``k`` parameters has ``2**k`` vertices (4096 for 12), each a system to
#: build and, in a synthesis, at least one LMI.
MAX_AFFINE_PARAMETERS = 12


def ss_data(item, name: str) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of a vertex, checked, whatever its timebase."""
    if isinstance(item, StateSpace):
        item = (item.A, item.B, item.C, item.D)
    return as_ss_data(item, name)


def checked_vertex_data(vertices, given_dt) -> tuple[tuple, object]:
    """Vertex matrices and common timebase of a sequence of vertex systems.

    Parameters
    ----------
    vertices : sequence of `control.StateSpace` or (A, B, C, D)
        The vertex systems, in the domain's order.
    given_dt : 0, True, float or `UNSET`
        The ``dt`` keyword of the constructor.

    Returns
    -------
    data : tuple of (A, B, C, D)
        Float matrices, the same shapes at every vertex.
    dt : 0, True or float
        The timebase.
    """
    if isinstance(vertices, (StateSpace, np.ndarray, str)) or not isinstance(
        vertices, Sequence
    ):
        raise TypeError(
            "vertices: expected a sequence of control.StateSpace or "
            "(A, B, C, D) tuples, or a mapping {vertex point: system}, got "
            f"{type(vertices).__name__}"
        )
    if len(vertices) == 0:
        raise ValueError("vertices: at least one vertex system is required")
    data = tuple(ss_data(v, f"vertices[{j}]") for j, v in enumerate(vertices))
    dt = common_dt(vertices, given_dt)
    shapes = [tuple(m.shape for m in d) for d in data]
    for j, shape in enumerate(shapes[1:], start=1):
        if shape != shapes[0]:
            raise ValueError(
                f"vertices[{j}]: dimensions {shape} differ from "
                f"vertices[0] {shapes[0]} (A, B, C, D shapes)"
            )
    return data, dt


def combine_data(data, delta) -> tuple[np.ndarray, ...]:
    """``sum_j delta_j (A_j, B_j, C_j, D_j)`` of vertex data."""
    return tuple(
        np.tensordot(delta, np.stack([d[i] for d in data]), axes=1) for i in range(4)
    )


def as_domain(domain, nvertices: int):
    """The parameter domain of `nvertices` vertex systems (default a simplex)."""
    if domain is None:
        return Simplex(nvertices)
    if isinstance(domain, Mapping):
        domain = ParameterBox(domain)
    if not isinstance(domain, (ParameterBox, Polytope, Simplex)):
        raise TypeError(
            "domain: expected a ParameterBox, Polytope, Simplex or a mapping of "
            f"bounds, got {type(domain).__name__}"
        )
    if domain.nvertices != nvertices:
        raise ValueError(
            f"domain: has {domain.nvertices} vertices but {nvertices} vertex "
            "systems were given"
        )
    return domain


def _domain_scale(domain) -> float:
    return max(1.0, float(np.abs(domain.points).max(initial=0.0)))


def _matching_vertex(point: np.ndarray, domain) -> list[int]:
    tol = 1e-9 * _domain_scale(domain)
    return [
        i
        for i, q in enumerate(domain.points)
        if q.shape == point.shape and np.all(np.abs(q - point) <= tol)
    ]


def ordered_vertices(mapping: Mapping, domain) -> list:
    """Vertex systems given as ``{vertex point: system}``, in domain order."""
    if domain is None:
        raise TypeError(
            "vertices: a mapping {vertex point: system} needs a domain (a "
            "ParameterBox, Polytope or a mapping of bounds)"
        )
    dom = as_domain(domain, len(mapping))
    ordered = [None] * dom.nvertices
    for key, system in mapping.items():
        try:
            point = np.asarray(
                key if isinstance(key, (tuple, list)) else (key,), dtype=float
            ).reshape(-1)
        except (TypeError, ValueError):
            raise TypeError(
                f"vertices: key {key!r} is not a parameter point (a number or a "
                "tuple of numbers, one per parameter)"
            ) from None
        match = _matching_vertex(point, dom)
        if not match:
            raise ValueError(
                f"vertices: key {key!r} is not a vertex of {dom!r}; its vertices "
                f"are {[tuple(q) for q in dom.points.tolist()]}"
            )
        if ordered[match[0]] is not None:
            raise ValueError(f"vertices: vertex {key!r} is given twice")
        ordered[match[0]] = system
    return ordered


def check_vertex_order(vertices: Sequence, domain) -> None:
    """Check vertex systems that carry ``params`` against the domain order.

    A vertex `control.StateSpace` built with ``params={name: value}`` for
    every parameter states its own point; it must be the domain's vertex of
    the same index. Vertices without such ``params`` cannot be checked.
    """
    if isinstance(domain, Simplex):
        return
    names = domain.names
    for j, vertex in enumerate(vertices):
        own = (
            getattr(vertex, "params", None) if isinstance(vertex, StateSpace) else None
        )
        if not own or not all(name in own for name in names):
            continue
        try:
            point = np.array([float(own[name]) for name in names])
        except (TypeError, ValueError):
            continue
        if j in _matching_vertex(point, domain):
            continue
        match = _matching_vertex(point, domain)
        where = (
            f"vertex {match[0]} of the domain"
            if match
            else "not a vertex of the domain"
        )
        raise ValueError(
            f"vertices[{j}]: its params {dict(zip(names, point.tolist()))} are "
            f"{where}, but vertex {j} of {domain!r} is "
            f"{dict(zip(names, domain.points[j].tolist()))}; vertex systems must "
            "follow the domain's vertex order (ParameterBox: the first parameter "
            "varies slowest, lower bound first), or pass a mapping "
            "{vertex point: system}"
        )


def _affine_size_or_raise(bounds) -> None:
    """Refuse a box with too many vertices before enumerating them."""
    if isinstance(bounds, ParameterBox):
        names = list(bounds.names)
    elif isinstance(bounds, Mapping):
        names = list(bounds)
    else:
        return  # ParameterBox reports the type error
    if len(names) > MAX_AFFINE_PARAMETERS:
        raise ValueError(
            f"bounds: {len(names)} parameters {names} give a box of "
            f"2**{len(names)} = {2 ** len(names):,} vertices, more than the "
            f"{2**MAX_AFFINE_PARAMETERS:,} (2**{MAX_AFFINE_PARAMETERS}) "
            "from_affine builds. Use fewer parameters: fix those that matter "
            "little at a nominal value, or merge parameters that enter "
            "together into one; or give the vertices of a smaller polytope "
            "that contains the parameter set (PolytopicStateSpace(vertices, "
            "domain))."
        )


def affine_vertices(base, terms: Mapping, bounds, kwargs: dict):
    """Vertices of ``M(p) = M0 + sum_i p_i M_i`` at the corners of a box.

    The arguments of `PolytopicStateSpace.from_affine`.

    Returns
    -------
    vertices : list of (A, B, C, D)
        One per corner of the box, in its vertex order.
    domain : `ParameterBox`
    kwargs : dict
        The constructor keywords, with the signal names, name and timebase
        of `base` as defaults when it is a `control.StateSpace`.
    """
    _affine_size_or_raise(bounds)
    domain = bounds if isinstance(bounds, ParameterBox) else ParameterBox(bounds)
    base_data = ss_data(base, "base")
    if not isinstance(terms, Mapping):
        raise TypeError("terms: expected a mapping {parameter name: matrices}")
    if set(terms) != set(domain.names):
        raise ValueError(
            f"terms: keys {sorted(terms)} must equal the parameter names "
            f"{list(domain.names)} of bounds"
        )
    term_data = []
    for pname in domain.names:
        term = terms[pname]
        if isinstance(term, Sequence) and not isinstance(term, StateSpace):
            term = tuple(
                np.zeros_like(b) if np.isscalar(t) and t == 0 else t
                for t, b in zip(term, base_data)
            )
        data = ss_data(term, f"terms[{pname!r}]")
        for t, b, label in zip(data, base_data, "ABCD"):
            if t.shape != b.shape:
                raise ValueError(
                    f"terms[{pname!r}].{label}: shape {t.shape} differs from "
                    f"base.{label} {b.shape}"
                )
        term_data.append(data)
    vertices = [
        tuple(
            b + sum(pi * t[i] for pi, t in zip(point, term_data))
            for i, b in enumerate(base_data)
        )
        for point in domain.points
    ]
    kwargs = dict(kwargs)
    if isinstance(base, StateSpace):
        kwargs.setdefault("inputs", base.input_labels)
        kwargs.setdefault("outputs", base.output_labels)
        kwargs.setdefault("states", base.state_labels)
        kwargs.setdefault("name", base.name)
        base_dt = base.dt
        if base_dt is not None and "dt" in kwargs:
            if not same_dt(as_dt(base_dt, "base.dt"), as_dt(kwargs["dt"])):
                raise ValueError(
                    f"dt: {kwargs['dt']!r} differs from the timebase of base "
                    f"(dt = {base_dt!r})"
                )
        elif base_dt is not None:
            kwargs["dt"] = base_dt
    return vertices, domain, kwargs
