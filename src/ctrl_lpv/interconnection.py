"""Interconnections whose outputs are evaluated once per call.

`interconnect` builds a system with `control.interconnect` and replaces
python-control's fixed-point evaluation of the signals by the straight-line
code of an `EvaluationPlan` (`ctrl_lpv.evaluation_plan`), generated when
first simulated from the blocks' kernels (`ctrl_lpv.block_kernel`). The
same code drives the fused fast path of `ctrl_lpv.simulation.simulate`.
The kernels and plans are importable from here too.
"""

from __future__ import annotations

import control as ct
from control.nlsys import InterconnectedSystem
from control.statesp import LinearICSystem

from ._checks import real_number
from .block_kernel import BlockKernel, feedthrough, kernel_nlsys
from .evaluation_plan import EvaluationPlan, plan

__all__ = [
    "interconnect",
    "BlockKernel",
    "kernel_nlsys",
    "feedthrough",
    "plan",
    "EvaluationPlan",
    "FastInterconnectedSystem",
    "FastLinearICSystem",
]


class _FastMixin:
    """Outputs in one pass through a generated plan (see module doc)."""

    _fast_plan = None
    _fast_owner = None

    def _plan(self):
        # Built on first use and kept; rebuilt for a copy (deepcopy would
        # share the old subsystems' bound methods) or after set_*_map.  The
        # generated functions then shadow `_rhs` and `_out` on the instance,
        # so that python-control calls them without any wrapper.
        if self._fast_owner is not self:
            self._unbind()
            self._fast_plan = plan(self)
            self._fast_owner = self
            if self._fast_plan is not None:
                self._rhs, self._out = self._fast_plan.rhs, self._fast_plan.out
        return self._fast_plan

    def _rhs(self, t, x, u):
        p = self._plan()
        return super()._rhs(t, x, u) if p is None else p.rhs(t, x, u)

    def _out(self, t, x, u):
        p = self._plan()
        return super()._out(t, x, u) if p is None else p.out(t, x, u)

    def _unbind(self):
        self.__dict__.pop("_rhs", None)
        self.__dict__.pop("_out", None)

    def _invalidate(self):
        self._fast_owner = None
        self._unbind()

    def __getstate__(self):
        # Generated code is neither copied nor pickled: a copy builds its own.
        state = self.__dict__.copy()
        for key in ("_fast_plan", "_fast_owner", "_rhs", "_out"):
            state.pop(key, None)
        return state

    def set_connect_map(self, connect_map):
        super().set_connect_map(connect_map)
        self._invalidate()

    def set_input_map(self, input_map):
        super().set_input_map(input_map)
        self._invalidate()

    def set_output_map(self, output_map):
        super().set_output_map(output_map)
        self._invalidate()

    @property
    def algebraic_loop(self) -> bool:
        """True if outputs are found by python-control's iteration."""
        return self._plan() is None


class FastInterconnectedSystem(_FastMixin, InterconnectedSystem):
    """`control.InterconnectedSystem` with one-pass output evaluation.

    Created by `interconnect`; see there.
    """


class FastLinearICSystem(_FastMixin, LinearICSystem):
    """`control.LinearICSystem` with one-pass output evaluation.

    Created by `interconnect` when every block is a `control.StateSpace`.
    """


def system_plan(sys) -> EvaluationPlan | None:
    """The evaluation plan of `sys`: the one it keeps, or a new one.

    A system from `interconnect` builds its plan once and keeps it; any
    other system gets a plan of its own (None for an algebraic loop).
    """
    return sys._plan() if isinstance(sys, _FastMixin) else plan(sys)


_FAST_CLASS = {
    InterconnectedSystem: FastInterconnectedSystem,
    LinearICSystem: FastLinearICSystem,
}


