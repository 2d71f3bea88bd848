"""Simulation speed of the two-mass closed loop, eight ways, side by side.

The 5 s closed loop of the paper: exact backlash plant (alpha = 0.03 rad)
under the published LPV gain (`twomass.lpv_controller()`), step of theta_r
to 0.5 rad, Td = 8 Nm, from rest, 5001 output points; outputs theta_l, Tm,
theta_m, omega_m, omega_l, Ts (those of `twomass.closed_loop`).

Variants (same equations, same solver and tolerances, rtol 1e-6 and
atol 1e-9, LSODA and RK45):

* ``a hand``: one hand-written `scipy.integrate.solve_ivp` right-hand side
  of plant and controller on Python floats, outputs computed vectorized;
* ``a2 hand/numpy``: the same right-hand side in the common numpy style
  (arrays, numpy scalars), for scale: "hand-written" is not one number;
* ``a3 hand/odeint`` (LSODA only): the right-hand side of ``a hand``
  integrated by `scipy.integrate.odeint`, the same LSODA without
  solve_ivp's Python loop around every step; the fast path does this for
  LSODA, so this is its like-for-like baseline;
* ``a' hand+events``: the same by hand, but the ideal backlash model with
  the contact and separation located as terminal events and the mode
  switched there (does event location pay?);
* ``b minimal nlsys``: a minimal `control.nlsys` of the same plant and
  controller equations, `control.interconnect`,
  `control.input_output_response`;
* ``c library/ct``: the library's blocks (`twomass.plant`,
  `twomass.lpv_controller`) through `control.interconnect`;
* ``d library/lpv``: the same blocks through `ctrl_lpv.interconnect`, still
  simulated by `control.input_output_response`;
* ``e fast``: `ctrl_lpv.simulate(..., engine="fast")` on the same system.

Columns: median CPU time (this process) and wall time of a whole
simulation, response included, each with the median over the repeats of
its ratio to ``a hand`` in the same repeat; the median cost of one call of
the right-hand side on 200 states of the trajectory, which isolates the
machinery from the solver (``sys._rhs(t, x, u)`` for b-d; for a and e the
function given to `solve_ivp`, with the array conversion that solve_ivp
applies to its result; python-control's own input interpolation, called
before every right-hand side in b-d, is measured on its own below the
table); right-hand-side calls per run; and the largest |theta_l error|
against a tight reference (the hand-written right-hand side with DOP853,
rtol 1e-11, atol 1e-13).  The variants run round robin within each
repeat, the fast path right after the hand-written baseline, so that the
load of the machine hits them alike.

Usage::

    python benchmarks/bench_simulation.py [--quick] [--repeat N] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time

import control as ct
import numpy as np
import scipy
from scipy.integrate import odeint, solve_ivp

import ctrl_lpv
from ctrl_lpv import twomass
from ctrl_lpv.interconnection import interconnect
from ctrl_lpv.ode_integration import integrate
from ctrl_lpv.simulation import simulate

ALPHA, THETA_R, TD = 0.03, 0.5, 8.0
RTOL, ATOL = 1e-6, 1e-9
METHODS = ("LSODA", "RK45")
TOLERANCE = 1e-6  # accuracy target on theta_l, rad
P = twomass.Parameters()
K = twomass.paper_gain()[0].tolist()
LAYER, BAND = 1e-6, 1e-5  # the plant's contact layer and rest band
OUTPUTS = ["theta_l", "Tm", "theta_m", "omega_m", "omega_l", "Ts"]
ONLY_WITH = {"a3 hand/odeint": "LSODA"}  # variant -> the one method it has


def has(name, method):
    return ONLY_WITH.get(name, method) == method


# ---------------------------------------------------------------- a: by hand
def hand_rhs(alpha=ALPHA, theta_r=THETA_R, Td=TD):
    """Plant and controller in one function on Python floats."""
    inv_jm, inv_jl, cm, cl, cs = 1.0 / P.Jm, 1.0 / P.Jl, P.cm, P.cl, P.cs
    rate, a = P.ks / cs, alpha
    k1, k2, k3, k4 = K
    array = np.array

    def rhs(t, x):
        tm, wm, tl, wl, tb = x.tolist()
        Tm = -(k1 * (tm - theta_r) + k2 * wm + k3 * (tl - theta_r) + k4 * wl)
        wd = wm - wl
        if tb >= a:
            s = wd + rate * (tm - tl - a)
            v = s if s < 0.0 else 0.0
            ts = cs * (s - v)
            dtb = v - rate * (tb - a - BAND) if tb - a > BAND else v
        elif tb <= -a:
            s = wd + rate * (tm - tl + a)
            v = s if s > 0.0 else 0.0
            ts = cs * (s - v)
            dtb = v + rate * (-a - tb - BAND) if -a - tb > BAND else v
        else:
            s = wd + rate * (tm - tl - tb)
            depth = a - tb if s > 0.0 else a + tb
            if depth < LAYER:
                dtb = s * depth / LAYER
                ts = cs * (s - dtb)
            else:
                ts, dtb = 0.0, s
        return array(
            (wm, (Tm - cm * wm - ts) * inv_jm, wl, (ts - cl * wl - Td) * inv_jl, dtb)
        )

    return rhs


def numpy_rhs(alpha=ALPHA, theta_r=THETA_R, Td=TD):
    """The same right-hand side in the common numpy style (for scale)."""
    Jm, Jl, cm, cl = P.Jm, P.Jl, P.cm, P.cl
    shaft = minimal_shaft(alpha)
    offset = np.array([theta_r, 0.0, theta_r, 0.0])
    Kvec = np.array(K)

    def rhs(t, x):
        Tm = -Kvec @ (x[:4] - offset)
        ts, dtb = shaft(*x)
        return np.array(
            [x[1], (Tm - cm * x[1] - ts) / Jm, x[3], (ts - cl * x[3] - Td) / Jl, dtb]
        )

    return rhs


def hand_outputs(y, alpha=ALPHA, theta_r=THETA_R):
    """theta_l, Tm, theta_m, omega_m, omega_l, Ts from the states, vectorized."""
    tm, wm, tl, wl, tb = y
    cs, rate = P.cs, P.ks / P.cs
    Tm = -(K[0] * (tm - theta_r) + K[1] * wm + K[2] * (tl - theta_r) + K[3] * wl)
    wd = wm - wl
    s_up, s_low = wd + rate * (tm - tl - alpha), wd + rate * (tm - tl + alpha)
    s_in = wd + rate * (tm - tl - tb)
    depth = np.where(s_in > 0, alpha - tb, alpha + tb)
    Ts = np.select(
        [tb >= alpha, tb <= -alpha, depth < LAYER],
        [cs * np.maximum(s_up, 0), cs * np.minimum(s_low, 0),
         cs * (s_in - s_in * depth / LAYER)],
        0.0,
    )  # fmt: skip
    return np.vstack([tl, Tm, tm, wm, wl, Ts])


def run_hand(T, method, rhs=hand_rhs):
    sol = solve_ivp(rhs(), (T[0], T[-1]), np.zeros(5), method=method,
                    rtol=RTOL, atol=ATOL, t_eval=T)  # fmt: skip
    return hand_outputs(sol.y), sol.nfev


def run_numpy(T, method):
    return run_hand(T, method, numpy_rhs)


def run_hand_odeint(T, method):
    assert method == "LSODA"
    y, info = odeint(hand_rhs(), np.zeros(5), T, tfirst=True, rtol=RTOL,
                     atol=ATOL, full_output=True, mxstep=10**9)  # fmt: skip
    return hand_outputs(y.T), int(info["nfe"][-1])


def run_hybrid(T, method, alpha=ALPHA, theta_r=THETA_R, Td=TD):
    """The ideal backlash model: three linear modes, events at the switches."""
    Jm, Jl, cm, cl, ks, cs = P.Jm, P.Jl, P.cm, P.cl, P.ks, P.cs
    rate = ks / cs
    k1, k2, k3, k4 = K

    def rhs(t, x, mode):
        tm, wm, tl, wl, tb = x.tolist()
        Tm = -(k1 * (tm - theta_r) + k2 * wm + k3 * (tl - theta_r) + k4 * wl)
        if mode == 0:
            ts, dtb = 0.0, (wm - wl) + rate * (tm - tl - tb)
        else:
            ts, dtb = ks * (tm - tl - mode * alpha) + cs * (wm - wl), 0.0
        return np.array(
            (wm, (Tm - cm * wm - ts) / Jm, wl, (ts - cl * wl - Td) / Jl, dtb)
        )

    def impact_up(t, x, mode):
        return x[4] - alpha

    def impact_down(t, x, mode):
        return x[4] + alpha

    def separation(t, x, mode):
        return ks * (x[0] - x[2] - mode * alpha) + cs * (x[1] - x[3])

    impact_up.terminal = impact_down.terminal = separation.terminal = True
    impact_up.direction, impact_down.direction = 1, -1
    t0, x, mode, nfev = T[0], np.zeros(5), 0, 0
    ys = [x[:, None]]
    while True:
        if mode == 0:
            events = [impact_up, impact_down]
        else:
            separation.direction = -mode
            events = [separation]
        sol = solve_ivp(rhs, (t0, T[-1]), x, method=method, rtol=RTOL, atol=ATOL,
                        args=(mode,), events=events, t_eval=T[T > t0])  # fmt: skip
        nfev += sol.nfev
        ys.append(sol.y)
        if sol.status != 1:
            break
        t0 = next(te[0] for te in sol.t_events if len(te))
        x = next(ye[0] for ye in sol.y_events if len(ye)).copy()
        if mode == 0:
            mode = 1 if x[4] > 0 else -1
            x[4] = mode * alpha
        else:
            mode = 0
    y = np.concatenate(ys, axis=1)
    return hand_outputs(y), nfev


# -------------------------------------------------- b: minimal control.nlsys
def minimal_shaft(alpha=ALPHA):
    """(Ts, d theta_b/dt) of the exact model, written plainly."""
    cs, rate, a = P.cs, P.ks / P.cs, alpha

    def shaft(tm, wm, tl, wl, tb):
        wd = wm - wl
        if tb >= a:
            s = wd + rate * (tm - tl - a)
            v = min(s, 0.0)
            return cs * (s - v), (v - rate * (tb - a - BAND) if tb - a > BAND else v)
        if tb <= -a:
            s = wd + rate * (tm - tl + a)
            v = max(s, 0.0)
            return cs * (s - v), (v + rate * (-a - tb - BAND) if -a - tb > BAND else v)
        s = wd + rate * (tm - tl - tb)
        depth = a - tb if s > 0 else a + tb
        if depth < LAYER:
            v = s * depth / LAYER
            return cs * (s - v), v
        return 0.0, s

    return shaft


def minimal_blocks(alpha=ALPHA):
    """Plant and controller as a user would write them for python-control."""
    Jm, Jl, cm, cl = P.Jm, P.Jl, P.cm, P.cl
    shaft = minimal_shaft(alpha)
    Kmat = np.array([K])

    def plant_update(t, x, u, params):
        ts, dtb = shaft(*x)
        return np.array([x[1], (u[0] - cm * x[1] - ts) / Jm, x[3],
                         (ts - cl * x[3] - u[1]) / Jl, dtb])  # fmt: skip

    def plant_output(t, x, u, params):
        return np.array([x[0], x[1], x[2], x[3], shaft(*x)[0]])

    def control_output(t, x, u, params):
        e = np.array([u[0] - u[4], u[1], u[2] - u[4], u[3]])
        return -Kmat @ e

    plant = ct.nlsys(plant_update, plant_output, inputs=["Tm", "Td"],
                     outputs=["theta_m", "omega_m", "theta_l", "omega_l", "Ts"],
                     states=5, name="plant")  # fmt: skip
    ctrl = ct.nlsys(None, control_output,
                    inputs=["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"],
                    outputs=["Tm"], name="lpv")  # fmt: skip
    return plant, ctrl


def library_blocks():
    return twomass.plant(alpha=ALPHA), twomass.lpv_controller()


def loop(blocks, connect):
    return connect(
        list(blocks), inplist=["theta_r", "Td"], inputs=["theta_r", "Td"],
        outlist=["plant.theta_l", "plant.Tm", "plant.theta_m", "plant.omega_m",
                 "plant.omega_l", "plant.Ts"],
        outputs=OUTPUTS, name="loop",
    )  # fmt: skip


class counted:
    """Count the right-hand-side calls of a python-control run (context)."""

    def __init__(self, sys):
        self.sys, self.calls = sys, 0

    def __enter__(self):
        self.saved = self.sys.__dict__.get("_rhs")
        rhs = self.sys._rhs

        def wrapper(t, x, u):
            self.calls += 1
            return rhs(t, x, u)

        self.sys._rhs = wrapper
        return self

    def __exit__(self, *exc):
        if self.saved is None:
            del self.sys._rhs
        else:
            self.sys._rhs = self.saved


def io_runner(sys):
    def run(T, method):
        U = np.vstack([np.full_like(T, THETA_R), np.full_like(T, TD)])
        resp = ct.input_output_response(
            sys, T, U, 0, solve_ivp_method=method,
            solve_ivp_kwargs={"rtol": RTOL, "atol": ATOL},
        )  # fmt: skip
        return resp.outputs, None

    return run


def fast_runner(sys):
    def run(T, method):
        U = np.vstack([np.full_like(T, THETA_R), np.full_like(T, TD)])
        resp = simulate(sys, T, U, 0, engine="fast", method=method, rtol=RTOL,
                        atol=ATOL)  # fmt: skip
        return resp.outputs, None

    return run


# ------------------------------------------------------------- measurements
def rhs_cost(fun, points, repeat):
    """Median over `repeat` of the mean CPU microseconds per call on `points`."""
    times = []
    for _ in range(repeat):
        start = time.process_time()
        for _ in range(5):
            for args in points:
                fun(*args)
        times.append((time.process_time() - start) / (5 * len(points)) * 1e6)
    return statistics.median(times)


def python_control_input_cost(T, repeat):
    """python-control's per-call input interpolation (``ufun``), copied."""
    U = np.vstack([np.full_like(T, THETA_R), np.full_like(T, TD)])

    def ufun(t):
        idx = np.clip(np.searchsorted(T, t, side="left"), 1, len(T) - 1)
        dt = (t - T[idx - 1]) / (T[idx] - T[idx - 1])
        return U[..., idx - 1] * (1.0 - dt) + U[..., idx] * dt

    points = [(t,) for t in np.linspace(T[0], T[-1], 200)]
    return rhs_cost(ufun, points, repeat)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick",
        action="store_true",
        help="1 s instead of 5 s, 2 repeats (a smoke test)",
    )
    parser.add_argument("--repeat", type=int, help="timed repeats (default 9)")
    parser.add_argument("--json", help="write the results to this JSON file")
    args = parser.parse_args(argv)  # fmt: skip
    repeat = args.repeat or (2 if args.quick else 9)
    if repeat < 1:
        parser.error("--repeat must be >= 1")
    duration = 1.0 if args.quick else 5.0
    T = np.linspace(0.0, duration, int(round(duration * 1000)) + 1)

    start = time.perf_counter()
    ref = solve_ivp(hand_rhs(), (0.0, duration), np.zeros(5), method="DOP853",
                    rtol=1e-11, atol=1e-13, t_eval=T)  # fmt: skip
    reference = hand_outputs(ref.y)
    print(f"reference: DOP853 rtol 1e-11, {ref.nfev} calls, "
          f"{time.perf_counter() - start:.1f} s")  # fmt: skip

    minimal_ct = loop(minimal_blocks(), ct.interconnect)
    library_ct = loop(library_blocks(), ct.interconnect)
    library_lpv = loop(library_blocks(), interconnect)
    fast_sys = loop(library_blocks(), interconnect)
    library_lpv._plan()  # as on the first call of a simulation
    variants = {
        "a hand": run_hand,
        "a2 hand/numpy": run_numpy,
        "a3 hand/odeint": run_hand_odeint,
        "a' hand+events": run_hybrid,
        "b minimal nlsys": io_runner(minimal_ct),
        "c library/ct": io_runner(library_ct),
        "d library/lpv": io_runner(library_lpv),
        "e fast": fast_runner(fast_sys),
    }
    # Timing order: the fast path right after the hand-written baseline, so
    # that the two see the same load; the slow python-control runs last.
    timing_order = ["a hand", "e fast", "a3 hand/odeint", "a2 hand/numpy",
                    "a' hand+events",
                    "d library/lpv", "b minimal nlsys", "c library/ct"]  # fmt: skip
    python_control = {"b": minimal_ct, "c": library_ct, "d": library_lpv}

    # RHS cost on states of the reference trajectory.
    idx = np.linspace(0, T.size - 1, 200).astype(int)
    u = np.array([THETA_R, TD])
    states = [(float(T[i]), ref.y[:, i].copy()) for i in idx]
    for sys_ in python_control.values():
        sys_._update_params(None)
    rhs_funs = {
        "a hand": (hand_rhs(), False),
        "a2 hand/numpy": (numpy_rhs(), False),
        "a3 hand/odeint": (None, False),
        "a' hand+events": (None, False),
        "b minimal nlsys": (minimal_ct._rhs, True),
        "c library/ct": (library_ct._rhs, True),
        "d library/lpv": (library_lpv._rhs, True),
        "e fast": (fast_sys._plan().rhs_function((THETA_R, TD)), False),
    }
    cost_repeat = 5 if args.quick else 15
    rhs_us = {}
    for name, (fun, with_u) in rhs_funs.items():
        if fun is None:
            rhs_us[name] = None
            continue
        if not with_u:  # as solve_ivp calls it: its result made an array

            def fun(t, x, f=fun, asarray=np.asarray):
                return asarray(f(t, x), dtype=float)

        points = [(t, x, u) if with_u else (t, x) for t, x in states]
        rhs_us[name] = rhs_cost(fun, points, cost_repeat)
    ufun_us = python_control_input_cost(T, cost_repeat)

    # Call counts (one untimed run each) and accuracy.
    nfev, error = {}, {}
    for method in METHODS:
        for name, run in variants.items():
            if not has(name, method):
                continue
            if name[0] in python_control:
                with counted(python_control[name[0]]) as count:
                    out, _ = run(T, method)
                n = count.calls
            else:
                out, n = run(T, method)
                if n is None:
                    n = _fast_nfev(fast_sys, T, method)
            nfev[name, method] = n
            error[name, method] = float(np.abs(out[0] - reference[0]).max())

    # CPU and wall times, round robin.
    cpu = {key: [] for key in nfev}
    wall = {key: [] for key in nfev}
    for _ in range(repeat):
        for method in METHODS:
            for name in filter(lambda v: has(v, method), timing_order):
                run = variants[name]
                start, start_cpu = time.perf_counter(), time.process_time()
                run(T, method)
                cpu[name, method].append(time.process_time() - start_cpu)
                wall[name, method].append(time.perf_counter() - start)

    def paired(times, name, method):
        # Median of the per-repeat ratios: runs of one repeat are close in
        # time, so a slow drift of the machine's load cancels.
        pairs = zip(times[name, method], times["a hand", method])
        return statistics.median(t / base for t, base in pairs)

    rows = []
    for method in METHODS:
        for name in filter(lambda v: has(v, method), variants):
            cost = rhs_us[name]
            rows.append({
                "variant": name, "method": method,
                "cpu_s": statistics.median(cpu[name, method]),
                "ratio": paired(cpu, name, method),
                "cpu_min_s": min(cpu[name, method]),
                "wall_s": statistics.median(wall[name, method]),
                "wall_ratio": paired(wall, name, method),
                "rhs_us": cost,
                "rhs_ratio": None if cost is None else cost / rhs_us["a hand"],
                "rhs_calls": nfev[name, method],
                "max_theta_l_error": error[name, method],
                "within_tolerance": error[name, method] <= TOLERANCE,
                "cpu_times_s": cpu[name, method],
                "wall_times_s": wall[name, method],
            })  # fmt: skip
    print_table(rows, repeat, duration, ufun_us, T.size)
    checks = targets(rows)
    for text, ok in checks:
        print(f"  [{'ok' if ok else 'MISSED'}] {text}")
    if args.json:
        document = {
            "benchmark": "bench_simulation",
            "duration_s": duration, "points": int(T.size), "repeat": repeat,
            "rtol": RTOL, "atol": ATOL, "reference": "DOP853 rtol 1e-11 atol 1e-13",
            "python_control_input_interpolation_us": ufun_us,
            "rows": rows,
            "targets": [{"target": t, "met": ok} for t, ok in checks],
            "environment": environment(),
        }  # fmt: skip
        with open(args.json, "w") as fh:
            json.dump(document, fh, indent=2)
        print(f"wrote {args.json}")
    return rows


