"""The default back-off's gains and solver calls, against another run's.

Issue 20 asks for the default back-off within 2.5x of one direct solve
without inflating the gains. This study designs, with the default
``backoff=0.2``, the two-mass Lemma 2 and Theorem 2 designs
(``twomass.lpv_model(p_bounds=(-0.95, 0), formulation="tracking",
integral=True)``) and 38 random polytopes (``tests/_direct_reference.py``'s
``random_vertices``: n = 2 to 8, N = 3 to 16; odd seeds Theorem 2, even
seeds Lemma 2), and records per design the largest gain norm, gamma,
gamma*, whether it certified, the Clarabel calls and their iterations and
CPU time (``clarabel.DefaultSolver`` wrapped, one BLAS thread).

Run it once per version of the library (``PYTHONPATH`` picks it) with
``--json``; ``--against OTHER.json`` prints the gain ratios to that run:
the two-mass designs, and the random corpus's median and worst.

Usage::

    python benchmarks/study_backoff.py [--json PATH] [--against PATH]
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"  # before numpy: one BLAS thread
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))
sys.path.insert(0, HERE)

from synthesis_cases import SOLVES, _record_solves  # noqa: E402

# (n, N, seeds) of the random corpus.
CORPUS = (
    (3, 4, range(1, 7)),
    (4, 8, range(1, 7)),
    (6, 8, range(1, 5)),
    (4, 16, (1, 2)),
    (8, 16, (1, 2)),
    (5, 4, range(7, 15)),
    (2, 3, range(7, 13)),
    (8, 4, range(7, 11)),
)


def cases(lpv):
    import _direct_reference as dr

    model = lpv.twomass.lpv_model(
        p_bounds=(-0.95, 0), formulation="tracking", integral=True
    )
    kw = {"w": "Td", "u": "Tm", "z": list(model.output_labels)}
    yield "two-mass Lemma 2", lambda: lpv.hinf_state_feedback(model, **kw)
    yield "two-mass Theorem 2", lambda: lpv.gain_scheduled_hinf(model, **kw)
    for n, N, seeds in CORPUS:
        for seed in seeds:
            sys_ = lpv.pss(dr.random_vertices(n, N, seed=seed))
            scheduled = seed % 2 == 1
            function = lpv.gain_scheduled_hinf if scheduled else lpv.hinf_state_feedback
            name = f"n{n} N{N} seed {seed} {'Th2' if scheduled else 'L2'}"
            yield name, lambda s=sys_, f=function: f(s, w=[0], u=[1, 2], z=[0, 1, 2])


def run():
    _record_solves()
    import ctrl_lpv as lpv

    rows = {}
    for name, call in cases(lpv):
        first, cpu = len(SOLVES), time.process_time()
        design = call()
        solves = SOLVES[first:]
        rows[name] = {
            "gain": max(float(np.linalg.norm(K, 2)) for K in design.gains),
            "gamma": design.gamma,
            "gamma_opt": design.gamma_opt,
            "verified": bool(design.certificate.verified),
            "cpu": time.process_time() - cpu,
            "solves": len(solves),
            "iterations": [s["iterations"] for s in solves],
            "solver_cpu": sum(s["cpu"] for s in solves),
        }
        print(f"{name:24s} " + json.dumps(rows[name]), flush=True)
    return rows


def compare(rows, other):
    common = [k for k in rows if k in other]
    ratio = {k: rows[k]["gain"] / other[k]["gain"] for k in common}
    random = [ratio[k] for k in common if not k.startswith("two-mass")]
    for k in common:
        if k.startswith("two-mass"):
            print(f"{k}: largest gain {rows[k]['gain']:.4g} vs "
                  f"{other[k]['gain']:.4g} (x{ratio[k]:.3f})")  # fmt: skip
    print(f"random corpus ({len(random)}): gain ratio median "
          f"{np.median(random):.3f}, worst {max(random):.3f}")  # fmt: skip
    for key in ("solves", "solver_cpu"):
        mine = sum(np.sum(rows[k][key]) for k in common)
        theirs = sum(np.sum(other[k][key]) for k in common)
        print(f"total {key}: {mine:.4g} vs {theirs:.4g} (x{mine / theirs:.3f})")
    its = sum(sum(rows[k]["iterations"]) for k in common)
    its_other = sum(sum(other[k]["iterations"]) for k in common)
    print(f"total iterations: {its} vs {its_other} (x{its / its_other:.3f})")
    print("every design certified:", all(rows[k]["verified"] for k in common))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", help="write the rows to this JSON file")
    parser.add_argument("--against", help="a previous run's JSON to compare")
    args = parser.parse_args(argv)
    rows = run()
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    if args.against:
        with open(args.against) as f:
            compare(rows, json.load(f))


if __name__ == "__main__":
    main()
