"""Refusals of polytopes with no common Lyapunov matrix: class and time.

Random autonomous polytopes (issue 19): ``A0`` a random 2x2 or 3x3 matrix
(``3 N(0, 1)``) shifted so that its spectral abscissa is -0.2, vertices
``A0 + 0.25 N(0, 1)`` (2 or 3 of them, seeded), kept when every vertex is
Hurwitz. Each is
classified independently of ctrl_lpv:

* ``no CQLF``: an unstable convex combination of the vertices (a grid), or
  a dual certificate found with plain cvxpy (``Y_j >= 0``, ``sum tr Y_j =
  1``, ``sum_j A_j Y_j + Y_j A_j' >= t I``) whose ``t`` stays above the
  float64 rounding after projecting the ``Y_j`` on the PSD cone: then no
  ``P > 0`` has ``A_j' P + P A_j < 0`` for every ``j``;
* ``CQLF``: a plain cvxpy ``P`` whose float64 eigenvalues show a common
  Lyapunov matrix with a clear margin;
* ``undecided`` otherwise.

Then the library is called (``quadratic_stability``, and
``quadratic_stabilization`` / ``gain_scheduled_stabilization`` with a zero
input matrix, so that no gain can help) and the outcome class and wall time
are recorded. Run it once with the code to measure on ``PYTHONPATH``::

    OMP_NUM_THREADS=1 PYTHONPATH=src python benchmarks/study_true_refusals.py \
        --cases 30 --json out.json
"""

from __future__ import annotations

import argparse
import json
import time
import warnings

import cvxpy as cp
import numpy as np

import ctrl_lpv as lpv

SCALE = 3.0
SHIFT = 0.2
SPREAD = 0.25


def polytope(seed: int):
    """Vertex matrices of case `seed`, or None if a vertex is not Hurwitz."""
    rng = np.random.default_rng([2019, seed])
    nvert = 2 + seed % 2
    n = 2 + (seed // 2) % 2
    A0 = SCALE * rng.normal(size=(n, n))
    A0 -= (np.linalg.eigvals(A0).real.max() + SHIFT) * np.eye(n)
    As = [A0 + SPREAD * rng.normal(size=A0.shape) for _ in range(nvert)]
    if max(np.linalg.eigvals(A).real.max() for A in As) >= 0:
        return None
    return As


def unstable_combination(As, count=4000) -> bool:
    rng = np.random.default_rng(0)
    weights = rng.dirichlet(np.ones(len(As)), count)
    if len(As) == 2:
        t = np.linspace(0, 1, count)
        weights = np.column_stack([1 - t, t])
    return any(
        np.linalg.eigvals(sum(w * A for w, A in zip(ws, As))).real.max() > 0
        for ws in weights
    )


def dual_proof(As) -> float:
    """Least eigenvalue of ``sum A_j Y_j + Y_j A_j'`` less its rounding bound,
    for PSD ``Y_j`` of total trace one found by cvxpy (> 0: no CQLF)."""
    n = As[0].shape[0]
    Ys = [cp.Variable((n, n), symmetric=True) for _ in As]
    t = cp.Variable()
    S = sum(A @ Y + Y @ A.T for A, Y in zip(As, Ys))
    cons = [Y >> 0 for Y in Ys] + [sum(cp.trace(Y) for Y in Ys) == 1]
    cons += [0.5 * (S + S.T) >> t * np.eye(n)]
    try:
        cp.Problem(cp.Maximize(t), cons).solve(solver="SCS", eps=1e-9)
    except cp.error.SolverError:
        return -np.inf
    if Ys[0].value is None:
        return -np.inf
    Yp = []
    for Y in Ys:
        lam, V = np.linalg.eigh(0.5 * (Y.value + Y.value.T))
        Yp.append((V * np.clip(lam, 0, None)) @ V.T)
    total = sum(np.trace(Y) for Y in Yp)
    Yp = [Y / total for Y in Yp]
    Sv = sum(A @ Y + Y @ A.T for A, Y in zip(As, Yp))
    # |rounding| of S, of the projection and of eigvalsh: generous bound.
    err = (
        1e3
        * n
        * np.finfo(float).eps
        * sum(np.abs(A).sum() * np.abs(Y).sum() + 1 for A, Y in zip(As, Yp))
    )
    return float(np.linalg.eigvalsh(0.5 * (Sv + Sv.T))[0] - err)


def primal_proof(As) -> float:
    """Margin of a cvxpy common Lyapunov matrix (> 0: a CQLF exists)."""
    n = As[0].shape[0]
    P = cp.Variable((n, n), symmetric=True)
    t = cp.Variable()
    cons = [P >> t * np.eye(n), P << np.eye(n)]
    cons += [A.T @ P + P @ A << -t * np.eye(n) for A in As]
    try:
        cp.Problem(cp.Maximize(t), cons).solve(solver="CLARABEL")
    except cp.error.SolverError:
        return -np.inf
    if P.value is None:
        return -np.inf
    Pv = 0.5 * (P.value + P.value.T)
    worst = max(np.linalg.eigvalsh(A.T @ Pv + Pv @ A)[-1] for A in As)
    return float(min(np.linalg.eigvalsh(Pv)[0], -worst))


def truth(As) -> str:
    if unstable_combination(As):
        return "no CQLF (unstable combination)"
    if dual_proof(As) > 1e-9:
        return "no CQLF (dual)"
    if primal_proof(As) > 1e-8:
        return "CQLF"
    return "undecided"


CALLS = {
    "quadratic_stability": lambda s: lpv.quadratic_stability(s),
    "quadratic_stabilization": lambda s: lpv.quadratic_stabilization(s, u=[0]),
    "gain_scheduled_stabilization": lambda s: lpv.gain_scheduled_stabilization(
        s, u=[0]
    ),
}


def run(As, call):
    n = As[0].shape[0]
    sys = lpv.PolytopicStateSpace(
        [(A, np.zeros((n, 1)), np.eye(n), np.zeros((n, 1))) for A in As]
    )
    start = time.perf_counter()
    try:
        call(sys)
        outcome = "design"
    except lpv.SynthesisError as exc:
        outcome = type(exc).__name__
    return outcome, time.perf_counter() - start


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--cases", type=int, default=30)
    parser.add_argument("--feasible", type=int, default=10)
    parser.add_argument("--json")
    args = parser.parse_args()
    warnings.simplefilter("ignore")  # cvxpy's "may be inaccurate": judged here
    rows, seed, counts = [], 0, {"no": 0, "yes": 0}
    while counts["no"] < args.cases or counts["yes"] < args.feasible:
        As = polytope(seed)
        seed += 1
        if As is None:
            continue
        fact = truth(As)
        kind = "no" if fact.startswith("no") else "yes" if fact == "CQLF" else None
        if kind is None or counts[kind] >= (
            args.cases if kind == "no" else args.feasible
        ):
            continue
        counts[kind] += 1
        row = {"seed": seed - 1, "vertices": len(As), "truth": fact}
        for name, call in CALLS.items():
            row[name] = run(As, call)
        rows.append(row)
        print(json.dumps(row), flush=True)
    for name in CALLS:
        for kind in ("no", "yes"):
            sel = [r for r in rows if r["truth"].startswith("no") == (kind == "no")]
            times = [r[name][1] for r in sel]
            classes = {}
            for r in sel:
                classes[r[name][0]] = classes.get(r[name][0], 0) + 1
            print(
                f"{name:30s} {'no CQLF' if kind == 'no' else 'CQLF':8s} "
                f"n={len(sel):3d} median {np.median(times):6.2f} s "
                f"max {np.max(times):6.2f} s {classes}"
            )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
