"""
H2, H-infinity and mixed H2/H-infinity
======================================

Three state-feedback designs for one polytopic plant, each a call of
`ctrl_lpv.synthesize` with a different objective:

* ``objective=Hinf(...)``: the smallest certified L2 gain from ``w`` to
  ``z``;
* ``objective=H2(...)``: the smallest certified H2 bound (for a
  time-varying ``k``, a bound on the worst-case energy of the impulse
  response);
* mixed: the H2 objective with an H-infinity constraint,
  ``constraints=[Hinf(..., bound=...)]``.

The figure shows the H2 and H-infinity norms of the frozen closed loops
(``k`` held constant) against ``k``, computed with `control.norm` and
`control.linfnorm`, beside the certified bounds (dashed). A certified
bound holds for every trajectory of ``k`` in its interval, so it lies above
every frozen norm.
"""

import control as ct
import matplotlib.pyplot as plt
import numpy as np

import ctrl_lpv as lpv

# %%
# The plant
# ---------
# States ``q`` (position) and ``v`` (velocity); the disturbance ``w`` enters
# the position equation, the force ``u`` the velocity equation. The
# performance output is ``z = (q, effort)`` with ``effort = u``.
base = ct.ss(
    [[0, 1], [0, -0.5]],
    [[1, 0], [0, 1]],  # B = [B_w, B_u]
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
# Three objectives
# ----------------
# The specs name the channel by signal names. One common gain ``K`` for all
# ``k`` (``gains="common"``, the default) and a constant Lyapunov matrix.
hinf = lpv.Hinf(w="w", z=["q", "effort"])
h2 = lpv.H2(w="w", z=["q", "effort"])

d_hinf = lpv.synthesize(plant, "u", objective=hinf)
d_h2 = lpv.synthesize(plant, "u", objective=h2)


def frozen_norms(design, ks):
    """H2 and H-infinity norms of the frozen closed loops at each k."""
    h2_norms, hinf_norms = [], []
    for k in ks:
        A, Bw, Cz, Dzw = design.closed_loop({"k": k})
        loop = ct.ss(A, Bw, Cz, Dzw)
        h2_norms.append(ct.norm(loop, 2))
        hinf_norms.append(ct.linfnorm(loop)[0])
    return np.array(h2_norms), np.array(hinf_norms)


ks = np.linspace(0.5, 8.0, 31)
# The H2 design's worst frozen L2 gain: the mixed design asks for a
# certified gain halfway between it and the H-infinity optimum.
worst_gain_h2 = frozen_norms(d_h2, ks)[1].max()
bound = 0.5 * (d_hinf.gamma + worst_gain_h2)
d_mixed = lpv.synthesize(
    plant,
    "u",
    objective=h2,
    constraints=[lpv.Hinf(w="w", z=["q", "effort"], bound=bound)],
)

designs = {"H-infinity": d_hinf, "H2": d_h2, "mixed": d_mixed}
for label, design in designs.items():
    certified = ", ".join(
        f"{type(s).__name__} <= {g:.3f}" for s, g in design.bounds.items()
    )
    print(f"{label:>10}: K = {np.round(design.gains[0], 3)}, certified {certified}")

# %%
# Frozen norms against the certified bounds
# -----------------------------------------
fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharex=True)
for (label, design), color in zip(designs.items(), ("C0", "C1", "C2")):
    n2, ninf = frozen_norms(design, ks)
    axes[0].plot(ks, n2, color=color, label=label)
    axes[1].plot(ks, ninf, color=color, label=label)
    for spec, value in design.bounds.items():
        ax = axes[0] if isinstance(spec, lpv.H2) else axes[1]
        ax.axhline(value, color=color, linestyle="--", linewidth=1)
axes[0].set(title="H2 norm (frozen k)", xlabel="k", ylabel="norm")
axes[1].set(title="H-infinity norm (frozen k)", xlabel="k")
axes[1].legend(title="design (dashed: certified)")
fig.tight_layout()
plt.show()

# %%
# The H2 design has the smallest H2 norms and the H-infinity design the
# smallest peak gain; the mixed design trades between the two. Each dashed
# line is above its curves: for the H-infinity bounds this is the frozen
# case of the L2-gain certificate; for the H2 bounds it is because the
# bound covers the worst impulse response over all trajectories of ``k``,
# of which the frozen ones are a part.
