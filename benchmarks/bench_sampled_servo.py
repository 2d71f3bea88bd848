"""The sampled servo on encoders against the targets of issue 22.

The exact backlash plant (|Tm| <= 500 Nm) is integrated between samples by
`ctrl_lpv.sampled_response`, read through a 20-bit motor and a 17-bit load
encoder with half a count of noise, and driven by
``servo_design(dt=..., delay=1, sensors="encoders").controller()``, one
sample of computation delay. Each row prints the 2 % settling time, the
overshoot, the error at the end, the error's peak-to-peak and the torque's
standard deviation over the last second, and whether the certified rest
bounds (``design.certificate.rest_error_bound``, ``rest_ripple_bound``)
hold along the run (``n/a`` below the certificate's load-torque floor
``rest.min_load_torque``: the certified loop assumes the shaft in contact,
the observer scheduled on contact and the flank choice saturated, which
only a load torque that large guarantees against worst-case reading
errors); ``ok`` marks the rows that
meet the issue's targets (settling <= 0.25 s and overshoot <= 1 % for the
paper scenario and the 0.5 rad moves without load torque, 0.3 s and 1.5 %
otherwise, |e| <= 2e-4 rad, error peak-to-peak <= 2e-4 rad, torque std
<= 3 Nm (5 Nm at 125 us and 2 ms)).

A second table streams the set-point: ``theta_r`` a 0.2 rad, 1 Hz sine sent
every sample, followed by ``servo_design(..., reference="stream")`` (the
tracker of `ctrl_lpv.twomass.stream`, no re-planning) and, for contrast, by
the planner (which re-plans a move at every new sample); each row prints the
largest ``|theta_l - theta_r|`` after the first second (target <= 5 mrad),
its RMS and the peak torque.

A third table reads the motor encoder alone (``sensors="motor"``, the
dead-zone estimator of `ctrl_lpv.twomass.motor_estimator`): ``ok`` marks
the issue's targets for it, with a load torque settling <= 0.5 s,
overshoot <= 2 %, |e| <= 1e-3 rad at the end; without one a torque std
<= 3 Nm and the error over the last second within the gap (the load is
not observable inside it). The rows marked ``(beyond)`` are outside what
the mode is shown to do (printed to say so, not targets).

Usage::

    python benchmarks/bench_sampled_servo.py [--dt 1e-3] [--seed 1]
        [--seeds 1,2,3,4,5,6] [--tables encoders,stream,motor]

With ``--seeds`` every row of the encoders and motor tables is the worst of
each metric over the noise seeds (the settling, the overshoot, the errors and
the torque std each at its own worst seed), printed (encoders table) with
the seed of the worst torque std.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder

SCENARIOS = [
    # name, Td, alpha (None: the paper's step 0.03 -> 0.045), Jl, theta_r
    ("paper", 8.0, None, 1.0, 0.5),
    ("Td=5, alpha 0.06, Jl x0.8", 5.0, 0.06, 0.8, 0.5),
    ("Td=5, alpha 0.03, Jl x1.2, -1 rad", 5.0, 0.03, 1.2, -1.0),
    ("Td=2, alpha 0.06", 2.0, 0.06, 1.0, 0.5),
    ("Td=3, alpha 0.06, 0.05 rad", 3.0, 0.06, 1.0, 0.05),
    ("Td=0, alpha 0.03", 0.0, 0.03, 1.0, 0.5),
    ("Td=0, alpha 0.06", 0.0, 0.06, 1.0, 0.5),
    ("Td=1, alpha 0.03", 1.0, 0.03, 1.0, 0.5),
    ("Td=1, alpha 0.06", 1.0, 0.06, 1.0, 0.5),
    ("Td=0.5, alpha 0.03", 0.5, 0.03, 1.0, 0.5),
    ("Td=0, alpha 0.03, Jl x0.8, 0.05 rad", 0.0, 0.03, 0.8, 0.05),
    ("Td=0, alpha 0.03, Jl x1.2, 1 rad", 0.0, 0.03, 1.2, 1.0),
    ("Td=30, alpha 0.03 (certified rest)", 30.0, 0.03, 1.0, 0.5),
    # The first move from mid-gap, the load torque along the step (docs:
    # "The first move from mid-gap").
    ("Td=8, alpha 0.03, -0.05 rad", 8.0, 0.03, 1.0, -0.05),
    # Gaps narrower than the first estimate (alpha_max / 2; docs: "Gaps
    # narrower than the first estimate").
    ("Td=0, alpha 0.01", 0.0, 0.01, 1.0, 0.5),
    ("Td=1, no gap", 1.0, 0.0, 1.0, 0.5),
    ("Td=0, alpha 0.01, 0.05 rad", 0.0, 0.01, 1.0, 0.05),
]


ENCODERS = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}
MOTOR_ENCODER = {"theta_m": Encoder(2**20, 0.5)}


def run(design, Td, alpha, Jl, theta_r, *, T=5.0, seed=1, sensors=ENCODERS):
    params = twomass.Parameters()
    plant = twomass.plant(
        params.replace(Jl=Jl * params.Jl),
        alpha=twomass.alpha_step() if alpha is None else alpha,
    )
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": theta_r},
        delay=design.delay, sensors=sensors, seed=seed,
    )  # fmt: skip
    t, e = res.plant.time, res.plant.outputs[2] - theta_r
    torque = res.plant.inputs[0]
    outside = np.flatnonzero(np.abs(e) > 0.02 * abs(theta_r))
    settling = (
        0.0
        if not outside.size
        else (t[outside[-1] + 1] if outside[-1] + 1 < t.size else np.inf)
    )
    last = t >= T - 1.0
    # The rest flank's changes over the last second (latch, flip, release):
    # each one swings the motor across the gap, the torque chatter at Td = 0.
    c = res.controller
    if "flank_side" in c.state_labels:
        side = c.states[c.state_labels.index("flank_side")][c.time >= T - 1.0]
        flank_changes = int(np.count_nonzero(np.diff(side)))
    else:
        flank_changes = 0
    return {
        "settling": settling,
        "overshoot": max(0.0, float(np.max(np.sign(theta_r) * e))) / abs(theta_r) * 100,
        "error": abs(e[-1]),
        "ptp": np.ptp(e[last]),
        "torque_std": np.std(torque[last]),
        "rest_error": np.abs(e[last]).max(),
        "ripple": np.abs(torque[last] - torque[last].mean()).max(),
        "flank_changes": flank_changes,
    }


def worst_over_seeds(design, Td, alpha, Jl, theta_r, seeds):
    """The run's metrics, each the worst over the noise `seeds`, and the seed
    of the worst torque std (the targets' least margin is there)."""
    runs = {seed: run(design, Td, alpha, Jl, theta_r, seed=seed) for seed in seeds}
    worst = {key: max(m[key] for m in runs.values()) for key in runs[seeds[0]]}
    return worst, max(runs, key=lambda seed: runs[seed]["torque_std"])


STREAM_SCENARIOS = [
    # name, Td, alpha (None: the paper's step 0.03 -> 0.045 at 2.5 s)
    ("paper gap step, Td=8", 8.0, None),
    ("alpha 0.03, Td=8", 8.0, 0.03),
    ("alpha 0.03, Td=0", 0.0, 0.03),
    ("alpha 0.06, Td=0", 0.0, 0.06),
    ("alpha 0.06, Td=8", 8.0, 0.06),
    ("alpha 0, Td=0", 0.0, 0.0),
]


def sine(t):
    return 0.2 * np.sin(2.0 * np.pi * t)


def run_stream(design, Td, alpha, *, T=5.0, seed=1):
    plant = twomass.plant(alpha=twomass.alpha_step() if alpha is None else alpha)
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": sine},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    t = res.plant.time
    after = t >= 1.0
    e = (res.plant.outputs[2] - sine(t))[after]
    # The torque after the first second: the sine starts at full speed, a
    # step the tracker takes at the limit; after it, the gap crossings.
    peak = np.abs(res.plant.inputs[0][after]).max()
    return np.abs(e).max(), np.sqrt(np.mean(e**2)), peak


def stream_table(dt, seed, planned):
    stream = twomass.servo_design(
        dt=dt, delay=1, sensors="encoders", reference="stream", certify=False
    )
    print(f"\nstreamed 0.2 rad 1 Hz sine at dt = {dt:g} s (max |e| after 1 s "
          "<= 5 mrad)")  # fmt: skip
    print(f"{'reference':10s} {'scenario':24s} {'max |e|':>9s} {'rms e':>9s} "
          f"{'peak Tm':>8s}  ok  (after the first second)")  # fmt: skip
    for name, Td, alpha in STREAM_SCENARIOS:
        rows = [("stream", stream)]
        if alpha is None:
            rows.append(("plan", planned))
        for label, design in rows:
            worst, rms, peak = run_stream(design, Td, alpha, seed=seed)
            print(f"{label:10s} {name:24s} {worst:9.2e} {rms:9.2e} {peak:8.1f}  "
                  f"{'ok' if worst <= 5e-3 else '--'}")  # fmt: skip


MOTOR_SCENARIOS = [
    # name, Td, alpha (None: the paper's step 0.03 -> 0.045), Jl, theta_r
    ("paper, alpha 0.03", 8.0, 0.03, 1.0, 0.5),
    ("Td=8, alpha 0.06", 8.0, 0.06, 1.0, 0.5),
    ("Td=8, alpha 0.03, -0.5 rad", 8.0, 0.03, 1.0, -0.5),
    ("Td=0, alpha 0.03", 0.0, 0.03, 1.0, 0.5),
    ("Td=0, alpha 0.06", 0.0, 0.06, 1.0, 0.5),
    ("Td=0, alpha 0.03, -0.5 rad", 0.0, 0.03, 1.0, -0.5),
    ("Td=2, alpha 0.03", 2.0, 0.03, 1.0, 0.5),
    ("Td=5, alpha 0.03", 5.0, 0.03, 1.0, 0.5),
    ("Td=8, alpha 0.03, 0.05 rad", 8.0, 0.03, 1.0, 0.05),
    ("Td=8, alpha 0.03, -0.05 rad", 8.0, 0.03, 1.0, -0.05),
    ("Td=8, alpha 0.06, 0.05 rad", 8.0, 0.06, 1.0, 0.05),
    ("Td=8, alpha 0.06, -0.05 rad", 8.0, 0.06, 1.0, -0.05),
    ("Td=8, alpha 0.03, 1 rad", 8.0, 0.03, 1.0, 1.0),
    ("Td=8, alpha 0.03, -1 rad", 8.0, 0.03, 1.0, -1.0),
    ("Td=8, Jl x0.8", 8.0, 0.03, 0.8, 0.5),
    ("paper gap step", 8.0, None, 1.0, 0.5),
    ("Td=30, alpha 0.03", 30.0, 0.03, 1.0, 0.5),
    ("Td=8, Jl x1.2", 8.0, 0.03, 1.2, 0.5),
]


#: Rows run on a servo commissioned on the drive (the estimator's nominal
#: inertia fails the Jl rows above, its first half-gap estimate, 0.03, the
#: small moves at the widest gap): the nominal design's 0.5 rad move under
#: 8 Nm on the drive, recorded for 0.4 s on the run's noise seed, gives the
#: load inertia and the half-gap (`twomass.identify_load_inertia`), and the
#: servo is designed on them.
MOTOR_COMMISSIONED = [
    ("Td=8, Jl x0.8, commissioned", 8.0, 0.03, 0.8, 0.5),
    ("Td=8, Jl x0.9, commissioned", 8.0, 0.03, 0.9, 0.5),
    ("Td=8, Jl x1.1, commissioned", 8.0, 0.03, 1.1, 0.5),
    ("Td=8, Jl x1.2, commissioned", 8.0, 0.03, 1.2, 0.5),
    ("Td=8, a 0.06, Jl x0.8, comm.", 8.0, 0.06, 0.8, 0.5),
    ("Td=8, a 0.06, Jl x1.2, comm.", 8.0, 0.06, 1.2, 0.5),
    ("Td=8, a 0.06, 0.05 rad, comm.", 8.0, 0.06, 1.0, 0.05),
    ("Td=8, a 0.06, -0.05 rad, comm.", 8.0, 0.06, 1.0, -0.05),
    ("Td=8, a 0.06, 0.1 rad, comm.", 8.0, 0.06, 1.0, 0.1),
    ("Td=8, a 0.06, -0.2 rad, comm.", 8.0, 0.06, 1.0, -0.2),
    ("Td=8, a 0.045, -0.1 rad, comm.", 8.0, 0.045, 1.0, -0.1),
]


def motor_design(dt, Jl=1.0, half_gap=None):
    params = twomass.Parameters()
    return twomass.servo_design(
        params.replace(Jl=Jl * params.Jl), dt=dt, delay=1, sensors="motor",
        certify=False, estimator=twomass.ServoEstimator(initial_half_gap=half_gap),
    )  # fmt: skip


def commissioned(nominal, Jl, alpha, seed):
    """The motor-encoder servo designed on the load inertia and the
    half-gap identified from a record of `nominal` on the drive (load
    inertia ``Jl x`` nominal, half-gap `alpha`), and what was identified."""
    params = twomass.Parameters()
    drive = twomass.plant(params.replace(Jl=Jl * params.Jl), alpha=alpha)
    res = sampled_response(
        drive, nominal.controller(), 0.4, inputs={"Td": 8.0, "theta_r": 0.5},
        delay=nominal.delay, sensors=MOTOR_ENCODER, seed=seed,
    )  # fmt: skip
    applied = np.concatenate([[0.0], res.controller.outputs[0][:-1]])
    found = twomass.identify_load_inertia(nominal, res.controller.inputs[0], applied)
    return motor_design(nominal.dt, found.factor, found.half_gap), found


def motor_table(dt, seeds):
    start = time.perf_counter()
    design = motor_design(dt)
    print(f"\nmotor encoder alone at dt = {dt:g} s (design "
          f"{time.perf_counter() - start:.2f} s; no rest certificate)")  # fmt: skip
    if len(seeds) > 1:
        print(f"worst over seeds {','.join(map(str, seeds))}")
    print(f"{'scenario':30s} {'settle':>7s} {'over%':>6s} {'|e| end':>8s} "
          f"{'max|e| 1s':>9s} {'T std':>6s}  ok")  # fmt: skip
    rows = [(row, {seed: design for seed in seeds}) for row in MOTOR_SCENARIOS]
    drives = {}
    for row in MOTOR_COMMISSIONED:
        _, _, alpha, Jl, _ = row
        if (Jl, alpha) not in drives:
            drives[Jl, alpha] = {
                seed: commissioned(design, Jl, alpha, seed) for seed in seeds
            }
            found = [f for _, f in drives[Jl, alpha].values()]
            factors = [f.factor for f in found]
            gaps = [f.half_gap for f in found]
            print(
                f"  (Jl x{Jl:g}, half-gap {alpha:g}: identified as "
                f"x{min(factors):.4f}-{max(factors):.4f}, "
                f"{min(gaps):.4f}-{max(gaps):.4f})"
            )
        rows.append((row, {seed: d for seed, (d, _) in drives[Jl, alpha].items()}))
    for (name, Td, alpha, Jl, theta_r), designs in rows:
        runs = [
            run(designs[seed], Td, alpha, Jl, theta_r, seed=seed, sensors=MOTOR_ENCODER)
            for seed in seeds
        ]
        m = {key: max(r[key] for r in runs) for key in runs[0]}
        if Td > 0:
            ok = m["settling"] <= 0.5 and m["overshoot"] <= 2.0 and m["error"] <= 1e-3
        else:
            ok = m["torque_std"] <= 3.0 and m["rest_error"] <= alpha
        print(f"{name:30s} {m['settling']:7.3f} {m['overshoot']:6.2f} "
              f"{m['error']:8.1e} {m['rest_error']:9.1e} {m['torque_std']:6.2f}  "
              f"{'ok' if ok else '--'}")  # fmt: skip


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument(
        "--seeds", type=lambda text: [int(v) for v in text.split(",")], default=None,
        help="noise seeds of the encoders and motor tables, e.g. 1,2,3,4,5,6: "
        "each row is the worst over them (the stream table uses --seed)",
    )  # fmt: skip
    parser.add_argument("--tables", default="encoders,stream,motor")
    args = parser.parse_args()
    tables = set(args.tables.split(","))
    if "motor" in tables:
        motor_table(args.dt, args.seeds or [args.seed])
    if not tables & {"encoders", "stream"}:
        return
    start = time.perf_counter()
    design = twomass.servo_design(dt=args.dt, delay=1, sensors="encoders")
    cert = design.certificate
    print(f"design at dt = {args.dt:g} s: {time.perf_counter() - start:.2f} s")
    print(f"certified rest: |e| <= {cert.rest_error_bound:.3g} rad, ripple <= "
          f"{cert.rest_ripple_bound:.3g} Nm for |Td| >= "
          f"{cert.rest.min_load_torque:.3g} Nm")  # fmt: skip
    std_max = 3.0 if args.dt == 1e-3 else 5.0
    seeds = args.seeds or [args.seed]
    if len(seeds) > 1:
        print(f"worst over seeds {','.join(map(str, seeds))} (and the seed of it)")
    print(f"{'scenario':36s} {'settle':>7s} {'over%':>6s} {'|e| end':>8s} "
          f"{'e ptp':>8s} {'T std':>6s} {'flank':>5s}  bounds  ok")  # fmt: skip
    for name, Td, alpha, Jl, theta_r in SCENARIOS:
        m, worst = worst_over_seeds(design, Td, alpha, Jl, theta_r, seeds)
        paper = name == "paper" or (Td == 0.0 and Jl == 1.0 and theta_r == 0.5)
        ok = (
            m["settling"] <= (0.25 if paper else 0.3)
            and m["overshoot"] <= (1.0 if paper else 1.5)
            and m["error"] <= 2e-4 and m["ptp"] <= 2e-4
            and m["torque_std"] <= std_max
        )  # fmt: skip
        held = (
            m["rest_error"] <= cert.rest_error_bound
            and m["ripple"] <= cert.rest_ripple_bound
        )
        # Below the certificate's load-torque floor the switches of the law
        # (contact, contact schedule, flank) may move: not the certified loop.
        covered = Td >= cert.rest.min_load_torque
        held = ("hold" if held else "EXCEED") if covered else "n/a"
        print(f"{name:36s} {m['settling']:7.3f} {m['overshoot']:6.2f} "
              f"{m['error']:8.1e} {m['ptp']:8.1e} {m['torque_std']:6.2f} "
              f"{m['flank_changes']:5d}  {held:6s}  {'ok' if ok else '--'}"
              + (f"  (seed {worst})" if len(seeds) > 1 else ""))  # fmt: skip
    if "stream" in tables:
        stream_table(args.dt, args.seed, design)


if __name__ == "__main__":
    main()
