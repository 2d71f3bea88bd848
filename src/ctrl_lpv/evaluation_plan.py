"""Evaluation plans: straight-line code generated for a block diagram.

python-control's `InterconnectedSystem` finds the signals of a block diagram
by fixed-point iteration: every right-hand-side call evaluates the output
function of every subsystem up to ``len(syslist) + 1`` times. `plan`
generates, once, functions that compute the subsystems' outputs in a
topological order of the direct-feedthrough graph, each at most once, only
where they are needed, with the connection gains folded into the code.
`ctrl_lpv.interconnect` binds them on its systems and
`ctrl_lpv.simulation.simulate` integrates them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from control.nlsys import InterconnectedSystem

from .block_kernel import feedthrough, floats, kernel_of, loop_many

__all__ = ["EvaluationPlan", "plan"]


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
        self.kernel = kernel_of(sys)
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
        env = {"_array": np.array, "_ndarray": np.ndarray, "_floats": floats}
        env.update(inf=math.inf, nan=math.nan)
        for b in blocks:
            env[f"_o{b.index}"] = b.kernel.out
            env[f"_r{b.index}"] = b.kernel.rhs
            env[f"_m{b.index}"] = b.kernel.out_many or loop_many(b.kernel.out)
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
