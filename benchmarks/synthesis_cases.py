"""One measured case of ``bench_synthesis.py``, run in a process of its own.

``python synthesis_cases.py '<json spec>'`` prints, after each measured call,
one JSON line of the results so far: the CPU and wall time of each call, the
Clarabel solves it made (CPU time of each ``solve()`` call, Clarabel's
``solve_time``, iterations, status: ``clarabel.DefaultSolver`` is wrapped
before anything else is imported), the library's result and the process's
peak RSS. Kinds: ``direct``, ``library``
and ``backoff`` (random polytopes, a cold then a warm call), ``h2`` (an H2
design, then an identical second call), ``twomass`` and ``twomass_direct``.
"""

from __future__ import annotations

import os

os.environ["OMP_NUM_THREADS"] = "1"  # before numpy: one BLAS thread
os.environ["OPENBLAS_NUM_THREADS"] = "1"

import json  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from functools import partial  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(
    0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests")
)

TWO_MASS_FUNCTIONS = {
    "Lemma 1": ("quadratic_stabilization", False, False),
    "Theorem 1": ("gain_scheduled_stabilization", False, True),
    "Lemma 2": ("hinf_state_feedback", True, False),
    "Theorem 2": ("gain_scheduled_hinf", True, True),
}


# ----------------------------------------------------------------------
# Measurement
# ----------------------------------------------------------------------
SOLVES: list[dict] = []


def _record_solves():
    """Wrap ``clarabel.DefaultSolver`` so that every solve is recorded."""
    import clarabel

    original = clarabel.DefaultSolver

    class Recorded:
        def __init__(self, *args, **kwargs):
            self._solver = original(*args, **kwargs)

        def solve(self):
            cpu = time.process_time()
            sol = self._solver.solve()
            SOLVES.append(
                {
                    "cpu": time.process_time() - cpu,
                    "solve_time": float(sol.solve_time),
                    "iterations": int(sol.iterations),
                    "status": str(sol.status),
                }
            )
            return sol

        def __getattr__(self, name):
            return getattr(self._solver, name)

    clarabel.DefaultSolver = Recorded


def _preload():
    """Imports and first uses shared by both sides: equal baselines."""
    import control  # noqa: F401
    import cvxpy  # noqa: F401

    import _direct_reference  # noqa: F401
    import ctrl_lpv as lpv

    for name in ("gain_scheduled_hinf", "synthesize", "pss", "H2", "twomass"):
        getattr(lpv, name)
    return lpv


def _measured(call):
    """Run `call`; its CPU and wall time and the solves it made."""
    first = len(SOLVES)
    cpu, wall = time.process_time(), time.perf_counter()
    error = None
    try:
        out = call()
    except Exception as exc:  # a refusal is a result here
        out, error = None, f"{type(exc).__name__}: {str(exc).splitlines()[0][:160]}"
    record = {
        "cpu": time.process_time() - cpu,
        "wall": time.perf_counter() - wall,
        "error": error,
    }
    solves = SOLVES[first:]
    record["solver_calls"] = len(solves)
    record["solver_cpu"] = sum(s["cpu"] for s in solves)
    record["solver_time"] = sum(s["solve_time"] for s in solves)
    record["statuses"] = sorted({s["status"] for s in solves})
    return out, record


def _rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _library_design(design, record):
    if design is not None:
        record["gamma"] = design.gamma
        record["gamma_opt"] = design.gamma_opt
        record["attempts"] = len(design.attempts)
        record["verified"] = bool(design.certificate.verified)
        record["timing"] = dict(design.timing)
    return record


def _frozen_norm_ratio(data, K, gamma, N, seed=0):
    """Largest frozen-loop H-infinity norm over `gamma` (vertices and 2N
    random points)."""
    import control as ct

    import _direct_reference as dr

    rng = np.random.default_rng(seed)
    points = list(np.eye(N)) + list(rng.dirichlet(np.ones(N), size=2 * N))
    worst = max(
        ct.linfnorm(ct.ss(*dr.frozen_loop(data, K, delta)))[0] for delta in points
    )
    return float(worst / gamma)


def _emit(result):
    """Print the results so far (the driver keeps the last line, also of a
    process it ends at the cap)."""
    result["peak_rss_mb"] = _rss_mb()
    print(json.dumps(result, default=float), flush=True)


def _library_hinf(lpv, sys_, backoff):
    return lpv.gain_scheduled_hinf(sys_, w=[0], u=[1, 2], z=[0, 1, 2], backoff=backoff)


