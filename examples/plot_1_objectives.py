"""
H2, H-infinity and mixed H2/H-infinity
======================================

Three state-feedback designs for one polytopic plant, each a call of
`ctrl_lpv.synthesize` with a different objective:

* ``objective=Hinf(...)``: the smallest certified L2 gain from ``w`` to
  ``z``;
* ``objective=H2(...)``: the smallest certified H2 bound (for a
  time-varying ``k``, a bound on the output variance under white noise,
  for every trajectory of ``k``);
* mixed: the H2 objective with an H-infinity constraint,
  ``constraints=[Hinf(..., bound=...)]``.

The figures show the H2 and H-infinity norms of the frozen closed loops
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
# The mass-spring plant of the gallery with a milder variation of the
# stiffness, ``k`` in ``[1, 2]``. The disturbance ``w`` enters the position
# equation, the force ``u`` the velocity equation; the performance output is
# ``z = (q, effort)`` with ``effort = u``.
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
    base, {"k": ([[0, 0], [-1, 0]], 0, 0, 0)}, {"k": (1.0, 2.0)}
)

# %%
# H-infinity and H2 objectives
# ----------------------------
# The specs name the channel by signal names. One common gain ``K`` for all
# ``k`` (``gains="common"``, the default) and a constant Lyapunov matrix.
z = ["q", "effort"]
d_hinf = lpv.synthesize(plant, "u", objective=lpv.Hinf(w="w", z=z))
d_h2 = lpv.synthesize(plant, "u", objective=lpv.H2(w="w", z=z))
ks = np.linspace(1.0, 2.0, 21)


def frozen_norms(design):
    """H2 and H-infinity norms of the frozen closed loops on the k grid."""
    loops = [design.closed_loop({"k": k}) for k in ks]
    return [ct.norm(g, 2) for g in loops], [ct.linfnorm(g)[0] for g in loops]


def plot(designs):
    """Frozen norms (solid) and certified bounds (dashed) of each design."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharex=True)
    for (label, design), color in zip(designs.items(), ("C0", "C1", "C2")):
        for ax, norms in zip(axes, frozen_norms(design)):
            ax.plot(ks, norms, color=color, label=label)
        for spec, value in design.bounds.items():
            ax = axes[0] if isinstance(spec, lpv.H2) else axes[1]
            ax.axhline(value, color=color, linestyle="--", linewidth=1)
        print(f"{label:>10}: K = {np.round(design.gains[0], 3)}, certified", end="")
        print(
            ", ".join(
                f" {type(s).__name__} <= {g:.3f}" for s, g in design.bounds.items()
            )
        )
    axes[0].set(title="H2 norm (frozen k)", xlabel="k", ylabel="norm")
    axes[1].set(title="H-infinity norm (frozen k)", xlabel="k")
    axes[1].legend(title="design (dashed: certified)", fontsize="small")
    fig.tight_layout()
    plt.show()


plot({"H-infinity": d_hinf, "H2": d_h2})

# %%
# Mixed H2/H-infinity
# -------------------
# The H2 design's own certified L2 gain (`ctrl_lpv.l2_gain_bound` of its
# gain) is above the H-infinity optimum; the mixed design asks for the
# smallest H2 bound with a certified L2 gain halfway between the two. The
# two specs share one Lyapunov matrix, which keeps the problem convex.
gain_of_h2 = lpv.l2_gain_bound(plant, d_h2.gains, "w", "u", z).gamma
bound = 0.5 * (d_hinf.gamma + gain_of_h2)
print(f"H2 design: certified L2 gain {gain_of_h2:.3f}; mixed bound {bound:.3f}")
d_mixed = lpv.synthesize(
    plant,
    "u",
    objective=lpv.H2(w="w", z=z),
    constraints=[lpv.Hinf(w="w", z=z, bound=bound)],
)
plot({"H-infinity": d_hinf, "H2": d_h2, "mixed": d_mixed})

# %%
# Each design has the smallest certified value of its own objective (dashed
# lines), and each dashed line is above its curves: for the H-infinity
# bounds this is the frozen case of the L2-gain certificate; for the H2
# bounds it is because the bound covers the output variance along every
# trajectory of ``k``, of which the frozen ones are a part. The frozen
# norms themselves need not follow the same order, since the designs
# minimise certificates for time-varying ``k``, not frozen norms. The mixed
# design is certified for both specs by one Lyapunov matrix: a convex
# problem, but a conservative one (each certified bound is at least what the
# spec alone would give).
