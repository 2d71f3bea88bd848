"""State-feedback controllers as python-control I/O systems."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import control as ct
import numpy as np

from ._checks import flag, signal_indices, signal_name
from .interconnection import BlockKernel, kernel_nlsys
from .systems import PolytopicStateSpace

__all__ = ["state_feedback", "integral_augmentation"]


def state_feedback(
    design,
    scheduling: str | Callable | None = None,
    *,
    reference: bool = False,
    states: Sequence[str] | Mapping[str, str] | None = None,
    integrals: Mapping[str, str] | None = None,
    name: str | None = None,
) -> ct.NonlinearIOSystem:
    """Controller ``u = -K(delta) x`` (or ``u = ud - K (x - xd)``).

    The controller has the timebase of the design model ``design.system``:
    for a discrete-time model (``dt > 0`` or True) it is a discrete
    `control.NonlinearIOSystem` with the same ``dt``, ``u[k] = -K(p[k])
    x[k]``, and its integral states are accumulators ``q[k+1] = q[k] +
    e[k]`` (the convention of `integral_augmentation` in discrete time).

    In the spirit of `control.create_statefbk_iosystem`: the controller reads
    the measured states and outputs the control inputs of the design, named
    after the design model's signals, so that `control.interconnect` can
    connect it by name. The measured-state inputs are named after the
    design model's *state* labels: the plant to connect must have outputs
    with these names (give it outputs that measure its states, e.g.
    ``C = I`` with ``outputs`` equal to ``states``), or rename the
    controller's inputs with `states`.

    Integral states added by `integral_augmentation` are integrated by the
    controller itself, as with the ``integral_action`` of
    `control.create_statefbk_iosystem`: the controller has one state per
    integral (same label), reads the integrated signal (a state input, or an
    input named after the integrated output), and needs nothing from the
    augmented plant. So the loop is ``interconnect([plant, controller])``
    with the plant *without* augmentation (or with it: its own integral
    states are then unobservable and harmless).

    Parameters
    ----------
    design : `StateFeedbackDesign`
        A certified design.
    scheduling : None, "inputs" or callable, optional
        For vertex gains only: where the parameter comes from. ``"inputs"``
        (the default for vertex gains) adds one input per parameter, named
        after the parameters; a callable ``p = f(t, x)`` computes it from
        time and the design model's state vector (measured states and the
        controller's integral states, in the design's state order). It may
        return a mapping ``{name: value}``. The parameter is projected onto
        the domain (a saturated scheduling signal). Must be None for a
        common gain.
    reference : bool, optional
        If True, add inputs ``xd`` (desired states, named ``<state>_d``;
        ``<output>_d`` for an integrated output) and ``ud`` (feedforward,
        named ``<input>_d``): ``u = ud - K (x - xd)``, the integrators
        integrating ``s - s_d``.
    states : sequence of str or mapping, optional
        Names of the measured-state inputs: a sequence (one name per
        measured state, i.e. per design state that is not a controller
        integral) or a mapping ``{state label: input name}`` renaming some
        of them. Default: the design model's state labels.
    integrals : mapping of str to str, optional
        ``{integral state label: integrated signal}``: the design states
        that the controller integrates itself, each from a state or output
        label of the design model. Default: those recorded by
        `integral_augmentation` on the design's system (``{}`` if none);
        ``{}`` reads every state as an input.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        Inputs ``measured states [+ integrated outputs] [+ xd + ud]
        [+ parameters]``, outputs the control inputs ``design.u``, states
        the integral states (none without integrals); ``dt`` that of
        ``design.system``.

    Raises
    ------
    ValueError
        For a `scheduling` that does not fit the design, `states` of the
        wrong length or with unknown labels, or `integrals` naming unknown
        states or signals.

    Examples
    --------
    >>> ctrl = design.controller()                      # doctest: +SKIP
    >>> loop = ct.interconnect([plant, ctrl], ...)      # doctest: +SKIP
    """
    sys = design.system
    labels = list(design.states)
    n = len(labels)
    reference = flag(reference, "reference")
    if name is not None:
        signal_name(name, "name")
    if integrals is None:
        integrals = getattr(sys, "integral_signals", None) or {}
    if not isinstance(integrals, Mapping):
        raise TypeError(
            f"integrals: expected a mapping {{state: signal}}, got {integrals!r}"
        )
    for state, signal in integrals.items():
        if state not in labels:
            raise ValueError(
                f"integrals: {state!r} is not a state of the design ({labels})"
            )
        if signal not in labels and signal not in sys.output_labels:
            raise ValueError(
                f"integrals: the signal {signal!r} of {state!r} is neither a "
                "state nor an output of the design model"
            )
        if signal in integrals:
            raise ValueError(f"integrals: {signal!r} is itself a controller integral")
    measured = [i for i, s in enumerate(labels) if s not in integrals]
    names = _measured_names(states, [labels[i] for i in measured])
    if design.scheduled:
        scheduling = "inputs" if scheduling is None else scheduling
        if not (scheduling == "inputs" or callable(scheduling)):
            raise ValueError(
                "scheduling: expected 'inputs' or a callable f(t, x), "
                f"got {scheduling!r}"
            )
    elif scheduling is not None:
        raise ValueError("scheduling: a common-gain design is not scheduled")

    # Input layout: measured states, integrated outputs, references, params.
    inputs = list(names)
    source = {labels[i]: k for k, i in enumerate(measured)}  # state -> input
    extra = []  # integrated outputs that are not measured states
    for signal in integrals.values():
        if signal not in source and signal not in extra:
            extra.append(signal)
    inputs += extra
    for k, signal in enumerate(extra):
        source[signal] = len(measured) + k
    outputs = list(design.u)
    ref = None
    if reference:
        ref = len(inputs)
        inputs += [f"{s}_d" for s in names] + [f"{s}_d" for s in extra]
        inputs += [f"{u}_d" for u in outputs]
    nref = len(inputs)
    if design.scheduled and scheduling == "inputs":
        inputs += list(sys.param_names)
    if len(set(inputs)) != len(inputs):
        raise ValueError(f"states: the controller's input names repeat: {inputs}")

    layout = _Layout(
        n=n,
        measured=tuple(measured),
        integral=tuple(labels.index(s) for s in integrals),
        integrated=tuple(source[sig] for sig in integrals.values()),
        nsignals=len(measured) + len(extra),
        ref=ref,
        nref=nref,
    )
    gains = np.stack(design.gains)  # (N, m, n)
    discrete = sys.isdtime(strict=True)
    kernel = _feedback_kernel(
        gains,
        sys.domain,
        scheduling if design.scheduled else None,
        layout,
        getattr(design, "rational", None),
        discrete=discrete,
    )
    # u depends on the measured states, references and parameters, not on
    # the integrated outputs (they enter through the integrators).
    through = np.ones((len(outputs), len(inputs)), dtype=bool)
    through[:, len(measured) : len(measured) + len(extra)] = False
    if ref is not None:
        start = ref + len(measured)
        through[:, start : start + len(extra)] = False
    return kernel_nlsys(
        kernel,
        inputs=inputs,
        outputs=outputs,
        states=list(integrals) or None,
        feedthrough=through,
        name=name,
        dt=sys.dt,
    )


def _measured_names(states, default: list[str]) -> list[str]:
    """Input names of the measured states (`state_feedback`'s `states`)."""
    if states is None:
        return list(default)
    if isinstance(states, Mapping):
        unknown = sorted(set(states) - set(default))
        if unknown:
            raise ValueError(
                f"states: {unknown} are not measured states of the design ({default})"
            )
        return [str(states.get(s, s)) for s in default]
    if isinstance(states, str):
        states = [states]
    states = list(states)
    if len(states) != len(default):
        raise ValueError(
            f"states: expected {len(default)} names (for {default}), got {len(states)}"
        )
    return [str(s) for s in states]


@dataclass(frozen=True)
class _Layout:
    """Where `state_feedback`'s kernel finds its signals.

    Design state ``i`` is measured (input ``measured.index(i)``) or a
    controller integral (state ``integral.index(i)``, integrating input
    ``integrated[j]``). References start at input `ref` (None without):
    one per signal input, then the feedforward ``ud``; parameters start at
    `nref`.
    """

    n: int
    measured: tuple[int, ...]
    integral: tuple[int, ...]
    integrated: tuple[int, ...]
    nsignals: int
    ref: int | None
    nref: int


def _feedback_kernel(
    gains, domain, scheduling, layout: _Layout, rational=None, *, discrete=False
) -> BlockKernel:
    """Scalar and vectorized functions of `state_feedback`.

    ``u = ud - K(delta) (x - xd)`` on Python floats (the gains are small),
    ``x`` the design state (measured states and integral states); the
    scheduled gain ``sum_j delta_j K_j`` comes from the domain's convex
    coordinates of the projected parameter, or is ``-Z(delta) W(delta)^-1``
    for the `rational` vertex matrices ``(Z_j, W_j)`` of a design with a
    parameter-dependent Lyapunov function. The integrators return
    ``dq/dt = e`` (continuous) or the next state ``q + e`` (`discrete`).
    """
    N, m, n = gains.shape
    flat_gains = gains.reshape(N, m * n)
    weights = domain._weights
    common = tuple(tuple(row) for row in gains[0].tolist())
    asarray = np.asarray
    measured, integral, integrated = layout.measured, layout.integral, layout.integrated
    ref, nref, nsig = layout.ref, layout.nref, layout.nsignals
    plain = not integral and ref is None  # inputs are the state vector

    def design_state(x, u):
        if plain:
            return u[:n]
        z = [0.0] * n
        for k, i in enumerate(measured):
            z[i] = u[k]
        for k, i in enumerate(integral):
            z[i] = x[k]
        return z

    def error(x, u):
        z = design_state(x, u)
        if ref is None:
            return z, (0.0,) * m
        e = list(z)
        for k, i in enumerate(measured):
            e[i] = z[i] - u[ref + k]
        return e, u[ref + nsig : ref + nsig + m]

    def parameter(p):
        if isinstance(p, Mapping):
            return domain._as_point(p)
        return asarray(p, dtype=float).reshape(-1)

    def gain(t, x, u):
        if scheduling is None:
            return common
        if scheduling == "inputs":
            p = asarray(u[nref:], dtype=float)
        else:
            p = parameter(scheduling(t, asarray(design_state(x, u), dtype=float)))
        delta = weights(p)
        if rational is not None:
            Z, W = (np.tensordot(delta, np.stack(M), axes=1) for M in rational)
            return (-np.linalg.solve(W.T, Z.T).T).tolist()
        flat = (delta @ flat_gains).tolist()
        return [flat[i * n : (i + 1) * n] for i in range(m)]

    def out(t, x, u):
        e, ud = error(x, u)
        return [
            d - sum(k * v for k, v in zip(row, e))
            for d, row in zip(ud, gain(t, x, u))
        ]  # fmt: skip

    def rate(t, x, u):
        if ref is None:
            return [u[k] for k in integrated]
        return [u[k] - u[ref + k] for k in integrated]

    if discrete:

        def rhs(t, x, u):
            return [q + e for q, e in zip(x, rate(t, x, u))]

    else:
        rhs = rate

    def out_many(t, x, u):
        shape = np.broadcast(t, *x, *u).shape
        U = np.array([np.broadcast_to(v, shape) for v in u]).reshape(len(u), -1)
        X = (
            np.array([np.broadcast_to(v, shape) for v in x]).reshape(len(x), -1)
            if integral
            else None
        )
        if scheduling is not None:
            times = np.broadcast_to(t, shape).ravel()
            Y = np.empty((m, U.shape[1]))
            for i in range(U.shape[1]):
                xi = X[:, i].tolist() if integral else ()
                Y[:, i] = out(times[i], xi, U[:, i].tolist())
            return Y.reshape((m,) + shape)
        E = np.zeros((n, U.shape[1]))
        E[list(measured)] = U[: len(measured)]
        if integral:
            E[list(integral)] = X
        ud = 0.0
        if ref is not None:
            E[list(measured)] -= U[ref : ref + len(measured)]
            ud = U[ref + nsig : ref + nsig + m]
        return (ud - gains[0] @ E).reshape((m,) + shape)

    return BlockKernel(out=out, rhs=rhs if integral else None, out_many=out_many)


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
    `sys` (outputs may depend on the inputs through ``D``). The integral
    states are appended after the original states, and also after the
    original outputs, as outputs with the same labels (``int_<signal>``),
    so that a performance spec can weight them (``Hinf(w, z=["q", "int_q",
    "uw"])``).

    The integral states must be weighted in ``z`` (or placed with a pole
    region, e.g. ``halfplane``): an objective that does not see them leaves
    the integrator's mode nearly uncontrolled, and the design can certify a
    closed loop whose slowest pole sits next to the origin (a design with a
    ``z`` that omitted ``int_q`` certified its slowest pole at -0.00035),
    so the integral action does nothing in practice. A ``z`` left at its
    default (every output) includes them.

    For a discrete-time `sys` the integrators are accumulators,
    ``xi_i[k+1] = xi_i[k] + s_i[k]`` (no factor ``dt``: scale the integral
    states if you want ``dt`` times the sum), so that the augmented plant
    is discrete with the same ``dt``: ``A_aug = [[A, 0], [C_s, I]]``,
    ``B_aug = [B; D_s]``. The controller of a design on it
    (`state_feedback`) accumulates the same way.

    The result is the *design model*. The result records which signal each
    integral state integrates (attribute ``integral_signals``, a dict
    ``{integral state: signal}``), so that the controller of a design on it
    (`state_feedback`, ``design.controller()``) integrates these signals
    itself, like `control.create_statefbk_iosystem` with
    ``integral_action``: connect it by name to the plant `sys` (whose
    outputs carry the measured states and the integrated signals). The
    record is not kept by operations that build a new system from the
    result (e.g. `PolytopicStateSpace.scheduled`); pass
    ``integrals=aug.integral_signals`` to `state_feedback` then.

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
        Over the same domain, with the same nominal point, scheduling and
        timebase; outputs those of `sys` followed by the integral states.

    Raises
    ------
    ValueError
        If a signal is neither a state nor an output label, or `names`
        repeat or reuse a state or output label.

    Examples
    --------
    >>> import control as ct
    >>> plant = PolytopicStateSpace([ct.ss(
    ...     [[0.0, 1.0], [-1.0, -0.5]], [[0.0, 0.0], [1.0, 1.0]],
    ...     [[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.1]],
    ...     inputs=["w", "u"], outputs=["q", "uw"], states=["q", "v"])])
    >>> aug = integral_augmentation(plant, "q")
    >>> aug.state_labels, aug.output_labels
    (['q', 'v', 'int_q'], ['q', 'uw', 'int_q'])
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
    # Continuous time: d xi/dt = s; discrete time: xi[k+1] = xi[k] + s[k].
    hold = np.eye(k) if sys.isdtime(strict=True) else np.zeros((k, k))
    vertices = []
    for A, B, C, D in sys.vertex_data():
        Ci = np.zeros((k, n))
        Di = np.zeros((k, B.shape[1]))
        for r, (kind, i) in enumerate(rows):
            if kind == "state":
                Ci[r, i] = 1.0
            else:
                Ci[r], Di[r] = C[i], D[i]
        # The integral states are also outputs, so that z can weight them.
        vertices.append(
            (
                np.block([[A, np.zeros((n, k))], [Ci, hold]]),
                np.vstack([B, Di]),
                np.block(
                    [[C, np.zeros((C.shape[0], k))], [np.zeros((k, n)), np.eye(k)]]
                ),
                np.vstack([D, np.zeros((k, B.shape[1]))]),
            )
        )
    clash = sorted(set(names) & (set(sys.state_labels) | set(sys.output_labels)))
    if clash or len(set(names)) != len(names):
        raise ValueError(
            "names: integral state labels must be new (not a state or output of "
            f"sys) and distinct, got {names}"
        )
    result = PolytopicStateSpace(
        vertices,
        sys.domain,
        scheduling=sys.scheduling,
        nominal=sys.nominal,
        inputs=list(sys.physical_inputs),
        outputs=list(sys.output_labels) + names,
        states=list(sys.state_labels) + names,
        name=name or sys.name,
        dt=sys.dt,
    )
    result.integral_signals = dict(zip(names, signals))
    return result
