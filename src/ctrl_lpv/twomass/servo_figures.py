"""Servo comparison of `reproduce`: rows, Markdown table and figures."""

from __future__ import annotations

import numpy as np

from ..plotting import _pyplot, controller_style, save_figure

__all__ = [
    "servo_rows",
    "servo_markdown_table",
    "servo_figure",
    "servo_rest_figure",
    "markdown_row",
    "markdown_rule",
    "SERVO_LIMITS",
]

#: Torque limits of the servo comparison, Nm.
SERVO_LIMITS = (500.0, 2000.0)

_TARGET = 0.5


def servo_rows(limits=SERVO_LIMITS, progress=None):
    """Paper scenario for every comparison controller under each limit.

    Returns
    -------
    rows : list of dict
        ``torque_limit``, ``controller``, the `ServoMetrics` fields, ``success``.
    responses : dict
        ``{(limit, controller): response}`` and ``("alpha_initial", limit)``.
    """
    from .cascade import cascade_design
    from .scenarios import alpha_step
    from .servo import servo_design
    from .servo_compare import (
        comparison_controllers,
        run_sampled_servo_scenario,
        run_servo_scenario,
        servo_metrics,
    )

    rows, responses = [], {}
    for limit in limits:
        d = servo_design(torque_limit=limit)
        responses["alpha_initial", limit] = float(d.tuning.alpha_initial)
        for name, ctrl in comparison_controllers(d, torque_limit=limit).items():
            r = run_servo_scenario(
                ctrl, alpha=alpha_step(), Td=8.0, T=5.0, torque_limit=limit
            )
            row = {"torque_limit": limit, "controller": name}
            row.update(servo_metrics(r).as_dict())
            row["success"] = bool(r.success)
            rows.append(row)
            responses[limit, name] = r
            if progress is not None:
                progress(f"servo comparison |Tm| <= {limit:g} Nm: {name}")
        # The servo as a drive runs it: 1 ms, one sample of delay, encoders.
        sampled = servo_design(
            torque_limit=limit, dt=1e-3, delay=1, sensors="encoders", certify=False
        )
        # The industrial reference on the same terms: the cascade P/PI with
        # the servo's trajectory, feedforward, sampling, delay and encoders.
        sampled_rows = (
            ("servo, 1 ms on encoders", sampled),
            ("cascade P/PI, 1 ms on encoders", cascade_design(sampled)),
        )
        for name, runs in sampled_rows:
            r = run_sampled_servo_scenario(runs, alpha=alpha_step(), Td=8.0, T=5.0)
            row = {"torque_limit": limit, "controller": name}
            row.update(servo_metrics(r).as_dict())
            row["success"] = True
            rows.append(row)
            responses[limit, name] = r
            if progress is not None:
                progress(f"servo comparison |Tm| <= {limit:g} Nm: {name}")
    return rows, responses


def markdown_row(cells) -> str:
    """One Markdown table row; a ``|`` inside a cell is escaped as ``\\|``."""
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"


def markdown_rule(columns: int) -> str:
    """The delimiter row of a Markdown table of `columns` columns."""
    return "|" + "---|" * columns


_SERVO_COLUMNS = (
    "limit (Nm)",
    "controller",
    "settle 2% (s)",
    "overshoot (%)",
    "abs(e(5 s)) (rad)",
    "peak Tm (Nm)",
    "peak command (Nm)",
)


def servo_markdown_table(rows) -> str:
    """The servo rows as a Markdown table."""
    lines = [markdown_row(_SERVO_COLUMNS), markdown_rule(len(_SERVO_COLUMNS))]
    for r in rows:
        s = r["settling"]
        settle = "never" if s is None or not np.isfinite(s) else f"{s:.3f}"
        lines.append(
            markdown_row(
                [
                    f"{r['torque_limit']:g}",
                    r["controller"],
                    settle,
                    f"{r['overshoot']:.2f}",
                    f"{r['error_5s']:.2e}",
                    f"{r['peak_torque']:.4g}",
                    f"{r['peak_command']:.4g}",
                ]
            )
        )
    return "\n".join(lines)


def _series(response, name):
    labels = list(response.output_labels)
    if name in labels:
        return np.asarray(response.outputs)[labels.index(name)]
    for i, lab in enumerate(response.state_labels or ()):
        if lab.endswith(name):
            return np.asarray(response.states)[i]
    return None


