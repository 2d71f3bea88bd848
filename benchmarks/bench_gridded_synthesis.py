"""Rate-bounded synthesis on a gridded plant against its grid size (issue 23).

The pendulum of ``bench_certify.py --gridded``: linearized with
`control.linearize` at the trim angles ``theta0`` in [0, 1.2] rad, damping
``d`` in [0.2, 1], on an ``m x m`` grid, with the control effort as a
second performance output (without it the optimum is approached with ever
larger gains). For each ``m``, the wall and CPU time and the certified L2
bound from ``w`` to ``(theta, effort)`` of

* ``synthesize(G, "u", objective=Hinf(w="w", z=["theta", "effort"]))``:
  gains at the grid points, one Lyapunov matrix (arbitrary rates);
* the same with ``lyapunov="affine", rate_bounds={"theta0": nu, "d": nu}``
  (``X(p)`` multilinear on the grid, a constant slack; the search over
  the slack scale; then `certify` with the rates).

Usage::

    python benchmarks/bench_gridded_synthesis.py [--sizes 5,10] [--rate 1]
"""

from __future__ import annotations

import argparse

import control as ct
import numpy as np

import ctrl_lpv as lpv
from bench_certify import GRAVITY, pendulum, timed


def gridded(m):
    """The pendulum on an m x m grid of (theta0, d), effort as an output."""
    sys = pendulum()

    def trim(theta0, d):
        lin = ct.linearize(sys, [theta0, 0.0], [GRAVITY * np.sin(theta0), 0.0],
                           params={"d": d}, copy_names=True)  # fmt: skip
        C = np.vstack([lin.C, [0.0, 0.0]])
        D = np.vstack([lin.D, [1.0, 0.0]])
        # B is constant in the model: rounded (linearize's finite differences).
        return ct.ss(lin.A, np.round(lin.B, 6), C, D, inputs=lin.input_labels,
                     outputs=["theta", "omega", "effort"])  # fmt: skip

    return lpv.gss(trim, {"theta0": np.linspace(0.0, 1.2, m),
                          "d": np.linspace(0.2, 1.0, m)})  # fmt: skip


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="5,10")
    parser.add_argument("--rate", type=float, default=1.0)
    args = parser.parse_args(argv)
    hinf = lpv.Hinf(w="w", z=["theta", "effort"])
    nu = args.rate
    print(f"{'grid':>7} {'constant s (cpu)':>17} {'L2':>7} "
          f"{'rate ' + format(nu, 'g') + ' s (cpu)':>17} {'L2':>7}")  # fmt: skip
    for m in (int(s) for s in args.sizes.split(",")):
        G = gridded(m)
        constant, wall, cpu = timed(lambda G=G: lpv.synthesize(G, "u", objective=hinf))
        rated, wall_r, cpu_r = timed(
            lambda G=G: lpv.synthesize(G, "u", objective=hinf, lyapunov="affine",
                                       rate_bounds={"theta0": nu, "d": nu})
        )  # fmt: skip
        print(f"{m:>3}x{m:<3} {wall:>8.2f} ({cpu:6.2f}) {constant.gamma:>7.4f} "
              f"{wall_r:>8.2f} ({cpu_r:6.2f}) {rated.gamma:>7.4f}")  # fmt: skip


if __name__ == "__main__":
    main()
