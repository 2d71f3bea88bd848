"""Two-mass H-infinity designs in one call.

`design` picks the channels of `lpv_model` for a formulation and runs
Lemma 2 (one common gain) or Theorem 2 (vertex gains). Their gain files
are written by `ctrl_lpv.twomass.gain_files` and read back, re-checked, by
`ctrl_lpv.twomass.gain_reader`.
"""

from __future__ import annotations

from ..synthesis import (
    StateFeedbackDesign,
    gain_scheduled_hinf,
    hinf_state_feedback,
)
from .model import INTEGRAL_WEIGHT, TORQUE_WEIGHT, lpv_model
from .parameters import Parameters

__all__ = ["design"]


def design(
    params: Parameters | None = None,
    *,
    p_bounds: tuple[float, float] = (-0.95, 0.0),
    formulation: str = "tracking",
    integral: bool = True,
    scheduled: bool = False,
    torque_weight: float = TORQUE_WEIGHT,
    integral_weight: float = INTEGRAL_WEIGHT,
    backoff: float | None = 0.2,
    **options,
) -> StateFeedbackDesign:
    """Certified H-infinity state feedback for the two-mass LPV model.

    Builds ``lpv_model(params, p_bounds, formulation, integral, ...)`` and
    solves Lemma 2 (`ctrl_lpv.hinf_state_feedback`, one gain for the whole
    interval) or Theorem 2 (`ctrl_lpv.gain_scheduled_hinf`, one gain per
    vertex) with the formulation's channels: ``w = Td``, ``z`` every output
    for ``"tracking"``; ``w = [Td, theta_r]``, ``z = theta_l`` for
    ``"paper"``. The control input is ``Tm``.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data of the design model.
    p_bounds : (float, float), optional
        Interval of the backlash parameter; ``p = -1`` is not stabilizable
        (see the errata), hence the default ``(-0.95, 0)``.
    formulation : {"tracking", "paper"}, optional
        Model formulation (`lpv_model`).
    integral : bool, optional
        Integral of the load-angle error as a state (tracking only).
    scheduled : bool, optional
        Vertex gains (Theorem 2) instead of one common gain (Lemma 2).
    torque_weight, integral_weight : float, optional
        Weights of the tracking formulation's performance outputs.
    backoff : float or None, optional
        Relative back-off from the optimal ``gamma`` (see
        `ctrl_lpv.hinf_state_feedback`).
    **options
        Further keywords of the synthesis function (``gain_bound``,
        ``regions``, ``margin``, ``solvers``).

    Returns
    -------
    `ctrl_lpv.StateFeedbackDesign`
        The certified design.

    Raises
    ------
    ValueError
        For invalid model options (see `lpv_model`).
    ctrl_lpv.InfeasibleError
        If no certified design exists.
    """
    if formulation == "paper" and integral:
        integral = False  # the paper's formulation has no integral state
    model = lpv_model(
        params,
        p_bounds,
        formulation,
        integral,
        torque_weight=torque_weight,
        integral_weight=integral_weight,
    )
    if formulation == "paper":
        channels = dict(w=["Td", "theta_r"], u=["Tm"], z=["theta_l"])
    else:
        channels = dict(w=["Td"], u=["Tm"], z=list(model.output_labels))
    synthesize = gain_scheduled_hinf if scheduled else hinf_state_feedback
    return synthesize(model, **channels, backoff=backoff, **options)
