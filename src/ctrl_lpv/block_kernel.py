"""Block kernels: the scalar functions a block is evaluated through.

A block of a diagram may provide a `BlockKernel` (scalar functions on lists
of floats) and declare which inputs feed through to its outputs; the plant
and controllers of this package do (`kernel_nlsys` makes such a block a
`control.NonlinearIOSystem`). Other blocks are called through their own
``_out`` and ``_rhs`` methods (`kernel_of`). `ctrl_lpv.evaluation_plan`
generates the code of a diagram from its blocks' kernels.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import control as ct
import numpy as np
from control.nlsys import InterconnectedSystem

__all__ = ["BlockKernel", "kernel_nlsys", "feedthrough"]


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
    compiled : object, optional
        The block as data for a compiled engine that knows it (the two-mass
        blocks give a `ctrl_lpv.twomass.compiled_data.CompiledBlock`);
        None (default): the block runs on the scipy engines only.
    advance : callable, optional
        ``advance(t, x, u, t_end, rtol, atol) -> x_end``: the state at
        ``t_end`` from ``x`` at ``t`` with the inputs ``u`` held, by a
        compiled integrator (`ctrl_lpv.sampled_response` steps the plant
        with it between samples); it raises `ctrl_lpv.SimulationError` when
        the integration fails.  None (default): scipy integrates `rhs`.
    """

    out: Callable
    rhs: Callable | None = None
    out_many: Callable | None = None
    state_outputs: tuple[int | None, ...] | None = None
    compiled: object | None = None
    advance: Callable | None = None


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
        return array(out(t, floats(x), floats(u)), dtype=float)

    if rhs is None:
        updfcn = None
    else:

        def updfcn(t, x, u, params=None):
            return array(rhs(t, floats(x), floats(u)), dtype=float)

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


def floats(v) -> list:
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


def _generic_kernel(sys) -> BlockKernel:
    """Kernel calling a block's own ``_out`` and ``_rhs``."""
    sys_out, sys_rhs = sys._out, sys._rhs
    asarray = np.asarray

    def out(t, x, u):
        return sys_out(t, asarray(x, dtype=float), asarray(u, dtype=float)).tolist()

    def rhs(t, x, u):
        return sys_rhs(t, asarray(x, dtype=float), asarray(u, dtype=float)).tolist()

    return BlockKernel(out=out, rhs=rhs if sys.nstates else None)


def kernel_of(sys) -> BlockKernel:
    """The kernel a block is evaluated through: its own, or its methods'."""
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


def loop_many(out: Callable) -> Callable:
    """Vectorized outputs by a loop over the times."""

    def out_many(t, x, u):
        t = np.asarray(t, dtype=float)
        X = [np.broadcast_to(v, t.shape).tolist() for v in x]
        U = [np.broadcast_to(v, t.shape).tolist() for v in u]
        rows = [out(ti, [v[i] for v in X], [v[i] for v in U]) for i, ti in
                enumerate(t.tolist())]  # fmt: skip
        return np.array(rows, dtype=float).reshape(t.size, -1).T

    return out_many
