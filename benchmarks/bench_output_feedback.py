"""Output-feedback design times against hinfsyn and state feedback (issue 21).

CPU seconds (``time.process_time``, one BLAS thread) of
``hinf_output_feedback`` (default back-off, and ``backoff=None``) on random
normalised plants (``tests/test_output_feedback.random_plant``'s recipe: two
exogenous inputs, one control input, one measurement, two performance
outputs) against

* python-control's `control.hinfsyn` (SLICOT, Riccati; LTI only), and
* the state-feedback design of the same plant and channels
  (``synthesize(..., objective=Hinf(w, z), gains="scheduled")``),

for ``n = 4, 8, 12`` states and ``N = 1, 2, 4`` vertices. The median of
``--repeat`` runs (default 3); a design that refuses is marked.

Usage::

    python benchmarks/bench_output_feedback.py [--sizes 4x1,8x2] [--repeat 3]
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"  # before numpy: one BLAS thread
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import control as ct  # noqa: E402

import ctrl_lpv as lpv  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
from test_output_feedback import W, Z, random_plant  # noqa: E402


def cpu(f):
    start = time.process_time()
    try:
        f()
    except lpv.SynthesisError:
        return None
    return time.process_time() - start


def median(values):
    ok = [v for v in values if v is not None]
    return statistics.median(ok) if ok else None


def fmt(x):
    return "refused" if x is None else f"{x:.3f}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="4x1,8x1,12x1,4x2,8x2,4x4")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    print(f"{'n x N':>6} {'OF default':>11} {'OF raw':>9} {'hinfsyn':>8} "
          f"{'SF':>8} {'OF/SF':>6}")  # fmt: skip
    for size in args.sizes.split(","):
        n, N = (int(x) for x in size.split("x"))
        times = {"of": [], "raw": [], "hinfsyn": [], "sf": []}
        for seed in range(args.repeat):
            sys_ = random_plant(seed, n=n, vertices=N, stable=N > 1)
            times["of"].append(cpu(lambda s=sys_: lpv.hinf_output_feedback(
                s, W, "u", Z, "y")))  # fmt: skip
            times["raw"].append(cpu(lambda s=sys_: lpv.hinf_output_feedback(
                s, W, "u", Z, "y", backoff=None)))  # fmt: skip
            if N == 1:
                G = ct.ss(*ct.ssdata(sys_.vertices[0]))
                times["hinfsyn"].append(cpu(lambda G=G: ct.hinfsyn(G, 1, 1)))
            times["sf"].append(cpu(lambda s=sys_: lpv.synthesize(
                s, "u", objective=lpv.Hinf(W, Z), gains="scheduled")))  # fmt: skip
        m = {k: median(v) for k, v in times.items()}
        ratio = (m["of"] / m["sf"]) if m["of"] and m["sf"] else None
        print(f"{n:>3}x{N:<2} {fmt(m['of']):>11} {fmt(m['raw']):>9} "
              f"{fmt(m['hinfsyn']) if N == 1 else '-':>8} {fmt(m['sf']):>8} "
              f"{'-' if ratio is None else f'{ratio:.1f}':>6}")  # fmt: skip


if __name__ == "__main__":
    main()
