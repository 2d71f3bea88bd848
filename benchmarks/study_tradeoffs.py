"""How eps, the torque weight and back-off trade gamma against gain and torque.

Designs `hinf_state_feedback` (robust common gain) on
``twomass.lpv_model(p_bounds=(-1 + eps, 0), formulation="tracking",
integral=True, torque_weight=rho)`` and simulates each on the exact plant in
the paper's scenario with the backlash step (0.03 -> 0.045 rad at 2.5 s,
Td = 8 Nm, theta_r = 0.5 rad). One factor varies at a time around the
defaults (eps = 0.05, rho = 2e-3, back-off 0.2).

Usage::

    python benchmarks/study_tradeoffs.py [--json PATH]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv import twomass

DEFAULTS = {"eps": 0.05, "torque_weight": 2e-3, "backoff": 0.2}
VARIATIONS = {
    "eps": [0.2, 0.1, 0.05, 0.02, 0.01],
    "torque_weight": [5e-4, 1e-3, 2e-3, 5e-3, 1e-2],
    "backoff": [None, 0.05, 0.2, 0.5, 1.0],
}


def run_case(eps, torque_weight, backoff):
    model = twomass.lpv_model(
        p_bounds=(-1.0 + eps, 0.0),
        formulation="tracking",
        integral=True,
        torque_weight=torque_weight,
    )
    design = lpv.hinf_state_feedback(
        model, w="Td", u="Tm", z=model.output_labels, backoff=backoff
    )
    response = twomass.simulate(
        twomass.lpv_controller(design), alpha=twomass.alpha_step()
    )
    m = twomass.metrics(response)
    return {
        "eps": eps,
        "torque_weight": torque_weight,
        "backoff": backoff,
        "gamma_opt": design.gamma_opt,
        "gamma": design.gamma,
        "gain_norm": float(np.linalg.norm(design.gains[0], 2)),
        "peak_torque": m.peak_input,
        "rise_time": m.rise_time,
        "settling_time": m.settling_time,
        "error_5s": m.steady_state_error,
        "closed_loop_max_real": design.certificate.max_closed_loop_real,
    }


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the rows to this JSON file")
    args = parser.parse_args(argv)
    rows = []
    header = (
        "| varied | value | gamma* | gamma | ||K|| | peak |Tm| (Nm) | rise (s) "
        "| settle (s) | error 5 s (rad) |"
    )
    print(header)
    print("|" + "---|" * 9)
    for factor, values in VARIATIONS.items():
        for value in values:
            case = dict(DEFAULTS, **{factor: value})
            row = run_case(**case)
            rows.append(row)
            gamma_opt = "n/a" if row["gamma_opt"] is None else f"{row['gamma_opt']:.4g}"
            print(
                f"| {factor} | {value} | {gamma_opt} | {row['gamma']:.4g} | "
                f"{row['gain_norm']:.3g} | {row['peak_torque']:.4g} | "
                f"{row['rise_time']:.3f} | {row['settling_time']:.3f} | "
                f"{row['error_5s']:.2e} |",
                flush=True,
            )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
