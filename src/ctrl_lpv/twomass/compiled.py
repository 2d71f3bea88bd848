"""The compiled engine of the two-mass scenarios (needs numba).

`simulate_loop` runs what ``twomass.simulate(..., engine="compiled")``
asks for: the plant of `twomass.plant` (exact or dead-zone backlash,
constant or stepped ``alpha``) under `lpv_controller` or
`backstepping_controller`, integrated by the numba Dormand-Prince 5(4) of
`ctrl_lpv.twomass.dopri5` (scipy's RK45, compiled), outputs computed in
compiled code too. `plant_advance` steps the plant alone with a held
torque, for `ctrl_lpv.sampled_response`.

The blocks describe themselves as data (`compiled_data.CompiledBlock` in
``sys._kernel.compiled``); `compiled_form` reads that description.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from .._numba import require_numba
from ..simulation_guard import DivergenceError, SimulationError
from .compiled_data import (
    B_EPS,
    B_JL,
    B_K,
    B_KS,
    C_KIND,
    CONTROLLER_SLOTS,
    D_BIJL,
    D_BIK,
    D_BIKEPS,
    D_BIKS,
    D_IJL,
    D_IJM,
    D_RATE,
    I_TD,
    I_TM,
    I_TR,
    KIND_BACKSTEPPING,
    P_CS,
    P_JL,
    P_JM,
    P_KS,
    PLANT_SLOTS,
    SIZE,
    CompiledBlock,
)

require_numba("the compiled two-mass engine")

from . import compiled_kernels, dopri5  # noqa: E402  (they import numba)
from .plant import _STATES as PLANT_STATES  # noqa: E402

__all__ = ["compiled_form", "simulate_loop", "plant_advance", "MAX_STEPS"]

#: Steps after which a run is given up (a chattering loop), as a failure.
MAX_STEPS = 10_000_000
#: The compiled Dormand-Prince integrates at this fraction of the requested
#: tolerances, so that at the same `rtol` it is at least as accurate as
#: scipy's LSODA, today's path: on 96 sweep runs against DOP853 at rtol
#: 1e-10, the largest theta_l error per run has median 2e-8 rad and 90th
#: percentile 2e-7 rad, against LSODA's 1.5e-7 and 4.6e-7 (at the requested
#: tolerances themselves, RK45's 90th percentile is 3 times LSODA's, at a
#: fifth of them about LSODA's); see ``benchmarks/bench_compiled_sweep.py``.
TOLERANCE_FACTOR = 0.1
_LOOP_OUTPUTS = ["theta_l", "Tm", "theta_m", "omega_m", "omega_l", "Ts"]


def _fresh_cache():
    """Drop compiled code cached from other sources (see `dopri5.SOURCES`)."""
    if dopri5.fingerprint() == dopri5.FINGERPRINT:
        return
    for module in (compiled_kernels, dopri5):
        for function in vars(module).values():
            cache = getattr(function, "_cache", None)
            if cache is not None and hasattr(function, "recompile"):
                cache.flush()
    dopri5.fingerprint.recompile()


_fresh_cache()


def compiled_form(sys, role: str) -> CompiledBlock | None:
    """The `CompiledBlock` that `sys` carries for `role`, or None."""
    block = getattr(getattr(sys, "_kernel", None), "compiled", None)
    if isinstance(block, CompiledBlock) and block.role == role:
        return block
    return None


def _data(plant: CompiledBlock, controller: CompiledBlock | None, **inputs):
    d = np.zeros(SIZE)
    d[list(PLANT_SLOTS)] = plant.values
    if controller is not None:
        d[list(CONTROLLER_SLOTS)] = controller.values
    for slot, name in ((I_TR, "theta_r"), (I_TD, "Td"), (I_TM, "Tm")):
        d[slot] = inputs.get(name, 0.0)
    d[D_RATE] = d[P_KS] / d[P_CS]
    d[D_IJM] = 1.0 / d[P_JM]
    d[D_IJL] = 1.0 / d[P_JL]
    if d[C_KIND] == KIND_BACKSTEPPING:
        d[D_BIK] = 1.0 / d[B_K]  # 0 for k = inf (alpha = 0): not used then
        d[D_BIJL] = 1.0 / d[B_JL]
        d[D_BIKEPS] = 1.0 / (d[B_KS] * d[B_EPS])
        d[D_BIKS] = 1.0 / d[B_KS]
    return d


def _raise(status, reached, steps, X, labels, what):
    if status == dopri5.DIVERGED:
        column = X[:, np.isfinite(X).all(axis=0)]
        row = int(np.argmax(np.abs(column[:, -1]))) if column.size else 0
        raise DivergenceError(
            f"{what}: state {labels[row]!r} diverged at t = {reached:g} s",
            reached, labels[row], float(column[row, -1]) if column.size else np.nan,
        )  # fmt: skip
    reason = {
        dopri5.TOO_SMALL: "step size too small",
        dopri5.STEPS: f"more than {steps} steps",
    }[status]
    raise SimulationError(f"{what}: integration failed at t = {reached:g} s: "
                          f"{reason}", reached)  # fmt: skip


def simulate_loop(
    plant: CompiledBlock | None,
    controller: ct.NonlinearIOSystem,
    t: np.ndarray,
    *,
    theta_r: float,
    Td: float,
    rtol: float,
    atol: float,
    state_bound: float = 1e12,
) -> ct.TimeResponseData:
    """The loop of `twomass.closed_loop` from rest, by the compiled engine.

    `plant` is the plant's compiled form (`twomass.plant.compiled_plant`;
    None: it has none). Returns the response of
    ``twomass.simulate(..., engine="fast")`` (same labels, shapes and
    fields); raises `ValueError` if a block has no compiled form,
    `DivergenceError` past `state_bound`, and `SimulationError` if the
    integration fails.
    """
    plant_block = plant
    law = compiled_form(controller, "controller")
    if plant_block is None:
        raise ValueError(
            "alpha: the compiled engine runs a constant backlash or a step "
            "(twomass.alpha_step), not a general alpha(t); use engine='fast'"
        )
    if law is None:
        raise ValueError(
            f"controller: {controller.name!r} has no compiled form (the compiled "
            "engine runs lpv_controller and backstepping_controller with a "
            "constant alpha_estimate); use engine='fast'"
        )
    d = _data(plant_block, law, theta_r=theta_r, Td=Td)
    n = plant_block.nstates + law.nstates
    X, status, reached, steps = dopri5.solve(
        d, np.zeros(n), t, TOLERANCE_FACTOR * rtol, TOLERANCE_FACTOR * atol,
        state_bound, MAX_STEPS,
    )  # fmt: skip
    # The state names of `twomass.closed_loop` (plant named "plant").
    labels = [f"plant_{s}" for s in PLANT_STATES[: plant_block.nstates]] + [
        f"{controller.name}_{s}" for s in controller.state_labels
    ]
    if status != dopri5.OK:
        _raise(status, reached, steps, X, labels, "compiled engine")
    U = np.empty((2, t.size))
    U[0], U[1] = theta_r, Td
    return ct.TimeResponseData(
        t, dopri5.outputs(d, t, X), X, U, issiso=False,
        output_labels=list(_LOOP_OUTPUTS), input_labels=["theta_r", "Td"],
        state_labels=labels, sysname="loop",
        title="Input/output response for loop",
    )  # fmt: skip


def plant_advance(block: CompiledBlock, labels):
    """``advance(t, x, u, t_end, rtol, atol)`` of the plant alone.

    ``u = (Tm, Td)`` held over ``[t, t_end]`` (see `BlockKernel.advance`),
    at `TOLERANCE_FACTOR` times the tolerances asked for, as `simulate_loop`.
    A call that starts where the previous one ended (the next sample
    interval) starts with the step size the previous one reached, instead
    of selecting one again: a fifth of the cost of a 1 ms interval, and
    still the same results for the same sequence of calls.
    """
    base = _data(block, None)
    base[C_KIND] = 0.0
    advance = dopri5.advance
    last = [math.nan, 0.0]  # where the previous call ended, its step size

    def step(t, x, u, t_end, rtol, atol):
        d = base.copy()
        d[I_TM] = u[0]
        d[I_TD] = u[1]
        # Contiguous: a strided column would compile another specialization.
        x = np.ascontiguousarray(x, dtype=float)
        h = last[1] if t == last[0] else 0.0
        y, status, reached, h_next = advance(
            d, x, t, t_end, TOLERANCE_FACTOR * rtol, TOLERANCE_FACTOR * atol, h,
            MAX_STEPS,
        )  # fmt: skip
        if status != dopri5.OK:
            last[0] = math.nan
            _raise(status, reached, MAX_STEPS, y[:, None], labels, "plant")
        last[0], last[1] = t_end, h_next
        return y

    return step
