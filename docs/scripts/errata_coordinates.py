"""The published gain on the exact plant, in two readings of the states.

The paper's scenario: theta_r = 0.5 rad, Td = 8 Nm, alpha = 0.03 rad, 5 s
from rest, exact backlash model, ``Tm = K_paper x = -K x``, integrated with
RK45 at rtol = 1e-6, atol = 1e-9. Run from the repository root::

    PYTHONPATH=src python docs/scripts/errata_coordinates.py
"""

import control as ct
import numpy as np

from ctrl_lpv import twomass
from ctrl_lpv.metrics import step_metrics

K = twomass.paper_gain()  # u = -K x, K = -K_paper
MEASURED = ["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"]


def controller(x1_error):
    """Tm = -K x; x1 = theta_m - theta_r if x1_error else theta_m."""

    def output(t, x, u, params=None):
        theta_m, omega_m, theta_l, omega_l, theta_r = u
        x1 = theta_m - theta_r if x1_error else theta_m
        return -K @ np.array([x1, omega_m, theta_l - theta_r, omega_l])

    return ct.nlsys(None, output, inputs=MEASURED, outputs=["Tm"], name="ctrl")


for x1_error in (True, False):
    # twomass.simulate: control.interconnect of the exact plant and the
    # controller, then control.input_output_response.
    resp = twomass.simulate(controller(x1_error), alpha=0.03, method="RK45")
    T = resp.time
    theta_l = resp.outputs[resp.output_labels.index("theta_l")]
    Tm = resp.outputs[resp.output_labels.index("Tm")]
    m = step_metrics(T, theta_l, 0.5, Tm, initial=0.0)
    i = int(np.argmax(np.abs(Tm)))
    label = "x1 = theta_m - theta_r" if x1_error else "x1 = theta_m        "
    print(
        f"{label}: theta_l(5 s) = {theta_l[-1]:.4f} rad, "
        f"max theta_l = {theta_l.max():.4f} rad, "
        f"peak |Tm| = {abs(Tm[i]):.4g} Nm at t = {T[i]:g} s, "
        f"rise 10-90 % = {m.rise_time:.4f} s"
    )