def interconnect(syslist, connections=None, inplist=None, outlist=None, **kwargs):
    """Interconnect I/O systems, with one-pass output evaluation.

    Same signature, signal naming, connection rules, warnings and errors
    as `control.interconnect`, which builds the system.  The result is an
    instance of a subclass of the class `control.interconnect` returns
    (`control.InterconnectedSystem` or `control.LinearICSystem`) whose
    ``_rhs`` and ``_out`` evaluate each subsystem's outputs at most once
    per call, in a topological order of the direct-feedthrough graph,
    through code generated when first simulated.  Results agree with
    python-control's to rounding; use it with
    `control.input_output_response` or `ctrl_lpv.simulate`.

    Parameters
    ----------
    syslist : list of `control.NonlinearIOSystem`
        The subsystems.
    connections : list, False or None, optional
        Internal connections, one list ``[input_spec, output_spec, ...]``
        per subsystem input: the input is the sum of the listed outputs,
        each given as ``"sys.sig"``, ``"-sys.sig"`` (gain -1),
        ``("sys", "sig", gain)`` or index tuples, with lists and slices
        for vector signals. Default (None): every subsystem input is
        connected to the subsystem outputs of the same name (summed if
        several); False leaves the connection map empty.
    inplist : list, optional
        For each external input, the subsystem input(s) it drives
        (``"sys.sig"`` or a list of them). Default: the ``inputs`` keyword,
        whose names are matched to subsystem inputs.
    outlist : list, optional
        For each external output, the subsystem output(s) summed into it
        (``"sys.sig"``, ``"-sys.sig"``, a list of them). Default: the
        ``outputs`` keyword, whose names are matched to subsystem outputs.
    **kwargs
        Passed to `control.interconnect` (``inputs``, ``outputs``,
        ``states``, ``name``, ``params``, ``check_unused``, ...).

    Returns
    -------
    `FastInterconnectedSystem` or `FastLinearICSystem`

    Raises
    ------
    TypeError, ValueError
        For a `syslist` that is not a non-empty list of I/O systems with
        distinct names (python-control would rename a repeated name, so
        that ``"name.signal"`` silently means the first), a gain that is
        not a finite real number, and from `control.interconnect`, e.g. for
        a connection that names an unknown system or signal or is not a
        list.

    Notes
    -----
    Direct feedthrough: a subsystem may declare which of its inputs reach
    its outputs directly with an attribute ``_feedthrough`` (a bool or a
    ``(noutputs, ninputs)`` bool matrix); the two-mass plant and the
    controllers of this package do.  Without it a `control.StateSpace`
    feeds through where ``D != 0``, a system without output function does
    not, and any other system is assumed to feed every input through.  An
    undeclared nonlinear plant in a feedback loop therefore looks like an
    algebraic loop: the system then falls back on python-control's
    fixed-point iteration (attribute ``algebraic_loop`` is True), which is
    also what happens for a genuine algebraic loop.

    A subsystem that declares no feedthrough is evaluated with zero inputs
    when its outputs are needed before its inputs are known: the
    declaration must be true.

    Examples
    --------
    >>> import control as ct
    >>> from ctrl_lpv.interconnection import interconnect
    >>> P = ct.nlsys(lambda t, x, u, p: -x + u, None, inputs="u", outputs="y",
    ...              states=1, name="P")
    >>> C = ct.nlsys(None, lambda t, x, u, p: 2 * (u[0] - u[1]),
    ...              inputs=["r", "y"], outputs="u", name="C")
    >>> loop = interconnect([P, C], inplist="C.r", outlist="P.y")
    >>> loop.algebraic_loop
    False
    """
    _check_syslist(syslist)
    for name, spec in (
        ("connections", connections), ("inplist", inplist), ("outlist", outlist)
    ):  # fmt: skip
        _check_gains(spec, name)
    sys = ct.interconnect(syslist, connections, inplist, outlist, **kwargs)
    fast = _FAST_CLASS.get(type(sys))
    if fast is None:  # pragma: no cover - python-control returned a new type
        return sys
    sys.__class__ = fast
    return sys


def _check_syslist(syslist) -> None:
    """A non-empty list of I/O systems with distinct names."""
    if isinstance(syslist, (str, bytes, ct.InputOutputSystem)) or not isinstance(
        syslist, (list, tuple)
    ):
        raise TypeError(
            "syslist: expected a list of control.NonlinearIOSystem (e.g. "
            f"[plant, controller]), got {type(syslist).__name__}"
        )
    if not syslist:
        raise ValueError("syslist: the list is empty; give the systems to connect")
    seen = {}
    for k, item in enumerate(syslist):
        if not isinstance(item, ct.InputOutputSystem):
            raise TypeError(
                f"syslist[{k}]: expected a control I/O system, got "
                f"{type(item).__name__}"
            )
        if item.name in seen:
            raise ValueError(
                f"syslist: systems {seen[item.name]} and {k} are both named "
                f"{item.name!r}, so 'name.signal' would be ambiguous; give each "
                "system its own name (e.g. sys.copy(name=...))"
            )
        seen[item.name] = k


def _check_gains(spec, name: str, path: str = "") -> None:
    """Every gain of a ``(system, signal, gain)`` spec is a finite real number.

    python-control reads any tuple of a connection, `inplist` or `outlist`
    as a signal spec, whose third entry is its gain; a NaN there would make
    the diagram's outputs NaN (reported later as an "algebraic loop").
    """
    if isinstance(spec, tuple) and len(spec) == 3:
        real_number(spec[2], f"{name}{path}: gain of {spec[:2]!r}")
    elif isinstance(spec, (list, tuple)):
        for k, item in enumerate(spec):
            _check_gains(item, name, f"{path}[{k}]")
