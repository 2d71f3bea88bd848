"""Synthesis cost: the library against the direct conic build and Clarabel's solve.

Issue 20's "Must show", measured side by side in one run. The reference is
``tests/_direct_reference.py``: the same conic problem as the library's
minimum-gamma solve (Theorem 2 / Lemma 2; the stabilization stage for
Theorem 1 / Lemma 1), assembled with numpy/scipy.sparse into Clarabel's
``b - A x in K`` form and solved once (``chordal_decomposition_enable=False``,
as the library runs Clarabel). Parts (``--parts``, default all):

g  Theorem 2 on random polytopes (m = 2 inputs, one w, z = [C x; u]) for
   n = 4, 8, 12 and N = 16, 32 (64 with ``--full``): the library's
   ``gain_scheduled_hinf(backoff=None)`` cold (first call in a new process)
   and warm (a second call, new data, same shapes) against the direct
   build+solve of the same data and against Clarabel's own solve of it.
b  The default back-off (``backoff=0.2``) on the same polytopes, cold and
   warm, against one direct build+solve.
h  An H2 design with an affine Lyapunov matrix and scheduled gains
   (``synthesize(objective=H2, gains="scheduled", lyapunov="affine")``),
   n = 4, four parameters (N = 16 vertices), under a cap; then an identical
   second call, against the solver time inside it.
t  The four functions on the two-mass model (``lpv_model(p_bounds=(-0.95,
   0), formulation="tracking", integral=True)``, N = 2), cold and an
   identical warm call, against the direct build+solve.

Method: ``OMP_NUM_THREADS=1`` and ``OPENBLAS_NUM_THREADS=1`` are set before
numpy is imported; every (case, side) runs in its own process
(``benchmarks/synthesis_cases.py``), so that a
cold call is truly cold and the peak RSS (``ru_maxrss``) is that case's. Both
sides import the same modules before measuring (ctrl_lpv's synthesis
functions, cvxpy, control, clarabel), so their baselines are equal and the
peak difference is what the path allocates. Each process wraps
``clarabel.DefaultSolver`` to record every solve (CPU time of the call,
Clarabel's ``solve_time``, iterations, status): the number of solver calls
per library call and the solver's share. Times are CPU seconds
(``time.process_time``) unless marked wall; repeats are interleaved (library,
direct, library, ...) and the tables show medians. The direct side also
checks its gains: the largest H-infinity norm (``control.linfnorm``) of the
frozen closed loops at the vertices and random points, over its gamma.

Usage::

    python benchmarks/bench_synthesis.py [--quick] [--full] [--repeat R]
        [--sizes 4x16,8x32] [--parts gbht] [--cap SECONDS] [--h2-cap SECONDS]
        [--json PATH]
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"  # before numpy: one BLAS thread
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

import numpy as np  # noqa: E402

CASES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "synthesis_cases.py")

# Targets of issue 20 (ratios of CPU times; memory of peak RSS).
TARGETS = {
    "cold": 1.3,  # Theorem 2 backoff=None, cold / Clarabel's solve, N >= 16
    "warm": 1.1,  # the same, warm
    "backoff": 2.5,  # default back-off / one direct build+solve
    "memory": 1.2,  # peak RSS, library / direct
    "h2_repeat": 1.1,  # identical second H2 call / its solver time
}


def random_polytope(n, N, m=2, seed=0):
    """Part g's random polytope as a system (also used by ``bench_farkas.py``
    and ``time_budget.py``): ``tests/_direct_reference.random_vertices``."""
    import ctrl_lpv as lpv

    sys.path.insert(0, os.path.join(os.path.dirname(CASES), "..", "tests"))
    from _direct_reference import random_vertices

    return lpv.pss(random_vertices(n, N, m, seed))


# ----------------------------------------------------------------------
# The driver
# ----------------------------------------------------------------------
def spawn(spec, cap):
    """Run a case in a new process, ended after `cap` seconds per measured
    call (two) plus imports: the results of the calls that finished, with
    ``"skipped"`` saying why the others did not."""
    cmd = [sys.executable, CASES, json.dumps(spec)]
    process = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        stdout, stderr = process.communicate(timeout=2 * cap + 60)
        why = (
            None
            if process.returncode == 0
            else "failed: " + (stderr.strip().splitlines() or ["?"])[-1][:120]
        )
    except subprocess.TimeoutExpired:
        process.kill()  # this process's own child
        stdout, _ = process.communicate()  # what it printed before
        why = f"over the cap ({cap:g} s per call)"
    lines = stdout.strip().splitlines()
    out = json.loads(lines[-1]) if lines else {}
    if why:
        out["skipped"] = why
    return out


def medians(runs):
    """Median of every numeric entry (``"cold.cpu"``, ``"peak_rss_mb"``, ...)
    over the runs that were not skipped; the errors and skips seen."""
    flat: dict[str, list] = {}
    notes = set()
    for run in runs:
        if "skipped" in run:
            notes.add(run["skipped"])
        for key, value in run.items():
            items = value.items() if isinstance(value, dict) else [(None, value)]
            for sub, x in items:
                name = key if sub is None else f"{key}.{sub}"
                if isinstance(x, (int, float)) and not isinstance(x, bool):
                    flat.setdefault(name, []).append(x)
                elif sub == "error" and x:
                    notes.add(x)
    out = {k: float(np.median(v)) for k, v in flat.items()}
    out["notes"] = sorted(notes)
    return out


def ratio(a, b):
    return None if a is None or b is None or b <= 0 else a / b


def table(title, columns, rows):
    """Print `rows` under `title`: columns ``(header, width, value, digits)``."""
    print(f"\n{title}")
    print(" ".join(f"{h:>{w}s}" for h, w, _, _ in columns))
    for row in rows:
        cells = []
        for _, width, value, digits in columns:
            x = value(row)
            if isinstance(x, float):
                x = f"{x:.{-digits}e}" if digits < 0 else f"{x:.{digits}f}"
            cells.append(f"{'-' if x is None else x:>{width}}")
        notes = [
            n
            for side in ("direct", "library", "backoff")
            for n in row.get(side, {}).get("notes", [])
        ]
        print(" ".join(cells) + "".join(f"  [{n}]" for n in notes), flush=True)


def grid(sizes, repeat, cap, parts):
    """Parts g and b: every size, the sides interleaved in each repeat."""
    kinds = ["direct"] + ["library"] * ("g" in parts) + ["backoff"] * ("b" in parts)
    runs = {(n, N, k): [] for n, N in sizes for k in kinds}
    for r in range(repeat):
        for n, N in sizes:
            for kind in kinds:
                previous = runs[(n, N, kind)]
                if previous and (
                    "skipped" in previous[-1]
                    or "cold" not in previous[-1]
                    or previous[-1]["cold"]["error"]
                ):
                    continue  # over the cap or refused: not again
                out = spawn({"kind": kind, "n": n, "N": N}, cap)
                previous.append(out)
                print(
                    f"  [{r + 1}/{repeat}] n={n} N={N} {kind}: {brief(out)}", flush=True
                )
    rows = []
    for n, N in sizes:
        row = {"n": n, "N": N, **lmi_size(n, N)}
        row.update({k: medians(runs[(n, N, k)]) for k in kinds})
        row["runs"] = {k: runs[(n, N, k)] for k in kinds}
        d = row["direct"]
        for kind in kinds[1:]:
            side = row[kind]
            row[f"{kind}_ratios"] = {
                "cold_over_direct": ratio(side.get("cold.cpu"), d.get("cold.cpu")),
                "warm_over_direct": ratio(side.get("warm.cpu"), d.get("warm.cpu")),
                "cold_over_solve": ratio(
                    side.get("cold.cpu"), d.get("cold.solver_cpu")
                ),
                "warm_over_solve": ratio(
                    side.get("warm.cpu"), d.get("warm.solver_cpu")
                ),
                "cold_over_solve_wall": ratio(
                    side.get("cold.wall"), d.get("cold.solver_time")
                ),
                "memory": ratio(side.get("peak_rss_mb"), d.get("peak_rss_mb")),
                "gamma_rel_diff": ratio(
                    abs(side["cold.gamma_opt"] - d["cold.gamma"])
                    if "cold.gamma_opt" in side and "cold.gamma" in d
                    else None,
                    d.get("cold.gamma"),
                ),
            }
        rows.append(row)
    return rows


def brief(out):
    parts = [
        f"{when} {r['cpu']:.2f} s cpu, {r['solver_calls']} solves"
        + (f" ({r['error']})" if r.get("error") else "")
        for when, r in out.items()
        if when in ("cold", "warm", "first", "second")
    ]
    parts.append(f"peak {out.get('peak_rss_mb', 0):.0f} MB")
    return "; ".join(parts + ([out["skipped"]] if "skipped" in out else []))


def lmi_size(n, N, m=2, nw=1, nz=3):
    """LMI count, conic rows, and entries of Clarabel's dense Nesterov-Todd
    blocks (one ``d(d+1)/2`` square per PSD cone of side d)."""
    count, d = N * (N + 1) // 2, n + nw + nz
    svec, wsvec = d * (d + 1) // 2, n * (n + 1) // 2
    return {
        "lmis": count,
        "cone_rows": count * svec + wsvec,
        "nt_entries": count * svec**2 + wsvec**2,
    }


def get(side, key):
    return lambda row: row.get(side, {}).get(key)


def rat(kind, key):
    return lambda row: row.get(f"{kind}_ratios", {}).get(key)


def print_grid(rows, kind):
    head = [("n", 2, lambda r: r["n"], 0), ("N", 3, lambda r: r["N"], 0)]
    if kind == "library":
        title = (
            "Theorem 2, backoff=None, random polytopes: CPU s, medians; direct = "
            "build + one Clarabel solve of the same conic problem; calls = solver "
            "calls per library call; |T|/g = the direct gains' largest frozen "
            "H-infinity norm / its gamma"
        )
        columns = head + [
            ("LMIs", 5, lambda r: r["lmis"], 0),
            ("rows", 7, lambda r: r["cone_rows"], 0),
            ("build", 6, lambda r: ratio(r["direct"].get("cold.build_cpu"), 1), 3),
            ("solve", 6, get("direct", "cold.solver_cpu"), 2),
            ("s.wall", 6, get("direct", "cold.solver_time"), 2),
            ("it", 3, get("direct", "cold.iterations"), 0),
            ("|T|/g", 5, get("direct", "cold.norm_over_gamma"), 3),
            ("| cold", 7, get(kind, "cold.cpu"), 2),
            ("calls", 5, get(kind, "cold.solver_calls"), 0),
            ("slv", 6, get(kind, "cold.solver_cpu"), 2),
            ("warm", 6, get(kind, "warm.cpu"), 2),
            ("calls", 5, get(kind, "warm.solver_calls"), 0),
            ("| c/dir", 7, rat(kind, "cold_over_direct"), 2),
            ("c/slv", 6, rat(kind, "cold_over_solve"), 2),
            ("w/dir", 6, rat(kind, "warm_over_direct"), 2),
            ("w/slv", 6, rat(kind, "warm_over_solve"), 2),
            ("| RSS", 6, get(kind, "peak_rss_mb"), 0),
            ("direct", 6, get("direct", "peak_rss_mb"), 0),
            ("ratio", 5, rat(kind, "memory"), 2),
            ("| gamma diff", 12, rat(kind, "gamma_rel_diff"), -1),
        ]
    else:
        title = "Default back-off (0.2) against one direct build+solve: CPU s, medians"
        columns = head + [
            ("| cold", 7, get(kind, "cold.cpu"), 2),
            ("calls", 5, get(kind, "cold.solver_calls"), 0),
            ("slv", 6, get(kind, "cold.solver_cpu"), 2),
            ("warm", 6, get(kind, "warm.cpu"), 2),
            ("calls", 5, get(kind, "warm.solver_calls"), 0),
            ("slv", 6, get(kind, "warm.solver_cpu"), 2),
            ("| direct", 8, get("direct", "cold.cpu"), 2),
            ("| c/dir", 7, rat(kind, "cold_over_direct"), 2),
            ("w/dir", 6, rat(kind, "warm_over_direct"), 2),
            ("| RSS", 6, get(kind, "peak_rss_mb"), 0),
            ("ratio", 5, rat(kind, "memory"), 2),
            ("| gamma", 9, get(kind, "cold.gamma"), 5),
        ]
    table(title, columns, rows)


def h2_part(cap):
    out = spawn({"kind": "h2"}, cap)
    print(
        f"\nH2, lyapunov='affine', gains='scheduled', n = 4, N = 16 (4 parameters,"
        f" rate bounds 1), cap {cap:g} s per call; then an identical call: "
        + brief(out)
    )
    first = out.get("first", {})
    # Finished: certified, and not by the time budget ending the ladder.
    row = {
        "run": out,
        "finished": bool(first.get("verified"))
        and "MaxTime" not in first.get("statuses", [])
        and first.get("wall", np.inf) < 0.95 * cap,
    }
    for label in ("first", "second"):
        r = out.get(label)
        if r:
            print(
                f"  {label}: {r['cpu']:.2f} s cpu, {r['wall']:.2f} s wall, solver "
                f"{r['solver_cpu']:.2f} s cpu, statuses {r['statuses']}, gamma "
                f"{r.get('gamma')}, certified {r.get('verified')}"
            )
    second = out.get("second")
    if second and not second["error"]:
        row["second_over_solver"] = ratio(second["cpu"], second["solver_cpu"])
        print(f"  second call / its solver time: {row['second_over_solver']:.2f}")
    return row


def two_mass_part(repeat, cap):
    cases = [
        ("Lemma 1", None),
        ("Theorem 1", None),
        ("Lemma 2", None),
        ("Theorem 2", None),
        ("Lemma 2", 0.2),
        ("Theorem 2", 0.2),
    ]
    rows = []
    for name, backoff in cases:
        spec = {"function": name, "backoff": backoff}
        runs = {"library": [], "direct": []}
        for _ in range(repeat):  # interleaved
            runs["library"].append(spawn({**spec, "kind": "twomass"}, cap))
            runs["direct"].append(spawn({**spec, "kind": "twomass_direct"}, cap))
        row = {"function": name, "pipeline": f"backoff={backoff}", "runs": runs}
        row.update({k: medians(v) for k, v in runs.items()})
        rows.append(row)
    ms = 1e3
    table(
        "Two-mass model (n = 5, N = 2): CPU ms, medians; warm = an identical "
        "second call; direct = build + one solve (the stabilization stage for "
        "Lemma 1 / Theorem 1)",
        [
            ("function", 9, lambda r: r["function"], 0),
            ("pipeline", 12, lambda r: r["pipeline"], 0),
            ("| cold", 7, lambda r: ms * r["library"].get("cold.cpu", np.nan), 1),
            ("calls", 5, get("library", "cold.solver_calls"), 0),
            ("warm", 7, lambda r: ms * r["library"].get("warm.cpu", np.nan), 1),
            ("calls", 5, get("library", "warm.solver_calls"), 0),
            ("| direct", 8, lambda r: ms * r["direct"].get("warm.cpu", np.nan), 1),
            ("solve", 6, lambda r: ms * r["direct"].get("warm.solver_cpu", np.nan), 1),
            (
                "| c/dir",
                7,
                lambda r: ratio(
                    r["library"].get("cold.cpu"), r["direct"].get("warm.cpu")
                ),
                2,
            ),
            (
                "w/dir",
                6,
                lambda r: ratio(
                    r["library"].get("warm.cpu"), r["direct"].get("warm.cpu")
                ),
                2,
            ),
            ("| gamma_opt", 11, get("library", "cold.gamma_opt"), 6),
            ("direct", 9, get("direct", "warm.gamma"), 6),
        ],
        rows,
    )
    return rows


def verdicts(results):
    """Per target: the worst measured case (N >= 16), PASS or MISS."""
    rows = [r for r in results.get("grid", []) if r["N"] >= 16]
    out = []

    def add(what, values, limit):
        values = [v for v in values if v is not None]
        worst = max(values) if values else None
        status = "-" if worst is None else ("PASS" if worst <= limit else "MISS")
        out.append(
            {"target": what, "measured": worst, "limit": limit, "status": status}
        )

    if any("library_ratios" in r for r in rows):
        for n in sorted({r["n"] for r in rows}):
            mine = [r["library_ratios"] for r in rows if r["n"] == n]
            add(
                f"Theorem 2 n={n}: cold / Clarabel solve",
                [q["cold_over_solve"] for q in mine],
                TARGETS["cold"],
            )
            add(
                f"Theorem 2 n={n}: warm / Clarabel solve",
                [q["warm_over_solve"] for q in mine],
                TARGETS["warm"],
            )
        add(
            "Theorem 2: peak RSS library / direct",
            [r["library_ratios"]["memory"] for r in rows],
            TARGETS["memory"],
        )
    if any("backoff_ratios" in r for r in rows):
        for key, label in (
            ("cold_over_direct", "cold"),
            ("warm_over_direct", "warm"),
            ("memory", "peak RSS"),
        ):
            limit = TARGETS["memory" if key == "memory" else "backoff"]
            add(
                f"default back-off: {label} / direct",
                [r["backoff_ratios"][key] for r in rows],
                limit,
            )
    h2 = results.get("h2")
    if h2 is not None:
        out.append(
            {
                "target": "H2 affine n=4 N=16 certified within budget",
                "measured": h2["finished"],
                "limit": True,
                "status": "PASS" if h2["finished"] else "MISS",
            }
        )
        add(
            "H2: identical second call / its solver time",
            [h2.get("second_over_solver")],
            TARGETS["h2_repeat"],
        )
    return out


def print_verdicts(rows):
    print("\nTargets (issue 20): the worst case over the rows measured with N >= 16")
    for v in rows:
        m = v["measured"]
        shown = m if m is None or isinstance(m, bool) else f"{m:.2f}"
        print(
            f"  {v['status']:4s}  {v['target']:44s} {str(shown):>6s}  "
            f"(target <= {v['limit']})"
        )


def load_note():
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} CPUs"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="n=4, N=16, 1 repeat")
    parser.add_argument("--full", action="store_true", help="also N = 64")
    parser.add_argument("--sizes", help="comma-separated nxN, e.g. 4x16,8x32")
    parser.add_argument("--repeat", type=int, help="runs per median (default 3)")
    parser.add_argument("--parts", default="gbht", help="any of g, b, h, t")
    parser.add_argument("--cap", type=float, help="s per call (300; quick 120)")
    parser.add_argument(
        "--h2-cap", type=float, default=600.0, help="s per H2 call (600, its budget)"
    )
    parser.add_argument("--json", help="write all results to this JSON file")
    args = parser.parse_args(argv)
    if args.sizes:
        sizes = [tuple(int(x) for x in s.split("x")) for s in args.sizes.split(",")]
    else:
        Ns = (16, 32, 64) if args.full else (16, 32)
        sizes = [(4, 16)] if args.quick else [(n, N) for n in (4, 8, 12) for N in Ns]
    repeat = args.repeat or (1 if args.quick else 3)
    cap = args.cap or (120.0 if args.quick else 300.0)
    import clarabel

    results = {
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "clarabel": clarabel.__version__,
            "numpy": np.__version__,
            "repeat": repeat,
            "cap_seconds": cap,
            "load_before": os.getloadavg(),
        }
    }
    print(f"bench_synthesis: repeat {repeat}, cap {cap:g} s; {load_note()}", flush=True)
    if "g" in args.parts or "b" in args.parts:
        results["grid"] = grid(sizes, repeat, cap, args.parts)
        for kind, part in (("library", "g"), ("backoff", "b")):
            if part in args.parts:
                print_grid(results["grid"], kind)
    if "h" in args.parts:
        results["h2"] = h2_part(args.h2_cap)
    if "t" in args.parts:
        results["two_mass"] = two_mass_part(repeat, cap)
    results["verdicts"] = verdicts(results)
    print_verdicts(results["verdicts"])
    results["machine"]["load_after"] = os.getloadavg()
    print(f"\n{load_note()}")
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2, default=float)


if __name__ == "__main__":
    main()
