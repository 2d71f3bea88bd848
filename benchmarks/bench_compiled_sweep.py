"""Compiled two-mass sweeps and sampled runs against today's scipy path.

One process, BLAS threads 1, CPU time of this process (the machine may be
shared: CPU time is what a core spends), in one run:

1. **Sweep speed**, scenarios per second per core: `twomass.run_scenario`
   (what `twomass.sweep` runs in each worker) over the grid of
   ``bench_sweep.py`` (alpha in {0, 0.015, 0.03, 0.045, 0.06} rad, Td in
   {0, 8} Nm, Jl x {0.8 ... 1.2}, torque limit none, 500, 1000, 2000, 5000
   Nm; 0.5 rad step, 5 s, 5001 points, exact backlash, rtol 1e-6) for the
   four controllers of the comparison, with ``engine="fast"`` (today's
   path: the fused Python right-hand side, LSODA through odeint) and
   ``engine="compiled"`` (numba Dormand-Prince 5(4)), controller by
   controller, round robin.
2. **JIT warm-up**, separately: the first compiled simulation in a fresh
   process with an empty numba cache (compilation) and with the cache
   filled (loading), and numba's import.
3. **Accuracy**: every metric of the compiled table against today's; and,
   on an evenly spread subset and on the runs where the two engines'
   IAE differ most, both against a tight reference (scipy DOP853 at rtol
   1e-10 on the python-control loop): the largest theta_l error per run
   (median, 90th percentile, max over the subset) and per metric.
4. **sampled_response**: a 5 s run at 1 ms of the exact plant under a
   saturated state-feedback controller written in Python (one evaluation
   per sample), with the plant stepped by LSODA (before) and by its
   compiled ``advance`` (after), and the CPU time of the controller's own
   calls.

numbalsoda (a compiled LSODA) is not measured: it has no wheels (building
it needs a Fortran toolchain), so it could not be a dependency.

Usage::

    python benchmarks/bench_compiled_sweep.py [--quick] [--json PATH]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402

import control as ct  # noqa: E402
import numpy as np  # noqa: E402

from ctrl_lpv import sampled_response, twomass  # noqa: E402
from ctrl_lpv.batch import scenario_grid  # noqa: E402
from ctrl_lpv.ode_integration import integrate  # noqa: E402
from ctrl_lpv.twomass import batch as tsweep  # noqa: E402

GRID = dict(
    alpha=[0.0, 0.015, 0.03, 0.045, 0.06],
    Td=[0.0, 8.0],
    Jl_scale=[0.8, 0.9, 1.0, 1.1, 1.2],
    torque_limit=[math.inf, 500.0, 1000.0, 2000.0, 5000.0],
)
QUICK_GRID = dict(alpha=[0.0, 0.03, 0.06], Td=[0.0, 8.0], Jl_scale=[0.8, 1.2],
                  torque_limit=[math.inf, 500.0])  # fmt: skip
METRICS = ("rise_time", "settling_time", "overshoot", "steady_state_error",
           "iae", "ise", "peak_input", "energy")  # fmt: skip
ENGINES = ("fast", "compiled")

WARMUP = """
import time
start = time.perf_counter()
import numba
numba_import = time.perf_counter() - start
from ctrl_lpv import twomass
controller = twomass.lpv_controller()
start = time.perf_counter()
twomass.simulate(controller, T=0.01, npoints=11, engine="compiled")
print(numba_import, time.perf_counter() - start)
"""


def warmup_times():
    """(numba import, first compiled run with an empty cache, with it filled)."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    with tempfile.TemporaryDirectory() as cache:
        env["NUMBA_CACHE_DIR"] = cache
        runs = []
        for _ in range(2):  # the first compiles into `cache`, the second loads
            out = subprocess.run(
                [sys.executable, "-c", WARMUP], env=env, capture_output=True,
                text=True, check=True,
            )  # fmt: skip
            runs.append([float(v) for v in out.stdout.split()])
    return runs[0][0], runs[0][1], runs[1][1]


