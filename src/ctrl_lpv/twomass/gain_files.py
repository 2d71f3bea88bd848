"""Gain files of two-mass designs: the format, `GainFile`, writing.

`save_gains` writes the certified gains of a `design` as JSON together
with the options of `lpv_model` they were certified for;
`ctrl_lpv.twomass.gain_reader.load_gains` rebuilds that model itself and
re-checks the gains against it (never against matrices from the file),
giving a `GainFile` from which `GainFile.controller` builds the same
controller as `lpv_controller` would from the design.

Gain file format ``"ctrl_lpv.twomass.gains/2"`` (a JSON object):
``format``; ``sign`` (``"u = -K x"``, or ``"u = K x"`` for the paper's
sign); ``states``; ``w``, ``u``, ``z`` (channels); ``p_vertices``
(``[lower, upper]``, equal to ``model.p_bounds``); ``gains`` (one
``m x n`` gain, or one per entry of ``p_vertices``); ``gamma`` (the claimed
H-infinity bound from ``w`` to ``z``, or null); ``P`` (the Lyapunov
matrix of the claim); ``model`` (``params``: every field of `Parameters`,
``p_bounds``, ``formulation``, ``integral``, ``torque_weight``,
``integral_weight``: the `lpv_model` call the loader makes); informative
entries (``method``, ``gamma_opt``, ``backoff``, ``certificate``) and any
extra metadata. A ``model_data`` entry (vertex matrices, written by format
1) is ignored. Files of format ``/1`` are read when they have the
``model`` entry (their drive data are the default `Parameters`, the only
ones that format could load) and refused without it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..persistence import as_path, same_plant, write_json
from ..synthesis import StateFeedbackDesign
from .feedback import lpv_controller
from .model import INTEGRAL_WEIGHT, TORQUE_WEIGHT, lpv_model
from .parameters import Parameters

__all__ = ["GAIN_FILE_FORMAT", "GainFile", "gains_document", "save_gains"]

#: Identifies the JSON layout written by `save_gains`.
GAIN_FILE_FORMAT = "ctrl_lpv.twomass.gains/2"
#: The previous layout: read only with its ``model`` entry (module doc).
FORMAT_1 = "ctrl_lpv.twomass.gains/1"

#: States of the tracking formulation, the coordinates of `lpv_controller`.
TRACKING_STATES = ("e_m", "omega_m", "e_l", "omega_l")

#: Sign conventions a gain file may declare, and the factor to ``u = -K x``.
SIGNS = {"u = -K x": 1.0, "u = K x": -1.0}

#: Keys every gain file must have.
REQUIRED = ("format", "sign", "states", "p_vertices", "gains", "model")

#: Options of `lpv_model` a file names (all required in format 2).
MODEL_KEYS = (
    "params", "p_bounds", "formulation", "integral", "torque_weight",
    "integral_weight",
)  # fmt: skip


@dataclass(frozen=True)
class GainFile:
    """Gains read from a file written by `save_gains`, re-checked on load.

    Attributes
    ----------
    gains : ndarray
        ``N x m x n`` gains for ``u = -K x`` (``N = 1`` for a common gain,
        else one per vertex of `p_vertices`), converted to this sign if the
        file declares ``"sign": "u = K x"``.
    states : tuple of str
        State labels of the gains' columns.
    p_vertices : ndarray
        Values of ``p`` at the vertices (ascending), in the order of `gains`.
    gamma : float or None
        The H-infinity bound the file claims (certified only when
        ``check["certified"]``).
    metadata : dict
        Everything else in the file (method, model options, certificate
        summary as written, library version).
    check : dict
        What `load_gains` recomputed in float64 on the model it rebuilt
        from the file's ``model`` options (the file's own ``"verified"`` is
        not trusted): ``npoints`` (parameter points, the vertices
        included), ``max_closed_loop_real`` (largest real part of the
        closed-loop eigenvalues over them), ``lyapunov_max_eig`` (largest
        Jacobi-normalised eigenvalue of the bounded-real inequality with
        the file's ``P`` and `gamma`, or of the Lyapunov inequality without
        `gamma`; None when the file has no ``P``), ``rounding_bound`` (the
        rounding level it must stay below) and ``certified`` (True only
        when the inequalities hold at every point).
    design : `ctrl_lpv.StateFeedbackDesign` or None
        The design rebuilt on that model (its ``certificate`` the
        recomputed one; ``closed_loop``, ``controller``); None without
        ``P``.
    """

    gains: np.ndarray
    states: tuple[str, ...]
    p_vertices: np.ndarray
    gamma: float | None
    metadata: dict = field(default_factory=dict)
    check: dict = field(default_factory=dict)
    design: StateFeedbackDesign | None = None

    @property
    def scheduled(self) -> bool:
        """Whether the file holds one gain per vertex."""
        return self.gains.shape[0] > 1

    def gain(self, p: float | None = None) -> np.ndarray:
        """Gain at `p`, interpolated linearly between the vertex gains.

        Parameters
        ----------
        p : float, optional
            Backlash parameter in the design interval `p_vertices` (required
            for vertex gains, ignored for a common gain).

        Returns
        -------
        ndarray
            ``m x n`` gain for ``u = -K x``.

        Raises
        ------
        ValueError
            If `p` is missing for vertex gains or outside the interval.
        """
        if not self.scheduled:
            return self.gains[0].copy()
        if p is None:
            raise ValueError("p: vertex gains need the parameter value")
        lo, hi = float(self.p_vertices[0]), float(self.p_vertices[-1])
        p = float(p)
        slack = 1e-12 * max(1.0, hi - lo)
        if not (lo - slack <= p <= hi + slack):
            raise ValueError(f"p: {p} is outside the design interval [{lo}, {hi}]")
        s = (min(max(p, lo), hi) - lo) / (hi - lo)
        return (1.0 - s) * self.gains[0] + s * self.gains[-1]

    def controller(self, **kwargs):
        """Two-mass controller of these gains (see `lpv_controller`).

        Parameters
        ----------
        **kwargs
            ``alpha_estimate`` (required for vertex gains, refused for a
            common gain), ``torque_limit``, ``name``.

        Returns
        -------
        `control.NonlinearIOSystem`
            The `lpv_controller` of these gains: inputs ``["theta_m",
            "omega_m", "theta_l", "omega_l", "theta_r"]``, output
            ``["Tm"]``, state ``["int_e_l"]`` for integral designs.

        Raises
        ------
        ValueError
            If the gains are not on the tracking formulation's states (the
            coordinates `lpv_controller` computes), or for the arguments'
            errors of `lpv_controller`.
        """
        if self.states[:4] != TRACKING_STATES or self.states[4:] not in (
            (),
            ("int_e_l",),
        ):
            raise ValueError(
                f"gains: the controller computes the states {list(TRACKING_STATES)}"
                f"[+ int_e_l]; these gains are on {list(self.states)}"
            )
        if self.gains.shape[1] != 1:
            raise ValueError("gains: a two-mass controller has one input, Tm")
        if self.scheduled:
            return lpv_controller(
                self.gains[:, 0, :], p_bounds=tuple(self.p_vertices), **kwargs
            )
        return lpv_controller(self.gains[0], **kwargs)


def _model_options(design: StateFeedbackDesign, given) -> dict:
    """The `lpv_model` options of `design`, checked to rebuild its plant."""
    if given is None:
        given = {}
    if not isinstance(given, dict):
        raise TypeError(f"model: expected a dict of lpv_model options, got {given!r}")
    unknown = set(given) - set(MODEL_KEYS)
    if unknown:
        raise ValueError(f"model: unknown lpv_model options {sorted(unknown)}")
    system = design.system
    params = given.get("params", Parameters())
    if isinstance(params, dict):
        params = Parameters(**params)
    if not isinstance(params, Parameters):
        raise TypeError(f"model: params: expected twomass.Parameters, got {params!r}")
    states = tuple(system.state_labels)
    formulation = given.get(
        "formulation", "paper" if "theta_r" in system.input_labels else "tracking"
    )
    options = {
        "params": dataclasses.asdict(params),
        "p_bounds": [
            float(b) for b in given.get("p_bounds", system.domain.points[:, 0])
        ],
        "formulation": formulation,
        "integral": bool(given.get("integral", "int_e_l" in states)),
        "torque_weight": float(given.get("torque_weight", TORQUE_WEIGHT)),
        "integral_weight": float(given.get("integral_weight", INTEGRAL_WEIGHT)),
    }
    rebuilt = _rebuild(options, params)
    difference = same_plant(rebuilt, system, rtol=1e-12)
    if difference is not None:
        raise ValueError(
            f"model: lpv_model of {options} is not the design's plant ({difference}); "
            "pass model={...} with the options and params the design was made with"
        )
    return options


def _rebuild(options: dict, params: Parameters):
    return lpv_model(
        params,
        tuple(options["p_bounds"]),
        options["formulation"],
        options["integral"],
        torque_weight=options["torque_weight"],
        integral_weight=options["integral_weight"],
    )


def gains_document(design: StateFeedbackDesign, **metadata) -> dict:
    """The JSON document `save_gains` writes for a two-mass design.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        A design on `lpv_model` (one scheduling parameter ``p``, a constant
        Lyapunov matrix).
    **metadata
        Extra JSON-serializable entries. ``model`` is special: the options
        of `lpv_model` the design was made with (``params`` as a
        `Parameters` or a dict of its fields, ``p_bounds``, ``formulation``,
        ``integral``, ``torque_weight``, ``integral_weight``); those not
        given are inferred (the default drive data and weights, the
        design's interval and states), and the result must rebuild the
        design's plant exactly.

    Returns
    -------
    dict
        The format-2 document (see the module docstring).

    Raises
    ------
    TypeError
        If `design` is not a `ctrl_lpv.StateFeedbackDesign`.
    ValueError
        If the design is not on the single parameter ``p``, has a
        parameter-dependent Lyapunov matrix (use ``design.save``), or the
        model options do not rebuild its plant.
    """
    if not isinstance(design, StateFeedbackDesign):
        raise TypeError(
            f"design: expected a StateFeedbackDesign, got {type(design).__name__}"
        )
    system = design.system
    if list(getattr(system.domain, "names", ())) != ["p"]:
        raise ValueError("design: expected a design on twomass.lpv_model (parameter p)")
    if design.lyapunov != "constant":
        raise ValueError(
            "design: a gain file holds one Lyapunov matrix; save a design with "
            "lyapunov='affine' with design.save(path)"
        )
    model = _model_options(design, metadata.pop("model", None))
    p_vertices = [float(v[0]) for v in system.domain.points]
    order = np.argsort(p_vertices)
    gain_order = order if design.scheduled else [0]
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
        "gains": [design.gains[i].tolist() for i in gain_order],
        "gamma": design.gamma,
        "gamma_opt": design.gamma_opt,
        "backoff": design.backoff,
        "certificate": {"verified": bool(cert.verified), "summary": str(cert)},
        "P": np.asarray(design.P, dtype=float).tolist(),
        **metadata,
        "model": model,
    }


def save_gains(design: StateFeedbackDesign, path: str | Path, **metadata) -> Path:
    """Write a two-mass design's gains and certificate data as JSON.

    The file is written atomically (a temporary file in the same folder,
    then `os.replace`).

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        A design on `lpv_model` (see `gains_document`).
    path : str or path
        File to write; its folder must exist.
    **metadata
        Extra JSON-serializable entries; ``model``: the options of
        `lpv_model` used (see `gains_document`).

    Returns
    -------
    `pathlib.Path`
        The file written.

    Raises
    ------
    TypeError, ValueError
        For a `path` that is not a file name, and as `gains_document`.
    """
    path = as_path(path)
    return write_json(path, gains_document(design, **metadata))
