"""Tutorial: reproduce the LPV two-mass backlash paper step by step.

Run from the repository root (figures go to the folder given, default
``tutorial_output``)::

    PYTHONPATH=src python docs/scripts/tutorial.py [OUTDIR]

The documentation build runs this file section by section (the ``# [name]``
comments) and shows each section's code, its printed output and its figure.
"""

import sys
from pathlib import Path

import control as ct
import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.plotting import plot_responses, save_figure

OUT = Path(sys.argv[1] if len(sys.argv) > 1 else "tutorial_output")
UNITS = {"theta_l": "rad", "Tm": "Nm"}

# [model]
params = twomass.Parameters()  # the paper's table
model = twomass.lpv_model(params, p_bounds=(-1.0, 0.0))  # (30), as published
print(model.domain)
print("states:", model.state_labels)
print("inputs:", model.input_labels, " outputs:", model.output_labels)
for p in (-1.0, 0.0):
    print(f"A(p = {p:g}) =\n{model.at(p).A}")

# [infeasible]
try:
    lpv.gain_scheduled_hinf(model, w=["Td", "theta_r"], u="Tm", z="theta_l")
except lpv.InfeasibleError as exc:
    print("InfeasibleError:", exc)

# [published]
K_paper = twomass.paper_gain()  # u = -K x: the published matrix, negated
paper = twomass.lpv_controller(K_paper)  # Tm from measured states and theta_r
response = twomass.simulate(paper, alpha=0.03, Td=8.0, theta_r=0.5)
print(twomass.metrics(response))
fig = plot_responses(
    {"paper K": response},
    ["theta_l", "Tm"],
    units=UNITS,
    reference={"theta_l": 0.5},
    symlog=["Tm"],
    title="Published gain, alpha = 0.03 rad (Figs. 4-5)",
)
save_figure(fig, OUT / "published", formats=["png"])

# [design]
robust = twomass.design(p_bounds=(-0.95, 0.0))  # Lemma 2: one common gain
scheduled = twomass.design(p_bounds=(-0.95, 0.0), scheduled=True)  # Theorem 2
print(robust)
print()
print(scheduled)

# [check]
# An independent check of the certificate: the H-infinity norm that
# python-control computes for frozen closed loops stays below gamma.
w, z = ["Td"], list(robust.z)
for p in np.linspace(-0.95, 0.0, 5):
    A, Bw, Cz, Dzw = ct.ssdata(robust.closed_loop(p))
    norm = ct.linfnorm(ct.ss(A, Bw, Cz, Dzw))[0]
    print(f"p = {p:+.4f}: ||T_zw||_inf = {norm:.5f} <= gamma = {robust.gamma:.5f}")

# [simulate]
controllers = {
    "paper K": paper,
    "LPV robust": twomass.lpv_controller(robust),
    "LPV scheduled": twomass.lpv_controller(scheduled, alpha_estimate=0.03),
}
responses = {name: twomass.simulate(c, alpha=0.03) for name, c in controllers.items()}
for name, r in responses.items():
    m = twomass.metrics(r)
    print(
        f"{name:14s} theta_l(5 s) = {r.outputs[0][-1]:.5f} rad, "
        f"peak |Tm| = {m.peak_input:8.0f} Nm, rise = {m.rise_time:.3f} s"
    )
fig = plot_responses(
    responses,
    ["theta_l", "Tm"],
    units=UNITS,
    reference={"theta_l": 0.5},
    symlog=["Tm"],
    title="Published and certified gains (Fig. 8)",
)
save_figure(fig, OUT / "designs", formats=["png"])

# [alpha-step]
step = twomass.alpha_step(0.03, 0.045, at=2.5)  # the backlash grows at 2.5 s
stepped = {name: twomass.simulate(c, alpha=step) for name, c in controllers.items()}
for name, r in stepped.items():
    print(f"{name:14s} theta_l(5 s) = {r.outputs[0][-1]:.5f} rad")
fig = plot_responses(
    stepped,
    ["theta_l", "Tm"],
    units=UNITS,
    reference={"theta_l": 0.5},
    symlog=["Tm"],
    title="Backlash step 0.03 -> 0.045 rad at 2.5 s (Figs. 6-7)",
)
save_figure(fig, OUT / "alpha_step", formats=["png"])

# [backstepping]
limit = 500.0  # Nm, the same for every controller
limited = {
    "paper K": twomass.lpv_controller(K_paper, torque_limit=limit),
    "LPV robust": twomass.lpv_controller(robust, torque_limit=limit),
    "backstepping": twomass.backstepping_controller(Td_hat=8.0, torque_limit=limit),
}
compared = {name: twomass.simulate(c, alpha=step) for name, c in limited.items()}
for name, r in compared.items():
    m = twomass.metrics(r)
    print(
        f"{name:13s} rise = {m.rise_time:.3f} s, settle = {m.settling_time:.3f} s, "
        f"error(5 s) = {m.steady_state_error:+.2e} rad, "
        f"peak |Tm| = {m.peak_input:.0f} Nm"
    )
fig = plot_responses(
    compared,
    ["theta_l", "Tm"],
    units=UNITS,
    reference={"theta_l": 0.5},
    limits={"Tm": limit},
    title="LPV vs backstepping, |Tm| <= 500 Nm",
)
save_figure(fig, OUT / "backstepping", formats=["png"])
