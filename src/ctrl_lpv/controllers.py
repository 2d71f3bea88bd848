"""State-feedback controllers as python-control I/O systems."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import control as ct
import numpy as np

from ._checks import signal_indices
from .interconnection import BlockKernel, kernel_nlsys
from .systems import PolytopicStateSpace

__all__ = ["state_feedback", "integral_augmentation"]


def state_feedback(
    design,
    scheduling: str | Callable | None = None,
    *,
    reference: bool = False,
    states: Sequence[str] | None = None,
    name: str | None = None,
) -> ct.NonlinearIOSystem:
    """Controller ``u = -K(delta) x`` (or ``u = ud - K (x - xd)``).

    In the spirit of `control.create_statefbk_iosystem`: the controller reads
    the measured states and outputs the control inputs of the design, named
    after the design model's signals, so that `control.interconnect` can
    connect it by name.

    Parameters
    ----------
    design : `StateFeedbackDesign`
        A certified design.
    scheduling : None, "inputs" or callable, optional
        For vertex gains only: where the parameter comes from. ``"inputs"``
        (the default for vertex gains) adds one input per parameter, named
        after the parameters; a callable ``p = f(t, x)`` computes it from
        time and the measured states (the controller's state inputs). The
        parameter is projected onto the domain (a saturated scheduling
        signal). Must be None for a common gain.
    reference : bool, optional
        If True, add inputs ``xd`` (desired states, named ``<state>_d``) and
        ``ud`` (feedforward, named ``<input>_d``): ``u = ud - K (x - xd)``.
    states : sequence of str, optional
        Names of the measured-state inputs; default the design model's state
        labels.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        Static system: inputs ``states [+ xd + ud] [+ parameters]``,
        outputs the control inputs ``design.u``.

    Examples
    --------
    >>> ctrl = design.controller()                      # doctest: +SKIP
    >>> loop = ct.interconnect([plant, ctrl], ...)      # doctest: +SKIP
    """
    sys = design.system
    states = list(design.states if states is None else states)
    n = len(design.states)
    if len(states) != n:
        raise ValueError(f"states: expected {n} names, got {len(states)}")
    if design.scheduled:
        scheduling = "inputs" if scheduling is None else scheduling
        if not (scheduling == "inputs" or callable(scheduling)):
            raise ValueError(
                "scheduling: expected 'inputs' or a callable f(t, x), "
                f"got {scheduling!r}"
            )
    elif scheduling is not None:
        raise ValueError("scheduling: a common-gain design is not scheduled")

    inputs = list(states)
    outputs = list(design.u)
    if reference:
        inputs += [f"{s}_d" for s in states] + [f"{u}_d" for u in outputs]
    nref = len(inputs)
    if design.scheduled and scheduling == "inputs":
        inputs += list(sys.param_names)

    gains = np.stack(design.gains)  # (N, m, n)
    kernel = _feedback_kernel(
        gains,
        sys.domain,
        scheduling if design.scheduled else None,
        reference=reference,
        nref=nref,
    )
    return kernel_nlsys(kernel, inputs=inputs, outputs=outputs, name=name)


def _feedback_kernel(gains, domain, scheduling, *, reference, nref) -> BlockKernel:
    """Scalar and vectorized functions of `state_feedback`.

    ``u = ud - K(delta) (x - xd)`` on Python floats (the gains are small);
    the scheduled gain ``sum_j delta_j K_j`` comes from the domain's convex
    coordinates of the projected parameter.
    """
    N, m, n = gains.shape
    flat_gains = gains.reshape(N, m * n)
    weights = domain._weights
    common = tuple(tuple(row) for row in gains[0].tolist())
    asarray = np.asarray

    def error(u):
        if reference:
            return [u[i] - u[n + i] for i in range(n)], u[2 * n : 2 * n + m]
        return u[:n], (0.0,) * m

    def gain(t, u):
        if scheduling is None:
            return common
        if scheduling == "inputs":
            p = asarray(u[nref:], dtype=float)
        else:
            p = asarray(scheduling(t, asarray(u[:n], dtype=float)), float).reshape(-1)
        flat = (weights(p) @ flat_gains).tolist()
        return [flat[i * n : (i + 1) * n] for i in range(m)]

    def out(t, x, u):
        e, ud = error(u)
        return [
            d - sum(k * v for k, v in zip(row, e))
            for d, row in zip(ud, gain(t, u))
        ]  # fmt: skip

    def out_many(t, x, u):
        shape = np.broadcast(t, *u).shape
        U = np.array([np.broadcast_to(v, shape) for v in u]).reshape(len(u), -1)
        E = U[:n] - U[n : 2 * n] if reference else U[:n]
        ud = U[2 * n : 2 * n + m] if reference else 0.0
        if scheduling is None:
            return (ud - gains[0] @ E).reshape((m,) + shape)
        times = np.broadcast_to(t, shape).ravel()
        Y = np.empty((m, U.shape[1]))
        for i in range(U.shape[1]):
            Y[:, i] = out(times[i], (), U[:, i].tolist())
        return Y.reshape((m,) + shape)

    return BlockKernel(out=out, out_many=out_many)


def integral_augmentation(
    sys: PolytopicStateSpace,
    signals,
    *,
    names: Sequence[str] | None = None,
    name: str | None = None,
) -> PolytopicStateSpace:
    """Append integrators of states or outputs to a polytopic system.

    For tracking with integral action: the new states are
    ``d xi_i / dt = s_i`` where each ``s_i`` is a state or an output of
    `sys` (outputs may depend on the inputs through ``D``). The outputs are
    unchanged; integral states are appended after the original states.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The system.
    signals : str or sequence of str
        State or output labels to integrate.
    names : sequence of str, optional
        Labels of the integral states; default ``int_<signal>``.
    name : str, optional
        Name of the result; default the name of `sys`.

    Returns
    -------
    `PolytopicStateSpace`
        Over the same domain, with the same nominal point and scheduling.

    Raises
    ------
    ValueError
        If a signal is neither a state nor an output label.
    """
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(f"sys: expected a PolytopicStateSpace, got {type(sys)!r}")
    signals = [signals] if isinstance(signals, str) else list(signals)
    if not signals:
        raise ValueError("signals: at least one signal to integrate is required")
    names = [f"int_{s}" for s in signals] if names is None else list(names)
    if len(names) != len(signals):
        raise ValueError(f"names: expected {len(signals)} names, got {len(names)}")
    n = sys.nstates
    rows = []
    for s in signals:
        if s in sys.state_labels:
            rows.append(("state", sys.state_labels.index(s)))
        elif s in sys.output_labels:
            rows.append(("output", sys.output_labels.index(s)))
        else:
            signal_indices(
                s, list(sys.state_labels) + list(sys.output_labels), "signals"
            )
    k = len(signals)
    vertices = []
    for A, B, C, D in sys.vertex_data():
        Ci = np.zeros((k, n))
        Di = np.zeros((k, B.shape[1]))
        for r, (kind, i) in enumerate(rows):
            if kind == "state":
                Ci[r, i] = 1.0
            else:
                Ci[r], Di[r] = C[i], D[i]
        vertices.append(
            (
                np.block([[A, np.zeros((n, k))], [Ci, np.zeros((k, k))]]),
                np.vstack([B, Di]),
                np.hstack([C, np.zeros((C.shape[0], k))]),
                D,
            )
        )
    return PolytopicStateSpace(
        vertices,
        sys.domain,
        scheduling=sys.scheduling,
        nominal=sys.nominal,
        inputs=list(sys.physical_inputs),
        outputs=list(sys.output_labels),
        states=list(sys.state_labels) + names,
        name=name or sys.name,
    )
