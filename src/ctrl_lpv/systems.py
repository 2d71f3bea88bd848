"""Polytopic LPV systems as python-control `StateSpace` objects."""

from __future__ import annotations

import sys as _sys
import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from control import NonlinearIOSystem, StateSpace

from ._checks import as_ss_data, flag, real_number, signal_labels, signal_name
from .exceptions import NominalPointWarning, ParameterClipWarning
from .polytope import ParameterBox, Polytope, Simplex

__all__ = ["PolytopicStateSpace", "pss"]

Scheduling = None | str | Callable


# ----------------------------------------------------------------------
# Who reads the matrices: python-control's linear tools read ``sys.A, B, C,
# D`` directly (no method receives ``params``), so the matrices are
# properties that look at the calling frames. Nothing in python-control is
# patched: the lookup only reads the frames of the current call.
# ----------------------------------------------------------------------
def _module(frame) -> str:
    return frame.f_globals.get("__name__", "") if frame is not None else ""


def _in(package: str, module: str) -> bool:
    return module == package or module.startswith(package + ".")


def _given(params) -> bool:
    """Whether a ``params`` argument asks for something (not None or {})."""
    return params is not None and not (isinstance(params, Mapping) and not params)


def _reader(frame):
    """Classify the code reading a polytopic system's matrices.

    Walks up from `frame` over python-control's frames (and the numpy or
    scipy frames between them) and returns ``(entry, caller, params)``: the
    outermost python-control frame of the call (None for a direct attribute
    access), the first frame outside these packages, and the ``params``
    argument of an enclosing time response of `control.timeresp`
    (``forced_response``, ``step_response``, ``initial_response``, ...), or
    None.
    """
    entry, params = None, None
    # numpy and scipy frames are crossed too: python-control's lambdas run
    # inside scipy.optimize (``bandwidth``) or numpy callbacks.
    while frame is not None and any(
        _in(pkg, _module(frame)) for pkg in ("control", "numpy", "scipy")
    ):
        if not _in("control", _module(frame)):
            frame = frame.f_back
            continue
        if (
            params is None
            and _module(frame) == "control.timeresp"
            and "params" in frame.f_code.co_varnames
        ):
            value = frame.f_locals.get("params")
            if _given(value):
                params = value
        entry = frame
        frame = frame.f_back
    return entry, frame, params


def _user_frame(frame):
    """First frame outside python-control, scipy, numpy and ctrl_lpv."""
    while frame is not None and any(
        _in(pkg, _module(frame)) for pkg in ("control", "scipy", "numpy", "ctrl_lpv")
    ):
        frame = frame.f_back
    return frame


def _warn_at(message: str, category, frame) -> None:
    """Issue a warning attributed to the line of `frame`."""
    if frame is None:
        warnings.warn(message, category, stacklevel=3)
        return
    module_globals = frame.f_globals
    warnings.warn_explicit(
        message,
        category,
        frame.f_code.co_filename,
        frame.f_lineno,
        module=module_globals.get("__name__"),
        registry=module_globals.setdefault("__warningregistry__", {}),
    )


def _call_name(entry, attribute: str) -> str:
    """User-facing name of the python-control call (or attribute) reading."""
    if entry is None:
        return f"reading sys.{attribute}"
    code = entry.f_code
    qualname = getattr(code, "co_qualname", code.co_name)
    if qualname.endswith("__call__"):
        return "sys(s)"
    return f"{_module(entry)}.{qualname}"


# The last nominal-point warning, so that one call warns once, whatever
# systems it reads: (the frame of the call, line for direct accesses).
_last_nominal_warning: list = [None]


def _matrix_property(index: int, label: str) -> property:
    def getter(self):
        return self._matrices_for(_sys._getframe(1), label)[index]

    def setter(self, value):
        data = list(self.__dict__.get("_ss_data", (None,) * 4))
        data[index] = value
        self.__dict__["_ss_data"] = tuple(data)

    return property(
        getter,
        setter,
        doc=f"""``{label}`` matrix at the nominal point `nominal` (see the class).

        Read by python-control's linear tools, which then warn with
        `NominalPointWarning`; inside a time response with ``params`` it is
        ``sys.at(params).{label}``.""",
    )


