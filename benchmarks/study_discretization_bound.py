"""Sampling error bound against the measured error, two-mass drive and quarter car.

For each model and sampling period: the bound of
``plant.sample(T).discretization_error`` (``phi`` on ``Phi = Ad``,
``gamma`` on ``Gamma = Bd``), the error it bounds measured on a dense grid
of the parameter box with cell centres (``tests/_quarter_car.py``: exact
ZOH of the frozen system by `scipy.linalg.expm`, minus the interpolated
vertex ZOHs), and their ratio. For comparison, the two analytic bounds
without the sampled grid: in the 2-norm (the first release's bound) and in
the best scaled norm (``ctrl_lpv.discretization``, steps 1 to 3).
``T rho`` is the period times the largest spectral radius of a vertex.

Models: the two-mass drive (``twomass.lpv_model``, tracking form, backlash
parameter in [-0.95, 0]); the quarter car with suspension stiffness and
damping in boxes (4 states, 4 vertices), and with the inverse sprung mass
as a third parameter (8 vertices).

Usage::

    python benchmarks/study_discretization_bound.py [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from ctrl_lpv import discretization as disc
from ctrl_lpv import twomass

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
from _quarter_car import box_grid, measured_errors, quarter_car  # noqa: E402

PERIODS = (0.5e-3, 1e-3, 2e-3, 5e-3, 10e-3)
GRID = {1: 401, 2: 41, 3: 11}  # measurement points per parameter


def analytic_bounds(plant, T, norms):
    """``(phi, gamma)`` from steps 1 to 3 only, over the given norms."""
    n, m = plant.nstates, plant.ninputs
    Ms = []
    for A, B, _, _ in plant.vertex_data():
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        Ms.append(M)
    As, Bs = [M[:n, :n] for M in Ms], [M[:n, n:] for M in Ms]
    block = min(min(disc._expm_bound(Ms, plant.domain, T, c)) for c in norms(Ms))
    phi = min(min(disc._expm_bound(As, plant.domain, T, c)) for c in norms(As))
    gamma = min(min(disc._gamma_bound(As, Bs, plant.domain, T, c)) for c in norms(As))
    return min(phi, block), min(gamma, block)


def two_norm(mats):
    size = mats[0].shape[0]
    return [disc._Norm(np.eye(size), np.eye(size))]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the rows to this JSON file")
    args = parser.parse_args(argv)
    models = {
        "two-mass": twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking"),
        "quarter car (ks, cs)": quarter_car(),
        "quarter car (ks, cs, 1/ms)": quarter_car(payload=(1 / 400, 1 / 250)),
    }
    print(
        "| model | T (ms) | T rho | phi: bound | measured | ratio | 2-norm | scaled "
        "| gamma: bound | measured | ratio | 2-norm | scaled | sample (s) |"
    )
    print("|" + "---|" * 14)
    rows = []
    for name, plant in models.items():
        rho = max(np.abs(np.linalg.eigvals(v.A)).max() for v in plant.vertices)
        points = box_grid(plant.domain, GRID[plant.domain.nparams])
        for T in PERIODS:
            start = time.process_time()
            sysd = plant.sample(T)
            seconds = time.process_time() - start
            bound = sysd.discretization_error
            phi, gamma = measured_errors(plant, sysd, points)
            plain = analytic_bounds(plant, T, two_norm)
            scaled = analytic_bounds(plant, T, disc._norms)
            row = dict(
                model=name, T=T, T_rho=T * rho, phi=bound.phi, phi_measured=phi,
                phi_2norm=plain[0], phi_scaled=scaled[0], gamma=bound.gamma,
                gamma_measured=gamma, gamma_2norm=plain[1], gamma_scaled=scaled[1],
                sample_seconds=seconds,
            )  # fmt: skip
            rows.append(row)
            print(
                f"| {name} | {T * 1e3:g} | {T * rho:.3f} | {bound.phi:.3e} | "
                f"{phi:.3e} | {bound.phi / phi:.3f} | {plain[0] / phi:.3g} | "
                f"{scaled[0] / phi:.3g} | {bound.gamma:.3e} | {gamma:.3e} | "
                f"{bound.gamma / gamma:.3f} | {plain[1] / gamma:.3g} | "
                f"{scaled[1] / gamma:.3g} | {seconds:.3f} |",
                flush=True,
            )
    print(
        "\nratio: bound / measured; 2-norm, scaled: the analytic bounds without "
        "the grid, as multiples of the measured error."
    )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=2)


if __name__ == "__main__":
    main()
