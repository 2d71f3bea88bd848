"""Two-mass H-infinity designs in one call, and their gain files.

`design` picks the channels of `lpv_model` for a formulation and runs
Lemma 2 (one common gain) or Theorem 2 (vertex gains). `save_gains` writes
the certified gains as JSON together with the options of `lpv_model` they
were certified for; `load_gains` rebuilds that model itself and re-checks
the gains against it (never against matrices from the file), giving a
`GainFile` from which `GainFile.controller` builds the same controller as
`lpv_controller` would from the design.

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
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._design_files import _UNCHECKED
from ..persistence import DocumentReader, as_path, read_json, same_plant, write_json
from ..synthesis import (
    Hinf,
    StateFeedbackDesign,
    gain_scheduled_hinf,
    hinf_state_feedback,
)
from ..synthesis.recheck import recheck
from ..synthesis.results import ORIGINAL_UNITS_TOL
from .feedback import lpv_controller
from .model import INTEGRAL_WEIGHT, TORQUE_WEIGHT, lpv_model
from .parameters import Parameters

__all__ = ["design", "gains_document", "save_gains", "load_gains", "GainFile"]

#: Identifies the JSON layout written by `save_gains`.
GAIN_FILE_FORMAT = "ctrl_lpv.twomass.gains/2"
#: The previous layout: read only with its ``model`` entry (module doc).
_FORMAT_1 = "ctrl_lpv.twomass.gains/1"


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


#: States of the tracking formulation, the coordinates of `lpv_controller`.
TRACKING_STATES = ("e_m", "omega_m", "e_l", "omega_l")

#: Sign conventions a gain file may declare, and the factor to ``u = -K x``.
_SIGNS = {"u = -K x": 1.0, "u = K x": -1.0}

#: Keys every gain file must have.
_REQUIRED = ("format", "sign", "states", "p_vertices", "gains", "model")

#: Options of `lpv_model` a file names (all required in format 2).
_MODEL_KEYS = (
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
    unknown = set(given) - set(_MODEL_KEYS)
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


def load_gains(path: str | Path) -> GainFile:
    """Read gains written by `save_gains`, validate them and re-check them.

    Nothing in the file is trusted. The file's ``model`` entry (the
    options of `lpv_model`, drive data included) is validated and the
    model rebuilt with `lpv_model`; the keys, the sign convention, the
    parameter interval, the states and the channels are checked against
    that model; and the closed loop and (with ``P``) the bounded-real
    inequality of the claimed ``gamma`` (the Lyapunov inequality without
    ``gamma``) are recomputed in float64 on it at the vertices and interior
    points of the interval, with the library's rounding level. Vertex
    matrices in the file (``model_data``) are ignored; see the module
    docstring for the format and for files of format 1.

    Parameters
    ----------
    path : str or path
        A JSON file from `save_gains` (or ``ctrl-lpv design --save``).

    Returns
    -------
    `GainFile`
        The gains (in the sign ``u = -K x``), their states, the design
        metadata and what was re-checked.

    Raises
    ------
    TypeError
        If `path` is not a file name.
    ValueError
        Naming the file and the key: if the file is not a gain file (or
        not JSON, or nested too deeply), a key is missing or of the wrong
        type (a bool is not a number, a string not a bool), the sign
        convention is unknown, the model options do not build a model,
        ``p_vertices``, the states or the channels do not match it, a
        ``gamma`` has no channels ``w`` and ``z``, or the re-check fails
        (closed loop not stable, or the inequality of ``P`` and ``gamma``
        does not hold).

    Warns
    -----
    UserWarning
        If the file has no ``P``: only closed-loop stability is re-checked
        and the gains load with ``check["certified"]`` False.
    """
    path, document = read_json(path)
    return _GainReader(path, document).read()


class _GainReader(DocumentReader):
    """Validation of one gain document; every error names the file and key."""

    def read(self) -> GainFile:
        doc = self.doc
        if not isinstance(doc, dict) or doc.get("format") not in (
            GAIN_FILE_FORMAT,
            _FORMAT_1,
        ):
            raise ValueError(
                f"path: {self.path} is not a ctrl_lpv two-mass gain file "
                f"(expected format {GAIN_FILE_FORMAT!r})"
            )
        for key in _REQUIRED:
            if key not in doc:
                why = (
                    " (it says which plant the gains were certified for: without "
                    "it they cannot be re-certified)"
                    if key == "model"
                    else ""
                )
                raise ValueError(
                    f"{self.path}: missing key {key!r}{why} (a gain file has the "
                    f"keys {', '.join(_REQUIRED)})"
                )
        sign = doc["sign"]
        if not isinstance(sign, str) or sign not in _SIGNS:
            raise self.fail(
                "sign", f"expected one of {list(_SIGNS)}, got {sign!r} (refused)"
            )
        states = self.labels(doc["states"], "states")
        p_vertices = self.array(doc["p_vertices"], "p_vertices", (2,))
        self.check_interval(p_vertices)
        model = self.model(doc["model"], p_vertices)
        if states != tuple(model.state_labels):
            raise self.fail(
                "states",
                f"{list(states)} do not match the model's states "
                f"{list(model.state_labels)}",
            )
        version1 = doc["format"] == _FORMAT_1
        u = self.labels(doc.get("u", ["Tm"] if version1 else None), "u")
        iu = self.indices("u", u, model.physical_inputs)
        raw = doc["gains"]
        count = len(raw) if isinstance(raw, list) else 0
        if count not in (1, 2):
            raise self.fail(
                "gains", "expected 1 (common) or one gain per vertex of p_vertices"
            )
        gains = _SIGNS[sign] * self.array(raw, "gains", (count, len(iu), len(states)))
        gamma = self.number(doc.get("gamma"), "gamma", allow_none=True, positive=True)
        specs = []
        w = z = ()
        if gamma is not None:
            w = self.channel("w", model.physical_inputs)
            z = self.channel("z", model.output_labels)
            if set(w) & set(u):
                raise self.fail(
                    "u", f"{sorted(set(w) & set(u))} is also an exogenous input w"
                )
            iw = self.indices("w", w, model.physical_inputs)
            iz = self.indices("z", z, model.output_labels)
            specs = [(Hinf(w, z), (iw, iz), gamma)]
        P = None
        if doc.get("P") is not None:
            P = self.symmetric(doc["P"], "P", len(states))
        design = StateFeedbackDesign(
            system=model, method=str(doc.get("method", "gain file")),
            gains=tuple(gains), P=P, gamma=gamma, gamma_opt=None, w=w, u=u, z=z,
            certificate=_UNCHECKED, attempts=(),
        )  # fmt: skip
        result = recheck(design, specs)
        for what, message in result.failures:
            raise self.fail(
                what, f"{message} on the model rebuilt from the file's 'model'"
            )
        if P is None:
            warnings.warn(
                f"{self.path}: no Lyapunov matrix P in the file: only closed-loop "
                f"stability at {result.certificate.npoints} points was re-checked, "
                "not the H-infinity bound; the gains are not certified",
                UserWarning,
                stacklevel=3,
            )
        cert = result.certificate
        check = {
            "npoints": cert.npoints,
            "max_closed_loop_real": cert.max_closed_loop_real,
            "lyapunov_max_eig": None if P is None else cert.max_original_eig,
            "rounding_bound": None if P is None else ORIGINAL_UNITS_TOL,
            "certified": P is not None and result.verified,
        }
        metadata = {
            k: v
            for k, v in doc.items()
            if k not in ("gains", "states", "p_vertices", "gamma", "model_data")
        }
        return GainFile(
            gains, states, p_vertices, gamma, metadata, check,
            None if P is None else dataclasses.replace(design, certificate=cert),
        )  # fmt: skip

    def channel(self, key: str, labels) -> tuple[str, ...]:
        """``w`` or ``z`` of a claimed bound: non-empty names of the model."""
        if key not in self.doc:
            raise self.fail(key, "missing: a gamma needs its channels w and z")
        names = self.labels(self.doc[key], key)
        if not names:
            raise self.fail(key, "empty: a gamma needs channels w and z")
        return names

    def indices(self, key, names, labels) -> list[int]:
        missing = [s for s in names if s not in labels]
        if missing:
            raise self.fail(
                key, f"{missing} are not signals of the model {list(labels)}"
            )
        return [list(labels).index(s) for s in names]

    def check_interval(self, p_vertices: np.ndarray) -> None:
        if not p_vertices[0] < p_vertices[1]:
            raise self.fail(
                "p_vertices",
                "expected [lower, upper] with lower < upper, got "
                f"{p_vertices.tolist()}",
            )
        if p_vertices[0] < -1.0 or p_vertices[1] > 0.0:
            raise self.fail(
                "p_vertices",
                f"{p_vertices.tolist()} is outside the model's range -1 <= p <= 0 "
                "(p = -alpha / |theta_d|)",
            )

    def model(self, options, p_vertices):
        """`lpv_model` of the file's validated ``model`` options."""
        options = self.section("model", options)
        unknown = set(options) - set(_MODEL_KEYS)
        if unknown:
            raise self.fail("model", f"unknown options {sorted(unknown)}")
        if self.doc["format"] == _FORMAT_1:  # format 1 had the defaults below
            if "params" in options:
                raise self.fail("model", "format 1 has no params")
            options = {"params": {}, "p_bounds": p_vertices.tolist(),
                       "formulation": "tracking", "integral": False,
                       "torque_weight": TORQUE_WEIGHT,
                       "integral_weight": INTEGRAL_WEIGHT} | options  # fmt: skip
        for key in _MODEL_KEYS:
            if key not in options:
                raise self.fail(f"model.{key}", "missing")
        raw = self.section("model.params", options["params"])
        fields = {f.name for f in dataclasses.fields(Parameters)}
        if set(raw) - fields:
            raise self.fail(
                "model.params", f"unknown fields {sorted(set(raw) - fields)}"
            )
        values = {k: self.number(v, f"model.params.{k}") for k, v in raw.items()}
        bounds = self.array(options["p_bounds"], "model.p_bounds", (2,))
        formulation = self.string(
            options["formulation"], "model.formulation", ("paper", "tracking")
        )
        integral = self.boolean(options["integral"], "model.integral")
        weights = {
            k: self.number(options[k], f"model.{k}", positive=True)
            for k in ("torque_weight", "integral_weight")
        }
        try:
            model = lpv_model(
                Parameters(**values), tuple(bounds), formulation, integral, **weights
            )
        except (TypeError, ValueError) as exc:
            raise self.fail("model", str(exc)) from None
        if not np.array_equal(model.domain.points[:, 0], p_vertices):
            raise self.fail(
                "p_vertices",
                f"{p_vertices.tolist()} differ from the model's p_bounds "
                f"{bounds.tolist()}",
            )
        return model
