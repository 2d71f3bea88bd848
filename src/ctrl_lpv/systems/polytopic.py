"""The polytopic LPV system class, `PolytopicStateSpace`, and `pss`.

The class is a `control.StateSpace` assembled from one base per concept,
as python-control assembles `StateSpace` from `NonlinearIOSystem` and
`LTI`: the frozen view python-control's linear tools read
(`.nominal`), the scheduled I/O behaviour (`.scheduling`), the
block-diagram algebra (`.arithmetic`) and sampling (`.sampling`). This
module holds construction, the vertex data and display; vertex checks and
ordering are in `.vertices`, timebases in `.timebase`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from control import StateSpace

from ..polytope import ParameterBox
from .arithmetic import OperationsMixin
from .frozen import FrozenDataMixin, signal_names
from .nominal import NominalPointMixin
from .sampling import SamplingMixin
from .scheduling import Scheduling, SchedulingMixin
from .timebase import UNSET
from .vertices import (
    affine_vertices,
    as_domain,
    check_vertex_order,
    checked_vertex_data,
    ordered_vertices,
)

__all__ = ["PolytopicStateSpace", "pss"]


class PolytopicStateSpace(
    FrozenDataMixin,
    NominalPointMixin,
    SchedulingMixin,
    OperationsMixin,
    SamplingMixin,
    StateSpace,
):
    r"""Polytopic linear parameter-varying state-space system.

    .. math::

        \dot x = A(\delta) x + B(\delta) u, \quad
        y = C(\delta) x + D(\delta) u, \quad
        (A, B, C, D)(\delta) = \sum_{j=1}^N \delta_j (A_j, B_j, C_j, D_j),

    with convex coordinates :math:`\delta = \delta(p)` of a parameter `p` in a
    domain (a box of named bounds, a general polytope, or the simplex of the
    coordinates themselves).

    **Timebase.** As in python-control, ``dt = 0`` is continuous time and
    ``dt = True`` or a positive sampling period is discrete time,
    :math:`x[k+1] = A(\delta[k]) x[k] + B(\delta[k]) u[k]`. Every vertex has
    the same ``dt`` (taken from the vertex systems, or given with `dt`), and
    every system built from this one (`at`, `vertices`, `scheduled`,
    operations, `linearize`) keeps it; `isdtime` and `isctime` answer for
    it. `sample` discretizes a continuous-time system with a certified
    bound on the interpolation error (ZOH is not exact between vertices).

    It is a `control.StateSpace`: its matrices ``A, B, C, D`` are the frozen
    system at the `nominal` parameter value (default: the domain's center,
    the mean of its vertices), which is what python-control's linear tools
    (`poles`, `bode_plot`, `lqr`, ``sys(s)``, ...) see. Each such call
    issues one `NominalPointWarning` naming the nominal point; ``sys.at(p)``
    gives the frozen system at a point of your choice without a warning.
    python-control's time responses `control.step_response`,
    `control.forced_response`, `control.initial_response` and
    `control.step_info` given ``params={name: value}`` return the response
    of ``sys.at(params)`` (parameters missing from ``params`` keep their
    nominal value, with a warning); a ``params`` outside the domain, or
    naming none of the parameters, is a `ValueError`. The table of every
    python-control function is on :doc:`/python_control`.

    Its nonlinear I/O behaviour (`dynamics`, `output`, `linearize`,
    simulation with `control.input_output_response`) follows the scheduled
    matrices, with the parameter taken from one of three `scheduling`
    sources:

    * ``None`` (default): the system parameters ``params``, one entry per
      parameter name, default the nominal value (a frozen-parameter
      simulation at a value you choose with ``params={...}``; a value
      outside the domain is a `ValueError` naming ``params``);
    * ``"inputs"``: extra inputs, one per parameter, named after the
      parameters and appended after the physical inputs;
    * a callable ``p = f(t, x, u)`` of time, state and physical input
      (quasi-LPV), returning an array of the parameter values in the
      domain's order or a dict ``{name: value}``.

    A scheduled value (inputs or callable) outside the domain is projected
    onto it (a saturated scheduling signal), never extrapolated; the first
    one of each simulation issues a `ParameterClipWarning` naming the
    parameter, the value and the time. A non-finite scheduled value is a
    `ValueError`.

    **Vertex order.** The vertex systems correspond one to one, in order, to
    the vertices of the domain (``domain.points``). For a `ParameterBox` of
    ``k`` parameters these are the ``2**k`` corners with the first parameter
    varying slowest and each parameter at its lower bound first: for
    ``{"a": (a0, a1), "b": (b0, b1)}`` the order is ``(a0, b0), (a0, b1),
    (a1, b0), (a1, b1)``. A list in another order silently builds another
    system, so: give the vertices as a mapping ``{vertex point: system}``
    (``{(a0, b0): sys00, ...}``, a number for one parameter), which is
    matched to the domain's vertices and checked; or use `from_affine`,
    which builds them in order. Vertex `control.StateSpace` systems that
    carry ``params`` naming every parameter (``ct.ss(..., params={"k":
    1.0})``) are checked against the vertex of the same index.

    Operations that stay polytopic (negation, sums, products with LTI
    systems or gains, indexing, `append`, `feedback` where the closed loop is
    affine in the vertex data) return a `PolytopicStateSpace` computed vertex
    by vertex and checked at interior points; operations that would leave
    the polytopic class (`minreal`, products of two LPV systems with
    nonaffine result) raise `TypeError` instead of returning a frozen
    system; `sample` returns the vertexwise discretization together with a
    rigorous bound on its error between the vertices. Paths that
    python-control owns and that cannot be intercepted:

    * `control.interconnect` of blocks that are all `StateSpace` returns a
      `control.LinearICSystem`. Its simulation with
      `control.input_output_response` evaluates each block's own scheduled
      dynamics, so it keeps the LPV behaviour (and its ``params``); its
      ``A, B, C, D`` are python-control's linearization at ``x = 0, u = 0``
      and the nominal point (a frozen model), which its linear tools and
      its `control.step_response` use without a warning, ``params`` or not.
    * `control.ss(sys)`, ``control.StateSpace(sys)`` and
      ``G.feedback(sys)`` with a plain `StateSpace` ``G`` on the left read
      ``sys.A, B, C, D``: they convert to the frozen nominal system (with a
      `NominalPointWarning`). Use ``sys.at(p)`` to choose the point, or put
      `sys` on the left.

    Parameters
    ----------
    vertices : sequence or mapping of `control.StateSpace` or (A, B, C, D)
        Vertex systems, all of the same dimensions and timebase, in the
        order of the domain's vertices, or a mapping ``{vertex point:
        system}`` (see "Vertex order"). Signal names default to those of
        the first `StateSpace` vertex.
    domain : `ParameterBox`, `Polytope`, `Simplex` or mapping, optional
        Parameter domain whose vertices match `vertices` in number and order.
        A mapping ``{name: (lower, upper)}`` is a box. Default: the simplex of
        the convex coordinates.
    scheduling : None, "inputs" or callable, optional
        Source of the parameter in simulation (see above).
    nominal : array_like or mapping, optional
        Parameter value of the frozen matrices ``A, B, C, D``; default the
        domain's center.
    inputs, outputs, states : int, str or list of str, optional
        Signal names (physical inputs only), as in `control.ss`.
    name : str, optional
        System name.
    dt : 0, True or float, optional
        Timebase: 0 continuous time, True or a positive sampling period
        discrete time. Default: the ``dt`` of the vertex systems (0 for
        (A, B, C, D) tuples).

    Raises
    ------
    ValueError
        Vertices of different dimensions or timebases, a `dt` that differs
        from the vertices' or is not 0, True or positive, a vertex count
        that differs from the domain's, a mapping key that is not a vertex
        of the domain, a vertex whose ``params`` name another vertex, or a
        `nominal` outside the domain.

    Attributes
    ----------
    vertices : tuple of `control.StateSpace`
        The vertex systems (physical inputs only).
    domain : `ParameterBox`, `Polytope` or `Simplex`
        The parameter domain.
    nominal : ndarray
        Parameter value of the frozen ``A, B, C, D``.

    See Also
    --------
    pss, PolytopicStateSpace.from_affine

    Examples
    --------
    >>> import control as ct
    >>> v1 = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0)
    >>> v2 = ct.ss([[-3.0]], [[1.0]], [[1.0]], 0)
    >>> sys = PolytopicStateSpace([v1, v2], domain={"p": (0.0, 1.0)})
    >>> sys.at(0.5).A
    array([[-2.]])
    """

    def __init__(
        self,
        vertices,
        domain=None,
        *,
        scheduling: Scheduling = None,
        nominal=None,
        **kwargs,
    ):
        if isinstance(vertices, Mapping):
            vertices = ordered_vertices(vertices, domain)
        data, dt = checked_vertex_data(vertices, kwargs.pop("dt", UNSET))
        self._data = data
        self.domain = as_domain(domain, len(data))
        check_vertex_order(vertices, self.domain)
        self.nominal = (
            self.domain.center.copy()
            if nominal is None
            else self.domain._as_point(nominal)
        )
        self._nominal_source = (
            "the domain's center"
            if np.allclose(self.nominal, self.domain.center, rtol=1e-12, atol=0.0)
            else "nominal="
        )
        self._clip_warned = False
        if not self.domain.contains(self.nominal):
            raise ValueError(f"nominal: {self.nominal} is outside {self.domain!r}")
        self._set_scheduling(scheduling)

        labels = signal_names(vertices, data, kwargs)
        # Physical signal names, checked by building the nominal system once.
        frozen = self._name_points(data, labels, self.domain._weights(self.nominal), dt)
        args, kwargs = self._system_arguments(frozen, dt)
        super().__init__(*args, **kwargs)
        self._update_params(None)

    # ------------------------------------------------------------------
    # Construction helpers
    # ------------------------------------------------------------------
    @classmethod
    def from_affine(
        cls,
        base,
        terms: Mapping[str, object],
        bounds: Mapping[str, tuple[float, float]] | ParameterBox,
        **kwargs,
    ) -> PolytopicStateSpace:
        r"""Build a polytopic system from an affine parameter dependence.

        ``M(p) = M0 + sum_i p_i M_i`` for ``M = (A, B, C, D)`` over a box of
        named parameter bounds; the ``2**k`` vertices are ``M`` at the box
        corners.

        Parameters
        ----------
        base : `control.StateSpace` or (A0, B0, C0, D0)
            The system at ``p = 0``; signal names are taken from it.
        terms : mapping of str to `control.StateSpace` or (Ai, Bi, Ci, Di)
            The coefficient of each parameter; a scalar ``0`` stands for a
            zero matrix. Keys must be the parameter names in `bounds`.
        bounds : mapping of str to (float, float), or `ParameterBox`
            Parameter bounds.
        **kwargs
            Passed to `PolytopicStateSpace` (``scheduling``, ``nominal``,
            ``inputs``, ``outputs``, ``states``, ``name``, ``dt``). The
            timebase defaults to that of `base` when it is a
            `control.StateSpace`.

        Returns
        -------
        `PolytopicStateSpace`

        Raises
        ------
        ValueError
            For more than `MAX_AFFINE_PARAMETERS` (12) parameters: the box
            would have more than ``2**12 = 4096`` vertices, too many to
            build (and far too many LMIs for a synthesis).

        Examples
        --------
        >>> sys = PolytopicStateSpace.from_affine(
        ...     ([[-1.0]], [[1.0]], [[1.0]], 0),
        ...     {"p": ([[2.0]], 0, 0, 0)},
        ...     {"p": (-1.0, 0.0)},
        ... )
        >>> [float(v.A[0, 0]) for v in sys.vertices]
        [-3.0, -1.0]
        """
        vertices, domain, kwargs = affine_vertices(base, terms, bounds, kwargs)
        return cls(vertices, domain, **kwargs)

    # ------------------------------------------------------------------
    # Polytopic data
    # ------------------------------------------------------------------
    @property
    def nvertices(self) -> int:
        """Number of vertices ``N``."""
        return len(self._data)

    def _points_text(self) -> str:
        return f"{self.nvertices} vertices"

    def _points_repr(self) -> str:
        return f"{self.nvertices} vertices"


def pss(vertices, domain=None, **kwargs) -> PolytopicStateSpace:
    """Create a polytopic LPV state-space system.

    Short factory for `PolytopicStateSpace`, in the style of `control.ss`.

    Parameters
    ----------
    vertices : sequence of `control.StateSpace` or (A, B, C, D) tuples
        Vertex systems.
    domain : optional
        Parameter domain (see `PolytopicStateSpace`).
    **kwargs
        ``scheduling``, ``nominal``, ``inputs``, ``outputs``, ``states``,
        ``name``, ``dt``.

    Returns
    -------
    `PolytopicStateSpace`

    Examples
    --------
    >>> import control as ct
    >>> sys = pss([ct.rss(2, 1, 1), ct.rss(2, 1, 1)])
    >>> sys.nvertices
    2
    """
    return PolytopicStateSpace(vertices, domain, **kwargs)
