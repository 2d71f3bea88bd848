"""`lpv.simulate` against `control.input_output_response` on the README loops.

The README's gain-scheduled H-infinity loop (mass-spring-damper, stiffness
k = 2.5 + 1.5 sin t in [1, 4], from q = 1, 10 s, 501 points), and the same
with integral action (`lpv.integral_augmentation(plant, "q")`). Each is
simulated four ways, round robin:

* ``ct default``: `control.input_output_response` at its defaults (RK45,
  solve_ivp's rtol 1e-3, atol 1e-6);
* ``lpv default``: `ctrl_lpv.simulate` at its defaults (RK45, rtol 1e-6,
  atol 1e-9);
* ``ct tight``: python-control at the library's tolerances;
* ``lpv loose``: the library at python-control's tolerances.

Columns: median CPU time of a whole call (this process), its ratio to
``ct default`` (median over repeats of the per-repeat ratio), and the
largest output error against a reference (DOP853, rtol 1e-12, atol 1e-14,
through python-control).

Usage::

    python benchmarks/bench_readme_simulate.py [--repeat N] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import control as ct
import numpy as np

import ctrl_lpv as lpv

LOOSE = dict(rtol=1e-3, atol=1e-6)  # solve_ivp's defaults, python-control's
TIGHT = dict(rtol=1e-6, atol=1e-9)  # ctrl_lpv.simulate's defaults


def readme_plant():
    base = ct.ss(
        [[0, 1], [0, -0.5]], [[0, 0], [1, 1]],
        [[1, 0], [0, 1], [0, 0]], [[0, 0], [0, 0], [0, 0.1]],
        inputs=["w", "u"], outputs=["q", "v", "uw"], states=["q", "v"],
        name="plant",
    )  # fmt: skip
    stiffness = ([[0, 0], [-1, 0]], 0, 0, 0)
    return lpv.PolytopicStateSpace.from_affine(
        base, {"k": stiffness}, {"k": (1, 4)}, scheduling="inputs"
    )


def loops():
    """The README loop and its integral-action variant, with T, U, X0."""
    plant = readme_plant()
    T = np.linspace(0, 10, 501)
    U = [0 * T, 2.5 + 1.5 * np.sin(T)]
    design = lpv.gain_scheduled_hinf(plant, w="w", u="u", z=["q", "uw"])
    plain = ct.interconnect(
        [plant, design.controller()], inputs=["w", "k"], outputs=["q", "v", "u", "uw"]
    )
    augmented = lpv.integral_augmentation(plant, "q")
    z = ["q", "uw"] + [s for s in augmented.output_labels if s.startswith("int_")]
    integral_design = lpv.gain_scheduled_hinf(augmented, w="w", u="u", z=z)
    integral = ct.interconnect(
        [plant, integral_design.controller()],
        inputs=["w", "k"],
        outputs=["q", "v", "u", "uw"],
    )
    return {"README loop": plain, "README loop, integral": integral}, T, U


def run(name, loop, T, U):
    if name == "ct default":
        return ct.input_output_response(loop, T, U, X0=[1, 0])
    if name == "ct tight":
        return ct.input_output_response(loop, T, U, X0=[1, 0], solve_ivp_kwargs=TIGHT)
    if name == "lpv default":
        return lpv.simulate(loop, T, U, [1, 0])
    return lpv.simulate(loop, T, U, [1, 0], **LOOSE)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--json", help="write the rows to this JSON file")
    args = parser.parse_args(argv)
    systems, T, U = loops()
    variants = ["ct default", "lpv default", "ct tight", "lpv loose"]
    rows = []
    print("| loop | variant | rtol | CPU (ms) | ratio to ct default | max error |")
    print("|---|---|---|---|---|---|")
    for label, loop in systems.items():
        reference = ct.input_output_response(
            loop, T, U, X0=[1, 0], solve_ivp_method="DOP853",
            solve_ivp_kwargs=dict(rtol=1e-12, atol=1e-14),
        ).outputs  # fmt: skip
        times = {v: [] for v in variants}
        errors = {}
        for _ in range(args.repeat):
            for v in variants:
                start = time.process_time()
                resp = run(v, loop, T, U)
                times[v].append(time.process_time() - start)
                errors[v] = float(np.abs(resp.outputs - reference).max())
        for v in variants:
            ratios = [a / b for a, b in zip(times[v], times["ct default"])]
            row = dict(
                loop=label, variant=v,
                rtol=(LOOSE if v in ("ct default", "lpv loose") else TIGHT)["rtol"],
                cpu_ms=1e3 * statistics.median(times[v]),
                ratio=statistics.median(ratios), max_error=errors[v],
            )  # fmt: skip
            rows.append(row)
            print(
                f"| {label} | {v} | {row['rtol']:g} | {row['cpu_ms']:.1f} | "
                f"{row['ratio']:.2f} | {row['max_error']:.2e} |",
                flush=True,
            )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