def scenario_kwargs(scenario):
    """`twomass.simulate` arguments of a `run_scenario` scenario."""
    params = twomass.Parameters()
    params = params.replace(Jl=params.Jl * scenario["Jl_scale"])
    return dict(params=params, alpha=scenario["alpha"], Td=scenario["Td"])


def errors(value, reference):
    """Per metric: largest absolute difference, and the relative one where
    the reference is at least 1e-3 of its column's largest."""
    out = {}
    for key in METRICS:
        x, y = np.asarray(value[key], float), np.asarray(reference[key], float)
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        finite = np.isfinite(x) & np.isfinite(y)
        if np.any(~same & ~finite):
            out[key] = (math.inf, math.inf)
            continue
        d = np.abs(x[finite] - y[finite])
        large = np.abs(y[finite]) >= 1e-3 * np.abs(y[finite]).max(initial=0.0)
        rel = d[large] / np.abs(y[finite][large])
        out[key] = (float(d.max(initial=0.0)), float(rel.max(initial=0.0)))
    return out


def sweep_speed(specs, scenarios):
    """CPU seconds per engine and controller, and the metric tables."""
    seconds = {(e, c): 0.0 for e in ENGINES for c in specs}
    tables = {e: {key: [] for key in METRICS} for e in ENGINES}
    for name, spec in specs.items():
        for engine in ENGINES:
            tsweep.run_scenario(spec, **scenarios[0], engine=engine)  # warm
            start = time.process_time()
            rows = [tsweep.run_scenario(spec, **s, engine=engine) for s in scenarios]
            seconds[engine, name] = time.process_time() - start
            for key in METRICS:
                tables[engine][key] += [row[key] for row in rows]
            rate = len(scenarios) / seconds[engine, name]
            print(f"{name:>14} {engine:>8}: {rate:7.1f} scenarios/s",
                  file=sys.stderr, flush=True)  # fmt: skip
    return seconds, tables


