"""The two-mass example of docs/getting_started.rst, as a script.

Run from the repository root::

    PYTHONPATH=src python docs/scripts/getting_started_twomass.py
"""

import control as ct
import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv import twomass

# Design model: the tracking formulation (error coordinates) with the
# integral of the load-angle error, over p in [-0.95, 0]; p = -1 is not
# stabilizable (see the errata page).
model = twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking", integral=True)
print(model.state_labels)  # ['e_m', 'omega_m', 'e_l', 'omega_l', 'int_e_l']

# A robust common gain (Lemma 2): implementable without knowing the backlash.
design = lpv.hinf_state_feedback(model, w="Td", u="Tm", z=model.output_labels)
print(design)

# The controller forms the error coordinates and integrates e_l itself:
# inputs theta_m, omega_m, theta_l, omega_l, theta_r; output Tm.
ctrl = twomass.lpv_controller(design, name="lpv")
drive = twomass.plant(alpha=twomass.alpha_step(0.03, 0.045, at=2.5), name="plant")

loop = ct.interconnect(
    [drive, ctrl],
    inplist=["lpv.theta_r", "plant.Td"],
    inputs=["theta_r", "Td"],
    outlist=["plant.theta_l", "lpv.Tm"],
    outputs=["theta_l", "Tm"],
    ignore_outputs=["plant.Ts"],
    name="loop",
)

# The paper's scenario: theta_r = 0.5 rad, Td = 8 Nm, 5 s, from rest, with
# the backlash growing from 0.03 to 0.045 rad at 2.5 s. Tight tolerances:
# python-control's default RK45 rtol = 1e-3 is too loose here.
T = np.linspace(0.0, 5.0, 5001)
U = [np.full_like(T, 0.5), np.full_like(T, 8.0)]
resp = ct.input_output_response(
    loop,
    T,
    U,
    np.zeros(loop.nstates),
    solve_ivp_method="RK45",
    solve_ivp_kwargs={"rtol": 1e-6, "atol": 1e-9},
)
theta_l, Tm = resp.outputs
print(f"theta_l(5 s) = {theta_l[-1]:.5f} rad, peak |Tm| = {np.abs(Tm).max():.4g} Nm")
