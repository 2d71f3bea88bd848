"""Sampled-data simulation: a continuous-time plant, a discrete-time controller.

`control.interconnect` cannot mix time bases, yet that is how a controller
runs on a drive: the plant evolves continuously, the controller reads its
sensors at the sampling instants ``t_k = k dt``, computes a command, and a
zero-order hold applies it, possibly ``delay`` samples later.
`sampled_response` simulates exactly that loop: the plant is integrated
between samples with the held command (LSODA, tight tolerances; or the
plant's own compiled integrator, see below), the controller's output and
update run once per sample, and each measured signal passes through its
sensor model (`ctrl_lpv.sensors`) first.

A plant may step itself between samples: if its kernel offers
``advance(t, x, u, t_end, rtol, atol)`` (`ctrl_lpv.BlockKernel.advance`)
and every plant input is held over the interval (a callable input in
``inputs`` is not), that compiled integrator replaces LSODA. The two-mass
plant of `ctrl_lpv.twomass.plant` offers one when numba is installed
(``pip install "ctrl_lpv[fast]"``): a 5 s run at 1 ms then spends its time
in the controller, not in the plant
(``benchmarks/bench_compiled_sweep.py``).

Signals connect by name, as in `control.interconnect`: a controller output
that is a plant input drives it through the hold; a plant output that is a
controller input is sampled for it. Every other input of either system is
given in ``inputs``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import control as ct
import numpy as np

from ._checks import real_number
from .ode_integration import integrate
from .simulation_guard import SimulationError
from .simulation_inputs import initial_state

__all__ = ["sampled_response", "SampledResponse"]


@dataclass(frozen=True)
class SampledResponse:
    """The signals of a sampled-data simulation.

    Attributes
    ----------
    plant : `control.TimeResponseData`
        The plant at the recording points (``points_per_sample`` per
        sample interval, and the final time): its inputs as applied (the
        held commands and the external inputs), outputs and states.
    controller : `control.TimeResponseData`
        The controller at the sampling instants ``t_k``: its inputs as it
        read them (after the sensor models), the outputs it computed at
        ``t_k`` (applied from ``t_{k+delay}``), and its states.
    dt : float
        The sample time (the controller's ``dt``).
    delay : int
        Samples between a command's computation and its application.
    """

    plant: ct.TimeResponseData
    controller: ct.TimeResponseData
    dt: float
    delay: int


def sampled_response(
    plant: ct.NonlinearIOSystem,
    controller: ct.NonlinearIOSystem,
    T: float,
    *,
    inputs: Mapping | None = None,
    X0=0.0,
    controller_X0=0.0,
    delay: int = 0,
    initial_command=0.0,
    sensors: Mapping | None = None,
    seed=None,
    points_per_sample: int = 1,
    rtol: float = 1e-8,
    atol: float = 1e-10,
) -> SampledResponse:
    """Simulate a continuous plant under a discrete controller with a hold.

    At each sampling instant ``t_k = k dt`` (``dt`` the controller's sample
    time): the plant's outputs are read (before the hold updates) and
    passed through their sensor models; the controller computes its output
    ``v_k`` and its next state from them and from its external inputs at
    ``t_k``; the plant's held command on ``[t_k, t_{k+1})`` is
    ``v_{k-delay}`` (``initial_command`` while ``k < delay``).

    Parameters
    ----------
    plant : `control.NonlinearIOSystem`
        Continuous-time system (a `control.StateSpace`, an interconnection,
        the two-mass plant of `ctrl_lpv.twomass.plant`, ...).
    controller : `control.NonlinearIOSystem`
        Discrete-time system with a numeric sample time ``dt > 0``.
    T : float
        Final time; the last sample is at ``floor(T / dt) dt``.
    inputs : mapping of str to float or callable, optional
        The inputs that neither system drives: a plant input that is not a
        controller output (held or continuous: a callable ``f(t)`` is
        evaluated inside the integration) and a controller input that is
        not a plant output (a reference, read at ``t_k``).
    X0, controller_X0 : float or array_like, optional
        Initial states (a scalar for every state; default 0).
    delay : int, optional
        Samples of computation delay, ``>= 0`` (default 0; a drive that
        applies the command at the next interrupt has ``delay=1``).
    initial_command : float or mapping of str to float, optional
        The held command before the first computed one acts (default 0).
    sensors : mapping of str to callable, optional
        ``{plant output: sensor}``: each sensor ``f(value, rng)`` maps the
        true output to the measured one (`ctrl_lpv.sensors.Encoder`,
        `Quantizer`, `Noise`, or any callable).
    seed : int or `numpy.random.Generator`, optional
        Seed of the sensors' noise.
    points_per_sample : int, optional
        Recording points of the plant per sample interval (default 1: the
        sampling instants).
    rtol, atol : float, optional
        Tolerances of the integration between samples (LSODA's, or the
        plant's compiled integrator's, see the module notes).

    Returns
    -------
    `SampledResponse`

    Raises
    ------
    ValueError, TypeError
        For a plant that is not continuous-time, a controller that is not
        discrete-time, a signal that nothing drives, or an unused name in
        `inputs` or `sensors` (named).
    SimulationError
        If the integration fails between two samples.
    """
    if not isinstance(plant, ct.NonlinearIOSystem) or not plant.isctime(strict=True):
        raise ValueError("plant: expected a continuous-time I/O system (dt = 0)")
    if not isinstance(controller, ct.NonlinearIOSystem) or not _numeric_dt(
        controller.dt
    ):
        raise ValueError(
            "controller: expected a discrete-time I/O system with a numeric "
            f"sample time dt > 0, got dt={getattr(controller, 'dt', None)!r}"
        )
    dt = float(controller.dt)
    T = real_number(T, "T", positive=True)
    if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)) or delay < 0:
        raise ValueError(f"delay: expected an integer >= 0, got {delay!r}")
    if (
        isinstance(points_per_sample, bool)
        or not isinstance(points_per_sample, (int, np.integer))
        or points_per_sample < 1
    ):
        raise ValueError(
            f"points_per_sample: expected an integer >= 1, got {points_per_sample!r}"
        )
    rtol = real_number(rtol, "rtol", positive=True)
    atol = real_number(atol, "atol", positive=True)
    wiring = _Wiring(plant, controller, dict(inputs or {}), dict(sensors or {}))
    held = _initial_command(initial_command, wiring.driven)
    x = _named_state(X0, plant.nstates, "X0")
    xc = _named_state(controller_X0, controller.nstates, "controller_X0")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)

    advance = _compiled_advance(plant, wiring)
    nsamples = int(math.floor(T / dt + 1e-9))
    commands = []  # v_k, applied from k + delay
    c_in, c_out, c_x = [], [], []
    times, states, plant_u = [], [], []
    for k in range(nsamples + 1):
        t = k * dt
        # Read the plant with the command held over the last interval.
        y = plant._out(t, x, wiring.plant_input(t, held))
        measured = wiring.measure(t, y, rng)
        v = np.asarray(controller._out(t, xc, measured), dtype=float).reshape(-1)
        c_in.append(measured)
        c_out.append(v)
        c_x.append(xc)
        xc = np.asarray(controller._rhs(t, xc, measured), dtype=float).reshape(-1)
        commands.append(v)
        if k >= delay:
            held = commands[k - delay][wiring.command_rows]
        if k == nsamples:
            times.append(t)
            states.append(x)
            plant_u.append(wiring.plant_input(t, held))
            break
        grid = t + dt * np.arange(points_per_sample + 1) / points_per_sample
        if advance is not None:
            X = _advanced(advance, grid, x, wiring.plant_input(t, held), rtol, atol)
        else:
            X = _integrated(plant, wiring, grid, x, held, rtol, atol)
        times.extend(grid[:-1])
        states.extend(X[:, :-1].T)
        plant_u.extend(wiring.plant_input(s, held) for s in grid[:-1])
        x = X[:, -1]
    return SampledResponse(
        plant=_plant_response(plant, times, states, plant_u),
        controller=ct.TimeResponseData(
            np.arange(nsamples + 1) * dt,
            _columns(c_out, controller.noutputs),
            _columns(c_x, controller.nstates),
            _columns(c_in, controller.ninputs),
            output_labels=controller.output_labels,
            state_labels=controller.state_labels,
            input_labels=controller.input_labels,
            sysname=controller.name,
        ),
        dt=dt,
        delay=int(delay),
    )


def _compiled_advance(plant, wiring):
    """The plant's compiled `BlockKernel.advance`, if it has one and its
    inputs are held over each sample interval (no continuous input)."""
    advance = getattr(getattr(plant, "_kernel", None), "advance", None)
    if advance is None or not wiring.held_inputs:
        return None
    return advance


def _advanced(advance, grid, x, u, rtol, atol):
    """States at the grid points by the plant's compiled integrator."""
    X = np.empty((x.size, grid.size))
    X[:, 0] = x
    for j in range(1, grid.size):
        try:
            X[:, j] = advance(grid[j - 1], X[:, j - 1], u, grid[j], rtol, atol)
        except SimulationError as exc:
            raise SimulationError(
                f"sampled_response: integration failed in [{grid[0]:g}, "
                f"{grid[-1]:g}] s: {exc}",
                exc.time,
            ) from None
    return X


def _integrated(plant, wiring, grid, x, held, rtol, atol):
    """States at the grid points by LSODA on the plant's Python kernel."""

    def rhs(s, xs):
        return plant._rhs(s, xs, wiring.plant_input(s, held))

    reached, X, ok, message = integrate(
        rhs, grid, x, {"method": "LSODA", "rtol": rtol, "atol": atol}
    )
    if not ok:
        raise SimulationError(
            f"sampled_response: integration failed in [{grid[0]:g}, "
            f"{grid[-1]:g}] s: {message}",
            float(reached[-1]),
        )
    return X


class _Wiring:
    """Which signal feeds which input: resolved once, by name."""

    def __init__(self, plant, controller, inputs, sensors):
        c_outputs = list(controller.output_labels)
        p_outputs = list(plant.output_labels)
        used = set()
        # Plant inputs: held commands, or external signals.
        self.driven = [n for n in plant.input_labels if n in c_outputs]
        self.command_rows = [c_outputs.index(n) for n in self.driven]
        self.driven_rows = [plant.input_labels.index(n) for n in self.driven]
        self.plant_external = []
        self.held_inputs = True  # every plant input constant between samples
        for i, name in enumerate(plant.input_labels):
            if name in self.driven:
                continue
            if name not in inputs:
                raise ValueError(
                    f"inputs: plant input {name!r} is not a controller output; "
                    "give it in `inputs`"
                )
            used.add(name)
            self.plant_external.append((i, _source(inputs[name], name)))
            self.held_inputs = self.held_inputs and not callable(inputs[name])
        # Controller inputs: sampled plant outputs, or external signals.
        self.measured = []
        for i, name in enumerate(controller.input_labels):
            if name in p_outputs:
                if name in inputs:
                    raise ValueError(
                        f"inputs: {name!r} is a plant output that the "
                        "controller reads; it cannot also be given"
                    )
                sensor = sensors.get(name)
                if sensor is not None and not callable(sensor):
                    raise TypeError(f"sensors[{name!r}]: expected a callable")
                self.measured.append((i, p_outputs.index(name), sensor))
            elif name in inputs:
                used.add(name)
                self.measured.append((i, None, _source(inputs[name], name)))
            else:
                raise ValueError(
                    f"inputs: controller input {name!r} is not a plant output; "
                    "give it in `inputs`"
                )
        unused = sorted(set(inputs) - used)
        if unused:
            raise ValueError(f"inputs: {unused} feed neither system")
        read = {name for name in controller.input_labels if name in p_outputs}
        stray = sorted(set(sensors) - read)
        if stray:
            raise ValueError(
                f"sensors: {stray} are not plant outputs read by the controller"
            )
        self.nplant = plant.ninputs
        self.ncontroller = controller.ninputs

    def plant_input(self, t, held):
        u = np.empty(self.nplant)
        u[self.driven_rows] = held
        for i, source in self.plant_external:
            u[i] = source(t)
        return u

    def measure(self, t, y, rng):
        y = np.asarray(y, dtype=float).reshape(-1)
        c = np.empty(self.ncontroller)
        for i, row, source in self.measured:
            if row is None:
                c[i] = source(t)
            else:
                c[i] = y[row] if source is None else source(y[row], rng)
        return c


def _source(value, name):
    if callable(value):
        return lambda t: float(value(t))
    number = real_number(value, f"inputs[{name!r}]")
    return lambda t: number


def _initial_command(value, driven):
    if isinstance(value, Mapping):
        stray = sorted(set(value) - set(driven))
        if stray:
            raise ValueError(f"initial_command: {stray} are not held commands")
        return np.array([
            real_number(value.get(n, 0.0), f"initial_command[{n!r}]") for n in driven
        ])  # fmt: skip
    return np.full(len(driven), real_number(value, "initial_command"))


def _named_state(X0, n, name):
    try:
        return initial_state(X0, n)
    except (TypeError, ValueError) as exc:
        raise type(exc)(str(exc).replace("X0", name, 1)) from None


def _numeric_dt(dt) -> bool:
    return (
        not isinstance(dt, bool)
        and isinstance(dt, (int, float, np.integer, np.floating))
        and dt > 0
    )


def _plant_response(plant, times, states, inputs):
    t = np.asarray(times)
    X = _columns(states, plant.nstates)
    U = _columns(inputs, plant.ninputs)
    Y = _columns(
        [np.asarray(plant._out(s, X[:, j], U[:, j]), float).reshape(-1)
         for j, s in enumerate(t)],
        plant.noutputs,
    )  # fmt: skip
    return ct.TimeResponseData(
        t, Y, X, U,
        output_labels=plant.output_labels,
        state_labels=plant.state_labels,
        input_labels=plant.input_labels,
        sysname=plant.name,
    )  # fmt: skip


def _columns(rows, n):
    """One column per time point (also for systems without states)."""
    return np.array(rows, dtype=float).reshape(len(rows), n).T
