"""The example of docs/getting_started.rst, as a script.

Run from the repository root::

    PYTHONPATH=src python docs/scripts/getting_started.py
"""

import control as ct
import numpy as np

import ctrl_lpv as lpv

# A mass on a spring of uncertain, time-varying stiffness k in [1, 4]:
# states q (position) and v (velocity), control force u, disturbance w.
base = ct.ss(
    [[0, 1], [0, -0.5]],  # A0 (the system at k = 0)
    [[0, 0], [1, 1]],  # B = [B_w, B_u]
    [[1, 0], [0, 1], [0, 0]],  # outputs q, v and uw = 0.1 u
    [[0, 0], [0, 0], [0, 0.1]],
    inputs=["w", "u"],
    outputs=["q", "v", "uw"],
    states=["q", "v"],
    name="plant",
)
stiffness = ([[0, 0], [-1, 0]], 0, 0, 0)  # A(k) = A0 + k A1
plant = lpv.PolytopicStateSpace.from_affine(base, {"k": stiffness}, {"k": (1.0, 4.0)})

# Theorem 2: one gain per vertex, certified H-infinity bound from w to z.
design = lpv.gain_scheduled_hinf(plant, w="w", u="u", z=["q", "uw"])
print(design)  # gains, gamma, certificate, solver
print(design.gain({"k": 2.0}))  # K(delta(k)) for u = -K x

# u = -K(k) x as a python-control I/O system: inputs q, v (the states) and
# k (the scheduling parameter), output u.
ctrl = design.controller(name="ctrl")

# Standard python-control interconnection, connected by signal names. The
# plant takes its parameter from an input "k" too (a time-varying k).
loop = ct.interconnect(
    [plant.scheduled("inputs"), ctrl],
    inputs=["w", "k"],
    outputs=["q", "v", "uw", "u"],
    name="loop",
)
T = np.linspace(0.0, 10.0, 1001)
k = 2.5 + 1.5 * np.sin(T)  # inside the design box [1, 4]
resp = ct.input_output_response(
    loop,
    T,
    [np.zeros_like(T), k],
    X0=[1.0, 0.0],
    solve_ivp_kwargs={"rtol": 1e-6, "atol": 1e-9},
)
print(f"|q(10)| = {abs(resp.outputs[0, -1]):.2e}")
