"""Two-mass H-infinity designs in one call, and their gain files.

`design` picks the channels of `lpv_model` for a formulation and runs
Lemma 2 (one common gain) or Theorem 2 (vertex gains). `save_gains` writes
the certified gains with everything needed to use and audit them as JSON;
`load_gains` reads them back as a `GainFile`, from which `GainFile.controller`
builds the same controller as `lpv_controller` would from the design.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..synthesis import StateFeedbackDesign, gain_scheduled_hinf, hinf_state_feedback
from .feedback import lpv_controller
from .model import INTEGRAL_WEIGHT, TORQUE_WEIGHT, lpv_model
from .parameters import Parameters

__all__ = ["design", "gains_document", "save_gains", "load_gains", "GainFile"]

#: Identifies the JSON layout written by `save_gains`.
GAIN_FILE_FORMAT = "ctrl_lpv.twomass.gains/1"


def design(
    params: Parameters | None = None,
    *,
    p_bounds: tuple[float, float] = (-0.95, 0.0),
    formulation: str = "tracking",
    integral: bool = True,
    scheduled: bool = False,
    torque_weight: float = TORQUE_WEIGHT,
    integral_weight: float = INTEGRAL_WEIGHT,
    backoff: float | None = 0.2,
    **options,
) -> StateFeedbackDesign:
    """Certified H-infinity state feedback for the two-mass LPV model.

    Builds ``lpv_model(params, p_bounds, formulation, integral, ...)`` and
    solves Lemma 2 (`ctrl_lpv.hinf_state_feedback`, one gain for the whole
    interval) or Theorem 2 (`ctrl_lpv.gain_scheduled_hinf`, one gain per
    vertex) with the formulation's channels: ``w = Td``, ``z`` every output
    for ``"tracking"``; ``w = [Td, theta_r]``, ``z = theta_l`` for
    ``"paper"``. The control input is ``Tm``.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data of the design model.
    p_bounds : (float, float), optional
        Interval of the backlash parameter; ``p = -1`` is not stabilizable
        (see the errata), hence the default ``(-0.95, 0)``.
    formulation : {"tracking", "paper"}, optional
        Model formulation (`lpv_model`).
    integral : bool, optional
        Integral of the load-angle error as a state (tracking only).
    scheduled : bool, optional
        Vertex gains (Theorem 2) instead of one common gain (Lemma 2).
    torque_weight, integral_weight : float, optional
        Weights of the tracking formulation's performance outputs.
    backoff : float or None, optional
        Relative back-off from the optimal ``gamma`` (see
        `ctrl_lpv.hinf_state_feedback`).
    **options
        Further keywords of the synthesis function (``gain_bound``,
        ``regions``, ``margin``, ``solvers``).

    Returns
    -------
    `ctrl_lpv.StateFeedbackDesign`
        The certified design.

    Raises
    ------
    ValueError
        For invalid model options (see `lpv_model`).
    ctrl_lpv.InfeasibleError
        If no certified design exists.
    """
    if formulation == "paper" and integral:
        integral = False  # the paper's formulation has no integral state
    model = lpv_model(
        params,
        p_bounds,
        formulation,
        integral,
        torque_weight=torque_weight,
        integral_weight=integral_weight,
    )
    if formulation == "paper":
        channels = dict(w=["Td", "theta_r"], u=["Tm"], z=["theta_l"])
    else:
        channels = dict(w=["Td"], u=["Tm"], z=list(model.output_labels))
    synthesize = gain_scheduled_hinf if scheduled else hinf_state_feedback
    return synthesize(model, **channels, backoff=backoff, **options)


@dataclass(frozen=True)
class GainFile:
    """Gains read from a file written by `save_gains`.

    Attributes
    ----------
    gains : ndarray
        ``N x m x n`` gains for ``u = -K x`` (``N = 1`` for a common gain,
        else one per vertex of `p_vertices`).
    states : tuple of str
        State labels of the gains' columns.
    p_vertices : ndarray
        Values of ``p`` at the vertices, in the order of `gains`.
    gamma : float or None
        The certified H-infinity bound at design time.
    metadata : dict
        Everything else in the file (method, model options, certificate
        summary, library version).
    """

    gains: np.ndarray
    states: tuple[str, ...]
    p_vertices: np.ndarray
    gamma: float | None
    metadata: dict = field(default_factory=dict)

    @property
    def scheduled(self) -> bool:
        """Whether the file holds one gain per vertex."""
        return self.gains.shape[0] > 1

    def gain(self, p: float | None = None) -> np.ndarray:
        """Gain at `p`, interpolated linearly between the vertex gains.

        Parameters
        ----------
        p : float, optional
            Backlash parameter (required for vertex gains), clipped to the
            design interval.

        Returns
        -------
        ndarray
            ``m x n`` gain for ``u = -K x``.
        """
        if not self.scheduled:
            return self.gains[0].copy()
        if p is None:
            raise ValueError("p: vertex gains need the parameter value")
        lo, hi = self.p_vertices[0], self.p_vertices[-1]
        s = (min(max(float(p), lo), hi) - lo) / (hi - lo)
        return (1.0 - s) * self.gains[0] + s * self.gains[-1]

    def controller(self, **kwargs):
        """Two-mass controller of these gains (see `lpv_controller`).

        Parameters
        ----------
        **kwargs
            ``alpha_estimate`` (required for vertex gains),
            ``torque_limit``, ``name``.

        Returns
        -------
        `control.NonlinearIOSystem`
            As `lpv_controller`.
        """
        if self.scheduled:
            return lpv_controller(
                self.gains[:, 0, :], p_bounds=tuple(self.p_vertices), **kwargs
            )
        return lpv_controller(self.gains[0], **kwargs)


def _jsonable(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def gains_document(design: StateFeedbackDesign, **metadata) -> dict:
    """The JSON document `save_gains` writes for a two-mass design.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        A design on `lpv_model` (one scheduling parameter ``p``).
    **metadata
        Extra JSON-serializable entries (e.g. the model options used).

    Returns
    -------
    dict
        Format tag, method, sign convention, states, channels, vertex values
        of ``p`` (ascending) and the gains in that order, ``gamma``,
        ``gamma_opt``, back-off and a certificate summary.

    Raises
    ------
    TypeError
        If `design` is not a `ctrl_lpv.StateFeedbackDesign`.
    ValueError
        If the design is not on the single parameter ``p``.
    """
    if not isinstance(design, StateFeedbackDesign):
        raise TypeError(
            f"design: expected a StateFeedbackDesign, got {type(design).__name__}"
        )
    domain = design.system.domain
    if list(getattr(domain, "names", ())) != ["p"]:
        raise ValueError("design: expected a design on twomass.lpv_model (parameter p)")
    p_vertices = [float(v[0]) for v in domain.points]
    order = np.argsort(p_vertices) if design.scheduled else [0]
    cert = design.certificate
    return {
        "format": GAIN_FILE_FORMAT,
        "method": design.method,
        "sign": "u = -K x",
        "states": list(design.states),
        "w": list(design.w),
        "u": list(design.u),
        "z": list(design.z),
        "p_vertices": sorted(p_vertices),
        "gains": [design.gains[i].tolist() for i in order],
        "gamma": design.gamma,
        "gamma_opt": design.gamma_opt,
        "backoff": design.backoff,
        "certificate": {
            "verified": bool(cert.verified),
            "worst_lmi": cert.worst_lmi.name,
            "worst_lmi_max_eig": _jsonable(float(cert.worst_lmi.max_eig)),
            "margin": cert.margin,
            "max_closed_loop_real": _jsonable(float(cert.max_closed_loop_real)),
        },
        **metadata,
    }


def save_gains(design: StateFeedbackDesign, path: str | Path, **metadata) -> Path:
    """Write a two-mass design's gains and certificate summary as JSON.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        A design on `lpv_model` (see `gains_document`).
    path : str or path
        File to write (parent folders are created).
    **metadata
        Extra JSON-serializable entries (e.g. the model options used).

    Returns
    -------
    `pathlib.Path`
        The file written.
    """
    document = gains_document(design, **metadata)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(document, indent=2) + "\n")
    return path


def load_gains(path: str | Path) -> GainFile:
    """Read gains written by `save_gains`.

    Parameters
    ----------
    path : str or path
        A JSON file from `save_gains` (or ``ctrl-lpv design --save``).

    Returns
    -------
    `GainFile`
        The gains, their states and the design metadata.

    Raises
    ------
    ValueError
        If the file is not a gain file or its gains are malformed.
    """
    path = Path(path)
    try:
        document = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"path: {path} is not valid JSON ({exc})") from None
    if not isinstance(document, dict) or document.get("format") != GAIN_FILE_FORMAT:
        raise ValueError(
            f"path: {path} is not a ctrl_lpv two-mass gain file "
            f"(expected format {GAIN_FILE_FORMAT!r})"
        )
    gains = np.asarray(document["gains"], dtype=float)
    states = tuple(document["states"])
    p_vertices = np.asarray(document["p_vertices"], dtype=float)
    if (
        gains.ndim != 3
        or gains.shape[2] != len(states)
        or not np.all(np.isfinite(gains))
        or (gains.shape[0] > 1 and gains.shape[0] != len(p_vertices))
    ):
        raise ValueError(
            f"path: malformed gains of shape {gains.shape} for states {states}"
        )
    metadata = {
        k: v
        for k, v in document.items()
        if k not in ("gains", "states", "p_vertices", "gamma")
    }
    return GainFile(gains, states, p_vertices, document.get("gamma"), metadata)