def _grid_case(lpv, dr, kind, n, N, result):
    """Parts g and b: a cold call, then a warm one (new data, same shapes)."""
    systems = [dr.random_vertices(n, N, seed=s) for s in (1, 2)]
    for label, vertices in zip(("cold", "warm"), systems):
        if kind == "direct":
            data = dr.channels(vertices, [0], [1, 2], [0, 1, 2])
            out, rec = _measured(partial(dr.hinf, data, True))
            rec["gamma"] = out.gamma
            rec["build_cpu"] = rec["cpu"] - rec["solver_cpu"]
            rec["iterations"] = out.iterations
            rec["A_shape"], rec["A_nnz"] = list(out.conic.A.shape), out.conic.A.nnz
            result[label] = rec
            _emit(result)
            # Not timed, after the peak of the solve: the gains' own check.
            rec["norm_over_gamma"] = _frozen_norm_ratio(data, out.K, out.gamma, N)
            continue
        backoff = None if kind == "library" else 0.2
        design, rec = _measured(partial(_library_hinf, lpv, lpv.pss(vertices), backoff))
        result[label] = _library_design(design, rec)
        _emit(result)
        if rec["error"]:
            break


def _h2_case(lpv, result):
    """Part h: the H2 design, then an identical second call."""
    sys_ = h2_plant(lpv)
    call = partial(
        lpv.synthesize,
        sys_,
        "u",
        objective=lpv.H2(w="w", z=["y", "u_z"]),
        gains="scheduled",
        lyapunov="affine",
        rate_bounds={name: 1.0 for name in sys_.domain.names},
    )
    for label in ("first", "second"):
        out, rec = _measured(call)
        result[label] = _library_design(out, rec)
        _emit(result)
        if rec["error"]:
            break


def _two_mass_case(lpv, dr, kind, function, backoff, result):
    """Part t: one of the four functions on the two-mass model, twice."""
    model = lpv.twomass.lpv_model(
        p_bounds=(-0.95, 0), formulation="tracking", integral=True
    )
    name, hinf, scheduled = TWO_MASS_FUNCTIONS[function]
    inputs = list(model.physical_inputs)
    z = list(range(model.noutputs)) if hinf else []
    data = dr.channels(
        model.vertex_data(), [inputs.index("Td")], [inputs.index("Tm")], z
    )
    if kind == "twomass_direct":
        call = partial(dr.hinf if hinf else dr.stabilization, data, scheduled)
    else:
        kw = {"w": "Td", "z": list(model.output_labels), "backoff": backoff}
        call = partial(getattr(lpv, name), model, u="Tm", **(kw if hinf else {}))
    for label in ("cold", "warm"):
        out, rec = _measured(call)
        if kind == "twomass_direct":
            rec["gamma"] = out.gamma
        else:
            _library_design(out, rec)
        result[label] = rec
        _emit(result)


def run_case(spec):
    """One (case, side) in this process; prints a JSON line after each call.

    The library is called as a user would (its default time budget); the
    driver ends a process that runs over its cap.
    """
    _record_solves()
    lpv = _preload()
    import _direct_reference as dr

    result = {"baseline_rss_mb": _rss_mb()}
    kind = spec["kind"]
    if kind in ("library", "backoff", "direct"):
        _grid_case(lpv, dr, kind, spec["n"], spec["N"], result)
    elif kind == "h2":
        _h2_case(lpv, result)
    else:
        _two_mass_case(lpv, dr, kind, spec["function"], spec["backoff"], result)
    _emit(result)


def h2_plant(lpv, n=4, k=4, seed=3):
    """An affine random plant, four parameters in [-1, 1] (16 vertices).

    ``A(p) = A0 + sum p_i A_i``, ``B2(p)`` likewise; inputs ``[w, u]``,
    outputs ``[y, u_z]`` (``z = [C x; u]``, no feedthrough from w). One
    vertex is open-loop unstable; the polytope is quadratically stabilizable
    (checked with the direct build) and a constant-Lyapunov H2 design
    exists.
    """
    rng = np.random.default_rng(seed)
    S = rng.normal(size=(n, n))
    A0 = 0.5 * (S - S.T) - 0.5 * np.eye(n) + 0.2 * rng.normal(size=(n, n))
    B0 = rng.normal(size=(n, 2))
    C0 = np.vstack([rng.normal(size=(1, n)), np.zeros((1, n))])
    D0 = np.array([[0.0, 0.0], [0.0, 1.0]])
    terms = {}
    for i in range(k):
        A_i = 0.1 * rng.normal(size=(n, n))
        B_i = np.hstack([np.zeros((n, 1)), 0.1 * rng.normal(size=(n, 1))])
        terms[f"p{i}"] = (A_i, B_i, 0, 0)
    bounds = {name: (-1.0, 1.0) for name in terms}
    return lpv.PolytopicStateSpace.from_affine(
        (A0, B0, C0, D0), terms, bounds, inputs=["w", "u"], outputs=["y", "u_z"]
    )


if __name__ == "__main__":
    run_case(json.loads(sys.argv[1]))
