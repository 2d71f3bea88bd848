"""Time budgets: wall time of the slow cases of issue 19, and the overshoot.

Each case runs in a fresh process (no compiled problem cached from an
earlier run), once with the default budget (`ctrl_lpv.budget.
DEFAULT_TIME_LIMIT`, 600 s) and once with ``time_limit=20``. The table
gives the wall time of the call, its outcome (certified bound, or the
refusal's class and first line) and, where the budget ran out, the
overshoot ``wall time / time_limit`` (the target is at most 1.1).

Cases (the issue's, rebuilt here):

* ``rate 1e12``: mass-spring-damper ``k in [1, 4]`` (the README's plant),
  H-infinity objective, common gain, ``lyapunov="affine"``, ``rate_bounds=
  {"k": 1e12}``;
* ``disk(1e-3)``: the same plant sampled at 10 ms, H-infinity objective,
  poles in ``disk(1e-3)`` (a common gain cannot place them there);
* ``degenerate box``: ``k in [2, 2 + 1e-12]``, H-infinity objective,
  vertex gains, ``lyapunov="affine"``, ``rate_bounds={"k": 1}``;
* ``quarter car``: a new user's design: 5 states (suspension and tyre
  deflections, body and wheel velocities, integral of the suspension
  deflection), stiffness ``ks in [12, 20] kN/m`` and damping ``cs in
  [0.8, 1.5] kNs/m`` (4 vertices), road velocity ``w``, actuator force
  ``u``; ``z`` = body acceleration, deflection / 5 cm, ``1e-3 u``;
  ``Hinf + Saturation(2 kN, x0 = 5 cm deflection) + halfplane(1.0)``;
* ``quarter car, SCS``: the same with ``solvers="SCS"`` (slow solves, so
  that the budget runs out in mid-solve).

A second table compares `ctrl_lpv.budget.compile_seconds` (the estimate
checked before each compilation) with cvxpy's compilation time of each
stage, on random polytopes of `bench_synthesis` (vertex gains, H-infinity:
``N (N + 1) / 2`` LMIs).

The machine is shared (2 cores, other jobs running): times are noisy, by
tens of percent between runs.

Usage::

    python benchmarks/time_budget.py [--cases NAME ...] [--limits default 20]
                                      [--json PATH] [--no-compile]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


# ----------------------------------------------------------------------
# Plants
# ----------------------------------------------------------------------
def mass_spring(bounds=(1.0, 4.0), dt=0.0):
    """The README's plant: states q, v; inputs w, u; outputs q, uw."""
    import control as ct

    import ctrl_lpv as lpv

    base = ct.ss(
        [[0, 1], [0, -0.5]], [[0, 0], [1, 1]], [[1, 0], [0, 0]],
        [[0, 0], [0, 0.1]], inputs=["w", "u"], outputs=["q", "uw"],
        states=["q", "v"],
    )  # fmt: skip
    stiffness = ([[0, 0], [-1, 0]], 0, 0, 0)
    sys = lpv.PolytopicStateSpace.from_affine(base, {"k": stiffness}, {"k": bounds})
    return sys.sample(dt) if dt else sys


def quarter_car():
    """Quarter car with an integral of the suspension deflection (5 states)."""
    import control as ct

    import ctrl_lpv as lpv

    ms, mu, kt = 300.0, 40.0, 190e3  # body, wheel (kg), tyre stiffness (N/m)

    def matrices(ks, cs):
        # x = [zs - zu, zs', zu - zr, zu', int(zs - zu)]; w = zr', u = force.
        A = np.zeros((5, 5))
        A[0, [1, 3]] = 1, -1
        A[1, :4] = -ks / ms, -cs / ms, 0, cs / ms
        A[2, 3] = 1
        A[3, :4] = ks / mu, cs / mu, -kt / mu, -cs / mu
        A[4, 0] = 1
        B = np.zeros((5, 2))
        B[2, 0], B[1, 1], B[3, 1] = -1, 1 / ms, -1 / mu
        C = np.vstack([A[1], [1 / 0.05, 0, 0, 0, 0], np.zeros(5)])
        D = np.array([[0, 1 / ms], [0, 0], [0, 1e-3]])
        return A, B, C, D

    zero = matrices(0.0, 0.0)
    base = ct.ss(
        *zero, inputs=["w", "u"], outputs=["acc", "defl", "uw"],
        states=["defl", "vs", "tire", "vu", "int_defl"],
    )  # fmt: skip
    terms = {
        name: tuple(a - b for a, b in zip(matrices(*unit), zero))
        for name, unit in (("ks", (1.0, 0.0)), ("cs", (0.0, 1.0)))
    }
    bounds = {"ks": (12e3, 20e3), "cs": (800.0, 1500.0)}
    return lpv.PolytopicStateSpace.from_affine(base, terms, bounds)


def _quarter_car_call(time_limit, solvers=None):
    import ctrl_lpv as lpv

    constraints = [
        lpv.Saturation(2000.0, points=[[0.05, 0, 0, 0, 0]]),
        lpv.halfplane(1.0),
    ]
    return lpv.synthesize(
        quarter_car(), "u", objective=lpv.Hinf("w", ["acc", "defl", "uw"]),
        constraints=constraints, solvers=solvers, time_limit=time_limit,
    )  # fmt: skip