class PolytopicStateSpace(StateSpace):
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
            vertices = _ordered_vertices(vertices, domain)
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
        data = tuple(_ss_data(v, f"vertices[{j}]") for j, v in enumerate(vertices))
        dt = _common_dt(vertices, kwargs.pop("dt", _UNSET))
        shapes = [tuple(m.shape for m in d) for d in data]
        for j, shape in enumerate(shapes[1:], start=1):
            if shape != shapes[0]:
                raise ValueError(
                    f"vertices[{j}]: dimensions {shape} differ from "
                    f"vertices[0] {shapes[0]} (A, B, C, D shapes)"
                )
        self._data = data
        self.domain = _as_domain(domain, len(data))
        _check_vertex_order(vertices, self.domain)
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

        first = next((v for v in vertices if isinstance(v, StateSpace)), None)
        n, m = data[0][1].shape
        ny = data[0][2].shape[0]
        inputs = kwargs.pop("inputs", first.input_labels if first else m)
        outputs = kwargs.pop("outputs", first.output_labels if first else ny)
        states = kwargs.pop("states", first.state_labels if first else n)
        name = kwargs.pop("name", None)
        if kwargs:
            raise TypeError(f"unexpected keyword arguments: {sorted(kwargs)}")
        # python-control's own message for a repeated or missing name is a
        # dimension mismatch of A, B or C: check the names here instead.
        inputs = signal_labels(inputs, m, "inputs") or inputs
        outputs = signal_labels(outputs, ny, "outputs") or outputs
        states = signal_labels(states, n, "states") or states
        if name is not None:
            signal_name(name, "name")

        # Physical signal names, checked by building the nominal system once.
        delta0 = self.domain._weights(self.nominal)
        frozen = StateSpace(
            *self._combine(delta0),
            inputs=inputs,
            outputs=outputs,
            states=states,
            name=name,
            dt=dt,
            remove_useless_states=False,
        )
        self._physical_inputs = tuple(frozen.input_labels)
        self.vertices = tuple(
            StateSpace(
                *d,
                inputs=frozen.input_labels,
                outputs=frozen.output_labels,
                states=frozen.state_labels,
                name=f"{frozen.name}[{j}]",
                dt=dt,
                remove_useless_states=False,
            )
            for j, d in enumerate(data)
        )
        # Stacked [A B] and [C D] for the hot path: one matmul per call.
        self._AB = np.stack([np.hstack(d[:2]) for d in data])
        self._CD = np.stack([np.hstack(d[2:]) for d in data])

        A0, B0, C0, D0 = self._combine(delta0)
        sched_inputs = list(self.domain.names) if self.scheduling == "inputs" else []
        k = len(sched_inputs)
        super().__init__(
            A0,
            np.hstack([B0, np.zeros((n, k))]),
            C0,
            np.hstack([D0, np.zeros((ny, k))]),
            inputs=list(frozen.input_labels) + sched_inputs,
            outputs=frozen.output_labels,
            states=frozen.state_labels,
            name=frozen.name,
            params=dict(zip(self.domain.names, self.nominal.tolist())),
            dt=dt,
            remove_useless_states=False,
        )
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
        _affine_size_or_raise(bounds)
        domain = bounds if isinstance(bounds, ParameterBox) else ParameterBox(bounds)
        base_data = _ss_data(base, "base")
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
            data = _ss_data(term, f"terms[{pname!r}]")
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
        if isinstance(base, StateSpace):
            kwargs.setdefault("inputs", base.input_labels)
            kwargs.setdefault("outputs", base.output_labels)
            kwargs.setdefault("states", base.state_labels)
            kwargs.setdefault("name", base.name)
            base_dt = base.dt
            if base_dt is not None and "dt" in kwargs:
                if not _same_dt(_as_dt(base_dt, "base.dt"), _as_dt(kwargs["dt"])):
                    raise ValueError(
                        f"dt: {kwargs['dt']!r} differs from the timebase of base "
                        f"(dt = {base_dt!r})"
                    )
            elif base_dt is not None:
                kwargs["dt"] = base_dt
        return cls(vertices, domain, **kwargs)

    def _set_scheduling(self, scheduling: Scheduling) -> None:
        if not (scheduling is None or scheduling == "inputs" or callable(scheduling)):
            raise ValueError(
                "scheduling: expected None, 'inputs' or a callable f(t, x, u) -> p, "
                f"got {scheduling!r}"
            )
        self.scheduling = scheduling

    def scheduled(self, by: Scheduling) -> PolytopicStateSpace:
        """Return a copy with another scheduling source.

        Parameters
        ----------
        by : None, "inputs" or callable
            Where the parameter comes from in simulation: None, the system
            parameters ``params`` (a frozen parameter, default the nominal
            value); ``"inputs"``, one extra input per parameter, named after
            it and appended after the physical inputs; or a callable
            ``p = f(t, x, u)`` of time, state and physical input returning
            the parameter values (array in the domain's order, or a dict
            ``{name: value}``). Scheduled values outside the domain are
            projected onto it.

        Returns
        -------
        `PolytopicStateSpace`
            The same vertices, domain, nominal point, name and signal
            names (plus the scheduling inputs for ``"inputs"``), with
            `scheduling` set to `by`.

        Raises
        ------
        ValueError
            If `by` is not None, ``"inputs"`` or a callable.
        """
        return PolytopicStateSpace(
            self.vertices,
            self.domain,
            scheduling=by,
            nominal=self.nominal,
            name=self.name,
        )

    # ------------------------------------------------------------------
    # Polytopic data
    # ------------------------------------------------------------------
    @property
    def nvertices(self) -> int:
        """Number of vertices ``N``."""
        return len(self._data)

    @property
    def nparams(self) -> int:
        """Number of scheduling parameters."""
        return self.domain.nparams

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the scheduling parameters."""
        return self.domain.names

    @property
    def physical_inputs(self) -> tuple[str, ...]:
        """Input labels without the scheduling inputs."""
        return self._physical_inputs

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Convex coordinates ``delta(p)``, shape ``(N,)``.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value (for a simplex domain: the coordinates).
        clip : bool, optional
            Project `p` onto the domain instead of raising.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            If `p` has the wrong size or lies outside the domain.
        """
        return self.domain.weights(p, clip=flag(clip, "clip"))

    def _combine(self, delta: np.ndarray) -> tuple[np.ndarray, ...]:
        return tuple(
            np.tensordot(delta, np.stack([d[i] for d in self._data]), axes=1)
            for i in range(4)
        )

    def at(self, p, name: str | None = None) -> StateSpace:
        """Frozen system at parameter value `p`.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value inside the domain.
        name : str, optional
            Name of the returned system.

        Returns
        -------
        `control.StateSpace`
            With the physical inputs, outputs and states of this system.
        """
        delta = self.weights(p)
        first = self.vertices[0]
        return StateSpace(
            *self._combine(delta),
            inputs=first.input_labels,
            outputs=first.output_labels,
            states=first.state_labels,
            name=name,
            dt=self.dt,
            remove_useless_states=False,
        )

    def vertex_data(self) -> tuple[tuple[np.ndarray, ...], ...]:
        """Vertex matrices ``((A_j, B_j, C_j, D_j), ...)`` as float arrays."""
        return tuple(tuple(m.copy() for m in d) for d in self._data)

    # ------------------------------------------------------------------
    # The StateSpace matrices: nominal, or frozen at a time response's params
    # ------------------------------------------------------------------
    A = _matrix_property(0, "A")
    B = _matrix_property(1, "B")
    C = _matrix_property(2, "C")
    D = _matrix_property(3, "D")

    def _matrices_for(self, frame, attribute: str) -> tuple[np.ndarray, ...]:
        """The matrices as the code at `frame` should see them.

        Inside a `control.timeresp` call given ``params`` (the linear path of
        `control.forced_response`, which `step_response` and
        `initial_response` use): the frozen system at ``params``. Otherwise
        the nominal matrices, with a `NominalPointWarning` when the reader is
        not ctrl_lpv itself.
        """
        entry, caller, params = _reader(frame)
        if params is not None:
            return self._frozen_for_params(params, entry, caller)
        if not _in("ctrl_lpv", _module(caller)):
            self._warn_nominal(entry, caller, _call_name(entry, attribute))
        return self._ss_data

    def _nominal_text(self) -> str:
        point = dict(zip(self.domain.names, self.nominal.tolist()))
        return f"p = {point} ({self._nominal_source})"

    def _warn_nominal(self, entry, caller, what: str, detail: str = "") -> None:
        """Warn once per call that `what` reads the nominal frozen system."""
        anchor = entry if entry is not None else caller
        line = None if entry is not None or caller is None else caller.f_lineno
        last = _last_nominal_warning[0]
        if last is not None and last[0] is anchor and last[1] == line:
            return
        _last_nominal_warning[0] = (anchor, line)
        message = detail or (
            f"{what}: the polytopic system {self.name!r} is read at its nominal "
            f"point {self._nominal_text()}, i.e. as the frozen system "
            "sys.at(sys.nominal), not as the LPV system; use sys.at(p) to "
            "choose the point (time responses: params={...})"
        )
        _warn_at(message, NominalPointWarning, caller)

    def _params_point(self, params) -> tuple[np.ndarray, list[str]]:
        """Parameter point of a ``params`` dict; missing names are nominal.

        Raises
        ------
        TypeError, ValueError
            Naming ``params`` when it is not a mapping, names none of the
            parameters, or holds a value that is not a finite real number.
        """
        if not isinstance(params, Mapping):
            raise TypeError(
                "params: expected a dict {parameter name: value}, got "
                f"{type(params).__name__}"
            )
        names = self.domain.names
        if not any(name in params for name in names):
            raise ValueError(
                f"params: none of {sorted(map(str, params))} is a parameter of "
                f"{self.name!r}; its parameters are {list(names)}"
            )
        values = []
        for name, nominal in zip(names, self.nominal):
            values.append(real_number(params.get(name, nominal), f"params[{name!r}]"))
        return np.array(values), [name for name in names if name not in params]

    def _inside_or_raise(self, point: np.ndarray, label: str = "params") -> None:
        if not self.domain.contains(point):
            values = dict(zip(self.domain.names, point.tolist()))
            raise ValueError(
                f"{label}: {values} is outside the domain {self.domain!r} of "
                f"{self.name!r}; a frozen parameter value must lie in it"
            )

    def _frozen_for_params(self, params, entry, caller) -> tuple[np.ndarray, ...]:
        if self.scheduling is not None:
            how = "its inputs" if self.scheduling == "inputs" else "a callable"
            raise ValueError(
                f"params: {self.name!r} is scheduled by {how}, so params= does "
                "not freeze its parameter; use sys.at(p) for the frozen system "
                "or control.input_output_response for the scheduled simulation"
            )
        point, missing = self._params_point(params)
        self._inside_or_raise(point)
        if missing and not _in("ctrl_lpv", _module(caller)):
            nominal = {
                n: float(v)
                for n, v in zip(self.domain.names, self.nominal)
                if n in missing
            }
            self._warn_nominal(
                entry,
                caller,
                "params",
                detail=(
                    f"params: {missing} not given for {self.name!r}; the nominal "
                    f"value(s) {nominal} are used"
                ),
            )
        return self._combine(self.domain._weights(point))

    def linearize(self, x0, u0=None, t=0, params=None, **kwargs):
        """Linearize about ``(x0, u0)``, frozen at ``params``.

        With ``scheduling=None`` the result is the frozen system at ``params``
        (``sys.at(params)`` with the scheduling inputs, if any); without
        ``params`` it is the nominal one, with a `NominalPointWarning`. With
        a scheduling by inputs or by a callable it is the Jacobian of the
        scheduled (quasi-LPV) dynamics at ``(x0, u0)``.

        Parameters
        ----------
        x0 : array_like or `control.OperatingPoint`
            State at which to linearize (need not be an equilibrium); an
            operating point gives both the state and the input.
        u0 : array_like, optional
            Input at which to linearize, one entry per input of this system
            (physical inputs, then the scheduling inputs for
            ``scheduling="inputs"``); default 0 (or the operating point's).
        t : float, optional
            Time of the linearization, default 0 (it matters only for a
            time-dependent scheduling callable).
        params : dict, optional
            ``{parameter name: value}`` at which the matrices are frozen
            with ``scheduling=None``; names that are missing keep their
            nominal value (with a `NominalPointWarning`). Default: the
            nominal point, with a `NominalPointWarning`. Ignored by the
            dynamics with a scheduling by inputs or by a callable.
        **kwargs
            Passed to `control.NonlinearIOSystem.linearize`: ``eps``
            (finite-difference step, default 1e-6), ``copy_names``
            (copy the signal names, default False), ``name``, ``inputs``,
            ``outputs``, ``states``.

        Returns
        -------
        `control.StateSpace`
            The linearization, computed by finite differences.

        Raises
        ------
        TypeError
            If `params` is not a mapping or holds a value that is not a
            real number.
        ValueError
            If `params` names none of the parameters, or lies outside the
            domain.
        """
        if self.scheduling is None:
            entry, caller, _ = _reader(_sys._getframe(1))
            if _given(params):
                point, missing = self._params_point(params)
                self._inside_or_raise(point)
                if missing and not _in("ctrl_lpv", _module(caller)):
                    self._warn_nominal(
                        entry,
                        caller,
                        "linearize",
                        detail=f"params: {missing} not given; nominal value used",
                    )
            elif not _in("ctrl_lpv", _module(caller)):
                self._warn_nominal(entry, caller, _call_name(entry, "linearize"))
        return super().linearize(x0, u0, t=t, params=params, **kwargs)

    def _repr_html_(self):
        return StateSpace._repr_html_(self)

    def _repr_eval_(self):
        return StateSpace._repr_eval_(self)

    # ------------------------------------------------------------------
    # Nonlinear I/O behaviour: the scheduled matrices
    # ------------------------------------------------------------------
    def _update_params(self, params):
        super()._update_params(params)
        self._clip_warned = False
        # Parameters from the params dict are constant during a simulation:
        # combine the vertex matrices once, not on every RHS call. Names that
        # are not parameters of this system are ignored (python-control
        # passes one dict to every block of an interconnection).
        if self.scheduling is None:
            if _given(params):
                # A block of an interconnection always receives its own
                # names; a direct call naming none of them is a typo.
                self._params_point(params)
            own = {k: self._current_params[k] for k in self.domain.names}
            point, _ = self._params_point(own)
            self._inside_or_raise(point)
            self._params_delta = self.domain._weights(point)
            self._params_AB = np.tensordot(self._params_delta, self._AB, axes=1)
            self._params_CD = np.tensordot(self._params_delta, self._CD, axes=1)

    def _scheduled_point(self, value) -> np.ndarray:
        """Parameter point returned by a scheduling callable (dict or array)."""
        names = self.domain.names
        if type(value) is np.ndarray and value.shape == (len(names),):
            return value.astype(float, copy=False)
        if isinstance(value, Mapping):
            if set(value) != set(names):
                raise ValueError(
                    f"scheduling: the callable returned keys {sorted(map(str, value))}"
                    f"; expected the parameter names {list(names)}"
                )
            value = [value[name] for name in names]
        point = np.asarray(value, dtype=float).reshape(-1)
        if point.size != len(names):
            raise ValueError(
                f"scheduling: the callable returned {point.size} value(s); expected "
                f"{len(names)} for the parameters {list(names)}"
            )
        return point

    def _delta(self, t, x, u) -> np.ndarray:
        if self.scheduling is None:
            return self._params_delta
        if self.scheduling == "inputs":
            point = u[len(self._physical_inputs) :]
            source = "scheduling input"
        else:
            point = self._scheduled_point(
                self.scheduling(t, x, u[: len(self._physical_inputs)])
            )
            source = "scheduling callable"
        delta, report = self.domain._weights_report(point)
        if report is None:
            return delta
        if not np.all(np.isfinite(point)):
            values = dict(zip(self.domain.names, point.tolist()))
            raise ValueError(
                f"scheduling: non-finite parameter value {values} from the "
                f"{source} of {self.name!r} at t = {float(t):.6g}"
            )
        if not self._clip_warned:
            self._clip_warned = True
            _warn_at(
                f"{self.name!r}: the {source} gives {report} at t = {float(t):.6g}; "
                "it is projected onto the parameter domain (later values outside "
                "the domain in this simulation are projected without a warning)",
                ParameterClipWarning,
                _user_frame(_sys._getframe(1)),
            )
        return delta

    # The hot path: python-control passes float vectors; one matrix-vector
    # product per call when the parameter comes from `params`.
    def _rhs(self, t, x, u):
        if type(u) is not np.ndarray:
            u = np.asarray(u, dtype=float).reshape(-1)
        xu = np.concatenate((x, u[: len(self._physical_inputs)]))
        if self.scheduling is None:
            return self._params_AB @ xu
        return self._delta(t, x, u) @ (self._AB @ xu)

    def _out(self, t, x, u):
        if type(u) is not np.ndarray:
            u = np.asarray(u, dtype=float).reshape(-1)
        xu = np.concatenate((x, u[: len(self._physical_inputs)]))
        if self.scheduling is None:
            return self._params_CD @ xu
        return self._delta(t, x, u) @ (self._CD @ xu)

    @property
    def _feedthrough(self) -> np.ndarray:
        """Which inputs reach the outputs directly, ``(noutputs, ninputs)``.

        Read by `ctrl_lpv.interconnect`: ``D != 0`` at some vertex for the
        physical inputs; when ``C`` or ``D`` vary over the vertices, the
        scheduling inputs (``"inputs"``) or, through a callable
        ``f(t, x, u)``, all physical inputs reach the varying output rows.
        """
        n = self.nstates
        direct = np.any(self._CD[:, :, n:] != 0.0, axis=0)
        varying = np.any(self._CD != self._CD[:1], axis=(0, 2))[:, None]
        if self.scheduling == "inputs":
            k = self.ninputs - direct.shape[1]
            return np.hstack([direct, np.repeat(varying, k, axis=1)])
        if callable(self.scheduling):
            return direct | varying
        return direct

    def _checked_call(self, method, t, x, u, params):
        x = np.asarray(x, dtype=float).reshape(-1)
        u = np.zeros(self.ninputs) if u is None else np.asarray(u, float).reshape(-1)
        if x.size != self.nstates:
            raise ValueError(f"x: expected {self.nstates} states, got {x.size}")
        if u.size != self.ninputs:
            raise ValueError(f"u: expected {self.ninputs} inputs, got {u.size}")
        self._update_params(params)
        return method(t, x, u)

    def dynamics(self, t, x, u=None, params=None):
        """State derivative (continuous time) or next state (discrete time).

        Parameters
        ----------
        t : float
            Time (used by a callable scheduling).
        x : array_like
            State.
        u : array_like, optional
            Input (physical, then scheduling inputs); zero if omitted.
        params : dict, optional
            Parameter values (for ``scheduling=None``).

        Returns
        -------
        ndarray
        """
        return self._checked_call(self._rhs, t, x, u, params)

    def output(self, t, x, u=None, params=None):
        """Output of the scheduled system (see `dynamics`)."""
        return self._checked_call(self._out, t, x, u, params)

    # ------------------------------------------------------------------
    # python-control operations: stay polytopic or refuse
    # ------------------------------------------------------------------
    def _vertexwise(self, operation, other=None, label="operation"):
        """Apply `operation` per vertex and check the result is polytopic.

        The vertex-wise result equals the operation on the interpolated
        system only where the operation is affine in the vertex data; this
        is checked at interior points rather than assumed.
        """
        if self.scheduling is not None and callable(self.scheduling):
            raise TypeError(
                f"{label}: a system scheduled by a callable of its state cannot be "
                "combined vertex by vertex; combine the unscheduled system and "
                "schedule the result with .scheduled()"
            )
        if isinstance(other, PolytopicStateSpace):
            if other.domain != self.domain:
                raise TypeError(
                    f"{label}: the two polytopic systems have different parameter "
                    "domains; their combination is not polytopic"
                )
            results = [operation(v, w) for v, w in zip(self.vertices, other.vertices)]

            def interpolated(delta):
                return operation(self._frozen(delta), other._frozen(delta))

        else:
            results = [operation(v, other) for v in self.vertices]

            def interpolated(delta):
                return operation(self._frozen(delta), other)

        if not all(isinstance(r, StateSpace) for r in results):
            return NotImplemented
        out_data = [_ss_data(r, label) for r in results]
        rng = np.random.default_rng(0)
        checks = [np.full(self.nvertices, 1.0 / self.nvertices)]
        checks += list(rng.dirichlet(np.ones(self.nvertices), size=2))
        for delta in checks:
            expected = _ss_data(interpolated(delta), label)
            for got, ref in zip(_combine_data(out_data, delta), expected):
                if got.shape != ref.shape or not np.allclose(
                    got, ref, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(ref).max())
                ):
                    raise TypeError(
                        f"{label}: the result is not affine in the vertex data, so "
                        "it is not a polytopic system over the same domain; apply "
                        "it to a frozen system sys.at(p) instead"
                    )
        return PolytopicStateSpace(
            results,
            self.domain,
            scheduling=self.scheduling,
            nominal=self.nominal,
        )

    def _frozen(self, delta) -> StateSpace:
        return StateSpace(
            *self._combine(delta), dt=self.dt, remove_useless_states=False
        )

    def _binary(self, other, op, label):
        if isinstance(other, NonlinearIOSystem) and not isinstance(other, StateSpace):
            # A nonlinear partner: python-control's interconnection keeps this
            # system's scheduled dynamics.
            return getattr(NonlinearIOSystem, f"__{label}__")(self, other)
        return self._vertexwise(op, other, label=label)

    def __neg__(self):
        return self._vertexwise(lambda v, _: -v, label="neg")

    def __add__(self, other):
        return self._binary(other, lambda v, w: v + w, "add")

    def __radd__(self, other):
        return self._binary(other, lambda v, w: w + v, "radd")

    def __sub__(self, other):
        return self._binary(other, lambda v, w: v - w, "sub")

    def __rsub__(self, other):
        return self._binary(other, lambda v, w: w - v, "rsub")

    def __mul__(self, other):
        return self._binary(other, lambda v, w: v * w, "mul")

    def __rmul__(self, other):
        return self._binary(other, lambda v, w: w * v, "rmul")

    def __truediv__(self, other):
        return self._vertexwise(lambda v, w: v / w, other, label="truediv")

    def __rtruediv__(self, other):
        raise TypeError("division by a polytopic system is not polytopic")

    def __pow__(self, other):
        if other == 1:
            return self.scheduled(self.scheduling)
        raise TypeError("powers of a polytopic system are not polytopic")

    def __getitem__(self, key):
        return self._vertexwise(lambda v, _: v[key], label="getitem")

    def feedback(self, other=1, sign=-1):
        """Feedback interconnection, kept polytopic where exact.

        The closed loop of the vertices is the closed loop of the polytopic
        system only when it is affine in the vertex data (for example a
        constant input matrix with a static output feedback); otherwise a
        `TypeError` is raised.
        """
        return self._vertexwise(lambda v, w: v.feedback(w, sign), other, "feedback")

    def append(self, other):
        """Block-diagonal append, kept polytopic."""
        return self._vertexwise(lambda v, w: v.append(w), other, "append")

    def lft(self, other, nu=-1, ny=-1):
        """Linear fractional transformation, kept polytopic where exact."""
        return self._vertexwise(lambda v, w: v.lft(w, nu, ny), other, "lft")

    def sample(
        self,
        Ts,
        method="zoh",
        alpha=None,
        prewarp_frequency=None,
        name=None,
        copy_names=True,
        **kwargs,
    ):
        """Discretize vertex by vertex, with a bound on the error between them.

        Same signature as `control.StateSpace.sample` (so
        `control.sample_system` works too). The zero-order hold of the
        frozen system at ``p`` is not the interpolation of the vertices'
        ZOH (``expm`` is not affine), so the result carries a rigorous
        bound on that difference: ``sysd.discretization_error``, a
        `DiscretizationBound` with ``phi >= sup_p ||Phi(p) - sum_j
        delta_j(p) Phi_j||_2`` and ``gamma`` the same for ``Gamma``, where
        ``Phi(p), Gamma(p)`` is the ZOH of ``sys.at(p)`` (``C, D`` are
        unchanged, hence exact). The bound is second order in the period
        and the parameter range, derived in scaled norms (Lyapunov and
        balanced) where the 2-norm's logarithmic norm would overstate the
        growth; on a `ParameterBox` or a `Simplex` it is the error computed
        on a grid of about 1000 points plus a rigorous remainder for the
        cells between them (the derivation is in
        `ctrl_lpv.discretization`). Measured on a quarter car and on the
        two-mass drive at 0.5 to 10 ms
        (``benchmarks/study_discretization_bound.py``): 1.00 to 1.16 times
        the largest error on a dense grid with one or two parameters, up to
        2.9 times with three. It is looser with many parameters (the grid
        coarsens: none from 7 parameters on), for long periods, and on a
        `Polytope` (no grid: 36 to 49 times for ``Phi``, 45 to 600 for
        ``Gamma`` on the quarter car at 0.5, 2 and 10 ms). The bound is 0 for a
        single vertex (an LTI system) and for ``method="euler"``, whose
        model ``(I + T A_j, T B_j)`` is affine in the vertex data, hence
        exactly polytopic. A period too long for a meaningful bound gives a
        `UserWarning` (and ``inf`` where the growth factor overflows, never
        NaN).

        Use the bound to account for the sampling: the true sampled frozen
        system is ``sum_j delta_j (Phi_j, Gamma_j) + (E_Phi, E_Gamma)`` with
        ``||E_Phi|| <= phi``, ``||E_Gamma|| <= gamma``, a norm-bounded
        uncertainty.

        Parameters
        ----------
        Ts : float
            Sampling period, positive.
        method : {"zoh", "euler"}, optional
            Zero-order hold (default) or forward Euler. The other methods
            of python-control (``"bilinear"``, ``"tustin"``,
            ``"backward_diff"``, ``"gbt"`` with ``alpha != 0``) involve a
            matrix inverse, not affine in the vertex data, and have no
            bound here: a `ValueError`.
        alpha : float, optional
            For ``method="gbt"``: only ``alpha = 0`` (forward Euler) is
            accepted. Ignored otherwise, as in python-control.
        prewarp_frequency : float, optional
            Ignored with a warning (as python-control does for methods
            other than bilinear).
        name : str, optional
            Name of the result; default the name of this system with
            python-control's sampled-system prefix and suffix
            (``"$sampled"``) when `copy_names`.
        copy_names : bool, optional
            Copy the signal names (default True).
        **kwargs
            ``inputs``, ``outputs``, ``states``: signal names of the result
            (physical inputs only).

        Returns
        -------
        `PolytopicStateSpace`
            Discrete time with ``dt = Ts``, the same domain, nominal point
            and scheduling, and the attribute ``discretization_error`` (not
            kept by operations that build a new system from it).

        Raises
        ------
        ValueError
            If this system is already discrete time, `Ts` is not positive,
            `method` is not ``"zoh"`` or ``"euler"``, or the ZOH of a vertex
            overflows (`Ts` too long for an unstable vertex).

        Warns
        -----
        UserWarning
            If a bound is not below the largest norm of the sampled vertex
            matrices, or is ``inf``: `Ts` is too long for a meaningful bound.
        """
        import control as _ct

        from ._checks import real_number
        from .discretization import sampled_vertex_data

        if not self.isctime(strict=True):
            raise ValueError(
                "sample: the system is already discrete time "
                f"(dt = {self.dt!r}); sampling needs a continuous-time system"
            )
        Ts = real_number(Ts, "Ts", positive=True)
        if method == "gbt" and alpha in (0, 0.0):
            method = "euler"
        if method not in ("zoh", "euler"):
            raise ValueError(
                f"method: {method!r} is not available for a polytopic system: "
                "only 'zoh' (with a certified bound on the error between the "
                "vertices) and 'euler' (exactly polytopic) are; the other "
                "discretizations involve a matrix inverse, not affine in the "
                "vertex data, and have no error bound here"
            )
        if prewarp_frequency is not None:
            warnings.warn(
                "prewarp_frequency ignored: incompatible conversion",
                UserWarning,
                stacklevel=2,
            )
        unknown = sorted(set(kwargs) - {"inputs", "outputs", "states"})
        if unknown:
            raise TypeError(f"unexpected keyword arguments: {unknown}")
        vertices, bound = sampled_vertex_data(self._data, self.domain, Ts, method)
        first = self.vertices[0]
        if copy_names:
            defaults = _ct.config.defaults
            labels = {
                "inputs": list(first.input_labels),
                "outputs": list(first.output_labels),
                "states": list(first.state_labels),
                "name": name
                if name is not None
                else defaults["iosys.sampled_system_name_prefix"]
                + self.name
                + defaults["iosys.sampled_system_name_suffix"],
            }
        else:
            labels = {
                "inputs": first.ninputs,
                "outputs": first.noutputs,
                "states": first.nstates,
                "name": name,
            }
        labels.update(kwargs)
        result = PolytopicStateSpace(
            vertices,
            self.domain,
            scheduling=self.scheduling,
            nominal=self.nominal,
            dt=Ts,
            **labels,
        )
        result.discretization_error = bound
        return result

    def minreal(self, *args, **kwargs):
        """Not available: vertex realizations would differ.

        Raises
        ------
        TypeError
            Always; use ``sys.at(p).minreal()`` for a frozen system.
        """
        raise TypeError(
            "minreal: a minimal realization per vertex would break the common "
            "state basis; use sys.at(p).minreal() for a frozen parameter value"
        )

    def returnScipySignalLTI(self, *args, **kwargs):  # noqa: N802 (python-control name)
        """Not available: scipy's LTI classes are frozen systems."""
        raise TypeError(
            "returnScipySignalLTI: use sys.at(p).returnScipySignalLTI() for a "
            "frozen parameter value"
        )

    def __str__(self) -> str:
        sched = (
            "params"
            if self.scheduling is None
            else "inputs"
            if self.scheduling == "inputs"
            else "callable"
        )
        head = (
            f"PolytopicStateSpace: {self.name}, {self.nvertices} vertices over "
            f"{self.domain!r}, scheduled by {sched}\n"
            f"Nominal p = {dict(zip(self.domain.names, self.nominal.tolist()))} "
            "(the A, B, C, D below)\n"
        )
        return head + StateSpace.__str__(self)

    def __repr__(self) -> str:
        return (
            f"<PolytopicStateSpace {self.name}: {self.nvertices} vertices, "
            f"{self.nstates} states, inputs {list(self.input_labels)}, "
            f"outputs {list(self.output_labels)}"
            + (f", dt={self.dt}" if self.isdtime(strict=True) else "")
            + ">"
        )