def _fast_nfev(sys, T, method):
    """RHS calls of the fast path: the same run with a counting wrapper."""
    fused = sys._plan().rhs_function((THETA_R, TD))
    calls = [0]

    def counted_rhs(t, x):
        calls[0] += 1
        return fused(t, x)

    options = dict(method=method, rtol=RTOL, atol=ATOL)
    integrate(counted_rhs, T, np.zeros(sys.nstates), options)  # as simulate
    return calls[0]


def print_table(rows, repeat, duration, ufun_us, npoints):
    print(f"\n{duration:g} s closed loop, {repeat} repeats round robin (medians), "
          f"rtol {RTOL:g}, atol {ATOL:g}; CPU time of this process and wall "
          f"time; x hand = median of the per-repeat ratios to 'a hand'")  # fmt: skip
    head = (f"{'variant':<17} {'method':<6} {'CPU s':>7} {'x hand':>7} "
            f"{'wall s':>7} {'x hand':>7} {'RHS us':>7} {'x hand':>7} "
            f"{'calls':>6} {'max|dtheta_l|':>13}")  # fmt: skip
    print(head)
    print("-" * len(head))
    for r in rows:
        cost = "-" if r["rhs_us"] is None else f"{r['rhs_us']:.2f}"
        cr = "-" if r["rhs_ratio"] is None else f"{r['rhs_ratio']:.2f}"
        print(f"{r['variant']:<17} {r['method']:<6} {r['cpu_s']:>7.4f} "
              f"{r['ratio']:>7.2f} {r['wall_s']:>7.4f} {r['wall_ratio']:>7.2f} "
              f"{cost:>7} {cr:>7} {r['rhs_calls']:>6} "
              f"{r['max_theta_l_error']:>13.2e}")  # fmt: skip
    print(f"python-control's input interpolation (ufun) costs {ufun_us:.2f} us per "
          f"call, once per solver call and per output point in b-d:")  # fmt: skip
    for r in rows:
        if r["variant"].startswith("d"):
            share = ufun_us * 1e-6 * (r["rhs_calls"] + npoints)
            print(f"  {r['method']}: about {share:.3f} s of d's {r['cpu_s']:.3f} s "
                  f"(estimate: calls x cost)")  # fmt: skip


