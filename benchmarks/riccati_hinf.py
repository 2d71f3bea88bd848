"""LTI H-infinity state feedback against the Riccati bisection (issue 11).

For random problems of ``tests/_independent.random_lti_hinf``: the raw
optimum ``gamma_opt`` (``backoff=None``) against the Riccati value, and the
default design checked independently (``check_design``, ``linfnorm``).

Usage::

    python benchmarks/riccati_hinf.py [--seeds 1 2 3 4 5] [--n 40]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

from _independent import check_design, hinf_riccati, random_lti_hinf  # noqa: E402
from test_riccati_hinf import _call, _case, _closed_loop_norm  # noqa: E402


def run(seed: int, n: int) -> None:
    off = refused = 0
    worst = 0.0
    start = time.perf_counter()
    for i in range(n):
        problem = random_lti_hinf(np.random.default_rng([seed, i]))
        gamma, _, _ = hinf_riccati(*problem)
        try:
            raw = _call(problem, backoff=None)
            design = _call(problem)
        except Exception as exc:  # noqa: BLE001 - every refusal is reported
            refused += 1
            print(f"  {seed}:{i} refused: {type(exc).__name__}: {str(exc)[:100]}")
            continue
        err = abs(raw.gamma_opt / gamma - 1)
        worst = max(worst, err)
        ok = check_design(_case(problem), design.gains, design.P, design.gamma).ok
        ok = ok and design.gamma >= _closed_loop_norm(problem, design.gains[0]) * (
            1 - 1e-9
        )
        if err > 1e-3 or not ok:
            off += 1
            print(f"  {seed}:{i} gamma*={gamma:.6g} estimate={raw.gamma_opt:.6g} "
                  f"rel. error={err:.2e} default design ok={ok}")  # fmt: skip
    print(f"seed {seed}: {n} problems, {off} off by > 1e-3 or failing, {refused} "
          f"refused, worst rel. error {worst:.2e}, "
          f"{time.perf_counter() - start:.0f} s")  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    parser.add_argument("--n", type=int, default=40)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    for seed in args.seeds:
        run(seed, args.n)


if __name__ == "__main__":
    main()
