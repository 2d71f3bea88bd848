"""Trust fuzz: are ctrl_lpv's designs and refusals true? (issue 11).

Generates seeded polytopic state-feedback problems (badly scaled and
ill-conditioned coordinates, near-uncontrollable, marginal and lightly
damped vertices, duplicate vertices, ``D != 0``, N up to 16, n up to 10,
m 1..3, pole regions, gain bounds, required gammas; see
``tests/_independent.py``), calls the library, and checks every answer
independently:

* a returned design: float64 checks from its gains and ``P`` alone
  (Lyapunov / Theorem 1-2 pair LMIs and the bounded-real LMI with a
  rounding bound, Hurwitz and pole regions at vertices and samples,
  ``gamma`` against frozen H-infinity norms, gain bound, required gamma);
* a refusal: an independent search for a verified design (plain cvxpy
  LMIs in other scalings, margins and solvers; LQR / Riccati gains), then
  the verdict true (proved by the construction) / false (a verified design
  exists) / unresolved, and whether the message's claim is true.

Usage::

    python benchmarks/fuzz_trust.py [--n 1000] [--seed 0] [--start 0]
        [--json PATH] [--probe-budget SECONDS]
    python benchmarks/fuzz_trust.py --case SEED:INDEX [--small]   # one case, verbose
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import sys
import time
import warnings

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import ctrl_lpv as lpv  # noqa: E402
from _independent import generate_case, message_kind, run_case  # noqa: E402


def _json_default(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def summarize(records, seconds) -> str:
    """The result table."""
    designs = [r for r in records if r["outcome"] == "design"]
    refusals = [r for r in records if r["outcome"] == "refusal"]
    timeouts = [r for r in records if r["outcome"] == "timeout"]
    failed = [r for r in designs if not r["check_ok"]]
    soft = [r for r in designs if r["check_ok"] and not r["check_verified"]]
    known = [r for r in refusals if r["verdict"] != "uncaught exception"]
    uncaught = [r for r in refusals if r["verdict"] == "uncaught exception"]
    false_ref = [r for r in refusals if r["verdict"] == "false refusal"]
    feasible = len(designs) + sum(r.get("probe_found", False) for r in refusals)
    lines = [
        f"problems: {len(records)}   time: {seconds:.0f} s "
        f"(library {sum(r['seconds'] for r in records):.0f} s, probes "
        f"{sum(r.get('probe_seconds', 0) for r in refusals):.0f} s)",
        "",
        f"{'returned designs':44s} {len(designs):5d}",
        f"{'  failing the independent check (must be 0)':44s} {len(failed):5d}",
        f"{'  passing, but a proof step only up to rounding':44s} {len(soft):5d}",
        f"{'  returned on a proved-infeasible problem':44s} "
        f"{sum(r.get('design_on_proved_infeasible', False) for r in designs):5d}",
        f"{'refusals (SynthesisError: both classes)':44s} {len(known):5d}",
        f"{'  true (proved by construction)':44s} "
        f"{sum(r['verdict'] == 'true refusal (proved)' for r in refusals):5d}",
        f"{'  false (probe found a verified design)':44s} {len(false_ref):5d}",
        f"{'  unresolved':44s} "
        f"{sum(r['verdict'] == 'unresolved' for r in refusals):5d}",
        f"{'  with a false statement':44s} "
        f"{sum(bool(r.get('false_statement')) for r in refusals):5d}",
        f"{'uncaught exceptions (other classes)':44s} {len(uncaught):5d}",
        f"{'library calls past the time cap':44s} {len(timeouts):5d}",
        f"{'problems with a verified design (lib+probe)':44s} {feasible:5d}",
        f"{'false-refusal rate among them':44s} "
        f"{100.0 * len(false_ref) / max(feasible, 1):5.1f} %",
        "",
        "refusals by class / message kind / verdict:",
    ]
    counts = collections.Counter(
        (r["class"], r["kind"], r["verdict"]) for r in refusals
    )
    for (cls, kind, verdict), c in sorted(counts.items(), key=lambda x: -x[1]):
        lines.append(f"  {c:4d}  {cls:20s} {kind:18s} {verdict}")
    if uncaught:
        lines.append("uncaught exception types:")
        for name, c in collections.Counter(r["class"] for r in uncaught).most_common():
            lines.append(f"  {c:4d}  {name}")
    by_fn = collections.defaultdict(lambda: [0, 0, 0, 0])
    for r in records:
        row = by_fn[r["function"]]
        row[0] += 1
        row[1] += r["outcome"] == "design"
        row[2] += r["outcome"] == "design" and not r["check_ok"]
        row[3] += r.get("verdict") == "false refusal"
    lines += [
        "",
        f"{'function':30s} {'cases':>6s} {'designs':>8s} {'failed':>7s} "
        f"{'false ref':>9s}",
    ]
    for fn, (c, d, f, fr) in sorted(by_fn.items()):
        lines.append(f"{fn:30s} {c:6d} {d:8d} {f:7d} {fr:9d}")
    by_fam = collections.defaultdict(collections.Counter)
    for r in records:
        verdict = r.get("verdict") or r["outcome"]
        if r["outcome"] == "design":
            verdict = "design ok" if r["check_ok"] else "design FAILED"
        by_fam[_family(r["tags"])][verdict] += 1
    lines += ["", "by problem family:"]
    for fam, counter in sorted(by_fam.items()):
        lines.append(
            f"  {fam:16s} " + ", ".join(f"{k} {v}" for k, v in counter.items())
        )
    if failed:
        lines += ["", "failing designs:"]
        for r in failed[:20]:
            lines.append(f"  {r['describe']}\n      -> {'; '.join(r['hard'][:3])}")
    if false_ref or uncaught:
        lines += ["", "false refusals and uncaught exceptions:"]
        for r in (false_ref + uncaught)[:30]:
            lines.append(
                f"  {r['describe']}\n      -> {r['class']}: {r['message'][:160]}"
                + (
                    f"\n      probe: {r['probe_method']}"
                    if r.get("probe_found")
                    else ""
                )
            )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=1000, help="number of problems")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--start", type=int, default=0, help="first index")
    parser.add_argument("--json", help="write the records here")
    parser.add_argument(
        "--probe-budget", type=float, default=30.0, help="CPU seconds per refusal"
    )
    parser.add_argument(
        "--time-cap",
        type=float,
        default=90.0,
        help="seconds per library call (then recorded as a timeout)",
    )
    parser.add_argument("--case", help="SEED:INDEX: re-run one case verbosely")
    parser.add_argument(
        "--rescore",
        nargs="+",
        metavar="JSON",
        help="re-read record files (merged) and print the table",
    )
    parser.add_argument(
        "--small",
        action="store_true",
        help="the capped sizes of tests/test_trust_fuzz.py",
    )
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")

    if args.rescore:
        records, seconds = [], 0.0
        for path in args.rescore:
            with open(path) as f:
                data = json.load(f)
            records += [_rescore(r) for r in data["records"]]
            seconds += data["meta"]["seconds"]
        print(summarize(records, seconds))
        return 0

    if args.case:
        seed, index = (int(x) for x in args.case.split(":"))
        case = generate_case(seed, index, small=args.small)
        print(case.describe())
        with np.printoptions(precision=4, linewidth=120):
            for j, v in enumerate(case.vertices):
                print(f" vertex {j}: A=\n{v[0]}\n B2=\n{v[2]}")
                if case.hinf:
                    print(f" B1=\n{v[1]}\n C=\n{v[3]}\n D1=\n{v[4]}\n D2=\n{v[5]}")
                if j >= 1 and case.N > 3:
                    print(f" ... ({case.N - 2} more vertices)")
                    break
        rec = run_case(case, lpv, probe_budget=args.probe_budget, verbose=True)
        print(json.dumps(rec, indent=1, default=_json_default))
        return 0

    records = []
    t0 = time.perf_counter()
    for i in range(args.start, args.start + args.n):
        case = generate_case(args.seed, i, small=args.small)
        rec = run_case(
            case, lpv, probe_budget=args.probe_budget, time_cap=args.time_cap
        )
        records.append(rec)
        bad = sum(r["outcome"] == "design" and not r["check_ok"] for r in records)
        fr = sum(r.get("verdict") == "false refusal" for r in records)
        unc = sum(r.get("verdict") == "uncaught exception" for r in records)
        tag = rec["outcome"] if rec["outcome"] != "refusal" else rec.get("verdict", "")
        print(
            f"\r[{len(records):4d}/{args.n}] {time.perf_counter() - t0:6.0f} s  "
            f"failed designs {bad}  false refusals {fr}  uncaught {unc}  "
            f"last {case.label()} {tag[:24]:24s}",
            end="",
            file=sys.stderr,
            flush=True,
        )
        if args.json and len(records) % 10 == 0:
            _dump(args, records, time.perf_counter() - t0)
    print(file=sys.stderr)
    seconds = time.perf_counter() - t0
    print(summarize(records, seconds))
    if args.json:
        _dump(args, records, seconds)
    return 0


def _family(tags):
    """The generator's problem kind, from a case's tags."""
    text = " ".join(tags)
    for key, name in (
        ("issue", "issue examples"),
        ("uncontrollable mode", "uncontrollable"),
        ("weak B", "weak B"),
        ("illcond", "ill-conditioned"),
        ("scaled 1e-4", "scaled states"),
    ):
        if key in text:
            return name
    return "generic"


def _rescore(rec):
    """Re-derive the message kind and statement check of a stored refusal."""
    if rec["outcome"] != "refusal" or rec["verdict"] == "uncaught exception":
        return rec
    rec = dict(rec)
    rec["kind"] = message_kind(Exception(rec["message"]))
    if rec["kind"] != "not stabilizable":
        plain = rec["class"] == "InfeasibleError"
        rec["false_statement"] = (
            "InfeasibleError on a feasible problem"
            if plain and rec.get("probe_found")
            else None
        )
    return rec


def _dump(args, records, seconds):
    meta = {
        "seed": args.seed,
        "start": args.start,
        "n": args.n,
        "seconds": seconds,
        "python": platform.python_version(),
        "machine": platform.machine(),
        "ctrl_lpv": getattr(lpv, "__version__", "?"),
    }
    with open(args.json, "w") as f:
        json.dump(
            {"meta": meta, "records": records}, f, indent=1, default=_json_default
        )


if __name__ == "__main__":
    sys.exit(main())
