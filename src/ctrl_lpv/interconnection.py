"""Interconnections whose outputs are evaluated once per call.

python-control's `InterconnectedSystem` finds the signals of a block diagram
by fixed-point iteration: every right-hand-side call evaluates the output
function of every subsystem up to ``len(syslist) + 1`` times.
`interconnect` here builds the same system with `control.interconnect`
and replaces that evaluation by a straight-line function generated once:
the subsystems' outputs are computed in a topological order of the
direct-feedthrough graph, each at most once, only where they are needed,
with the connection gains folded into the generated code.

Blocks may provide a `BlockKernel` (scalar functions on lists of floats)
and declare which inputs feed through to their outputs; the plant and
controllers of this package do. Other blocks are called through their own
``_out`` and ``_rhs`` methods. The same generated code drives the fused
fast path of `ctrl_lpv.simulation.simulate`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import control as ct
import numpy as np
from control.nlsys import InterconnectedSystem
from control.statesp import LinearICSystem

from ._checks import real_number

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


@dataclass(frozen=True)
class BlockKernel:
    """Scalar evaluation functions of a block, for fused simulation.

    The functions take time ``t`` and sequences of floats ``x`` (states) and
    ``u`` (inputs) and return sequences of floats; they must not depend on
    system parameters (``params``) and must have no side effects.

    Attributes
    ----------
    out : callable
        ``out(t, x, u) -> outputs``.
    rhs : callable or None
        ``rhs(t, x, u) -> dx/dt``; None for a static block.
    out_many : callable, optional
        Vectorized outputs ``out_many(t, x, u) -> outputs`` where ``t`` is an
        array of times and ``x``, ``u`` are sequences of arrays (one per
        state and input, broadcastable against ``t``); each returned output
        is an array (or a scalar broadcast to the times).  Default: loop
        over the times with `out`.
    state_outputs : tuple of int or None, optional
        For each output, the index of the state it equals, or None.  Such
        outputs are read from the state without calling `out`.
    """

    out: Callable
    rhs: Callable | None = None
    out_many: Callable | None = None
    state_outputs: tuple[int | None, ...] | None = None


def kernel_nlsys(
    kernel: BlockKernel,
    *,
    inputs: Sequence[str],
    outputs: Sequence[str],
    states: Sequence[str] | None = None,
    feedthrough=True,
    name: str | None = None,
    dt=0,
) -> ct.NonlinearIOSystem:
    """Create a `control.NonlinearIOSystem` from a `BlockKernel`.

    The system's update and output functions call the kernel, so that both
    simulation paths (python-control's and the fused one) evaluate the
    same code.

    Parameters
    ----------
    kernel : `BlockKernel`
        The block's scalar functions.
    inputs, outputs : sequence of str
        Signal names.
    states : sequence of str, optional
        State names; None for a static block (then ``kernel.rhs`` must be
        None).
    feedthrough : bool or array_like of bool, optional
        Whether the outputs depend on the inputs directly: a bool for all
        pairs, or a ``(noutputs, ninputs)`` matrix.  Default True.
    name : str, optional
        System name.
    dt : 0, True or float, optional
        Timebase (python-control's convention); in discrete time
        ``kernel.rhs`` returns the next state. Default 0 (continuous).

    Returns
    -------
    `control.NonlinearIOSystem`

    Raises
    ------
    TypeError
        If `kernel` is not a `BlockKernel`.
    ValueError
        If `states` and ``kernel.rhs`` disagree, or `feedthrough` has the
        wrong shape.
    """
    if not isinstance(kernel, BlockKernel):
        raise TypeError(f"kernel: expected a BlockKernel, got {type(kernel).__name__}")
    if (states is None or len(states) == 0) != (kernel.rhs is None):
        raise ValueError("states: a block has states if and only if kernel.rhs is set")
    out, rhs = kernel.out, kernel.rhs
    array = np.array

    def outfcn(t, x, u, params=None):
        return array(out(t, _floats(x), _floats(u)), dtype=float)

    if rhs is None:
        updfcn = None
    else:

        def updfcn(t, x, u, params=None):
            return array(rhs(t, _floats(x), _floats(u)), dtype=float)

    sys = ct.nlsys(
        updfcn,
        outfcn,
        inputs=list(inputs),
        outputs=list(outputs),
        states=None if states is None else list(states),
        name=name,
        dt=dt,
    )
    sys._kernel = kernel
    sys._feedthrough = _as_feedthrough(
        feedthrough, sys.noutputs, sys.ninputs, "feedthrough"
    )
    return sys


def _floats(v) -> list:
    # python-control passes float arrays; anything else goes the slow way.
    if type(v) is np.ndarray:
        return v.tolist()
    return np.asarray(v, dtype=float).reshape(-1).tolist()


def _as_feedthrough(value, noutputs: int, ninputs: int, what: str) -> np.ndarray:
    if isinstance(value, (bool, np.bool_)):
        return np.full((noutputs, ninputs), bool(value))
    matrix = np.asarray(value, dtype=bool)
    if matrix.shape != (noutputs, ninputs):
        raise ValueError(
            f"{what}: expected a bool or a ({noutputs}, {ninputs}) matrix, "
            f"got shape {matrix.shape}"
        )
    return matrix


def feedthrough(sys) -> np.ndarray:
    """Which inputs of `sys` feed directly through to which outputs.

    Parameters
    ----------
    sys : `control.InputOutputSystem`
        A block of a diagram.

    A declared ``sys._feedthrough`` (bool or ``(noutputs, ninputs)``
    matrix) wins; otherwise a `control.StateSpace` feeds through where
    ``D != 0``, a system without output function (output = state) does not
    feed through, and any other system is assumed to feed every input to
    every output.

    Returns
    -------
    ndarray of bool
        Shape ``(noutputs, ninputs)``.
    """
    declared = getattr(sys, "_feedthrough", None)
    if declared is not None:
        return _as_feedthrough(
            declared, sys.noutputs, sys.ninputs, f"{sys.name}._feedthrough"
        )
    if isinstance(sys, ct.StateSpace) and not isinstance(sys, InterconnectedSystem):
        return np.asarray(sys.D != 0, dtype=bool).reshape(sys.noutputs, sys.ninputs)
    if (
        isinstance(sys, ct.NonlinearIOSystem)
        and not isinstance(sys, InterconnectedSystem)
        and sys.outfcn is None
    ):
        return np.zeros((sys.noutputs, sys.ninputs), dtype=bool)
    return np.ones((sys.noutputs, sys.ninputs), dtype=bool)


# ----------------------------------------------------------------------
# The evaluation plan: generated straight-line code
# ----------------------------------------------------------------------


def _generic_kernel(sys) -> BlockKernel:
    """Kernel calling a block's own ``_out`` and ``_rhs``."""
    sys_out, sys_rhs = sys._out, sys._rhs
    asarray = np.asarray

    def out(t, x, u):
        return sys_out(t, asarray(x, dtype=float), asarray(u, dtype=float)).tolist()

    def rhs(t, x, u):
        return sys_rhs(t, asarray(x, dtype=float), asarray(u, dtype=float)).tolist()

    return BlockKernel(out=out, rhs=rhs if sys.nstates else None)


def _kernel_of(sys) -> BlockKernel:
    kernel = getattr(sys, "_kernel", None)
    if isinstance(kernel, BlockKernel):
        return kernel
    kernel = _generic_kernel(sys)
    if (
        type(sys)._out is ct.NonlinearIOSystem._out
        and sys.outfcn is None
        and sys.noutputs <= sys.nstates
    ):
        # No output function: the outputs are the first states.
        kernel = BlockKernel(
            out=kernel.out,
            rhs=kernel.rhs,
            state_outputs=tuple(range(sys.noutputs)),
        )
    return kernel


def _loop_many(out: Callable) -> Callable:
    """Vectorized outputs by a loop over the times."""

    def out_many(t, x, u):
        t = np.asarray(t, dtype=float)
        X = [np.broadcast_to(v, t.shape).tolist() for v in x]
        U = [np.broadcast_to(v, t.shape).tolist() for v in u]
        rows = [out(ti, [v[i] for v in X], [v[i] for v in U]) for i, ti in
                enumerate(t.tolist())]  # fmt: skip
        return np.array(rows, dtype=float).reshape(t.size, -1).T

    return out_many


class _Expr(dict):
    """Linear combination ``{symbol: coefficient}`` of scalar signals."""

    def add(self, other, gain=1.0):
        for sym, coef in other.items():
            self[sym] = self.get(sym, 0.0) + gain * coef
        return self

    def code(self) -> str:
        terms = [(s, c) for s, c in self.items() if c != 0.0]
        if not terms:
            return "0.0"
        parts = []
        for sym, coef in terms:
            if coef == 1.0:
                parts.append(("+", sym))
            elif coef == -1.0:
                parts.append(("-", sym))
            elif coef > 0:
                parts.append(("+", f"{coef!r}*{sym}"))
            else:
                parts.append(("-", f"{-coef!r}*{sym}"))
        sign, first = parts[0]
        text = first if sign == "+" else f"-{first}"
        return text + "".join(f" {s} {t}" for s, t in parts[1:])

    def outputs(self) -> set[int]:
        return {int(s[1:]) for s in self if s[0] == "y" and self[s] != 0.0}


class _Block:
    __slots__ = ("index", "sys", "kernel", "n", "m", "p", "xo", "uo", "yo", "ft")

    def __init__(self, index, sys, xo, uo, yo):
        self.index, self.sys = index, sys
        self.kernel = _kernel_of(sys)
        self.n, self.m, self.p = sys.nstates, sys.ninputs, sys.noutputs
        self.xo, self.uo, self.yo = xo, uo, yo
        self.ft = feedthrough(sys)


@functools.lru_cache(maxsize=256)
def _code(name: str, source: str):
    """Compiled generated source: sweeps build the same loop thousands of times."""
    return compile(source, f"<ctrl_lpv.interconnect {name}>", "exec")


class EvaluationPlan:
    """Generated evaluation functions of a block diagram.

    Built by `plan`; holds scalar ``rhs(t, x, u)`` and ``out(t, x, u)``
    (arrays in, array out), ``out_many(t, X, U)`` (vectorized over times)
    and `rhs_function` for a given input source.  `None` from `plan` means
    the diagram has an algebraic loop (through the declared feedthrough).
    """

    def __init__(self, blocks, in_expr, out_expr, nstates, ninputs):
        self.blocks = blocks
        self.nstates, self.ninputs = nstates, ninputs
        self._in_expr, self._out_expr = in_expr, out_expr
        stateful = [b for b in blocks if b.n]
        rhs_targets = [in_expr[b.uo + j] for b in stateful for j in range(b.m)]
        rhs_order = _order(blocks, in_expr, rhs_targets)
        out_order = _order(blocks, in_expr, out_expr)
        if rhs_order is None or out_order is None:
            raise _AlgebraicLoop
        self._rhs_order, self._out_order, self._stateful = (
            rhs_order,
            out_order,
            stateful,
        )
        env = {"_array": np.array, "_ndarray": np.ndarray, "_floats": _floats}
        env.update(inf=math.inf, nan=math.nan)
        for b in blocks:
            env[f"_o{b.index}"] = b.kernel.out
            env[f"_r{b.index}"] = b.kernel.rhs
            env[f"_m{b.index}"] = b.kernel.out_many or _loop_many(b.kernel.out)
        env["_rows"] = _rows
        self._env = env
        # rhs and out may be bound on the system as python-control's `_rhs`
        # and `_out`: they accept any vector, arrays take the fast way.
        body = self._rhs_body(_ANY.format("u"), array=True, x_source=_ANY.format("x"))
        source = ["def rhs(t, x, u):"] + body
        self.rhs = self._compile("rhs", "\n".join(source))
        self._factories = {}
        self.out = self._compile("out", self._out_source())
        self.out_many = self._compile("out_many", self._out_many_source())

    # -- code generation ------------------------------------------------
    def _unpack(self, prefix, count, source):
        if count == 0:
            return []
        names = ", ".join(f"{prefix}{i}" for i in range(count))
        return [f"    {names}, = {source}"]

    def _call_out(self, b, fn):
        xs = "".join(f"x{b.xo + i}, " for i in range(b.n))
        us = "".join(
            (self._in_expr[b.uo + j].code() if b.ft[:, j].any() else "0.0") + ", "
            for j in range(b.m)
        )
        lhs = "".join(f"y{b.yo + k}, " for k in range(b.p))
        if not lhs:
            return []
        return [f"    {lhs}= {fn}{b.index}(t, ({xs}), ({us}))"]

    def _call_rhs(self, b):
        xs = "".join(f"x{b.xo + i}, " for i in range(b.n))
        us = "".join(self._in_expr[b.uo + j].code() + ", " for j in range(b.m))
        return f"_r{b.index}(t, ({xs}), ({us}))"

    def _rhs_body(self, u_source, array, x_source="x.tolist()"):
        lines = self._unpack("x", self.nstates, x_source)
        lines += self._unpack("u", self.ninputs, u_source)
        for b in self._rhs_order:
            lines += self._call_out(b, "_o")
        calls = [self._call_rhs(b) for b in self._stateful]
        if len(calls) == 1:
            value = calls[0]
        else:
            value = "(" + "".join(f"*{c}, " for c in calls) + ")"
        lines.append(f"    return _array({value})" if array else f"    return {value}")
        return lines

    def _out_source(self):
        lines = ["def out(t, x, u):"]
        lines += self._unpack("x", self.nstates, _ANY.format("x"))
        lines += self._unpack("u", self.ninputs, _ANY.format("u"))
        for b in self._out_order:
            lines += self._call_out(b, "_o")
        exprs = "".join(e.code() + ", " for e in self._out_expr)
        lines.append(f"    return _array(({exprs}))")
        return "\n".join(lines)

    def _out_many_source(self):
        lines = ["def out_many(t, x, u):"]
        lines += self._unpack("x", self.nstates, "x")
        lines += self._unpack("u", self.ninputs, "u")
        for b in self._out_order:
            lines += self._call_out(b, "_m")
        exprs = "".join(e.code() + ", " for e in self._out_expr)
        lines.append(f"    return _rows(t, ({exprs}))")
        return "\n".join(lines)

    def _compile(self, name, source, **extra):
        namespace = dict(self._env, **extra)
        exec(_code(name, source), namespace)
        function = namespace[name]
        function.source = source
        return function

    def rhs_function(self, inputs) -> Callable:
        """Right-hand side ``f(t, x)`` for `scipy.integrate.solve_ivp`.

        The generated code is compiled once per plan and kind of input;
        `f` returns a sequence of floats (``solve_ivp`` makes it an array).

        Parameters
        ----------
        inputs : sequence of float or callable
            Constant input values, or ``inputs(t) -> sequence of float``.

        Returns
        -------
        callable
        """
        kind = "callable" if callable(inputs) else "constant"
        if kind == "constant":
            inputs = tuple(float(v) for v in inputs)
        make = self._factories.get(kind)
        if make is None:
            body = self._rhs_body(
                "_input(t)" if kind == "callable" else "_input", array=False
            )
            source = "\n".join(
                ["def make(_input):", "    def rhs_t(t, x):"]
                + ["    " + line for line in body]
                + ["    return rhs_t"]
            )
            make = self._factories[kind] = self._compile("make", source)
        return make(inputs)


_ANY = "{0}.tolist() if type({0}) is _ndarray else _floats({0})"


class _AlgebraicLoop(Exception):
    pass


def _rows(t, exprs):
    shape = np.shape(t)
    return np.array([np.broadcast_to(e, shape) for e in exprs], dtype=float).reshape(
        (len(exprs),) + shape
    )


def _order(blocks, in_expr, targets):
    """Blocks that `targets` need, dependencies first; None on a loop."""
    owner = {}
    for b in blocks:
        for k in range(b.p):
            owner[b.yo + k] = b
    deps = {}
    for b in blocks:
        used = set()
        for j in range(b.m):
            if b.ft[:, j].any():
                used |= in_expr[b.uo + j].outputs()
        deps[b.index] = sorted({owner[k].index for k in used})
    order, state = [], {}

    def visit(i):
        mark = state.get(i)
        if mark == 2:
            return True
        if mark == 1:
            return False
        state[i] = 1
        if not all(visit(j) for j in deps[i]):
            return False
        state[i] = 2
        order.append(blocks[i])
        return True

    needed = sorted({owner[k].index for e in targets for k in e.outputs()})
    if not all(visit(i) for i in needed):
        return None
    return order


def plan(sys) -> EvaluationPlan | None:
    """Evaluation plan of a system (None for an algebraic loop).

    Parameters
    ----------
    sys : `control.NonlinearIOSystem`
        An `InterconnectedSystem` (its subsystems are the blocks) or any
        other I/O system (a single block).

    Returns
    -------
    `EvaluationPlan` or None
    """
    if isinstance(sys, InterconnectedSystem):
        syslist = sys.syslist
        cmap, imap, omap = sys.connect_map, sys.input_map, sys.output_map
    else:
        syslist = [sys]
        m, p = sys.ninputs, sys.noutputs
        cmap, imap = np.zeros((m, p)), np.eye(m)
        omap = np.hstack([np.eye(p), np.zeros((p, m))])
    blocks, xo, uo, yo = [], 0, 0, 0
    for i, s in enumerate(syslist):
        blocks.append(_Block(i, s, xo, uo, yo))
        xo, uo, yo = xo + s.nstates, uo + s.ninputs, yo + s.noutputs
    ny = yo

    # Symbols: x<i> states, u<j> external inputs, y<k> block outputs; an
    # output that equals a state (declared by the kernel) is that state.
    ysym = []
    for b in blocks:
        copies = b.kernel.state_outputs or (None,) * b.p
        ysym += [f"y{b.yo + k}" if s is None else f"x{b.xo + s}" for k, s in
                 enumerate(copies)]  # fmt: skip
    in_expr = []
    for r in range(cmap.shape[0]):
        e = _Expr()
        for k in np.flatnonzero(cmap[r]):
            e.add({ysym[k]: 1.0}, float(cmap[r, k]))
        for j in np.flatnonzero(imap[r]):
            e.add({f"u{j}": 1.0}, float(imap[r, j]))
        in_expr.append(e)
    out_expr = []
    for o in range(omap.shape[0]):
        e = _Expr()
        for c in np.flatnonzero(omap[o]):
            gain = float(omap[o, c])
            e.add({ysym[c]: 1.0} if c < ny else in_expr[c - ny], gain)
        out_expr.append(e)
    try:
        return EvaluationPlan(blocks, in_expr, out_expr, xo, imap.shape[1])
    except _AlgebraicLoop:
        return None


# ----------------------------------------------------------------------
# The interconnected system classes
# ----------------------------------------------------------------------


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
