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

On a gridded plant (`ctrl_lpv.GriddedStateSpace`, ``--gridded``): the
pendulum ``theta'' = -g sin(theta) - d theta' + u + w`` linearized with
`control.linearize` at the trim angles ``theta0`` in [0, 1.2] rad, with
damping ``d`` in [0.2, 1] (the model is nonlinear in ``theta0``: gridded,
not polytopic), on an ``m x m`` grid, LQR gains at the grid points as a
table (Delaunay triangles, two per grid cell: ``2 (m - 1)**2`` pieces).
For each ``m``: ``certify`` (arbitrary rates), ``certify`` with
``objective=Hinf(w="w", z="theta")``, and the rate-bounded analysis at
rate 1 (``P(p)`` multilinear on the grid, 40 LMIs per piece) up to
``--rate-max``.

Usage::

    python benchmarks/bench_certify.py [--sizes 5,10,15,20] [--gridded]
        [--rate-max 15]
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


GRAVITY = 9.81


def pendulum():
    def f(t, x, u, params):
        d = params.get("d", 0.5)
        return [x[1], -GRAVITY * np.sin(x[0]) - d * x[1] + u[0] + u[1]]

    return ct.nlsys(f, None, inputs=["u", "w"], states=["theta", "omega"],
                    outputs=["theta", "omega"], params={"d": 0.5})  # fmt: skip


def gridded(m):
    """The pendulum gridded on (theta0, d), and LQR gains at its points."""
    sys = pendulum()

    def trim(theta0, d):
        lin = ct.linearize(sys, [theta0, 0.0], [GRAVITY * np.sin(theta0), 0.0],
                           params={"d": d}, copy_names=True)  # fmt: skip
        # B is constant in the model; rounding removes the finite-difference
        # noise of linearize, which would make it vary (and the rate-bounded
        # analysis refuse a varying B with varying gains).
        return ct.ss(lin.A, np.round(lin.B, 6), lin.C, lin.D, inputs=lin.input_labels,
                     outputs=lin.output_labels, states=lin.state_labels)  # fmt: skip

    G = lpv.gss(trim, {"theta0": np.linspace(0.0, 1.2, m),
                       "d": np.linspace(0.2, 1.0, m)})  # fmt: skip
    points = G.grid.points
    gains = [ct.lqr(G.at(p)[:, "u"], np.diag([10.0, 1.0]), 1.0)[0] for p in points]
    return G, (gains, points)


def main_gridded(sizes, rate_max):
    from ctrl_lpv.schedules.certify import _gridded_loops

    hinf = lpv.Hinf(w="w", z="theta")
    print(f"{'grid':>7} {'pieces':>6} {'certify s (cpu)':>16} "
          f"{'+ Hinf s (cpu)':>16} {'rate 1 s (cpu)':>16}  verdicts")  # fmt: skip
    for m in sizes:
        G, table = gridded(m)
        verdict, wall, cpu = timed(lambda G=G, t=table: lpv.certify(t, G))
        bound, wall_h, cpu_h = timed(
            lambda G=G, t=table: lpv.certify(t, G, objective=hinf)
        )
        schedule = schedule_of(table, names=G.param_names)
        loops = _gridded_loops(schedule, G, table, None)
        assert loops.rate_refusal() is None
        if m <= rate_max:
            found, wall_r, cpu_r = timed(
                lambda L=loops: L.rate_bounded(np.ones(2), 1e-6)
            )
            rate = f"{wall_r:>7.2f} ({cpu_r:6.2f})"
        else:
            found, rate = None, f"{'-':>16}"
        print(f"{m:>3}x{m:<3} {len(loops.pieces):>6} {wall:>7.2f} ({cpu:6.2f}) "
              f"{wall_h:>7.2f} ({cpu_h:6.2f}) {rate}  certified "
              f"{verdict.certified}, L2 <= {bound.bound:.4g}, rate 1: "
              f"{found is not None if m <= rate_max else '-'}")  # fmt: skip


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="5,10,15,20")
    parser.add_argument("--gridded", action="store_true")
    parser.add_argument("--rate-max", type=int, default=15)
    args = parser.parse_args(argv)
    if args.gridded:
        main_gridded([int(s) for s in args.sizes.split(",")], args.rate_max)
        return
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
