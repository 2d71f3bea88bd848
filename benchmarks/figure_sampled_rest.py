"""Figure: the sampled servo's rest without load torque, before and after
the flank latch (`ctrl_lpv.twomass.rest_flank`).

Td = 0, 0.5 rad, 1 ms with one sample of delay, 20- and 17-bit encoders with
half a count of noise, the exact plant. Top: the motor torque; middle: the
load error; bottom: the shaft's backlash angle (which flank the motor is
on). Before: the continuous flank choice reads the encoders' noise in the
asked torque (0.2-0.3 Nm, inside its 0.5 Nm transition) and swings the
motor across the gap all the time. After: the flank is latched at the end
of the move and changed on evidence only (a CUSUM test), the motor parked
short of it; a few single crossings while the load settles, then none.

Usage::

    python benchmarks/figure_sampled_rest.py [--alpha 0.03] [--out PATH]
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ctrl_lpv import sampled_response, twomass  # noqa: E402
from ctrl_lpv.sensors import Encoder  # noqa: E402


def simulate(design, alpha, T=5.0, seed=1):
    res = sampled_response(
        twomass.plant(alpha=alpha), design.controller(), T,
        inputs={"Td": 0.0, "theta_r": 0.5}, delay=design.delay,
        sensors={"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)},
        seed=seed,
    )  # fmt: skip
    p = res.plant
    return p.time, p.inputs[0], p.outputs[2] - 0.5, p.states[4]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--alpha", type=float, default=0.03)
    parser.add_argument("--out", default="benchmarks/results/sampled_rest.png")
    args = parser.parse_args()
    common = dict(dt=1e-3, delay=1, sensors="encoders", certify=False)
    designs = {
        "before: continuous flank choice": twomass.servo_design(
            anti_hunting=twomass.ServoAntiHunting(rest_flank=None), **common
        ),
        "after: flank latched, changed on evidence": twomass.servo_design(**common),
    }
    fig, axes = plt.subplots(3, 2, figsize=(11, 7), sharex=True, sharey="row")
    for col, (label, design) in enumerate(designs.items()):
        t, torque, e, theta_b = simulate(design, args.alpha)
        last = t >= t[-1] - 1.0
        axes[0, col].plot(t, torque, lw=0.6)
        axes[0, col].set_title(
            f"{label}\ntorque std over the last second {np.std(torque[last]):.2f} Nm"
        )
        axes[1, col].plot(t, e * 1e3, lw=0.8)
        axes[1, col].axhline(0.2, color="k", ls=":", lw=0.8)
        axes[1, col].axhline(-0.2, color="k", ls=":", lw=0.8)
        axes[2, col].plot(t, theta_b, lw=0.8)
        axes[2, col].set_xlabel("t, s")
    axes[0, 0].set_ylim(-520, 520)
    axes[1, 0].set_ylim(-1.0, 1.0)
    axes[0, 0].set_ylabel("Tm, Nm")
    axes[1, 0].set_ylabel("theta_l - theta_r, mrad\n(target +-0.2)")
    axes[2, 0].set_ylabel("backlash angle, rad\n(+-alpha: a flank)")
    for ax in axes.ravel():
        ax.set_xlim(0.1, t[-1])
        ax.grid(alpha=0.3)
    fig.suptitle(
        f"Sampled servo at rest without load torque (alpha = {args.alpha:g} rad, "
        "1 ms, one sample of delay, 20/17-bit encoders)"
    )
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
