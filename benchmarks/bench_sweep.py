"""Wall time of a two-mass scenario sweep: serial, processes, Dask.

1,000 simulations (250 scenarios x the 4 controllers of the comparison):
alpha in {0, 0.015, 0.03, 0.045, 0.06} rad, Td in {0, 8} Nm, Jl scaled by
0.8 ... 1.2, torque limit none (inf), 500, 1000, 2000 or 5000 Nm; step of
theta_r to 0.5 rad, 5 s, exact backlash model, rtol 1e-6. A run that takes
longer than ``--timeout`` (30 s) is stopped and counted in the table.

Each simulation engine runs under three executors:

* ``serial``: `ctrl_lpv.sweep` with ``executor="serial"``;
* ``processes``: the default `ProcessPoolExecutor` (``--workers``, 2);
* ``dask``: a `distributed.LocalCluster` with the same number of
  single-threaded worker processes, through ``Client.get_executor()``
  (cluster start-up reported separately, not in the sweep time).

Serial and processes run round robin within each repeat, so that the load
of the machine hits them alike; the Dask repeats run afterwards, because
the cluster's scheduler lives in this process and its event loop takes the
GIL from a serial run (measured: an idle ``LocalCluster`` made a serial
python-control simulation 1.4 times slower).

Engines: ``python-control`` (`twomass.simulate` with
``engine="control"``, through `control.input_output_response`, ~2 s per
simulation) on an evenly spread subset (``--subset``), and ``fast``
(``twomass.simulate(..., engine="fast")``) on all runs. The table gives the
median wall time, simulations per second and the speed-up over serial with
the same engine; the checks compare every executor's table with the serial
one (identical numbers expected) and the fast engine with python-control on
the subset.

Usage::

    python benchmarks/bench_sweep.py [--quick] [--repeats N] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import platform
import statistics
import sys
import time

import numpy as np

from ctrl_lpv.batch import scenario_grid
from ctrl_lpv.twomass import batch as tsweep

GRID = dict(
    alpha=[0.0, 0.015, 0.03, 0.045, 0.06],
    Td=[0.0, 8.0],
    Jl_scale=[0.8, 0.9, 1.0, 1.1, 1.2],
    torque_limit=[math.inf, 500.0, 1000.0, 2000.0, 5000.0],
)
QUICK_GRID = dict(alpha=[0.0, 0.03], Td=[8.0], Jl_scale=[0.8, 1.2],
                  torque_limit=[math.inf, 2000.0])  # fmt: skip
METRICS = ("rise_time", "settling_time", "overshoot", "steady_state_error",
           "iae", "ise", "peak_input", "energy")  # fmt: skip


ENGINES = {"python-control": {"engine": "control"}, "fast": {"engine": "fast"}}


def subset(scenarios, count):
    """`count` scenarios spread evenly over the list."""
    index = np.linspace(0, len(scenarios) - 1, max(1, count)).round().astype(int)
    return [scenarios[i] for i in sorted(set(index))]


def differences(a, b):
    """Per metric: largest absolute difference, and largest relative one.

    The relative difference is taken where the value is at least 1e-3 of
    its column's largest: metrics near zero (an overshoot of 1e-10 %, a
    steady-state error of 1e-7 rad) have no meaningful relative error.
    Infinite where one table has a non-finite value the other has not.
    """
    out = {}
    for key in METRICS:
        x, y = a[key].to_numpy(float), b[key].to_numpy(float)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        finite = np.isfinite(x) & np.isfinite(y)
        if np.any(~same & ~finite):
            out[key] = (np.inf, np.inf)
            continue
        x, y = x[finite], y[finite]
        d = np.abs(x - y)
        large = np.abs(y) >= 1e-3 * np.abs(y).max(initial=0.0)
        relative = d[large] / np.abs(y[large])
        out[key] = (float(d.max(initial=0.0)), float(relative.max(initial=0.0)))
    return out


def max_difference(a, b):
    """Largest absolute difference over the metric columns."""
    return max(absolute for absolute, _ in differences(a, b).values())


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="32 runs, 1 repeat")
    parser.add_argument("--repeats", type=int, help="timed repeats (default 3)")
    parser.add_argument("--subset", type=int, help="python-control runs (16)")
    parser.add_argument("--workers", type=int, default=2, help="processes (2)")
    parser.add_argument("--no-dask", action="store_true", help="skip Dask")
    parser.add_argument("--timeout", type=float, default=30.0,
                        help="wall-time limit of one run, s (30)")  # fmt: skip
    parser.add_argument("--json", help="write the results to this JSON file")
    args = parser.parse_args(argv)
    repeats = args.repeats or (1 if args.quick else 3)
    specs = tsweep.comparison_specs()
    scenarios = scenario_grid(**(QUICK_GRID if args.quick else GRID))
    per = len(specs)
    slow = subset(scenarios, (args.subset or (4 if args.quick else 16)) // per)
    work = {engine: (slow if engine == "python-control" else scenarios, kwargs)
            for engine, kwargs in ENGINES.items()}  # fmt: skip
    local = {"serial": dict(executor="serial"),
             "processes": dict(max_workers=args.workers)}  # fmt: skip
    times = {(e, x): [] for e in work for x in local}
    tables = {}

    def measure(executors, rep):
        for engine, (cases, kwargs) in work.items():
            for executor, where in executors.items():
                start = time.perf_counter()
                table = tsweep.sweep(cases, specs, timeout=args.timeout,
                                     progress=False, **kwargs, **where)  # fmt: skip
                times[engine, executor].append(time.perf_counter() - start)
                tables[engine, executor] = table
                print(f"[{rep + 1}/{repeats}] {engine:>14} {executor:>9}: "
                      f"{len(table)} runs in {times[engine, executor][-1]:.2f} s",
                      file=sys.stderr, flush=True)  # fmt: skip

    for rep in range(repeats):
        measure(local, rep)

    startup = None
    if not args.no_dask:
        try:
            import distributed
        except ImportError:
            print("distributed is not installed: no Dask column", file=sys.stderr)
        else:
            start = time.perf_counter()
            with (
                distributed.LocalCluster(
                    n_workers=args.workers, threads_per_worker=1, processes=True,
                    dashboard_address=":0", silence_logs=logging.ERROR,
                ) as cluster,
                distributed.Client(cluster) as client,
            ):  # fmt: skip
                dask = {"dask": dict(executor=client.get_executor())}
                # Warm-up: workers import ctrl_lpv (seconds) before any timing.
                tsweep.sweep(slow[:1], specs, timeout=args.timeout,
                             progress=False, **dask["dask"])  # fmt: skip
                startup = time.perf_counter() - start
                times.update({(e, "dask"): [] for e in work})
                for rep in range(repeats):
                    measure(dask, rep)

    rows = []
    for (engine, executor), seconds in times.items():
        runs = len(tables[engine, executor])
        median = statistics.median(seconds)
        serial = statistics.median(times[engine, "serial"])
        rows.append({
            "engine": engine, "executor": executor, "runs": runs,
            "seconds": seconds, "median_s": median, "runs_per_s": runs / median,
            "speedup_vs_serial": serial / median,
            "max_abs_diff_vs_serial": max_difference(
                tables[engine, executor], tables[engine, "serial"]),
            "failed": int(tables[engine, executor]["status"]
                          .str.startswith("failed").sum()),
            "timeouts": int(tables[engine, executor]["status"]
                            .str.startswith("timeout").sum()),
        })  # fmt: skip
    base = statistics.median(times["python-control", "serial"]) / len(slow) / per
    for row in rows:
        row["per_run_speedup_vs_python_control_serial"] = base * row["runs_per_s"]

    fast, ref = tables["fast", "serial"], tables["python-control", "serial"]
    both = ref.merge(fast, on=list(GRID) + ["controller"], suffixes=("", "_fast"))
    ours = both[[k + "_fast" for k in METRICS]].set_axis(list(METRICS), axis=1)
    agreement = differences(ours, both[list(METRICS)])

    print(f"\n{len(scenarios) * per} runs (fast), {len(slow) * per} runs "
          f"(python-control), {args.workers} workers, median of {repeats}, "
          f"os.cpu_count() = {os.cpu_count()}")  # fmt: skip
    if startup is not None:
        print(f"Dask LocalCluster start-up incl. worker warm-up: {startup:.1f} s")
    print(
        "\n| engine | executor | runs | median (s) | runs/s | speed-up vs serial "
        "| per-run vs python-control serial | max abs diff vs serial | failed "
        "| timeouts |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['engine']} | {r['executor']} | {r['runs']} | "
              f"{r['median_s']:.2f} | {r['runs_per_s']:.2f} | "
              f"{r['speedup_vs_serial']:.2f} | "
              f"{r['per_run_speedup_vs_python_control_serial']:.1f} | "
              f"{r['max_abs_diff_vs_serial']:.1e} | {r['failed']} | "
              f"{r['timeouts']} |")  # fmt: skip
    print(f"\nfast vs python-control on {len(both)} common runs, largest "
          f"difference per metric (absolute; relative where not near 0):")  # fmt: skip
    for key, (absolute, relative) in agreement.items():
        print(f"  {key:>18}: {absolute:.1e}; {relative:.1e}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({
                "rows": rows,
                "dask_startup_s": startup,
                "fast_vs_python_control": {
                    key: {"max_abs_diff": a, "max_rel_diff": r}
                    for key, (a, r) in agreement.items()
                },
                "repeats": repeats,
                "timeout_s": args.timeout,
                "workers": args.workers,
                "cpu_count": os.cpu_count(),
                "python": platform.python_version(),
                "grid": {k: [None if v == math.inf else v for v in vals]
                         for k, vals in (QUICK_GRID if args.quick else GRID).items()},
            }, f, indent=2)  # fmt: skip
    return rows


if __name__ == "__main__":
    main()
