"""Old LMI layer (cvxpy/DPP) against the new one (direct conic data) on a fuzz corpus.

Issue 20's gate: before an old path goes, the old and the new code run the
same public calls on the same problems and must give the same verdicts and
bounds within solver tolerance. Two worker processes, one per source tree
(``PYTHONPATH=<tree>/src``), are fed the cases alternately (interleaved, so
that a change of the machine's load falls on both), each case from a cold
problem cache. Per case the table gives the verdict (design returned /
``InfeasibleError`` / ``CertificationError`` / time limit / other error),
the relative differences of ``gamma_opt``, ``gamma`` and every other
returned bound (``beta``, ``rho``, the spec bounds), of the gain norms, the
certificate of both, the number of solver attempts and the wall and CPU
time of the call (one BLAS thread).

The corpus (`corpus`) is generated in the workers from seeds, with numpy
only, so both see the same data:

* ``poly``: random polytopes stabilizable by construction (the generator of
  ``bench_synthesis.random_polytope``, which also gives a common
  stabilizing gain ``K0`` for the analysis calls), n = 2..6, N = 2..8, some
  with an ill-conditioned state basis; every synthesis and analysis call
  on each (`CALLS`), the discrete-time ones on ``sys.sample(dt)``;
* ``box``: systems affine in one or two box parameters, for
  ``lyapunov="affine"`` with rate bounds;
* ``trust``: problems of ``tests/_independent.generate_case`` (badly
  scaled, ill-conditioned, near-uncontrollable and unstabilizable
  vertices, pole regions, gain bounds, given gammas): refusals as well;
* ``twomass``: the two-mass designs, whose Lemma 2 optimum must agree
  (0.0170151 in both trees; the 0.017027 of the issue and of
  ``results/synthesis.json`` is the value before commit c18c4af, which
  changed the general engine's prescaling ladder; the design at 0.0170151
  passes the independent check of ``tests/_independent.check_design``).

Usage::

    OMP_NUM_THREADS=1 python benchmarks/compare_backends.py \\
        --old /path/to/old/tree --new /path/to/new/tree [--quick] \\
        [--only REGEX] [--json PATH]

Without ``--new`` the tree of this script is the new one. Flags per case:
``V`` verdicts differ, ``B`` a bound differs by more than ``--rtol``
(default 1e-4) relative.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
TREE = HERE.parent
TIME_LIMIT = 120.0  # per call, seconds (the library's own budget)


# ======================================================================
# Corpus (specs only: plain JSON, built into systems in the workers)
# ======================================================================
# name -> (system kind, function) ; see `_call`.
CALLS = {
    "quadratic_stabilization": "ct",
    "hinf_state_feedback": "ct",
    "hinf_state_feedback/backoff=None": "ct",
    "gain_scheduled_stabilization": "ct",
    "gain_scheduled_hinf/backoff=None": "ct",
    "gain_scheduled_hinf": "ct",
    "h2_state_feedback": "ct",
    "synthesize/H2": "ct",
    "synthesize/Hinf/scheduled": "ct",
    "synthesize/Peak": "ct",
    "synthesize/Hinf+halfplane": "ct",
    "synthesize/disk": "ct",
    "synthesize/H2+GainBound": "ct",
    "quadratic_stability": "ct",
    "l2_gain_bound": "ct",
    "h2_bound": "ct",
    "saturated_state_feedback": "ct",
    "saturation_region": "ct",
    "ultimate_bound": "ct",
    "dt/quadratic_stabilization": "dt",
    "dt/hinf_state_feedback/backoff=None": "dt",
    "dt/synthesize/H2": "dt",
    "dt/gain_scheduled_hinf": "dt",
}
BOX_CALLS = (
    "affine/synthesize/Hinf/scheduled",
    "affine/synthesize/H2",
    "affine/quadratic_stability",
    "affine/l2_gain_bound",
)
TWOMASS_CALLS = (
    "twomass/Lemma 2",
    "twomass/Lemma 2/backoff=None",
    "twomass/Theorem 2/backoff=None",
)


def corpus(quick: bool = False) -> list[dict]:
    """The cases, in order: dicts of JSON values."""
    polys = [  # (seed, n, N, m, condition exponent of the state basis or 0)
        (1, 2, 2, 1, 0),
        (2, 3, 4, 2, 0),
        (3, 4, 3, 2, 0),
        (4, 5, 6, 2, 0),
        (5, 6, 8, 2, 0),
        (6, 3, 8, 1, 0),
        (7, 4, 5, 2, 3.5),
        (8, 3, 2, 2, 5.0),
    ]
    boxes = [(11, 3, 1), (12, 4, 2), (13, 2, 2)]
    trust = [(2027, i) for i in range(12)]
    if quick:
        polys, boxes, trust = polys[:2], boxes[:1], trust[:3]
    cases = []
    for seed, n, N, m, cond in polys:
        for call in CALLS:
            cases.append(
                {"kind": "poly", "seed": seed, "n": n, "N": N, "m": m,
                 "cond": cond, "call": call}
            )  # fmt: skip
    for seed, n, k in boxes:
        for call in BOX_CALLS:
            cases.append({"kind": "box", "seed": seed, "n": n, "k": k, "call": call})
    for seed, index in trust:
        cases.append({"kind": "trust", "seed": seed, "index": index, "call": "case"})
    for call in TWOMASS_CALLS if not quick else TWOMASS_CALLS[:1]:
        cases.append({"kind": "twomass", "call": call})
    for case in cases:
        case["id"] = case_id(case)
    return cases


def case_id(case: dict) -> str:
    if case["kind"] == "poly":
        c = f",c1e{case['cond']:g}" if case["cond"] else ""
        return (
            f"poly{case['seed']}(n{case['n']},N{case['N']},m{case['m']}{c}) "
            f"{case['call']}"
        )
    if case["kind"] == "box":
        return f"box{case['seed']}(n{case['n']},k{case['k']}) {case['call']}"
    if case["kind"] == "trust":
        return f"trust{case['seed']}:{case['index']}"
    return case["call"]


# ======================================================================
# Worker: builds the systems and runs the calls with the tree on its path
# ======================================================================
def _polytope(seed, n, N, m, cond):
    """``bench_synthesis.random_polytope``, and its stabilizing gain.

    ``A_j - B_j K0 = skew - c_j I`` in the construction's basis, so ``K0
    T^-1`` stabilizes every vertex with the common ``P = T^-T T^-1``.
    `cond` > 0 replaces the well-conditioned basis by one of condition
    number ``10^cond``.
    """
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(m, n))
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    T = Q @ np.diag(rng.uniform(0.5, 2.0, size=n))
    if cond:
        Q2, _ = np.linalg.qr(rng.normal(size=(n, n)))
        T = Q @ np.diag(np.logspace(0, -cond, n)) @ Q2
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
    return vertices, K0 @ Ti


def _box(seed, n, k):
    """``M(p) = M0 + sum_i p_i M_i`` with ``A(p) - B(p) K0`` = skew - I."""
    rng = np.random.default_rng(seed)
    K0 = rng.normal(size=(1, n))

    def term(base):
        B = rng.normal(size=(n, 1))
        S = rng.normal(size=(n, n))
        A = B @ K0 + (S - S.T) - (1.0 if base else 0.0) * np.eye(n)
        Bw = rng.normal(size=(n, 1)) if base else np.zeros((n, 1))
        C = np.vstack([rng.normal(size=(1, n)), np.zeros((1, n))]) if base else 0
        D = np.array([[0.0, 0.0], [0.0, 1.0]]) if base else 0
        return (A, np.hstack([Bw, B]), C, D)

    base = term(True)
    terms = {f"p{i}": term(False) for i in range(k)}
    bounds = {f"p{i}": (-0.5, 0.5) for i in range(k)}
    rates = {f"p{i}": 0.5 * i for i in range(k)}  # p0 time-invariant
    return base, terms, bounds, rates, K0


def _closed_loop(lpv, vertices, K, m, dt=None):
    loops = [
        (A - B[:, 1:] @ K, B[:, :1], C - D[:, 1:] @ K, D[:, :1])
        for A, B, C, D in vertices
    ]
    kw = {} if dt is None else {"dt": dt}
    return lpv.pss(loops, inputs=["w0"], outputs=_zs(m), **kw)


def _zs(m):
    return ["z0"] + [f"z{i + 1}" for i in range(m)]


def _us(m):
    return [f"u{i}" for i in range(m)]


def _call(lpv, case):
    """The library call of `case`, ready to run (a thunk)."""
    kind, call = case["kind"], case["call"]
    if kind == "twomass":
        from ctrl_lpv import twomass

        if call == "twomass/Lemma 2":
            return lambda: twomass.design(time_limit=TIME_LIMIT)
        if call == "twomass/Lemma 2/backoff=None":
            return lambda: twomass.design(backoff=None, time_limit=TIME_LIMIT)
        return lambda: twomass.design(
            scheduled=True, backoff=None, time_limit=TIME_LIMIT
        )
    if kind == "trust":
        sys.path.insert(0, str(TREE / "tests"))
        from _independent import generate_case

        trust = generate_case(case["seed"], case["index"], small=True)
        case["label"] = trust.describe()
        return lambda: trust.call(lpv)
    if kind == "box":
        return _box_call(lpv, case)
    vertices, K = _polytope(case["seed"], case["n"], case["N"], case["m"], case["cond"])
    m = case["m"]
    u, w, z = _us(m), "w0", _zs(m)
    sys_ = lpv.pss(vertices, inputs=["w0"] + u, outputs=z)
    t = {"time_limit": TIME_LIMIT}
    if call.startswith("dt/"):
        sys_ = sys_.sample(0.05)
        call = call[3:]
    scale = max(np.linalg.norm(A, 2) for A, *_ in vertices)
    calls = {
        "quadratic_stabilization": lambda: lpv.quadratic_stabilization(sys_, u, **t),
        "hinf_state_feedback": lambda: lpv.hinf_state_feedback(sys_, w, u, z, **t),
        "hinf_state_feedback/backoff=None": lambda: lpv.hinf_state_feedback(
            sys_, w, u, z, backoff=None, **t
        ),
        "gain_scheduled_stabilization": lambda: lpv.gain_scheduled_stabilization(
            sys_, u, **t
        ),
        "gain_scheduled_hinf": lambda: lpv.gain_scheduled_hinf(sys_, w, u, z, **t),
        "gain_scheduled_hinf/backoff=None": lambda: lpv.gain_scheduled_hinf(
            sys_, w, u, z, backoff=None, **t
        ),
        "h2_state_feedback": lambda: lpv.h2_state_feedback(sys_, w, u, z, **t),
        "synthesize/H2": lambda: lpv.synthesize(sys_, u, objective=lpv.H2(w, z), **t),
        "synthesize/Hinf/scheduled": lambda: lpv.synthesize(
            sys_, u, objective=lpv.Hinf(w, z), gains="scheduled", **t
        ),
        "synthesize/Peak": lambda: lpv.synthesize(
            sys_, u, objective=lpv.Peak(w, z), **t
        ),
        "synthesize/Hinf+halfplane": lambda: lpv.synthesize(
            sys_, u, objective=lpv.Hinf(w, z), constraints=[lpv.halfplane(0.3)], **t
        ),
        "synthesize/disk": lambda: lpv.synthesize(
            sys_, u, constraints=[lpv.disk(3 * scale, -3 * scale)], **t
        ),
        "synthesize/H2+GainBound": lambda: lpv.synthesize(
            sys_,
            u,
            objective=lpv.H2(w, z),
            constraints=[lpv.GainBound(1.5 * np.linalg.norm(K, 2))],
            **t,
        ),  # fmt: skip
        "quadratic_stability": lambda: lpv.quadratic_stability(
            _closed_loop(lpv, vertices, K, m), **t
        ),
        "l2_gain_bound": lambda: lpv.l2_gain_bound(sys_, K, w, u, z, **t),
        "h2_bound": lambda: lpv.h2_bound(sys_, K, w, u, z, **t),
        "saturated_state_feedback": lambda: lpv.saturated_state_feedback(
            sys_, u, 1.0, **t
        ),
        "saturation_region": lambda: lpv.saturation_region(sys_, K, u, 1.0, **t),
        "ultimate_bound": lambda: lpv.ultimate_bound(
            _closed_loop(lpv, vertices, K, m),
            "w0",
            1.0,
            output=np.eye(case["n"]),
            **t,
        ),  # fmt: skip
    }
    return calls[call]


def _box_call(lpv, case):
    base, terms, bounds, rates, K = _box(case["seed"], case["n"], case["k"])
    sys_ = lpv.PolytopicStateSpace.from_affine(
        base, terms, bounds, inputs=["w0", "u0"], outputs=["z0", "z1"]
    )
    t = {"time_limit": TIME_LIMIT, "lyapunov": "affine", "rate_bounds": rates}
    call = case["call"]
    if call == "affine/synthesize/Hinf/scheduled":
        return lambda: lpv.synthesize(
            sys_, "u0", objective=lpv.Hinf("w0"), gains="scheduled", **t
        )
    if call == "affine/synthesize/H2":
        return lambda: lpv.synthesize(sys_, "u0", objective=lpv.H2("w0"), **t)
    if call == "affine/l2_gain_bound":
        return lambda: lpv.l2_gain_bound(sys_, K, "w0", "u0", ["z0", "z1"], **t)
    loop = lpv.PolytopicStateSpace.from_affine(
        (base[0] - base[1][:, 1:] @ K, base[1][:, :1], base[2], base[3][:, :1]),
        {k: (v[0] - v[1][:, 1:] @ K, v[1][:, :1], 0, 0) for k, v in terms.items()},
        bounds,
    )
    return lambda: lpv.quadratic_stability(loop, **t)


def _finite(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _summarize(result) -> dict:
    """What the comparison reads off a returned result (JSON values)."""
    out: dict = {"bounds": {}}
    for name in ("gamma", "gamma_opt", "beta", "beta_opt", "rho"):
        value = getattr(result, name, None)
        if isinstance(value, (int, float, np.floating)):
            out["bounds"][name] = _finite(value)
    bounds = getattr(result, "bounds", None)
    if isinstance(bounds, dict):  # a design's bound per spec
        for spec, value in bounds.items():
            out["bounds"][f"spec {spec!r}"] = _finite(value)
    elif bounds is not None:  # an ultimate bound per output
        for i, value in enumerate(np.atleast_1d(np.asarray(bounds, float))):
            out["bounds"][f"bound[{i}]"] = _finite(value)
    gains = getattr(result, "gains", None)
    if gains is not None:
        if isinstance(gains, np.ndarray) and gains.ndim == 2:
            gains = [gains]
        out["gain_norms"] = [float(np.linalg.norm(np.asarray(K), 2)) for K in gains]
    certificate = getattr(result, "certificate", None)
    if certificate is not None and hasattr(certificate, "verified"):
        out["verified"] = bool(certificate.verified)
    elif getattr(result, "checks", None) is not None:
        out["verified"] = all(c.passed for c in result.checks)
    return out


def _count_attempts(log):
    """Record every solver attempt of `LMIProblem` (old and new trees)."""
    from ctrl_lpv.lmi import LMIProblem

    original = LMIProblem._attempt

    def attempt(self, *args, **kwargs):
        out = original(self, *args, **kwargs)
        stage = next((a for a in args if isinstance(a, str)), "?")
        a = out[0]
        log.append([stage, a.solver, a.status, bool(a.certified), a.message])
        return out

    LMIProblem._attempt = attempt


def worker() -> None:
    """Read case specs (JSON lines) from stdin, answer JSON lines."""
    import warnings

    warnings.simplefilter("ignore")
    import ctrl_lpv as lpv

    log: list = []
    _count_attempts(log)
    cache = getattr(lpv, "synthesis_cache", None)
    # Warm up imports and solvers outside the measured calls.
    lpv.quadratic_stabilization(
        lpv.pss(_polytope(0, 2, 2, 1, 0)[0], inputs=["w0", "u0"]), "u0"
    )
    print(json.dumps({"ready": str(Path(lpv.__file__).parent)}), flush=True)
    for line in sys.stdin:
        case = json.loads(line)
        out = {"id": case["id"]}
        try:
            thunk = _call(lpv, case)
        except Exception as exc:  # noqa: BLE001 - reported, not hidden
            out.update(verdict=f"setup {type(exc).__name__}", message=str(exc)[:300])
            print(json.dumps(out), flush=True)
            continue
        if cache is not None:
            cache.clear()
        log.clear()
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            result = thunk()
            out["verdict"] = "design"
            out.update(_summarize(result))
        except Exception as exc:  # noqa: BLE001 - the verdict
            name = type(exc).__name__
            message = str(exc)
            if name == "TimeLimitReached" or message.startswith("time_limit"):
                name = "TimeLimit"
            out["verdict"] = name
            out["message"] = message.splitlines()[0][:300] if message else ""
        out["wall"] = time.perf_counter() - wall
        out["cpu"] = time.process_time() - cpu
        out["attempts"] = list(log)
        out["label"] = case.get("label")
        print(json.dumps(out), flush=True)


# ======================================================================
# Comparison
# ======================================================================
def _start(tree: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(tree / "src"), "OMP_NUM_THREADS": "1"}
    env.update(OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
    proc = subprocess.Popen(
        [sys.executable, str(Path(__file__).resolve()), "--worker"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        cwd=str(tree),
    )
    ready = json.loads(proc.stdout.readline())
    expected = (tree / "src" / "ctrl_lpv").resolve()
    if Path(ready["ready"]).resolve() != expected:
        raise RuntimeError(f"worker imported {ready['ready']}, not {expected}")
    return proc


def _ask(proc, case) -> dict:
    proc.stdin.write(json.dumps(case) + "\n")
    proc.stdin.flush()
    line = proc.stdout.readline()
    if not line:
        raise RuntimeError(f"worker died on {case['id']}")
    return json.loads(line)


def rel(a, b) -> float | None:
    if a is None or b is None:
        return None if a is None and b is None else math.inf
    return abs(a - b) / max(abs(a), abs(b), 1e-300)


def compare(old: dict, new: dict, rtol: float) -> dict:
    """Per-case differences and flags."""
    row = {
        "id": old["id"],
        "old": old["verdict"],
        "new": new["verdict"],
        "same_verdict": old["verdict"] == new["verdict"],
    }
    diffs = {}
    ob, nb = old.get("bounds", {}), new.get("bounds", {})
    for key in sorted(set(ob) | set(nb)):
        diffs[key] = rel(ob.get(key), nb.get(key))
    row["bound_diffs"] = diffs
    finite = [d for d in diffs.values() if d is not None]
    row["max_bound_diff"] = max(finite) if finite else None
    og, ng = old.get("gain_norms"), new.get("gain_norms")
    if og and ng and len(og) == len(ng):
        row["gain_diff"] = max(rel(a, b) for a, b in zip(og, ng))
    else:
        row["gain_diff"] = None
    row["verified"] = (old.get("verified"), new.get("verified"))
    row["attempts"] = (len(old.get("attempts", [])), len(new.get("attempts", [])))
    row["wall"] = (old.get("wall"), new.get("wall"))
    row["cpu"] = (old.get("cpu"), new.get("cpu"))
    flags = ""
    if not row["same_verdict"]:
        flags += "V"
    if row["max_bound_diff"] is not None and row["max_bound_diff"] > rtol:
        flags += "B"
    row["flags"] = flags
    return row


def _fmt(x, spec=".1e"):
    if x is None:
        return "-"
    if x == math.inf:
        return "inf"
    return format(x, spec)


def _short(verdict):
    return {
        "design": "design",
        "InfeasibleError": "Infeas",
        "CertificationError": "CertErr",
        "TimeLimit": "time",
    }.get(verdict, verdict[:10])


def table(rows) -> str:
    head = (
        f"{'case':58s} {'old':>7s} {'new':>7s} {'gamma':>8s} {'g_opt':>8s} "
        f"{'other':>8s} {'|K|':>8s} {'cert':>5s} {'att':>5s} {'wall o/n':>12s} "
        f"{'cpu n/o':>7s} fl"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        d = r["bound_diffs"]
        other = [v for k, v in d.items() if k not in ("gamma", "gamma_opt")]
        other = max((v for v in other if v is not None), default=None)
        cert = "".join("-" if v is None else ("y" if v else "n") for v in r["verified"])
        wo, wn = r["wall"]
        co, cn = r["cpu"]
        ratio = cn / co if co and cn is not None else None
        lines.append(
            f"{r['id'][:58]:58s} {_short(r['old']):>7s} {_short(r['new']):>7s} "
            f"{_fmt(d.get('gamma')):>8s} {_fmt(d.get('gamma_opt')):>8s} "
            f"{_fmt(other):>8s} {_fmt(r['gain_diff']):>8s} {cert:>5s} "
            f"{r['attempts'][0]:>2d}/{r['attempts'][1]:<2d} "
            f"{_fmt(wo, '5.2f'):>5s}/{_fmt(wn, '5.2f'):<6s} "
            f"{_fmt(ratio, '7.2f'):>7s} {r['flags']}"
        )
    return "\n".join(lines)


def _twomass(raw) -> str:
    """The two-mass Lemma 2 optimum of both trees (issue: 0.017027)."""
    out = []
    for r in raw:
        if r["case"]["kind"] == "twomass":
            values = [
                f"{side} gamma {_fmt(r[side].get('bounds', {}).get('gamma'), '.6f')}"
                f" gamma_opt {_fmt(r[side].get('bounds', {}).get('gamma_opt'), '.6f')}"
                for side in ("old", "new")
            ]
            out.append(f"  {r['case']['call']}: " + "; ".join(values))
    return "two-mass (Lemma 2 optimum):\n" + "\n".join(out) if out else ""


def summary(rows, rtol, raw=()) -> str:
    same = sum(r["same_verdict"] for r in rows)
    both = [r for r in rows if r["old"] == r["new"] == "design"]
    finite = [
        r["max_bound_diff"]
        for r in both
        if r["max_bound_diff"] is not None and math.isfinite(r["max_bound_diff"])
    ]
    wall_o = sum(r["wall"][0] or 0 for r in rows)
    wall_n = sum(r["wall"][1] or 0 for r in rows)
    cpu_o = sum(r["cpu"][0] or 0 for r in rows)
    cpu_n = sum(r["cpu"][1] or 0 for r in rows)
    ratios = [r["cpu"][1] / r["cpu"][0] for r in rows if r["cpu"][0] and r["cpu"][1]]
    att_o = sum(r["attempts"][0] for r in rows)
    att_n = sum(r["attempts"][1] for r in rows)
    verdicts: dict = {}
    for r in rows:
        verdicts[r["old"]] = verdicts.get(r["old"], 0) + 1
    flagged = [r for r in rows if r["flags"]]
    lines = [_twomass(raw)] if raw else []
    lines += [
        f"cases: {len(rows)} (old verdicts: "
        + ", ".join(f"{k} {v}" for k, v in sorted(verdicts.items()))
        + ")",
        f"same verdict: {same}/{len(rows)}",
        f"both designs: {len(both)}; max rel diff of the bounds over them: "
        f"{_fmt(max(finite, default=None), '.2e')} (median "
        f"{_fmt(float(np.median(finite)) if finite else None, '.1e')}); "
        f"above {rtol:g}: {sum(d > rtol for d in finite)}",
        f"certificates verified: old {sum(bool(r['verified'][0]) for r in rows)}, "
        f"new {sum(bool(r['verified'][1]) for r in rows)}",
        f"solver attempts: old {att_o}, new {att_n}",
        f"time: wall old {wall_o:.1f} s, new {wall_n:.1f} s; CPU old {cpu_o:.1f} s, "
        f"new {cpu_n:.1f} s (new/old total {cpu_n / max(cpu_o, 1e-9):.2f}, "
        f"median per case {_fmt(float(np.median(ratios)) if ratios else None, '.2f')})",
        f"flagged (V verdict, B bound > {rtol:g}): {len(flagged)}",
    ]
    for r in flagged:
        big = {k: v for k, v in r["bound_diffs"].items() if v is not None and v > rtol}
        lines.append(
            f"  [{r['flags']}] {r['id']}: {r['old']} -> {r['new']}"
            + (
                f"; {', '.join(f'{k} {_fmt(v)}' for k, v in big.items())}"
                if big
                else ""
            )
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--old", type=Path, help="tree of the old code (has src/)")
    parser.add_argument("--new", type=Path, default=TREE, help="tree of the new code")
    parser.add_argument("--quick", action="store_true", help="a few cases only")
    parser.add_argument("--only", help="regular expression on the case ids")
    parser.add_argument("--rtol", type=float, default=1e-4)
    parser.add_argument("--json", type=Path, help="write every result here")
    args = parser.parse_args(argv)
    if args.worker:
        worker()
        return 0
    if args.old is None:
        parser.error("--old: the tree of the old code is required")
    cases = corpus(args.quick)
    if args.only:
        cases = [c for c in cases if re.search(args.only, c["id"])]
    old, new = _start(args.old.resolve()), _start(args.new.resolve())
    rows, raw = [], []
    try:
        for i, case in enumerate(cases):
            # Alternate which tree goes first: neither gets the cooler machine.
            first, second = (old, new) if i % 2 == 0 else (new, old)
            a, b = _ask(first, case), _ask(second, case)
            o, n = (a, b) if i % 2 == 0 else (b, a)
            rows.append(compare(o, n, args.rtol))
            raw.append({"case": case, "old": o, "new": n})
            r = rows[-1]
            print(
                f"[{i + 1}/{len(cases)}] {r['id']}: {o['verdict']} / {n['verdict']} "
                f"{r['flags']}",
                file=sys.stderr,
                flush=True,
            )
    finally:
        for proc in (old, new):
            proc.stdin.close()
            proc.wait(timeout=60)
        if args.json:
            args.json.write_text(json.dumps({"rows": rows, "raw": raw}, indent=1))
    print(table(rows))
    print()
    print(summary(rows, args.rtol, raw))
    return 0


if __name__ == "__main__":
    sys.exit(main())
