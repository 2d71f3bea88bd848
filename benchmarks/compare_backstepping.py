"""LPV state feedback against backstepping on the exact two-mass plant.

Controllers (all with the same interface, see `ctrl_lpv.twomass`):

* ``paper K``: the published gain, error coordinates, no integral action;
* ``LPV robust``: the default certified common gain (Lemma 2) on
  ``lpv_model(p_bounds=(-0.95, 0), formulation="tracking", integral=True)``;
* ``LPV scheduled``: Theorem 2 vertex gains on the same model, scheduled on
  ``p`` computed with the nominal backlash estimate 0.03 rad;
* ``backstepping``: `twomass.backstepping_controller` with its default gains
  and the nominal load torque ``Td_hat = 8`` Nm.

Scenarios (step of theta_r to 0.5 rad from rest, 5 s, exact backlash model):

* ``paper``: alpha = 0.03, Td = 8, no torque limit (the paper's Fig. 8), and
  ``paper alpha step``: alpha 0.03 -> 0.045 at 2.5 s;
* ``Tmax=500``, ``Tmax=2000``: the alpha step under the same torque limit
  for every controller (the integrator of the LPV designs has
  conditional-integration anti-windup);
* robustness (not with ``--quick``): alpha in {0, 0.03, 0.045, 0.06},
  Td in {0, 8}, Jl scaled by 0.8, 1 and 1.2 (controllers designed on the
  nominal data).

Usage::

    python benchmarks/compare_backstepping.py [--quick] [--json PATH] [--out DIR]
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from pathlib import Path

import ctrl_lpv as lpv
from ctrl_lpv import twomass

METRICS = ("rise_time", "settling_time", "overshoot", "steady_state_error",
           "iae", "ise", "peak_input", "energy")  # fmt: skip


def controllers(torque_limit=None):
    """The four controllers, designed on the nominal data."""
    model = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    channels = dict(w="Td", u="Tm", z=model.output_labels)
    robust = lpv.hinf_state_feedback(model, **channels)
    scheduled = lpv.gain_scheduled_hinf(model, **channels)
    limit = {"torque_limit": torque_limit}
    return {
        "paper K": twomass.lpv_controller(**limit),
        "LPV robust": twomass.lpv_controller(robust, **limit),
        "LPV scheduled": twomass.lpv_controller(
            scheduled, alpha_estimate=0.03, **limit
        ),
        "backstepping": twomass.backstepping_controller(Td_hat=8.0, **limit),
    }


def scenarios(quick):
    """(name, torque limit, simulate keyword arguments)."""
    step = twomass.alpha_step(0.03, 0.045, at=2.5)
    out = [
        ("paper", None, dict(alpha=0.03, Td=8.0)),
        ("paper alpha step", None, dict(alpha=step, Td=8.0)),
        ("Tmax=2000", 2000.0, dict(alpha=step, Td=8.0)),
        ("Tmax=500", 500.0, dict(alpha=step, Td=8.0)),
    ]
    if quick:
        return out
    nominal = twomass.Parameters()
    for alpha, Td, scale in itertools.product(
        (0.0, 0.03, 0.045, 0.06), (0.0, 8.0), (0.8, 1.0, 1.2)
    ):
        params = nominal.replace(Jl=nominal.Jl * scale)
        name = f"alpha={alpha:g} Td={Td:g} Jl x{scale:g}"
        out.append((name, None, dict(alpha=alpha, Td=Td, params=params)))
    return out


def run(quick=False, progress=True, keep=()):
    """Simulate every controller in every scenario.

    Returns the rows and the responses of the scenarios named in `keep`.
    """
    rows = []
    responses = {}
    designs = {}
    cases = scenarios(quick)
    for index, (scenario, limit, kwargs) in enumerate(cases, start=1):
        if limit not in designs:
            designs[limit] = controllers(limit)
        for name, controller in designs[limit].items():
            start = time.perf_counter()
            row = {"scenario": scenario, "controller": name, "torque_limit": limit}
            try:
                response = twomass.simulate(controller, **kwargs)
                if scenario in keep:
                    responses[scenario, name] = response
                metrics = twomass.metrics(response).as_dict()
                final = response.outputs[response.output_labels.index("theta_l")][-1]
                row["status"] = "ok" if abs(final - 0.5) < 0.1 else "diverged"
            except (RuntimeError, ValueError) as exc:  # solver failure
                metrics = dict.fromkeys(METRICS, math.nan)
                row["status"] = f"failed: {exc}"
            row.update(metrics)
            row["seconds"] = time.perf_counter() - start
            rows.append(row)
        if progress:
            print(f"[{index}/{len(cases)}] {scenario}", file=sys.stderr, flush=True)
    return rows, responses


def figures(responses, out):
    """Load angle and motor torque per scenario, one PNG each."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no figures", file=sys.stderr)
        return
    for scenario in sorted({s for s, _ in responses}):
        fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
        for (s, name), resp in responses.items():
            if s != scenario:
                continue
            labels = resp.output_labels
            ax1.plot(resp.time, resp.outputs[labels.index("theta_l")], label=name)
            ax2.plot(resp.time, resp.outputs[labels.index("Tm")], label=name)
        ax1.axhline(0.5, color="k", linestyle=":", label="reference")
        ax1.set_ylabel("load angle theta_l (rad)")
        ax2.set_ylabel("motor torque Tm (Nm)")
        ax2.set_xlabel("time (s)")
        ax2.set_yscale("symlog", linthresh=100.0)
        ax1.legend(loc="lower right")
        ax1.set_title(scenario)
        fig.tight_layout()
        fig.savefig(out / f"{scenario.replace(' ', '_').replace('=', '')}.png", dpi=100)
        plt.close(fig)


def table(rows):
    """Markdown table of the rows."""
    lines = [
        "| scenario | controller | rise (s) | settle (s) | overshoot (%) "
        "| error 5 s (rad) | IAE | peak abs(Tm) (Nm) | energy | status |",
        "|" + "---|" * 10,
    ]
    for r in rows:
        lines.append(
            f"| {r['scenario']} | {r['controller']} | {r['rise_time']:.3f} | "
            f"{r['settling_time']:.3f} | {r['overshoot']:.2f} | "
            f"{r['steady_state_error']:.2e} | {r['iae']:.4f} | "
            f"{r['peak_input']:.4g} | {r['energy']:.3g} | {r['status']} |"
        )
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="paper scenarios only")
    parser.add_argument("--json", help="write the rows to this JSON file")
    parser.add_argument("--out", help="write table.md (and figures) to this folder")
    args = parser.parse_args(argv)
    keep = ("paper", "paper alpha step", "Tmax=500") if args.out else ()
    rows, responses = run(quick=args.quick, keep=keep)
    text = table(rows)
    print(text)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "table.md").write_text(text + "\n")
        figures(responses, out)
    return rows


if __name__ == "__main__":
    main()
