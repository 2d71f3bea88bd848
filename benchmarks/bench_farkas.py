"""Farkas certificates: time of `LMIProblem.farkas`, before and after.

The dual points are those of real infeasible solves: a synthesis call is run
once with `LMIProblem._best_farkas` replaced by a recorder, which keeps every
``(problem, dual point, stage)`` that the library would have judged. Each is
then judged twice, side by side in this process:

* ``reference``: the implementation of commit f3d83fd (Python loops: one
  eigendecomposition per LMI and round, one sparse product per LMI, a least
  squares solve on the Gram matrix per round), copied below verbatim;
* ``library``: `ctrl_lpv.lmi.LMIProblem.farkas` as installed, first with
  its cache of the affine map's columns emptied (what the first judgement of
  a stage costs), then with the columns kept (a later rung of the ladder on
  the same data: another margin or normalisation).

Both certificates are printed (offset, slope, radius, normalisation flag);
they must agree on what they prove, not to the last digit: the vectorised
version sums in another order and adds the worst-case bounds of its own sums
(see `ctrl_lpv._farkas.AffineMap.bound`), and it drops the normalisations'
rows in its normalisation-free variant where the reference only zeroed their
starting duals.

Cases: random stabilizable polytopes of ``benchmarks/bench_synthesis.py``
(m = 2), an 8-vertex n = 4 Theorem 1 problem with ``halfplane(1e4)`` (its
normalised stage is infeasible), and an 8-vertex Theorem 2 problem with an
impossible ``gamma``.

Usage::

    python benchmarks/bench_farkas.py [--repeat N] [--json PATH] [--no-reference]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import ctrl_lpv as lpv
from ctrl_lpv import lmi as L
from ctrl_lpv.lmi import (
    FarkasCertificate,
    _is_symmetric,
    _stronger,
    _unit_points,
    assemble,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_synthesis import random_polytope  # noqa: E402


# ----------------------------------------------------------------------
# The reference: LMIProblem.farkas and _affine_map of commit f3d83fd
# ----------------------------------------------------------------------
def _psd_part(Y):
    lam, V = np.linalg.eigh(Y)
    return (V * np.clip(lam, 0.0, None)) @ V.T


def reference_farkas(self, duals, stage="default"):
    """Verify a dual certificate of infeasibility in float64.

    Parameters
    ----------
    duals : sequence of ndarray
        One symmetric matrix per active inequality of `stage`, in the
        order they were added (e.g. cvxpy's dual values after an
        infeasible solve). Each is projected on the PSD cone, then the
        certificate is evaluated as described in `FarkasCertificate`;
        both signs are tried.
    stage : str, optional
        Stage name.

    Returns
    -------
    `FarkasCertificate` or None
        None if neither sign gives a positive offset.
    """
    active = self._active(stage)
    if len(duals) != len(active):
        raise ValueError(f"duals: expected {len(active)} matrices, got {len(duals)}")
    base, M = reference_affine_map(self, active)
    gram = sum((m.T @ m).toarray() for m in M)
    eps = np.finfo(float).eps
    best = None
    # Both signs (conventions differ), and without the duals of the
    # normalisations: a certificate that does not need them refutes the
    # LMIs themselves (for homogeneous strict LMIs the normalisations
    # are often what makes the solver's problem infeasible).
    symmetric = [0.5 * (np.asarray(d, float) + np.asarray(d, float).T) for d in duals]
    normalizing = [name in self._normalizations for name, *_ in active]
    variants = [
        (keep, [sign * y if keep or not nz else 0 * y
                for y, nz in zip(symmetric, normalizing)])
        for sign in (1.0, -1.0)
        for keep in (True, False)
    ]  # fmt: skip
    for keep, Y in variants:
        used = keep and any(nz and np.any(y) for y, nz in zip(symmetric, normalizing))
        slope_before = np.inf
        for _ in range(200):
            Y = [_psd_part(y) for y in Y]
            total = sum(np.trace(y) for y in Y)
            if not total > 0:
                break
            Y = [y / total for y in Y]
            # The smallest change of Y that zeroes the slope g; the
            # projections converge linearly, so stop when they stall.
            g = sum(m.T @ y.ravel() for m, y in zip(M, Y))
            slope = float(np.linalg.norm(g))
            if slope > 0.999 * slope_before or slope < 1e3 * eps:
                break
            slope_before = slope
            c = np.linalg.lstsq(gram, g, rcond=None)[0]
            Y = [y - (m @ c).reshape(y.shape) for m, y in zip(M, Y)]
            Y = [0.5 * (y + y.T) for y in Y]
        Y = [_psd_part(y) for y in Y]
        total = sum(np.trace(y) for y in Y)
        if not total > 0:
            continue
        Y = [y / total for y in Y]
        b, b_err = 0.0, 0.0
        g = np.zeros(gram.shape[0])
        g_err = 0.0
        for F0, m_i, y in zip(base, M, Y):
            scale = 10 * F0.shape[0] * eps * np.abs(y).max()
            b += float(np.sum(F0 * y))
            b_err += scale * np.abs(F0).sum()
            g += m_i.T @ y.ravel()
            g_err += scale * abs(m_i).sum()
        slope = float(np.linalg.norm(g)) + g_err
        proof = FarkasCertificate(stage, b - b_err, slope, bool(used))
        if best is None or _stronger(proof, best):
            best = proof
    return best


def reference_affine_map(self, active):
    """``F_i(0)`` and the sparse map ``x -> vec(F_i(x) - F_i(0))``.

    Evaluated in float64 with the block functions themselves, one free
    entry of the variables at a time (only for the variables that
    inequality ``i`` reads).
    """
    numeric = {k: np.asarray(p.value, float) for k, p in self._params.items()}
    zero = {k: np.zeros(x.shape) for k, x in self._vars.items()}
    units = {
        name: list(_unit_points(x.shape, _is_symmetric(x)))
        for name, x in self._vars.items()
    }
    probe = np.random.default_rng(0)
    base, maps = [], []
    for _, blocks, _, _ in active:

        def evaluate(values, blocks=blocks):
            v = self._namespace({**numeric, **zero, **values})
            return assemble(blocks(v), xp=np)

        F0 = evaluate({})
        columns = []
        for name, x in self._vars.items():
            if np.array_equal(evaluate({name: probe.standard_normal(x.shape)}), F0):
                columns.append(sp.csc_array((F0.size, len(units[name]))))
                continue
            dense = np.column_stack(
                [(evaluate({name: E}) - F0).ravel() for E in units[name]]
            )
            columns.append(sp.csc_array(dense))
        base.append(F0)
        maps.append(sp.hstack(columns, format="csr"))
    return base, maps


# ----------------------------------------------------------------------
# Cases and timing
# ----------------------------------------------------------------------
CASES = {
    "Theorem 1, N=8 n=4, halfplane(1e4)": (
        lpv.gain_scheduled_stabilization,
        dict(u=[1, 2], regions=[lpv.halfplane(1e4)]),
    ),
    "Theorem 2, N=8 n=4, gamma=1e-6": (
        lpv.gain_scheduled_hinf,
        dict(w=[0], u=[1, 2], z=[0, 1, 2], gamma=1e-6),
    ),
    "Lemma 2, N=8 n=4, gamma=1e-6": (
        lpv.hinf_state_feedback,
        dict(w=[0], u=[1, 2], z=[0, 1, 2], gamma=1e-6),
    ),
}


def record_duals(function, kwargs, limit):
    """Run the synthesis once; keep the dual points it would judge."""
    kept = []
    original = L.LMIProblem._best_farkas

    def recorder(self, dual_points, stage):
        for duals in dual_points:
            if len(kept) < limit:
                # copies: the problem object is reused by later rungs
                kept.append(
                    (
                        self,
                        [np.array(d, float) for d in duals],
                        stage,
                        {k: np.array(p.value, float) for k, p in self._params.items()},
                    )
                )
        return original(self, dual_points, stage)

    L.LMIProblem._best_farkas = recorder
    try:
        function(random_polytope(4, 8, seed=1), solvers=["CLARABEL"], **kwargs)
    except lpv.SynthesisError:
        pass
    finally:
        L.LMIProblem._best_farkas = original
    return kept


def describe(proof):
    if proof is None:
        return None
    return {
        "offset": float(proof.offset),
        "slope": float(proof.slope),
        "radius": float(proof.radius),
        "normalized": bool(proof.normalized),
        "proves_infeasible": bool(proof.proves_infeasible),
    }


def timed(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times)), out


def judge(lmi, duals, stage, params, repeat, reference):
    """Time the library's judgement of one dual point (and the reference's)."""
    for name, value in params.items():  # the values of that solve
        lmi._params[name].value = value
    row = {"stage": stage, "lmis": len(lmi._active(stage))}

    def cold():
        lmi._farkas_columns.clear()  # the columns of every LMI anew
        return lmi.farkas(duals, stage)

    row["library_s"], proof = timed(cold, repeat)
    row["library"] = describe(proof)
    # Again with the columns kept: what a later rung on the same data
    # (another margin) costs.
    row["library_reuse_s"] = timed(lambda: lmi.farkas(duals, stage), repeat)[0]
    if reference:
        seconds, proof = timed(lambda: reference_farkas(lmi, duals, stage), repeat)
        row["reference_s"], row["reference"] = seconds, describe(proof)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument(
        "--points", type=int, default=3, help="dual points judged per case"
    )
    parser.add_argument("--json", type=Path)
    parser.add_argument("--no-reference", action="store_true")
    args = parser.parse_args(argv)
    rows = []
    for label, (function, kwargs) in CASES.items():
        for index, recorded in enumerate(record_duals(function, kwargs, args.points)):
            row = judge(*recorded, args.repeat, not args.no_reference)
            row.update(case=label, point=index)
            rows.append(row)
            print_row(row)
    if args.json:
        meta = {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "machine": platform.machine(),
            "repeat": args.repeat,
            "load_average": os.getloadavg(),
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
        }
        args.json.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))


def print_row(r):
    def fmt(p):
        if p is None:
            return "none"
        flag = " normalised" if p["normalized"] else ""
        verdict = "PROOF" if p["proves_infeasible"] else "bound"
        return (
            f"{verdict} b={p['offset']:.3g} |g|={p['slope']:.3g} "
            f"r={p['radius']:.3g}{flag}"
        )

    line = (
        f"{r['case']:<36} #{r['point']} {r['stage']:<9} {r['lmis']:>4} LMIs  "
        f"library {r['library_s']:7.3f} s (reused columns "
        f"{r['library_reuse_s']:.3f} s) [{fmt(r['library'])}]"
    )
    if "reference_s" in r:
        line += (
            f"\n{'':<36}    {'':<9} {'':>4}       reference "
            f"{r['reference_s']:7.3f} s [{fmt(r['reference'])}]  "
            f"x{r['reference_s'] / r['library_s']:.0f}"
        )
    print(line, flush=True)


if __name__ == "__main__":
    main()
