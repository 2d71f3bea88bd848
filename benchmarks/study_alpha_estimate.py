"""Vertex gains scheduled on p with a right or wrong backlash estimate.

The scheduling parameter p = -alpha_hat / |theta_d| (or -1 in the gap) needs
the unknown backlash; this study designs Theorem 2 vertex gains on
``twomass.lpv_model(p_bounds=(-0.95, 0), formulation="tracking",
integral=True)`` and simulates the paper's alpha-step scenario (0.03 ->
0.045 rad at 2.5 s, Td = 8 Nm, theta_r = 0.5 rad) on the exact plant for
several estimates, next to the robust common gain (Lemma 2), which needs
no estimate.

Usage::

    python benchmarks/study_alpha_estimate.py [--json PATH]
"""

from __future__ import annotations

import argparse
import json

import ctrl_lpv as lpv
from ctrl_lpv import twomass

ESTIMATES = [0.0, 0.015, 0.03, 0.045, 0.06, 0.1]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the rows to this JSON file")
    args = parser.parse_args(argv)
    model = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    channels = dict(w="Td", u="Tm", z=model.output_labels)
    common = lpv.hinf_state_feedback(model, **channels)
    scheduled = lpv.gain_scheduled_hinf(model, **channels)
    cases = [("common gain (Lemma 2)", twomass.lpv_controller(common), None)]
    cases += [
        (f"vertex gains, alpha_hat = {a:g}",
         twomass.lpv_controller(scheduled, alpha_estimate=a), a)
        for a in ESTIMATES
    ]  # fmt: skip
    print(f"gamma: common {common.gamma:.4g}, scheduled {scheduled.gamma:.4g}")
    print("| controller | rise (s) | settle (s) | overshoot (%) | peak |Tm| (Nm) "
          "| IAE | error 5 s (rad) |")  # fmt: skip
    print("|" + "---|" * 7)
    rows = []
    for label, controller, estimate in cases:
        m = twomass.metrics(twomass.simulate(controller, alpha=twomass.alpha_step()))
        rows.append({"controller": label, "alpha_estimate": estimate, **m.as_dict()})
        print(
            f"| {label} | {m.rise_time:.3f} | {m.settling_time:.3f} | "
            f"{m.overshoot:.2f} | {m.peak_input:.4g} | {m.iae:.4f} | "
            f"{m.steady_state_error:.2e} |",
            flush=True,
        )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
