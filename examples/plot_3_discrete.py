"""
A discrete-time design, simulated
=================================

The continuous plant of the gallery is sampled with a zero-order hold
(`ctrl_lpv.PolytopicStateSpace.sample`), and a scheduled state feedback is
designed in discrete time: minimum certified H-infinity bound, with the
closed-loop eigenvalues in the disk ``|z| < 0.9`` of the z-plane
(`ctrl_lpv.disk`). The controller is a discrete-time python-control I/O
system with the plant's sampling period, simulated here against the exact
ZOH sampling of the frozen plant (`control.sample_system`) for three values
of ``k``.
"""

import control as ct
import matplotlib.pyplot as plt
import numpy as np

import ctrl_lpv as lpv

base = ct.ss(
    [[0, 1], [0, -0.5]],
    [[1, 0], [0, 1]],
    [[1, 0], [0, 1], [0, 0]],
    [[0, 0], [0, 0], [0, 1]],
    inputs=["w", "u"],
    outputs=["q", "v", "effort"],
    states=["q", "v"],
    name="plant",
)
plant = lpv.PolytopicStateSpace.from_affine(
    base, {"k": ([[0, 0], [-1, 0]], 0, 0, 0)}, {"k": (0.5, 8.0)}
)

# %%
# Sampling and design
# -------------------
# The vertices are sampled exactly; between them the ZOH of the frozen
# plant differs from the interpolated vertices by at most the stated bound.
Ts = 0.05
plant_d = plant.sample(Ts)
print(f"dt = {plant_d.dt}, interpolation error bound: {plant_d.discretization_error}")

design = lpv.synthesize(
    plant_d,
    "u",
    objective=lpv.Hinf(w="w", z=["q", "effort"]),
    constraints=[lpv.disk(0.9)],
    gains="scheduled",
)
print(f"certified gamma = {design.gamma:.3f}, verified: {design.certificate.verified}")
ctrl = design.controller(name="ctrl")
print(f"controller: dt = {ctrl.dt}, inputs {ctrl.input_labels}")

# %%
# Step response of the discrete closed loop
# -----------------------------------------
# Left: a unit step of ``w`` at ``t = 0``, with ``k`` held at three values.
# The loop is an ordinary python-control interconnection, by signal names.
T = np.arange(0.0, 8.0 + Ts / 2, Ts)
fig, (ax_t, ax_z) = plt.subplots(1, 2, figsize=(9.5, 3.8))
for k, color in zip((0.5, 2.0, 8.0), ("C0", "C1", "C2")):
    frozen = ct.sample_system(plant.at({"k": k}), Ts, name="frozen")
    loop = ct.interconnect(
        [frozen, ctrl], inputs=["w", "k"], outputs=["q", "effort"], name="loop"
    )
    resp = ct.input_output_response(loop, T, [np.ones_like(T), np.full_like(T, k)])
    ax_t.step(resp.time, resp.outputs[0], where="post", color=color, label=f"k = {k}")

# Right: closed-loop eigenvalues of the sampled frozen plants on a grid of
# ``k``, with the unit circle and the design disk.
for k in np.linspace(0.5, 8.0, 40):
    frozen = ct.sample_system(plant.at({"k": k}), Ts)
    Bu = frozen.B[:, [1]]
    poles = np.linalg.eigvals(frozen.A - Bu @ design.gain({"k": k}))
    ax_z.plot(poles.real, poles.imag, "k.", markersize=3)
theta = np.linspace(0, 2 * np.pi, 200)
ax_z.plot(np.cos(theta), np.sin(theta), color="0.6", label="|z| = 1")
ax_z.plot(0.9 * np.cos(theta), 0.9 * np.sin(theta), "--", color="C3", label="|z| = 0.9")
ax_z.set(xlabel="Re z", ylabel="Im z", title="closed-loop eigenvalues", aspect="equal")
ax_z.legend(loc="lower left", fontsize="small")
ax_t.set(xlabel="t [s]", ylabel="q", title="response of q to a unit step of w")
ax_t.legend()
fig.tight_layout()
plt.show()