_UNSET = object()


#: Most parameters `PolytopicStateSpace.from_affine` accepts: a box of
#: ``k`` parameters has ``2**k`` vertices (4096 for 12), each a system to
#: build and, in a synthesis, at least one LMI.
MAX_AFFINE_PARAMETERS = 12


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


def _as_dt(value, name: str = "dt"):
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


def _same_dt(a, b) -> bool:
    """Equal timebases (``True`` differs from ``1.0``)."""
    return (a is True) == (b is True) and a == b


def _common_dt(vertices, given):
    """The timebase of the vertices, checked against a given ``dt``.

    Every `control.StateSpace` vertex must have the same ``dt`` (a vertex
    with ``dt=None`` takes the common one); tuples take `given`, or 0.
    """
    found, first = None, None
    for j, vertex in enumerate(vertices):
        own = getattr(vertex, "dt", None) if isinstance(vertex, StateSpace) else None
        if own is None:
            continue
        own = _as_dt(own, f"vertices[{j}].dt")
        if found is None:
            found, first = own, j
        elif not _same_dt(own, found):
            raise ValueError(
                f"vertices: vertices[{j}] has dt = {own!r} but vertices[{first}] "
                f"has dt = {found!r}; every vertex must have the same timebase"
            )
    if given is _UNSET:
        return 0 if found is None else found
    given = _as_dt(given, "dt")
    if found is not None and not _same_dt(given, found):
        raise ValueError(
            f"dt: {given!r} differs from the timebase of the vertex systems "
            f"(dt = {found!r})"
        )
    return given


def _ss_data(item, name: str) -> tuple[np.ndarray, ...]:
    """``(A, B, C, D)`` of a vertex, checked, whatever its timebase."""
    if isinstance(item, StateSpace):
        item = (item.A, item.B, item.C, item.D)
    return as_ss_data(item, name)


def _combine_data(data, delta):
    return tuple(
        np.tensordot(delta, np.stack([d[i] for d in data]), axes=1) for i in range(4)
    )


def _as_domain(domain, nvertices: int):
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


def _ordered_vertices(mapping: Mapping, domain) -> list:
    """Vertex systems given as ``{vertex point: system}``, in domain order."""
    if domain is None:
        raise TypeError(
            "vertices: a mapping {vertex point: system} needs a domain (a "
            "ParameterBox, Polytope or a mapping of bounds)"
        )
    dom = _as_domain(domain, len(mapping))
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


def _check_vertex_order(vertices: Sequence, domain) -> None:
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