def _call(case: str, time_limit):
    import ctrl_lpv as lpv

    hinf = lpv.Hinf("w", ["q", "uw"])
    if case == "rate 1e12":
        return lpv.synthesize(
            mass_spring(), "u", objective=hinf, lyapunov="affine",
            rate_bounds={"k": 1e12}, time_limit=time_limit,
        )  # fmt: skip
    if case == "disk(1e-3)":
        return lpv.synthesize(
            mass_spring(dt=0.01), "u", objective=hinf,
            constraints=[lpv.disk(1e-3)], time_limit=time_limit,
        )  # fmt: skip
    if case == "degenerate box":
        return lpv.synthesize(
            mass_spring((2.0, 2.0 + 1e-12)), "u", objective=hinf, gains="scheduled",
            lyapunov="affine", rate_bounds={"k": 1.0}, time_limit=time_limit,
        )  # fmt: skip
    if case == "quarter car":
        return _quarter_car_call(time_limit)
    if case == "quarter car, SCS":
        return _quarter_car_call(time_limit, solvers="SCS")
    raise ValueError(f"case: unknown {case!r}")


CASES = ("rate 1e12", "disk(1e-3)", "degenerate box", "quarter car", "quarter car, SCS")


def _warm_up() -> None:
    """Import what a call needs (cvxpy, python-control, the solvers) and
    build the plants, so that the timed call measures the call alone."""
    import ctrl_lpv as lpv
    from ctrl_lpv.lmi import default_solvers

    default_solvers()
    mass_spring(dt=0.01)
    quarter_car()
    lpv.quadratic_stability(
        lpv.PolytopicStateSpace([([[-1.0]], [[0.0]], [[0.0]], [[0.0]])])
    )


def run_one(case: str, limit: str) -> dict:
    """One call in this process: wall time and outcome."""
    from ctrl_lpv import budget

    _warm_up()
    time_limit = budget.DEFAULT_TIME_LIMIT if limit == "default" else float(limit)
    start = time.perf_counter()
    try:
        design = _call(case, time_limit)
        outcome = f"certified, gamma {design.gamma:.6g}"
        message = ""
    except Exception as exc:  # noqa: BLE001 - the outcome is the point
        message = str(exc)
        outcome = f"{type(exc).__name__}: {message.splitlines()[0][:150]}"
    seconds = time.perf_counter() - start
    ran_out = message.startswith("time_limit:")
    return {
        "case": case,
        "time_limit": time_limit,
        "seconds": seconds,
        "overshoot": seconds / time_limit if ran_out else None,
        "outcome": outcome,
        "message_chars": len(message),
        "message_lines": len(message.splitlines()),
    }


def run_isolated(case: str, limit: str) -> dict:
    """`run_one` in a fresh interpreter (no cached compiled problems)."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out = subprocess.run(
        [sys.executable, __file__, "--one", case, limit],
        capture_output=True, text=True, env=env, check=True,
    )  # fmt: skip
    return json.loads(out.stdout.strip().splitlines()[-1])


# ----------------------------------------------------------------------
# Compile-time estimate
# ----------------------------------------------------------------------
def compile_table(sizes=((2, 4), (4, 4), (4, 8), (6, 12), (8, 16))) -> list[dict]:
    """Estimated and measured compilation of each stage (vertex gains)."""
    import ctrl_lpv as lpv
    from ctrl_lpv import budget
    from ctrl_lpv.lmi import LMIProblem

    sys.path.insert(0, str(HERE))
    from bench_synthesis import random_polytope

    rows = []
    real = LMIProblem.compile

    def recording(self, stage="default", objective=None, solver=None):
        seconds = real(self, stage, objective, solver)
        if seconds > 0:
            problem = self._problems[stage]
            entries = sum(int(np.prod(c.args[0].shape)) for c in problem.constraints)
            nlmis = len(problem.constraints)
            rows.append({
                "stage": stage, "lmis": nlmis, "entries": entries,
                "measured": seconds,
                "estimate": budget.compile_seconds(nlmis, entries),
            })  # fmt: skip
        return seconds

    LMIProblem.compile = recording
    try:
        out = []
        for n, N in sizes:
            lpv.synthesis_cache.clear()
            rows.clear()
            plant = random_polytope(n, N)
            lpv.gain_scheduled_hinf(plant, w=[0], u=[1, 2], z=[0, 1, 2])
            for row in rows:
                out.append({"n": n, "N": N, **row})
        return out
    finally:
        LMIProblem.compile = real


# ----------------------------------------------------------------------
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", default=list(CASES))
    parser.add_argument("--limits", nargs="*", default=["default", "20"])
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--no-compile", action="store_true")
    parser.add_argument("--one", nargs=2, metavar=("CASE", "LIMIT"))
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(*args.one)))
        return

    rows = []
    print(f"{'case':18} {'limit':>6} {'seconds':>8} {'ratio':>6}  outcome")
    for case in args.cases:
        for limit in args.limits:
            row = run_isolated(case, limit)
            rows.append(row)
            ratio = "" if row["overshoot"] is None else f"{row['overshoot']:.3f}"
            print(
                f"{case:18} {row['time_limit']:6g} {row['seconds']:8.1f} "
                f"{ratio:>6}  {row['outcome'][:110]} "
                f"[{row['message_chars']} chars, {row['message_lines']} lines]",
                flush=True,
            )
    compile_rows = [] if args.no_compile else compile_table()
    if compile_rows:
        print(f"\n{'n':>2} {'N':>3} {'stage':10} {'LMIs':>5} {'entries':>8} "
              f"{'measured':>9} {'estimate':>9}")  # fmt: skip
        for r in compile_rows:
            print(
                f"{r['n']:2d} {r['N']:3d} {r['stage']:10} {r['lmis']:5d} "
                f"{r['entries']:8d} {r['measured']:9.3f} {r['estimate']:9.3f}"
            )
    if args.json:
        args.json.write_text(json.dumps({"cases": rows, "compile": compile_rows},
                                        indent=1))  # fmt: skip


if __name__ == "__main__":
    main()
