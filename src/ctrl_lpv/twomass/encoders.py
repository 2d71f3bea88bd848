"""The encoder output-feedback design as a two-mass position controller.

`encoder_controller` wraps the dynamic controller of
`output_feedback_design` (``sensors="both"``) in the interface every
two-mass controller of this package has (inputs ``theta_m, omega_m,
theta_l, omega_l, theta_r``, output ``Tm``), so that `simulate` and the
comparison run it like the state-feedback designs. It reads the angles
only: the speeds are inputs of the interface and are not used.
"""

from __future__ import annotations

import math

import control as ct

from .feedback import MEASURED, backlash_parameter

__all__ = ["encoder_controller"]


def encoder_controller(
    design, *, alpha_estimate: float = 0.03, name: str = "encoders"
) -> ct.InterconnectedSystem:
    """Two-mass position controller from an encoder output-feedback design.

    The measurements of the design are formed from the encoder angles and
    the reference: ``y_e_m = theta_m - theta_r``, ``y_e_l = theta_l -
    theta_r`` and ``y_int_e_l``, the integral of ``y_e_l`` (a state of
    this controller); the scheduling parameter is ``p`` of (27) for the
    measured shaft twist ``theta_m - theta_l`` and the backlash estimate
    (`backlash_parameter`), projected onto the design's interval. The
    design's controller (`ctrl_lpv.OutputFeedbackDesign.controller`) then
    gives ``Tm`` directly, connected by name.

    Parameters
    ----------
    design : `ctrl_lpv.OutputFeedbackDesign`
        From ``output_feedback_design(sensors="both")``.
    alpha_estimate : float, optional
        Backlash estimate for the scheduling parameter, rad (default 0.03).
    name : str, optional
        System name.

    Returns
    -------
    `control.InterconnectedSystem`
        Inputs ``["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"]``,
        output ``["Tm"]``.

    Raises
    ------
    ValueError
        For a design that does not read ``y_e_m, y_e_l, y_int_e_l`` (the
        motor-encoder design is scheduled with ``p``, which needs the shaft
        twist and therefore the load encoder it does not have), or an
        `alpha_estimate` that is not a finite number ``>= 0``.
    """
    controller = design.controller()
    measured = ["y_e_m", "y_e_l", "y_int_e_l"]
    if list(controller.input_labels) != [*measured, "p"]:
        raise ValueError(
            "design: expected the design of output_feedback_design("
            f"sensors='both'), whose controller reads {measured} and p; got "
            f"inputs {list(controller.input_labels)} (a motor-encoder design "
            "is scheduled with p, which needs the load encoder)"
        )
    if not (
        isinstance(alpha_estimate, (int, float))
        and not isinstance(alpha_estimate, bool)
        and math.isfinite(alpha_estimate)
        and alpha_estimate >= 0
    ):
        raise ValueError(
            f"alpha_estimate: expected a finite number >= 0 rad, got {alpha_estimate!r}"
        )
    lower, upper = float(controller.domain.lower[0]), float(controller.domain.upper[0])
    alpha = float(alpha_estimate)

    def encoder_signals(t, x, u, params=None):
        theta_m, _, theta_l, _, theta_r = u
        p = float(backlash_parameter(theta_m - theta_l, alpha))
        return [theta_m - theta_r, theta_l - theta_r, min(max(p, lower), upper)]

    encoders = ct.nlsys(
        None, encoder_signals, inputs=[*MEASURED, "theta_r"],
        outputs=["y_e_m", "y_e_l", "p"], name=f"{name}_signals",
    )  # fmt: skip
    integral = ct.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], inputs=["y_e_l"],
                     outputs=["y_int_e_l"], name=f"{name}_integral")  # fmt: skip
    return ct.interconnect(
        [encoders, integral, controller], inputs=[*MEASURED, "theta_r"],
        outputs=["Tm"], name=name,
    )  # fmt: skip
