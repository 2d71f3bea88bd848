"""Synthesis speed: the library against plain cvxpy, re-solves, scaling.

Three parts, every comparison measured side by side in one run (medians of
``--repeat`` interleaved runs):

(a) The four synthesis functions on the two-mass model
    (``lpv_model(p_bounds=(-0.95, 0), formulation="tracking",
    integral=True)``, w = Td, u = Tm, z = all outputs), time split into
    build / compile / solve / verify, against the same LMIs written as a
    plain cvxpy script (no prescaling, no verification) with the same
    solver, Clarabel ("plain": Clarabel's defaults, what a script would
    use; "p.same": the library's Clarabel settings). "cold" is a first call
    (nothing compiled in the process), "warm" a repeated call that reuses
    the compiled problem. Like with like: ``backoff=None`` (one solve of the
    minimum gamma) against the plain minimum, and the stabilizations (the
    library's LMIs and objective in both); the default pipeline (back-off
    0.2: minimum gamma, centering, one to four gain iterations, so three to
    six solves) is listed against the same one-solve plain script.
(b) Re-solves on the two-mass model: first call, then cached re-solves for
    a gamma sweep, a back-off sweep, a performance-weight sweep and a plant
    sweep (``p_bounds``), against the plain script per point.
(c) Scaling on random well-conditioned polytopes (stabilizable by
    construction, m = 2 inputs, one w, z = [C x; u]) for the four functions
    (``--functions``; the H-infinity ones with ``backoff=None``, the
    stabilizations with their one solve): N = 2..64 vertices, n = 4, 8, 12. Each
    case runs in its own process with a time cap per measured call; cases
    beyond a capped one are skipped. The plain script uses the library's
    Clarabel settings here. Columns give the LMI count and size, the conic
    problem size (rows of the PSD cones) and the entries of the dense
    blocks of Clarabel's KKT system (one ``d(d+1)/2``-square Nesterov-Todd
    scaling block per PSD cone of size ``d``), and the peak memory.

Usage::

    python benchmarks/bench_synthesis.py [--quick] [--repeat N] [--json PATH]
        [--cap SECONDS] [--parts abc]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
import warnings

import cvxpy as cp
import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv import synthesis_cache, twomass

FUNCTIONS = {
    "Lemma 1": (lpv.quadratic_stabilization, False, False),
    "Theorem 1": (lpv.gain_scheduled_stabilization, False, True),
    "Lemma 2": (lpv.hinf_state_feedback, True, False),
    "Theorem 2": (lpv.gain_scheduled_hinf, True, True),
}
EPS = 1e-6  # margin of the plain scripts' strict LMIs


# ----------------------------------------------------------------------
# The plain cvxpy scripts (what a user would write without the library)
# ----------------------------------------------------------------------
def channels(sys, w, u, z):
    """Vertex data (A, B1, B2, C, D1, D2) for index lists w, u, z."""
    return [
        (A, B[:, w], B[:, u], C[z], D[np.ix_(z, w)], D[np.ix_(z, u)])
        for A, B, C, D in sys.vertex_data()
    ]


def plain_hinf(vertices, scheduled, **options):
    """Lemma 2 / Theorem 2 in plain cvxpy: minimise g = gamma^2."""
    N = len(vertices)
    n, m = vertices[0][2].shape
    nw, nz = vertices[0][1].shape[1], vertices[0][3].shape[0]
    W = cp.Variable((n, n), symmetric=True)
    Z = [cp.Variable((m, n)) for _ in range(N if scheduled else 1)]
    g = cp.Variable()
    cons = [W >> EPS * np.eye(n)]
    pairs = [(j, k) for j in range(N) for k in range(j, N if scheduled else j + 1)]
    for j, k in pairs:
        Aj, B1j, B2j, Cj, D1j, D2j = vertices[j]
        Ak, B1k, B2k, Ck, D1k, D2k = vertices[k]
        Zj, Zk = (Z[j], Z[k]) if scheduled else (Z[0], Z[0])
        if j == k:
            c, B1, D1 = 1.0, B1j, D1j
            q, R = Aj @ W + B2j @ Zj, Cj @ W + D2j @ Zj
        else:
            c, B1, D1 = 2.0, B1j + B1k, D1j + D1k
            q = (Aj + Ak) @ W + B2j @ Zk + B2k @ Zj
            R = (Cj + Ck) @ W + D2j @ Zk + D2k @ Zj
        M = cp.bmat(
            [
                [q + q.T, B1, R.T],
                [B1.T, -c * np.eye(nw), D1.T],
                [R, D1, -c * g * np.eye(nz)],
            ]
        )
        cons.append(M << -EPS * np.eye(n + nw + nz))
    problem = cp.Problem(cp.Minimize(g), cons)
    problem.solve(solver="CLARABEL", **options)
    gamma = float(np.sqrt(g.value)) if g.value is not None else None
    return problem, gamma


def plain_stabilization(vertices, scheduled, **options):
    """Lemma 1 / Theorem 1 in plain cvxpy, the library's LMIs and objective.

    Maximise t with t I <= W <= I, ||Z|| <= 1, the strict Lyapunov LMIs and
    sym(A_cl W) <= -t I at every vertex (and pair).
    """
    N = len(vertices)
    n, m = vertices[0][2].shape
    W = cp.Variable((n, n), symmetric=True)
    Z = [cp.Variable((m, n)) for _ in range(N if scheduled else 1)]
    t = cp.Variable()
    cons = [W >> EPS * np.eye(n), W << np.eye(n), W >> t * np.eye(n)]
    cons += [cp.bmat([[-np.eye(n), Zk.T], [Zk, -np.eye(m)]]) << 0 for Zk in Z]
    pairs = [(j, k) for j in range(N) for k in range(j, N if scheduled else j + 1)]
    for j, k in pairs:
        Aj, B2j, Ak, B2k = (
            vertices[j][0],
            vertices[j][2],
            vertices[k][0],
            vertices[k][2],
        )
        Zj, Zk = (Z[j], Z[k]) if scheduled else (Z[0], Z[0])
        if j == k:
            c, q = 1.0, Aj @ W + B2j @ Zj
        else:
            c, q = 2.0, (Aj + Ak) @ W + B2j @ Zk + B2k @ Zj
        cons.append(q + q.T << -EPS * np.eye(n))
        cons.append(q + q.T + c * t * np.eye(n) << 0)
    problem = cp.Problem(cp.Maximize(t), cons)
    problem.solve(solver="CLARABEL", **options)
    return problem, None


def run_plain(name, vertices, **options):
    _, hinf, scheduled = FUNCTIONS[name]
    start = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "may be inaccurate"
            problem, gamma = (plain_hinf if hinf else plain_stabilization)(
                vertices, scheduled, **options
            )
    except cp.error.SolverError:
        # Timed all the same: the script's user paid for it.
        return {"total": time.perf_counter() - start, "status": "solver_error"}
    total = time.perf_counter() - start
    stats = problem.solver_stats
    return {
        "total": total,
        "compile": problem.compilation_time,
        "solve": stats.solve_time if stats and stats.solve_time else np.nan,
        "status": problem.status,
        "gamma": gamma,
    }


# ----------------------------------------------------------------------
# Measurement helpers
# ----------------------------------------------------------------------
def run_library(function, sys, cold, **kwargs):
    if cold:
        synthesis_cache.clear()
    start = time.perf_counter()
    design = function(sys, **kwargs)
    total = time.perf_counter() - start
    return {
        "total": total,
        **design.timing,
        "attempts": len(design.attempts),
        "fallbacks": sum(a.solver != "CLARABEL" for a in design.attempts),
        "gamma": design.gamma,
        "verified": design.certificate.verified,
    }


def median(rows, key):
    values = [r[key] for r in rows if r.get(key) is not None]
    return float(np.median(values)) if values else None


def summary(rows, keys):
    return {k: median(rows, k) for k in keys}


def ms(x):
    return "-" if x is None or not np.isfinite(x) else f"{1e3 * x:.1f}"


def two_mass():
    return twomass.lpv_model(p_bounds=(-0.95, 0), formulation="tracking", integral=True)


def two_mass_kwargs(model, hinf):
    if hinf:
        return {"w": "Td", "u": "Tm", "z": list(model.output_labels)}
    return {"u": "Tm"}


# ----------------------------------------------------------------------
# (a) the four functions on the two-mass model
# ----------------------------------------------------------------------
def part_a(repeat):
    model = two_mass()
    vertices = channels(model, [0], [1], list(range(model.noutputs)))
    cases = [
        ("Lemma 1", {}),
        ("Theorem 1", {}),
        ("Lemma 2", {"backoff": None}),
        ("Theorem 2", {"backoff": None}),
        ("Lemma 2", {}),
        ("Theorem 2", {}),
    ]
    keys = ["total", "build", "compile", "solve", "verify", "attempts", "gamma"]
    keys += ["fallbacks"]
    out = []
    for name, extra in cases:
        function, hinf, _ = FUNCTIONS[name]
        kwargs = {**two_mass_kwargs(model, hinf), **extra}
        cold, warm, plain, plain_same = [], [], [], []
        run_library(function, model, True, **kwargs)  # imports, first use
        for _ in range(repeat):
            cold.append(run_library(function, model, True, **kwargs))
            warm.append(run_library(function, model, False, **kwargs))
            plain.append(run_plain(name, vertices))
            plain_same.append(
                run_plain(name, vertices, chordal_decomposition_enable=False)
            )
        row = {
            "function": name,
            "pipeline": "backoff=None"
            if extra.get("backoff", 0.2) is None
            else ("default" if hinf else "default (max decay)"),
            "cold": summary(cold, keys),
            "warm": summary(warm, keys),
            "plain": summary(plain, ["total", "compile", "solve", "gamma"]),
            "plain_same_options": summary(plain_same, ["total", "gamma"]),
            "plain_status": plain[-1]["status"],
            "verified": all(r["verified"] for r in cold + warm),
        }
        row["ratio_cold"] = row["cold"]["total"] / row["plain"]["total"]
        row["ratio_warm"] = row["warm"]["total"] / row["plain"]["total"]
        out.append(row)
        print_row_a(row)
    return out


def print_header_a():
    print(
        "\n(a) two-mass model (n = 5, N = 2), medians [ms]; ratio = library / plain\n"
        f"{'function':10s} {'pipeline':19s} | {'cold':>7s} {'build':>6s} "
        f"{'compile':>7s} {'solve':>6s} {'verify':>6s} | {'warm':>6s} | "
        f"{'plain':>6s} {'p.comp':>6s} {'p.solve':>7s} {'p.same':>6s} | "
        f"{'cold/pl':>7s} {'warm/pl':>7s} | gamma lib / plain"
    )


def print_row_a(r):
    c, w, p = r["cold"], r["warm"], r["plain"]
    gammas = ""
    if c["gamma"] is not None and p["gamma"] is not None:
        gammas = f"{c['gamma']:.5g} / {p['gamma']:.5g} ({r['plain_status']})"
    if c["fallbacks"]:
        gammas += f" [library used SCS {c['fallbacks']:g}x]"
    print(
        f"{r['function']:10s} {r['pipeline']:19s} | {ms(c['total']):>7s} "
        f"{ms(c['build']):>6s} {ms(c['compile']):>7s} {ms(c['solve']):>6s} "
        f"{ms(c['verify']):>6s} | {ms(w['total']):>6s} | {ms(p['total']):>6s} "
        f"{ms(p['compile']):>6s} {ms(p['solve']):>7s} "
        f"{ms(r['plain_same_options']['total']):>6s} | {r['ratio_cold']:7.2f} "
        f"{r['ratio_warm']:7.2f} | {gammas}",
        flush=True,
    )


# ----------------------------------------------------------------------
# (b) re-solves
# ----------------------------------------------------------------------
def part_b(repeat, quick):
    model = two_mass()
    kw = two_mass_kwargs(model, True)
    vertices = channels(model, [0], [1], list(range(model.noutputs)))
    best = lpv.gain_scheduled_hinf(model, backoff=None, **kw)
    factors = [1.05, 1.2, 2.0] if quick else [1.02, 1.05, 1.1, 1.2, 1.5, 2.0, 3.0]
    backoffs = [0.1, 0.5] if quick else [0.05, 0.1, 0.2, 0.5, 1.0]
    weights = [1e-3, 5e-3] if quick else [5e-4, 1e-3, 2e-3, 5e-3, 1e-2]
    epsilons = [0.1, 0.02] if quick else [0.2, 0.1, 0.05, 0.02, 0.01]

    def models_with(**kwargs):
        return twomass.lpv_model(formulation="tracking", integral=True, **kwargs)

    sweeps = [
        ("gamma (fixed-gamma feasibility)", "Theorem 2",
         [(model, {"gamma": f * best.gamma_opt, "backoff": None}) for f in factors]),
        ("gamma (fixed gamma, default back-off)", "Theorem 2",
         [(model, {"gamma": f * best.gamma_opt}) for f in factors]),
        ("back-off (default pipeline)", "Theorem 2",
         [(model, {"backoff": b}) for b in backoffs]),
        ("torque weight (z rows), backoff=None", "Theorem 2",
         [(models_with(p_bounds=(-0.95, 0), torque_weight=w), {"backoff": None})
          for w in weights]),
        ("plant p_bounds, backoff=None", "Theorem 2",
         [(models_with(p_bounds=(-1 + e, 0)), {"backoff": None}) for e in epsilons]),
        ("torque weight, Lemma 2, backoff=None", "Lemma 2",
         [(models_with(p_bounds=(-0.95, 0), torque_weight=w), {"backoff": None})
          for w in weights]),
    ]  # fmt: skip
    out = []
    print(
        "\n(b) re-solves on the two-mass model, medians [ms] "
        "(first = cold call incl. compile; re-solve = later calls of the sweep)\n"
        f"{'sweep':40s} {'fn':9s} {'pts':>3s} | {'first':>7s} {'compile':>7s} | "
        f"{'re-solve':>8s} {'compile':>7s} {'solve':>6s} {'verify':>6s} | "
        f"{'plain':>6s} | {'re/plain':>8s} | certified"
    )
    for label, name, points in sweeps:
        function, _, _ = FUNCTIONS[name]
        first, again, plain = [], [], []
        for _ in range(repeat):
            sys0, extra0 = points[0]
            first.append(run_library(function, sys0, True, **kw, **extra0))
            for sys_, extra in points[1:]:
                again.append(run_library(function, sys_, False, **kw, **extra))
        for sys_, _ in points:
            plain.append(run_plain(name, channels(sys_, [0], [1], [0, 1, 2])))
        row = {
            "sweep": label,
            "function": name,
            "points": len(points),
            "first": summary(first, ["total", "compile"]),
            "resolve": summary(again, ["total", "compile", "solve", "verify"]),
            "plain": summary(plain, ["total"]),
            "plain_failed": sum(r["status"] == "solver_error" for r in plain),
            "fallbacks": sum(r["fallbacks"] for r in first + again),
            "certified": all(r["verified"] for r in first + again),
        }
        row["ratio"] = row["resolve"]["total"] / row["plain"]["total"]
        out.append(row)
        f, a = row["first"], row["resolve"]
        print(
            f"{label:40s} {name:9s} {len(points):3d} | {ms(f['total']):>7s} "
            f"{ms(f['compile']):>7s} | {ms(a['total']):>8s} {ms(a['compile']):>7s} "
            f"{ms(a['solve']):>6s} {ms(a['verify']):>6s} | "
            f"{ms(row['plain']['total']):>6s} | {row['ratio']:8.2f} | "
            f"{row['certified']}, {row['fallbacks']} SCS attempts; plain "
            f"failed {row['plain_failed']}/{len(points)}",
            flush=True,
        )
    del vertices
    return out


# ----------------------------------------------------------------------
# (c) scaling on random polytopes, one process per case
# ----------------------------------------------------------------------
def random_polytope(n, N, m=2, seed=0):
    """Quadratically stabilizable by construction (see tests)."""
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(m, n))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q @ np.diag(rng.uniform(0.5, 2.0, size=n))
    Ti = np.linalg.inv(T)
    vertices = []
    for _ in range(N):
        B = rng.normal(size=(n, m))
        S = rng.normal(size=(n, n))
        A = B @ K0 + (S - S.T) - rng.uniform(0.1, 1.0) * np.eye(n)
        B1 = rng.normal(size=(n, 1))
        C = rng.normal(size=(1, n))
        Cz = np.vstack([C @ Ti, np.zeros((m, n))])
        Dz = np.zeros((1 + m, 1 + m))
        Dz[1:, 1:] = np.eye(m)
        vertices.append((T @ A @ Ti, T @ np.hstack([B1, B]), Cz, Dz))
    return lpv.pss(vertices)


def conic_size(name, n, N, m=2, nw=1, nz=3):
    """LMI count and size, and the PSD cones Clarabel sees."""
    _, hinf, scheduled = FUNCTIONS[name]
    count = N * (N + 1) // 2 if scheduled else N
    size = n + nw + nz if hinf else n
    svec = size * (size + 1) // 2
    wsvec = n * (n + 1) // 2
    return {
        "lmis": count,
        "lmi_size": size,
        "variables": wsvec + (N if scheduled else 1) * m * n + 1,
        "cone_rows": count * svec + wsvec,
        "nt_block_entries": count * svec**2 + wsvec**2,
    }


def run_case(spec):
    """One scaling case in this process; prints one JSON line.

    The library's warm re-solve (new data, same shapes) runs only when the
    cold call stayed within the cap.
    """
    name, n, N, what = spec["function"], spec["n"], spec["N"], spec["what"]
    function, hinf, scheduled = FUNCTIONS[name]
    sys = random_polytope(n, N, seed=1)
    u = [1, 2]
    kw = {"w": [0], "z": [0, 1, 2], "backoff": None} if hinf else {}
    result = {}
    if what == "library":
        result["cold"] = run_library(function, sys, True, u=u, **kw)
        if result["cold"]["total"] <= spec["cap"]:
            other = random_polytope(n, N, seed=2)  # same shapes, new data
            result["warm"] = run_library(function, other, False, u=u, **kw)
    else:
        start = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            # Same Clarabel settings as the library: like with like.
            problem, gamma = (plain_hinf if hinf else plain_stabilization)(
                channels(sys, [0], u, [0, 1, 2]),
                scheduled,
                chordal_decomposition_enable=False,
            )
        total = time.perf_counter() - start
        compiling = problem.compilation_time
        data = problem.get_problem_data("CLARABEL")[0]
        result["plain"] = {
            "total": total,
            "compile": compiling,
            "solve": problem.solver_stats.solve_time,
            "status": problem.status,
            "iterations": problem.solver_stats.num_iters,
            "gamma": gamma,
            "A_shape": list(data["A"].shape),
            "A_nnz": int(data["A"].nnz),
        }
    result["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps(result, default=float))


def spawn(spec, cap):
    """Run a case in a new process: cap per measured call, plus imports."""
    spec = {**spec, "cap": cap}
    cmd = [sys.executable, __file__, "--case", json.dumps(spec)]
    calls = 2 if spec["what"] == "library" else 1
    start = time.perf_counter()
    try:
        done = subprocess.run(
            cmd, capture_output=True, text=True, timeout=calls * cap + 30
        )
    except subprocess.TimeoutExpired:
        return {"skipped": f"over cap ({cap:g} s)"}
    wall = time.perf_counter() - start
    if done.returncode != 0:
        tail = (done.stderr.strip().splitlines() or ["?"])[-1]
        return {"skipped": f"failed: {tail[:80]}"}
    result = json.loads(done.stdout.strip().splitlines()[-1])
    result["process_wall"] = wall
    measured = result["cold" if spec["what"] == "library" else "plain"]["total"]
    if measured > cap:
        result["skipped"] = f"over cap ({measured:.0f} s > {cap:g} s)"
    return result


def part_c(quick, cap, functions):
    Ns = [2, 4, 8] if quick else [2, 4, 8, 16, 32, 64]
    ns = [4, 8] if quick else [4, 8, 12]
    print(
        f"\n(c) random polytopes, backoff=None, m = 2, one w, z = [Cx; u]; cap "
        f"{cap:g} s per call; times [s]; att = library attempts/SCS fallbacks, "
        f"it = plain Clarabel iterations (same settings as the library)\n"
        f"{'function':9s} {'n':>2s} {'N':>3s} {'LMIs':>5s} {'size':>4s} "
        f"{'vars':>5s} {'rows':>7s} {'NT blocks':>9s} | {'cold':>7s} {'build':>6s} "
        f"{'compile':>7s} {'solve':>7s} {'verify':>6s} {'att':>4s} {'warm':>7s} "
        f"{'RSS MB':>6s} | {'plain':>7s} {'p.comp':>7s} {'p.solve':>7s} {'it':>4s} "
        f"{'RSS MB':>6s} | {'cold/pl':>7s} {'warm/pl':>7s}"
    )
    out = []
    for name in functions:
        for n in ns:
            over = {"library": False, "plain": False}
            for N in Ns:
                row = {"function": name, "n": n, "N": N, **conic_size(name, n, N)}
                for what in ("library", "plain"):
                    if over[what]:
                        row[what] = {"skipped": "over cap at a smaller N"}
                        continue
                    row[what] = spawn(
                        {"function": name, "n": n, "N": N, "what": what}, cap
                    )
                    over[what] = "skipped" in row[what]
                out.append(row)
                print_row_c(row)
    return out


def print_row_c(r):
    def s(x):
        return "-" if x is None else f"{x:.2f}"

    lib, pl = r["library"], r["plain"]
    head = (
        f"{r['function']:9s} {r['n']:2d} {r['N']:3d} {r['lmis']:5d} "
        f"{r['lmi_size']:4d} {r['variables']:5d} {r['cone_rows']:7d} "
        f"{r['nt_block_entries']:9.2e} | "
    )
    if "cold" not in lib:
        left = f"{lib['skipped']:>58s}"
    else:
        c, warm = lib["cold"], lib.get("warm", {}).get("total")
        left = (
            f"{s(c['total']):>7s} {s(c['build']):>6s} {s(c['compile']):>7s} "
            f"{s(c['solve']):>7s} {s(c['verify']):>6s} {c['attempts']:2d}/"
            f"{c['fallbacks']:d} {s(warm):>7s} {lib['peak_rss_mb']:6.0f}"
        )
    if "plain" not in pl:
        right = f"{pl['skipped']:>35s}"
    else:
        p = pl["plain"]
        right = (
            f"{s(p['total']):>7s} {s(p['compile']):>7s} {s(p['solve']):>7s} "
            f"{p['iterations']:4d} {pl['peak_rss_mb']:6.0f}"
        )
    ratios = ""
    if "cold" in lib and "plain" in pl:
        ratios = f"{lib['cold']['total'] / pl['plain']['total']:7.2f} "
        if lib.get("warm"):
            ratios += f"{lib['warm']['total'] / pl['plain']['total']:7.2f}"
    notes = [x["skipped"] for x in (lib, pl) if "skipped" in x and len(x) > 1]
    print(head + left + " | " + right + " | " + ratios + " ".join(notes), flush=True)


# ----------------------------------------------------------------------
def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small grid, 2 repeats")
    parser.add_argument("--repeat", type=int, default=None, help="runs per median")
    parser.add_argument("--json", help="write all results to this JSON file")
    parser.add_argument("--cap", type=float, default=None, help="seconds per case")
    parser.add_argument("--parts", default="abc", help="any of a, b, c")
    parser.add_argument(
        "--functions",
        default="Theorem 2,Lemma 2,Theorem 1,Lemma 1",
        help="functions of part c, comma-separated (default all four)",
    )
    parser.add_argument("--case", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.case:
        run_case(json.loads(args.case))
        return
    repeat = args.repeat or (2 if args.quick else 7)
    cap = args.cap or (20.0 if args.quick else 60.0)
    results = {
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "cvxpy": cp.__version__,
            "clarabel": __import__("clarabel").__version__,
            "numpy": np.__version__,
            "repeat": repeat,
            "cap_seconds": cap,
        }
    }
    if "a" in args.parts:
        print_header_a()
        results["two_mass"] = part_a(repeat)
    if "b" in args.parts:
        results["resolve"] = part_b(repeat, args.quick)
    if "c" in args.parts:
        functions = [f.strip() for f in args.functions.split(",")]
        unknown = [f for f in functions if f not in FUNCTIONS]
        if unknown:
            parser.error(f"--functions: unknown {unknown}; use {list(FUNCTIONS)}")
        results["scaling"] = part_c(args.quick, cap, functions)
    if args.json:
        with open(args.json, "w") as handle:
            json.dump(results, handle, indent=2, default=float)


if __name__ == "__main__":
    main()