def spread(specs, scenarios, count):
    """(spec, scenario) pairs evenly spread over the grid, per controller."""
    index = np.linspace(0, len(scenarios) - 1, max(1, count // len(specs)))
    chosen = [scenarios[i] for i in sorted(set(index.round().astype(int)))]
    return [(spec, s) for spec in specs.values() for s in chosen]


def largest_disagreements(specs, scenarios, tables, count):
    """The (spec, scenario) pairs where the engines' IAE differ most."""
    pairs = [(spec, s) for spec in specs.values() for s in scenarios]
    fast = np.asarray(tables["fast"]["iae"], float)
    ours = np.asarray(tables["compiled"]["iae"], float)
    order = np.argsort(-np.abs(ours - fast) / np.abs(fast))
    return [pairs[i] for i in order[:count]]


def reference_study(pairs):
    """theta_l and metric errors of both engines against DOP853 1e-10."""
    theta = {e: [] for e in ENGINES}
    tables = {e: {key: [] for key in METRICS} for e in (*ENGINES, "reference")}
    for spec, s in pairs:
        limit = None if s["torque_limit"] == math.inf else s["torque_limit"]
        controller = spec.build(torque_limit=limit)
        kw = scenario_kwargs(s)
        ref = twomass.simulate(controller, engine="fast", method="DOP853",
                               rtol=1e-10, atol=1e-12, **kw)  # fmt: skip
        runs = {"reference": ref}
        for engine in ENGINES:
            runs[engine] = twomass.simulate(controller, engine=engine, **kw)
            diff = runs[engine].outputs[0] - ref.outputs[0]
            theta[engine].append(float(np.abs(diff).max()))
        for key_run, r in runs.items():
            m = twomass.metrics(r).as_dict()
            for key in METRICS:
                tables[key_run][key].append(m[key])
    summary = {
        engine: {
            "median": float(np.median(v)), "p90": float(np.quantile(v, 0.9)),
            "max": float(np.max(v)),
            "worse_than_fast": float(np.mean(np.array(v) > np.array(theta["fast"]))),
        }
        for engine, v in theta.items()
    }  # fmt: skip
    metric_errors = {e: errors(tables[e], tables["reference"]) for e in ENGINES}
    return len(pairs), summary, metric_errors


def print_reference(title, nref, theta_errors, metric_errors):
    print(f"\n{title}: against DOP853 rtol 1e-10 on {nref} runs, max "
          "|theta_l error| per run (rad):")  # fmt: skip
    for engine, s in theta_errors.items():
        print(f"  {engine:>8}: median {s['median']:.1e}, p90 {s['p90']:.1e}, "
              f"max {s['max']:.1e}; larger than today's in "
              f"{100 * s['worse_than_fast']:.0f} % of runs")  # fmt: skip
    print("  per metric, largest error (absolute; relative):")
    for key in METRICS:
        cells = "  ".join(
            f"{e} {metric_errors[e][key][0]:.1e}; {metric_errors[e][key][1]:.1e}"
            for e in ENGINES
        )
        print(f"  {key:>18}: {cells}")


def sampled_study(T=5.0, dt=1e-3):
    """CPU seconds of a sampled run: LSODA, compiled plant, controller calls."""
    K = twomass.paper_gain()[0]

    def out(t, x, u, params=None):
        tm, wm, tl, wl, tr = u
        v = -(K[0] * (tm - tr) + K[1] * wm + K[2] * (tl - tr) + K[3] * wl)
        return [min(max(v, -500.0), 500.0)]

    controller = ct.nlsys(
        None, out, inputs=["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"],
        outputs=["Tm"], dt=dt, name="sf",
    )  # fmt: skip
    compiled = twomass.plant()
    lsoda = twomass.plant()
    lsoda._kernel = dataclasses.replace(lsoda._kernel, advance=None)
    inputs = {"theta_r": 0.5, "Td": 8.0}
    result = {}
    for name, plant in (("lsoda", lsoda), ("compiled", compiled)):
        sampled_response(plant, controller, 0.01, inputs=inputs)  # warm
        start = time.process_time()
        r = sampled_response(plant, controller, T, inputs=inputs)
        result[name] = time.process_time() - start
        result[name + "_final_theta_l"] = float(r.plant.outputs[2, -1])
    # The plant's own share: each interval of the run above stepped again
    # from its recorded state under its held inputs, by LSODA on the
    # Python kernel (what sampled_response did) and compiled.
    X, U, grid = r.plant.states, r.plant.inputs, r.plant.time
    options = {"method": "LSODA", "rtol": 1e-8, "atol": 1e-10}
    start = time.process_time()
    for k in range(grid.size - 1):
        u = U[:, k]
        integrate(lambda s, xs, u=u: lsoda._rhs(s, xs, u), grid[k : k + 2],
                  X[:, k], options)  # fmt: skip
    result["plant_lsoda"] = time.process_time() - start
    advance = compiled._kernel.advance
    advance(grid[0], X[:, 0], U[:, 0], grid[1], 1e-8, 1e-10)  # warm
    start = time.process_time()
    for k in range(grid.size - 1):
        advance(grid[k], X[:, k], U[:, k], grid[k + 1], 1e-8, 1e-10)
    result["plant_compiled"] = time.process_time() - start
    # The controller's own share: its output and update once per sample.
    u = np.array([0.1, 0.0, 0.1, 0.0, 0.5])
    steps = int(round(T / dt)) + 1
    start = time.process_time()
    for k in range(steps):
        controller._out(k * dt, np.zeros(0), u)
        controller._rhs(k * dt, np.zeros(0), u)
    result["controller_calls"] = time.process_time() - start
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small grid")
    parser.add_argument("--reference", type=int, default=40,
                        help="runs of the DOP853 reference study (40)")  # fmt: skip
    parser.add_argument("--json", help="write the results to this JSON file")
    args = parser.parse_args(argv)
    numba_import, cold, warm = warmup_times()
    specs = tsweep.comparison_specs()
    scenarios = scenario_grid(**(QUICK_GRID if args.quick else GRID))
    seconds, tables = sweep_speed(specs, scenarios)
    agreement = errors(tables["compiled"], tables["fast"])
    spread_study = reference_study(
        spread(specs, scenarios, 8 if args.quick else args.reference)
    )
    worst_study = reference_study(
        largest_disagreements(specs, scenarios, tables, 4 if args.quick else 10)
    )
    sampled = sampled_study()

    n = len(scenarios)
    total = {e: sum(seconds[e, c] for c in specs) for e in ENGINES}
    print(f"\nsweep: {n} scenarios x {len(specs)} controllers, one process, "
          "CPU time, scenarios/s per core\n")  # fmt: skip
    print("| controller | today (fast, LSODA) | compiled | speed-up |")
    print("|---|---|---|---|")
    for c in specs:
        f, k = n / seconds["fast", c], n / seconds["compiled", c]
        print(f"| {c} | {f:.1f} | {k:.1f} | {k / f:.1f} |")
    f, k = len(specs) * n / total["fast"], len(specs) * n / total["compiled"]
    print(f"| all | {f:.1f} | {k:.1f} | {k / f:.1f} |")
    print(f"\nJIT warm-up: numba import {numba_import:.2f} s; first compiled "
          f"run {cold:.1f} s with an empty cache (compilation), {warm:.2f} s "
          "with the cache filled")  # fmt: skip
    print("\ncompiled vs today on every run, largest difference per metric "
          "(absolute; relative where not near 0):")  # fmt: skip
    for key, (a, r) in agreement.items():
        print(f"  {key:>18}: {a:.1e}; {r:.1e}")
    print_reference("evenly spread runs", *spread_study)
    print_reference("the runs where the engines' IAE differ most", *worst_study)
    print(f"\nsampled_response, 5 s at 1 ms, Python controller: LSODA plant "
          f"{sampled['lsoda']:.2f} s, compiled plant {sampled['compiled']:.2f} s "
          f"({sampled['lsoda'] / sampled['compiled']:.1f}x); of which the "
          f"plant's stepping alone {sampled['plant_lsoda']:.3f} s (LSODA) and "
          f"{sampled['plant_compiled']:.3f} s (compiled), the controller's own "
          f"calls {sampled['controller_calls']:.3f} s; the rest is "
          "sampled_response's bookkeeping")  # fmt: skip
    print("\nnumbalsoda (compiled LSODA) not measured: no wheels.")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({
                "scenarios": n, "controllers": list(specs),
                "cpu_seconds": {f"{e}/{c}": s for (e, c), s in seconds.items()},
                "scenarios_per_s": {
                    e: {c: n / seconds[e, c] for c in specs}
                    | {"all": len(specs) * n / total[e]} for e in ENGINES
                },
                "jit": {"numba_import_s": numba_import, "cold_first_run_s": cold,
                        "cached_first_run_s": warm},
                "compiled_vs_fast": {k: {"max_abs": a, "max_rel": r}
                                     for k, (a, r) in agreement.items()},
                "vs_dop853": {
                    name: {
                        "runs": study[0],
                        "theta_l_error": study[1],
                        "metric_error": {
                            e: {k: {"max_abs": a, "max_rel": r}
                                for k, (a, r) in study[2][e].items()}
                            for e in ENGINES
                        },
                    }
                    for name, study in (("spread", spread_study),
                                        ("largest_disagreements", worst_study))
                },
                "sampled_response_5s_1ms": sampled,
                "python": platform.python_version(),
                "grid": {k: [None if v == math.inf else v for v in vals]
                         for k, vals in (QUICK_GRID if args.quick else GRID).items()},
            }, f, indent=2)  # fmt: skip


if __name__ == "__main__":
    main()
