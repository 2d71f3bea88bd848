"""The two-mass blocks as data for the compiled engine (no numba needed).

The compiled engine (`ctrl_lpv.twomass.compiled`) cannot call Python
closures, so each block that it can run describes itself as numbers: the
plant of `twomass.plant`, `lpv_controller` and `backstepping_controller`
put a `CompiledBlock` in their kernel (``sys._kernel.compiled``), built
here when the block is built. A block without one (any other controller,
a backlash ``alpha(t)`` that is not a step) runs on the scipy engines.

The numbers go into one float64 vector per simulation, laid out by the
offsets below; `ctrl_lpv.twomass.compiled_kernels` reads them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["CompiledBlock", "plant_block", "lpv_block", "backstepping_block"]

# Plant: model (0 exact, 1 dead zone), data, backlash alpha(t) = A0 for
# t < AT, A1 from AT on (AT = inf: constant).
P_MODEL, P_JM, P_JL, P_CM, P_CL, P_KS, P_CS, P_A0, P_A1, P_AT = range(10)
# External inputs: reference, load torque, held motor torque (plant alone).
I_TR, I_TD, I_TM = 10, 11, 12
# Controller: kind (0 none: held torque, 1 LPV, 2 backstepping), |Tm| limit.
C_KIND, C_LIMIT = 13, 14
# LPV law: scheduled?, integral?, backlash estimate, p interval, the gains
# at p = lower and p = upper (equal for a common gain), 5 slots each.
L_SCHED, L_INTEGRAL, L_AEST, L_LO, L_HI, L_KLO, L_KHI = 15, 16, 17, 18, 19, 20, 25
# Backstepping law: design data, gains, backlash, sharpness k, eps, Td_hat,
# and the constants a, b of T* = a z1 + b x2 + Td_hat.
B_JM, B_JL, B_CM, B_CL, B_KS = 15, 16, 17, 18, 19
B_C1, B_C2, B_C3, B_C4, B_ALPHA, B_K, B_EPS, B_TDHAT, B_A, B_B = range(20, 30)
# Derived once per simulation (as the Python kernels do): ks / cs, 1 / Jm,
# 1 / Jl; for the backstepping law 1 / k, 1 / Jl, 1 / (ks eps), 1 / ks
# (multiplications instead of divisions on the hot path).
D_RATE, D_IJM, D_IJL = 30, 31, 32
D_BIK, D_BIJL, D_BIKEPS, D_BIKS = 33, 34, 35, 36
SIZE = 37

PLANT_SLOTS = range(P_MODEL, P_AT + 1)
CONTROLLER_SLOTS = range(C_KIND, SIZE)

KIND_NONE, KIND_LPV, KIND_BACKSTEPPING = 0.0, 1.0, 2.0
MODELS = {"exact": 0.0, "deadzone": 1.0}


@dataclass(frozen=True)
class CompiledBlock:
    """A block of the two-mass loop as numbers for the compiled engine.

    Attributes
    ----------
    role : {"plant", "controller"}
        Which slots of the data vector `values` fills.
    values : tuple of float
        The slots ``PLANT_SLOTS`` or ``CONTROLLER_SLOTS``, in order.
    nstates : int
        States of the block (the plant's first, then the controller's).
    """

    role: str
    values: tuple[float, ...]
    nstates: int


def alpha_schedule(alpha0: float, alpha_fun) -> tuple[float, float, float] | None:
    """``(before, after, at)`` of a constant or stepped backlash, else None.

    A step is any callable with float attributes ``before``, ``after`` and
    ``at`` that means ``before if t < at else after`` (`alpha_step`).
    """
    if alpha_fun is None:
        return alpha0, alpha0, math.inf
    try:
        step = (float(alpha_fun.before), float(alpha_fun.after), float(alpha_fun.at))
    except (AttributeError, TypeError, ValueError):
        return None
    if not all(0.0 <= a < math.inf for a in step[:2]):
        return None  # the scipy engines report the bad value where it acts
    return step


def plant_block(params, model: str, alpha0: float, alpha_fun) -> CompiledBlock | None:
    """The plant of `twomass.plant`, or None for a general ``alpha(t)``."""
    schedule = alpha_schedule(alpha0, alpha_fun)
    if schedule is None:
        return None
    p = params
    values = (MODELS[model], p.Jm, p.Jl, p.cm, p.cl, p.ks, p.cs, *schedule)
    nstates = 5 if model == "exact" else 4
    return CompiledBlock("plant", tuple(float(v) for v in values), nstates)


def _controller(kind, limit, law) -> CompiledBlock:
    values = [kind, limit, *law]
    values += [0.0] * (len(CONTROLLER_SLOTS) - len(values))
    return CompiledBlock("controller", tuple(float(v) for v in values), 0)


def lpv_block(k_lo, k_hi, integral, interval, alpha_estimate, limit):
    """The LPV law of `lpv_controller` (None for a callable estimate).

    `k_lo`, `k_hi` are the gains at the ends of the p `interval` (equal and
    `interval` None for a common gain).
    """
    if callable(alpha_estimate):
        return None
    scheduled = interval is not None
    lo, hi = interval if scheduled else (0.0, 1.0)
    pad = [0.0] * (5 - len(k_lo))
    law = [
        float(scheduled), float(integral),
        0.0 if alpha_estimate is None else alpha_estimate, lo, hi,
        *k_lo, *pad, *k_hi, *pad,
    ]  # fmt: skip
    block = _controller(KIND_LPV, limit, law)
    return CompiledBlock(block.role, block.values, int(integral))


def backstepping_block(law, limit: float) -> CompiledBlock:
    """The law of `backstepping_controller` (a `BacksteppingLaw`)."""
    p = law.p
    values = [
        p.Jm, p.Jl, p.cm, p.cl, p.ks, law.c1, law.c2, law.c3, law.c4,
        law.alpha, law.k, law.eps, law.Td_hat, law.a, law.b,
    ]  # fmt: skip
    return _controller(KIND_BACKSTEPPING, limit, values)
