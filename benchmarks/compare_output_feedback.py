"""Output-feedback verdicts and bounds on a fixed corpus, for comparing two
checkouts (the gate of a change to the output-feedback path, issue 20).

The corpus: the published cases (Doyle-Khargonekar's plant, the LPVTools
spinning disks, the missile autopilot), the two-mass drive on encoders, and
20 random polytopes (``tests/test_output_feedback.random_plant``: H-infinity
and H2, continuous two-vertex and discrete time, five seeds each). Each
case prints one JSON line: verdict (``certified`` or the refusal's class),
``gamma``, ``gamma_opt`` and CPU seconds.

Usage::

    PYTHONPATH=<old>/src python benchmarks/compare_output_feedback.py > old.jsonl
    PYTHONPATH=<new>/src python benchmarks/compare_output_feedback.py \\
        --against old.jsonl
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"  # before numpy: one BLAS thread
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import ctrl_lpv as lpv  # noqa: E402
from ctrl_lpv import twomass  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
import test_output_feedback as of  # noqa: E402
import test_output_feedback_published as dk  # noqa: E402
import test_output_feedback_published_lpv as pub  # noqa: E402

#: Relative difference of bounds counted as the same (solver tolerance).
RTOL = 1e-4


def cases():
    yield "DK default", lambda: lpv.hinf_output_feedback(
        lpv.pss([dk.dk_plant()]), dk.W, dk.U, dk.Z, dk.Y)  # fmt: skip
    yield "DK raw margin 1e-4", lambda: lpv.hinf_output_feedback(
        lpv.pss([dk.dk_plant()]), dk.W, dk.U, dk.Z, dk.Y, backoff=None,
        margin=1e-4)  # fmt: skip
    yield "DK raw", lambda: lpv.hinf_output_feedback(
        lpv.pss([dk.dk_plant()]), dk.W, dk.U, dk.Z, dk.Y, backoff=None)  # fmt: skip
    yield "spinning disks raw", lambda: lpv.hinf_output_feedback(
        pub.plant(), pub.W, pub.U, pub.Z, pub.Y, backoff=None)  # fmt: skip

    def missile():
        box = pub.MISSILE_BOX
        sys_ = lpv.PolytopicStateSpace(
            {(a, b): pub.missile(a, b) for a in box["Za"] for b in box["Ma"]},
            domain=box,
        )
        return lpv.hinf_output_feedback(sys_, "r", "u", ["z1", "z2"], ["e", "q"])

    yield "missile", missile
    for sensors in ("both", "motor"):
        yield f"two-mass {sensors}", lambda s=sensors: (
            twomass.output_feedback_design(sensors=s))  # fmt: skip
    for name, call in (("Hinf", lpv.hinf_output_feedback),
                       ("H2", lpv.h2_output_feedback)):  # fmt: skip
        for seed in range(5):
            yield (
                f"{name} continuous 2-vertex seed {seed}",
                lambda c=call, s=seed: c(
                    of.random_plant(s, vertices=2, stable=True), of.W, "u", of.Z, "y"
                ),
            )
            yield (
                f"{name} discrete seed {seed}",
                lambda c=call, s=seed: c(
                    of.random_plant(s, dt=0.1), of.W, "u", of.Z, "y"
                ),
            )


def run(case):
    name, call = case
    start = time.process_time()
    try:
        d = call()
        out = {"verdict": "certified" if d.certificate.verified else "unverified",
               "gamma": d.gamma, "gamma_opt": d.gamma_opt}  # fmt: skip
    except lpv.SynthesisError as exc:
        out = {"verdict": type(exc).__name__, "gamma": None, "gamma_opt": None}
    return {"case": name, **out, "cpu": time.process_time() - start}


def same(a, b) -> bool:
    if a is None or b is None:
        return a is b
    return abs(a - b) <= RTOL * max(abs(a), abs(b))


def _fmt(x) -> str:
    return "-" if x is None else f"{x:.6g}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--against", help="an earlier run's JSON lines")
    args = parser.parse_args(argv)
    old = {}
    if args.against:
        with open(args.against) as f:
            old = {r["case"]: r for r in map(json.loads, f)}
    differ = 0
    for case in cases():
        r = run(case)
        if not old:
            print(json.dumps(r), flush=True)
            continue
        o = old[r["case"]]
        ok = o["verdict"] == r["verdict"] and same(o["gamma"], r["gamma"])
        differ += not ok
        verdict = "same" if ok else "DIFFERENT"
        print(f"{r['case']:<32} {o['verdict']:>18} {_fmt(o['gamma']):>11} "
              f"{r['verdict']:>18} {_fmt(r['gamma']):>11} {o['cpu']:7.2f} "
              f"{r['cpu']:7.2f} {verdict}", flush=True)  # fmt: skip
    if old:
        print(f"{differ} of {len(old)} cases differ")
        sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
