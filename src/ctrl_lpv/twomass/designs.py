"""Two-mass H-infinity designs in one call.

`design` picks the channels of `lpv_model` for a formulation and runs
Lemma 2 (one common gain) or Theorem 2 (vertex gains);
`output_feedback_design` measures the model with angle encoders only. Their gain files
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

__all__ = ["design", "output_feedback_design"]


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


#: Measured outputs of `output_feedback_design`, by sensor set.
_SENSORS = {"motor": ("e_m",), "both": ("e_m", "e_l")}


def output_feedback_design(
    params: Parameters | None = None,
    *,
    sensors: str = "both",
    noise: float = 1e-3,
    p_bounds: tuple[float, float] = (-0.95, 0.0),
    torque_weight: float = TORQUE_WEIGHT,
    integral_weight: float = INTEGRAL_WEIGHT,
    backoff: float | None = 0.2,
    **options,
):
    """Certified H-infinity output feedback of the two-mass LPV model.

    The tracking formulation (`lpv_model`) measured by angle encoders only,
    no speeds: ``sensors="both"`` reads the motor and load angle errors
    ``e_m`` and ``e_l`` and the integral of ``e_l`` (which the controller
    computes from its own measurement); ``sensors="motor"`` reads ``e_m``
    alone, without the integral state (its integral of the load error
    could not be formed from the motor angle: that mode is unobservable).
    Each measurement carries a noise input ``n_<signal>`` of weight
    `noise` (rad); ``w`` is the load torque and the noises, ``z`` the
    formulation's performance outputs, ``u = Tm``. The controller is
    scheduled with the backlash parameter ``p`` (one per vertex,
    `ctrl_lpv.hinf_output_feedback`).

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data of the design model.
    sensors : {"both", "motor"}, optional
        The encoders read (default both).
    noise : float, optional
        Weight of each measurement's noise input, in rad (default 1e-3).
    p_bounds : (float, float), optional
        Interval of the backlash parameter.
    torque_weight, integral_weight : float, optional
        Weights of the tracking formulation's performance outputs.
    backoff : float or None, optional
        Back-off from the optimal bound (`ctrl_lpv.hinf_output_feedback`).
    **options
        ``margin``, ``solvers``, ``time_limit``.

    Returns
    -------
    `ctrl_lpv.OutputFeedbackDesign`
        Its controller reads ``y_<signal>`` and ``p``, and drives ``Tm``.

    Raises
    ------
    ValueError
        For an unknown `sensors` or a `noise` that is not positive.
    """
    import numpy as np

    from .._checks import real_number
    from ..output_feedback import hinf_output_feedback
    from ..systems import PolytopicStateSpace

    if sensors not in _SENSORS:
        raise ValueError(f"sensors: expected 'both' or 'motor', got {sensors!r}")
    noise = real_number(noise, "noise", positive=True)
    integral = sensors == "both"
    model = lpv_model(params, p_bounds, "tracking", integral,
                      torque_weight=torque_weight,
                      integral_weight=integral_weight)  # fmt: skip
    measured = _SENSORS[sensors] + (("int_e_l",) if integral else ())
    n, k = model.nstates, len(measured)
    Cy = np.zeros((k, n))
    for i, s in enumerate(measured):
        Cy[i, model.state_labels.index(s)] = 1.0
    noises = [f"n_{s}" for s in measured]
    vertices = []
    for A, B, C, D in model.vertex_data():
        nz = C.shape[0]
        vertices.append((
            A,
            np.hstack([B[:, :1], np.zeros((n, k)), B[:, 1:]]),
            np.vstack([C, Cy]),
            np.block([[D[:, :1], np.zeros((nz, k)), D[:, 1:]],
                      [np.zeros((k, 1)), noise * np.eye(k), np.zeros((k, 1))]]),
        ))  # fmt: skip
    plant = PolytopicStateSpace(
        vertices, model.domain, inputs=["Td", *noises, "Tm"],
        outputs=[*model.output_labels, *(f"y_{s}" for s in measured)],
        states=model.state_labels, name=f"twomass_{sensors}_encoders",
    )  # fmt: skip
    return hinf_output_feedback(
        plant, ["Td", *noises], "Tm", list(model.output_labels),
        [f"y_{s}" for s in measured], backoff=backoff, **options,
    )  # fmt: skip
