"""Figures of closed-loop responses (matplotlib, imported at call time).

One function draws any number of responses of several controllers in
stacked axes, one signal per axes, with the reference and the actuator
limits drawn and one style per controller throughout a set of figures.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

__all__ = ["plot_responses", "save_figure", "controller_style"]

# Colour-blind-safe palette (Okabe-Ito) with distinct dash patterns, so that
# figures stay readable in grey scale; the reference is the only dotted line.
_PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9")
_DASHES = ("-", "--", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 1)), (0, (3, 1)))


def _pyplot():
    try:
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover (matplotlib comes with control)
        raise ImportError(
            "ctrl_lpv.plotting needs matplotlib: pip install matplotlib"
        ) from exc
    return plt


def controller_style(index: int) -> dict:
    """Line style of the `index`-th controller of a figure set.

    Parameters
    ----------
    index : int
        Position of the controller in a fixed list of names.

    Returns
    -------
    dict
        ``color`` and ``linestyle`` keywords for `matplotlib.axes.Axes.plot`.
    """
    return {
        "color": _PALETTE[index % len(_PALETTE)],
        "linestyle": _DASHES[index % len(_DASHES)],
    }


def plot_responses(
    responses: Mapping[str, object],
    signals: Sequence[str],
    *,
    units: Mapping[str, str] | None = None,
    labels: Mapping[str, str] | None = None,
    reference: Mapping[str, float] | None = None,
    limits: Mapping[str, float] | None = None,
    styles: Mapping[str, dict] | None = None,
    title: str | None = None,
    symlog: Sequence[str] = (),
    figsize: tuple[float, float] | None = None,
):
    """Stacked time plots of several controllers' responses.

    Parameters
    ----------
    responses : mapping of str to `control.TimeResponseData`
        Responses by controller name (the legend entries).
    signals : sequence of str
        Output labels to draw, one axes each, top to bottom.
    units : mapping of str to str, optional
        Unit of each signal for its axis label, e.g. ``{"Tm": "Nm"}``.
    labels : mapping of str to str, optional
        Axis label text of each signal (default: the signal name).
    reference : mapping of str to float, optional
        Reference value of a signal, drawn as a dotted black line.
    limits : mapping of str to float, optional
        Symmetric limit ``|signal| <= limit`` (e.g. a torque limit), drawn as
        dashed grey lines.
    styles : mapping of str to dict, optional
        Line keywords per controller name; default `controller_style` in the
        order of `responses`.
    title : str, optional
        Figure title.
    symlog : sequence of str, optional
        Signals drawn on a symmetric log scale (for torques that span
        decades).
    figsize : (float, float), optional
        Figure size in inches.

    Returns
    -------
    `matplotlib.figure.Figure`
        The figure; save it with `save_figure`.

    Raises
    ------
    ValueError
        If `responses` or `signals` is empty, or a signal is not an output
        of a response.
    """
    if not responses:
        raise ValueError("responses: nothing to plot")
    if not signals:
        raise ValueError("signals: name at least one output to plot")
    units, labels = dict(units or {}), dict(labels or {})
    reference, limits = dict(reference or {}), dict(limits or {})
    plt = _pyplot()
    fig, axes = plt.subplots(
        len(signals),
        1,
        sharex=True,
        squeeze=False,
        figsize=figsize or (7.0, 2.6 * len(signals) + 0.6),
    )
    axes = axes[:, 0]
    for index, (name, response) in enumerate(responses.items()):
        style = (styles or {}).get(name) or controller_style(index)
        for ax, signal in zip(axes, signals):
            if signal not in response.output_labels:
                plt.close(fig)
                raise ValueError(
                    f"signals: {signal!r} is not an output of {name!r} "
                    f"(outputs {list(response.output_labels)})"
                )
            y = np.asarray(response.outputs)[response.output_labels.index(signal)]
            ax.plot(response.time, y, label=name, linewidth=1.4, **style)
    for ax, signal in zip(axes, signals):
        if signal in reference:
            ax.axhline(
                reference[signal],
                color="k",
                linestyle=":",
                linewidth=1.0,
                label="reference",
            )
        if signal in limits:
            for sign in (1, -1):
                ax.axhline(
                    sign * limits[signal],
                    color="0.5",
                    linestyle="--",
                    linewidth=0.9,
                    label="limit" if sign > 0 else None,
                )
        if signal in symlog:
            # Linear within the smallest decade that matters, log beyond.
            ax.set_yscale("symlog", linthresh=100.0)
        unit = units.get(signal)
        text = labels.get(signal, signal)
        ax.set_ylabel(f"{text} ({unit})" if unit else text)
        ax.grid(True, linewidth=0.4, alpha=0.6)
    axes[0].legend(loc="best", fontsize="small")
    axes[-1].set_xlabel("time (s)")
    if title:
        axes[0].set_title(title)
    fig.tight_layout()
    return fig


def save_figure(
    fig, stem: str | Path, formats: Sequence[str] = ("png", "svg"), dpi: int = 120
) -> list[Path]:
    """Save `fig` once per format and close it.

    Parameters
    ----------
    fig : `matplotlib.figure.Figure`
        The figure.
    stem : str or path
        File path without suffix.
    formats : sequence of str, optional
        File formats (suffixes), default PNG and SVG.
    dpi : int, optional
        Resolution of raster formats.

    Returns
    -------
    list of `pathlib.Path`
        The files written.
    """
    plt = _pyplot()
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    paths = []
    for fmt in formats:
        path = stem.with_suffix(f".{fmt}")
        fig.savefig(path, dpi=dpi)
        paths.append(path)
    plt.close(fig)
    return paths
