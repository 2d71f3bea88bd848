"""Certification time of a gain schedule against its grid size (issue 23).

Two scheduling parameters, a spring-damper ``x'' = -a x - b x' + u`` with
``a`` in [1, 3] and ``b`` in [0.1, 1], LQR gains at the points of an
``m x m`` grid, interpolated as python-control's
``create_statefbk_iosystem(..., gainsched_method="linear")`` does (Delaunay
triangles, two per grid square). For each ``m``: the wall and CPU time of

* ``certify(ctrl, plant)``: frozen checks, then one quadratic Lyapunov
  function for arbitrary rates (this schedule certifies there);
* ``certify(ctrl, plant, rate_bounds={"a": 1, "b": 1})`` forced through the
  rate-bounded analysis (piecewise-affine ``P(p)``: one 2x2 matrix per
  point, 24 LMIs per triangle) by skipping the quadratic test.

Usage::

    python benchmarks/bench_certify.py [--sizes 5,10,15,20]
"""

from __future__ import annotations

import argparse
import time

import control as ct
import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv.schedules.certify import _ClosedLoops
from ctrl_lpv.schedules.schedule import schedule_of


def spring(a, b):
    return ct.ss([[0.0, 1.0], [-a, -b]], [[0.0], [1.0]], np.eye(2), 0,
                 inputs="u", states=["x0", "x1"])  # fmt: skip


def plant():
    return lpv.PolytopicStateSpace.from_affine(
        spring(0.0, 0.0),
        {"a": ([[0, 0], [-1.0, 0]], 0, 0, 0), "b": ([[0, 0], [0, -1.0]], 0, 0, 0)},
        {"a": (1.0, 3.0), "b": (0.1, 1.0)},
    )


def controller(m):
    grid = [(a, b) for a in np.linspace(1, 3, m) for b in np.linspace(0.1, 1, m)]
    gains = [ct.lqr(spring(a, b), np.eye(2), 1.0)[0] for a, b in grid]
    ctrl, _ = ct.create_statefbk_iosystem(
        spring(2.0, 0.5), (gains, grid), gainsched_indices=["xd[0]", "xd[1]"]
    )
    return ctrl


def timed(f):
    w, c = time.perf_counter(), time.process_time()
    out = f()
    return out, time.perf_counter() - w, time.process_time() - c


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="5,10,15,20")
    args = parser.parse_args(argv)
    G = plant()
    print(f"{'grid':>7} {'cells':>6} {'quadratic s (cpu)':>18} "
          f"{'rate-bounded s (cpu)':>21}  verdicts")  # fmt: skip
    for m in (int(s) for s in args.sizes.split(",")):
        ctrl = controller(m)
        verdict, wall, cpu = timed(lambda ctrl=ctrl: lpv.certify(ctrl, G))
        loops = _ClosedLoops.of(schedule_of(ctrl), G, ctrl, None)
        found, wall_r, cpu_r = timed(lambda L=loops: L.rate_bounded(np.ones(2), 1e-6))
        print(f"{m:>3}x{m:<3} {len(loops.schedule.cells):>6} "
              f"{wall:>8.2f} ({cpu:6.2f}) {wall_r:>10.2f} ({cpu_r:7.2f})  "
              f"{verdict.rate_bound}, rate 1: {found is not None}")  # fmt: skip


if __name__ == "__main__":
    main()