def targets(rows):
    """The issue's targets, as (text, met) pairs."""
    by = {(r["variant"], r["method"]): r for r in rows}
    checks = []
    for m in METHODS:
        b, c = by["b minimal nlsys", m], by["c library/ct", m]
        d, e = by["d library/lpv", m], by["e fast", m]
        checks += [
            (f"{m}: library blocks through control.interconnect cost no more "
             f"than minimal nlsys (RHS {c['rhs_us']:.1f} vs {b['rhs_us']:.1f} us; "
             f"run {c['cpu_s']:.3f} vs {b['cpu_s']:.3f} s)",
             c["rhs_us"] <= b["rhs_us"] and c["cpu_s"] <= b["cpu_s"]),
            (f"{m}: ctrl_lpv.interconnect RHS within 3x of the hand-written RHS "
             f"({d['rhs_ratio']:.2f}x)", d["rhs_ratio"] <= 3.0),
            (f"{m}: ctrl_lpv.interconnect + control.input_output_response run "
             f"within 3x of hand-written ({d['ratio']:.2f}x)", d["ratio"] <= 3.0),
            (f"{m}: fast path at least as fast as hand-written "
             f"({e['ratio']:.2f}x)", e["ratio"] <= 1.0),
        ]  # fmt: skip
        if ("a3 hand/odeint", m) in by:
            a3 = by["a3 hand/odeint", m]
            checks.append((
                f"{m}: fast path at least as fast as the hand-written RHS through "
                f"odeint, like for like ({e['cpu_s'] / a3['cpu_s']:.2f}x)",
                e["cpu_s"] <= a3["cpu_s"],
            ))  # fmt: skip
        checks += [
            (f"{m}: every variant within {TOLERANCE:g} rad of the reference",
             all(r["within_tolerance"] for r in rows if r["method"] == m)),
        ]  # fmt: skip
    return checks


def environment():
    return {
        "python": sys.version.split()[0], "numpy": np.__version__,
        "scipy": scipy.__version__, "control": ct.__version__,
        "ctrl_lpv": ctrl_lpv.__version__, "platform": platform.platform(),
        "cpus": os.cpu_count(), "date": time.strftime("%Y-%m-%d %H:%M:%S"),
        "numba": _has("numba"),
    }  # fmt: skip


def _has(module):
    try:
        __import__(module)
    except ImportError:
        return False
    return True


if __name__ == "__main__":
    main()
