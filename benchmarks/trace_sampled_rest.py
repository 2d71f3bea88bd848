"""Trace of the sampled servo's rest on encoders: what switches at Td = 0.

One run (1 ms, one sample of delay, 20/17-bit encoders with half a count of
noise, the exact plant) logged per sample: the latched flank and its CUSUM
evidence (`ctrl_lpv.twomass.rest_flank`), the observer's shaft torque and
load torque, the true shaft torque and twist, the motor torque and the load
error and speed. Every change of the latched flank (a flip or a release) is
listed with the torque that follows it, and the last second's torque
variance is split into the share within `--window` s after such a change
and the rest (the question: is the chatter the flank switching, or the
loop between switches?).

Usage::

    python benchmarks/trace_sampled_rest.py [--Td 0] [--alpha 0.06] [--Jl 1]
        [--theta-r 0.5] [--seed 2] [--dt 1e-3] [--csv PATH] [--figure PATH]

``--figure`` draws the mechanism around the first flank change after
``--from`` s (default 0.9): the motor torque, the latched flank and its
evidence, the load error and speed, the true shaft torque (zero: the load
is free in the gap).
"""

from __future__ import annotations

import argparse

import numpy as np

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder

ENCODERS = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}


def trace(Td, alpha, Jl, theta_r, *, seed, dt=1e-3, T=5.0):
    """The run's per-sample log, a dict of arrays on the sampling instants."""
    design = twomass.servo_design(dt=dt, delay=1, sensors="encoders", certify=False)
    params = twomass.Parameters()
    plant = twomass.plant(params.replace(Jl=Jl * params.Jl), alpha=alpha)
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": theta_r},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    p, c = res.plant, res.controller
    n = min(p.time.size, c.time.size)
    state = dict(zip(c.state_labels, c.states[:, :n]))
    return {
        "t": p.time[:n],
        "Tm": p.inputs[0][:n],
        "e_l": p.outputs[2][:n] - theta_r,
        "omega_l": p.outputs[3][:n],
        "Ts": p.outputs[4][:n],
        "twist": p.outputs[0][:n] - p.outputs[2][:n],
        "side": state["flank_side"],
        "evidence": state["flank_evidence"],
        "Ts_hat": state["Ts_hat"],
        "Td_hat": state["Td_hat"],
    }


def switch_report(log, window=0.05, last=1.0):
    """The flank changes and the last second's torque variance near them."""
    t, side, Tm = log["t"], log["side"], log["Tm"]
    changes = np.flatnonzero(np.diff(side)) + 1
    rows = []
    for k in changes:
        after = (t >= t[k]) & (t < t[k] + window)
        rows.append(
            (t[k], side[k - 1], side[k], log["e_l"][k], log["omega_l"][k],
             np.abs(Tm[after]).max())
        )  # fmt: skip
    tail = t >= t[-1] - last
    near = np.zeros_like(tail)
    for k in changes:
        near |= (t >= t[k]) & (t < t[k] + window)
    dev = Tm[tail] - Tm[tail].mean()
    total = float(np.sum(dev**2))
    share = float(np.sum(dev[near[tail]] ** 2)) / total if total > 0 else 0.0
    return rows, float(np.std(Tm[tail])), share


def figure(log, path, start, span=0.45):
    """The mechanism around the first flank change after `start` s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = log["t"]
    changes = np.flatnonzero(np.diff(log["side"]) != 0.0) + 1
    changes = changes[t[changes] >= start]
    t0 = t[changes[0]] - 0.1 if changes.size else start
    w = (t >= t0) & (t <= t0 + span)
    fig, ax = plt.subplots(4, 1, figsize=(8, 8), sharex=True)
    ax[0].plot(t[w], log["Tm"][w], lw=0.8)
    ax[0].set_ylabel("motor torque, Nm")
    ax[1].step(t[w], log["side"][w], where="post", label="latched flank")
    ax[1].plot(t[w], log["evidence"][w] / 0.02, label="flip evidence / threshold")
    ax[1].set_ylabel("flank")
    ax[1].legend(loc="upper right", fontsize=8)
    ax[2].plot(t[w], 1e4 * log["e_l"][w], label="load error, 1e-4 rad")
    ax[2].plot(t[w], 1e3 * log["omega_l"][w], label="load speed, 1e-3 rad/s")
    ax[2].legend(loc="upper right", fontsize=8)
    ax[3].plot(t[w], log["Ts"][w], lw=0.8, label="shaft torque (true)")
    ax[3].plot(t[w], log["Ts_hat"][w], lw=0.5, alpha=0.6, label="estimate")
    ax[3].set_ylabel("Nm")
    ax[3].set_xlabel("t, s")
    ax[3].legend(loc="upper right", fontsize=8)
    fig.suptitle(
        "Rest at Td = 0, 1 ms, encoders: the load coasts free in the gap; a flip"
        " steps the motor reference across it",
        fontsize=9,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--Td", type=float, default=0.0)
    parser.add_argument("--alpha", type=float, default=0.06)
    parser.add_argument("--Jl", type=float, default=1.0)
    parser.add_argument("--theta-r", type=float, default=0.5)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--dt", type=float, default=1e-3)
    parser.add_argument("--window", type=float, default=0.05)
    parser.add_argument("--csv", default=None)
    parser.add_argument("--figure", default=None)
    parser.add_argument("--from", dest="start", type=float, default=0.9)
    args = parser.parse_args()
    log = trace(args.Td, args.alpha, args.Jl, args.theta_r, seed=args.seed, dt=args.dt)
    rows, std, share = switch_report(log, args.window)
    print(f"{'t':>6s} {'from':>4s} {'to':>3s} {'e_l':>9s} {'omega_l':>8s} "
          f"{'max|Tm| next':>12s}")  # fmt: skip
    for t, a, b, e, w, peak in rows:
        print(f"{t:6.3f} {a:+4.0f} {b:+3.0f} {e:9.2e} {w:+8.4f} {peak:12.1f}")
    tail = log["t"] >= log["t"][-1] - 1.0
    free = np.mean(np.abs(log["Ts"][tail]) < 0.05)
    print(f"last second: torque std {std:.2f} Nm, {100 * share:.0f} % of its "
          f"variance within {args.window:g} s after a flank change; "
          f"e ptp {np.ptp(log['e_l'][tail]):.2e} rad; "
          f"free load (|Ts| < 0.05 Nm) {100 * free:.0f} % of it")  # fmt: skip
    if args.figure:
        figure(log, args.figure, args.start)
    if args.csv:
        names = list(log)
        np.savetxt(args.csv, np.column_stack([log[k] for k in names]),
                   delimiter=",", header=",".join(names), comments="")  # fmt: skip


if __name__ == "__main__":
    main()