def servo_figure(responses, limit, alpha_initial, title=None):
    """Load angle, zoom 2.5-5 s, torque (full and +-20 Nm), alpha and estimate."""
    from .scenarios import alpha_step

    plt = _pyplot()
    fig, ax = plt.subplots(5, 1, figsize=(8.0, 13.0), sharex=False)
    step = alpha_step()
    for i, (name, r) in enumerate(responses.items()):
        st = controller_style(i)
        t = r.time
        y, tm = _series(r, "theta_l"), _series(r, "Tm")
        ax[0].plot(t, y, label=name, lw=1.3, **st)
        zoom = t >= 2.5
        ax[1].plot(t[zoom], y[zoom] - _TARGET, lw=1.3, **st)
        ax[2].plot(t, tm, lw=1.3, **st)
        ax[3].plot(t, tm, lw=1.3, **st)
        a_hat = _series(r, "alpha_hat_dev")
        if name == "servo" and a_hat is not None:
            ax[4].plot(t, a_hat + alpha_initial, label="servo gap estimate", **st)
    t = next(iter(responses.values())).time
    ax[0].axhline(_TARGET, color="k", ls=":", lw=1.0, label="target 0.5 rad")
    ax[1].axhline(0.0, color="k", ls=":", lw=1.0)
    for k in (2, 3):
        for sign in (1, -1):
            name = f"|Tm| <= {limit:g} Nm" if sign > 0 else None
            ax[k].axhline(sign * limit, color="0.4", ls="--", lw=0.9, label=name)
    ax[3].axhline(8.0, color="k", ls=":", lw=0.8, label="Td = 8 Nm")
    ax[3].set_ylim(-20, 20)
    ax[4].plot(t, [step(s) for s in t], color="k", lw=1.2, label="plant alpha(t)")
    ax[4].text(0.01, 0.05, "no controller here schedules on p (fixed gains)",
               transform=ax[4].transAxes, fontsize="small")  # fmt: skip
    names = ["load angle (rad)", "zoom 2.5-5 s: e_l (rad)", "motor torque Tm (Nm)",
             "Tm, zoom +-20 Nm", "backlash alpha (rad)"]  # fmt: skip
    for k, a in enumerate(ax):
        a.axvline(2.5, color="r", lw=0.8, ls="-.",
                  label="backlash step 0.03 -> 0.045" if k == 0 else None)  # fmt: skip
        a.set_ylabel(names[k])
        a.grid(True, lw=0.4, alpha=0.6)
        if k != 1:
            a.set_xlim(0, 5)
    ax[1].set_xlim(2.5, 5)
    ax[1].set_ylim(-0.06, 0.02)
    ax[0].legend(fontsize="x-small", loc="lower right")
    ax[2].legend(fontsize="x-small", loc="upper right")
    ax[3].legend(fontsize="x-small", loc="upper right")
    ax[4].legend(fontsize="x-small", loc="center right")
    ax[-1].set_xlabel("time (s)")
    ax[0].set_title(
        title or f"Servo vs published K and backstepping, |Tm| <= {limit:g} Nm"
    )
    fig.tight_layout()
    return fig


def servo_rest_figure(responses, names, window=(4.0, 5.0)):
    """Load error and torque at rest (the last second): the ripple of each."""
    plt = _pyplot()
    fig, ax = plt.subplots(2, 1, figsize=(8.0, 5.5), sharex=True)
    for i, name in enumerate(names):
        r, st = responses[name], controller_style(i)
        t = r.time
        rest = (t >= window[0]) & (t <= window[1])
        e = _series(r, "theta_l")[rest] - _TARGET
        tm = _series(r, "Tm")[rest]
        ax[0].plot(t[rest], 1e6 * e, lw=1.0, label=name, **st)
        ax[1].plot(t[rest], tm - tm.mean(), lw=1.0,
                   label=f"{name}: std {tm.std():.2g} Nm", **st)  # fmt: skip
    ax[0].set_ylabel("e_l (urad)")
    ax[1].set_ylabel("Tm - mean (Nm)")
    ax[1].set_xlabel("time (s)")
    for a in ax:
        a.grid(True, lw=0.4, alpha=0.6)
        a.legend(fontsize="x-small", loc="upper right")
    ax[0].set_title("At rest, paper scenario: continuous vs sampled on encoders")
    fig.tight_layout()
    return fig


def write_servo(out, formats, progress=None):
    """Write servo_comparison.{md,json} and servo_<limit> figures into `out`."""
    import json

    rows, responses = servo_rows(progress=progress)
    files = []
    (out / "servo_comparison.md").write_text(servo_markdown_table(rows) + "\n")
    (out / "servo_comparison.json").write_text(
        json.dumps(rows, indent=2, default=lambda v: None) + "\n"
    )
    files += [out / "servo_comparison.md", out / "servo_comparison.json"]
    for limit in SERVO_LIMITS:
        pick = {n: r for (lim, n), r in responses.items() if lim == limit}
        fig = servo_figure(pick, limit, responses["alpha_initial", limit])
        files += save_figure(fig, out / f"servo_{limit:g}", formats)
        rest = servo_rest_figure(
            pick,
            ["servo", "servo, 1 ms on encoders", "cascade P/PI, 1 ms on encoders"],
        )
        files += save_figure(rest, out / f"servo_rest_{limit:g}", formats)
    return rows, files
