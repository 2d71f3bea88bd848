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
import warnings
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


#: States of the tracking formulation, the coordinates of `lpv_controller`.
TRACKING_STATES = ("e_m", "omega_m", "e_l", "omega_l")

#: Sign conventions a gain file may declare, and the factor to ``u = -K x``.
_SIGNS = {"u = -K x": 1.0, "u = K x": -1.0}

#: Keys every gain file must have.
_REQUIRED = ("format", "sign", "states", "p_vertices", "gains")

#: Number of parameter points (vertices included) of the check on load.
_CHECK_POINTS = 21


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
        The H-infinity bound the file claims.
    metadata : dict
        Everything else in the file (method, model options, certificate
        summary as written, library version).
    check : dict
        What `load_gains` recomputed in float64 (the file's own
        ``"verified"`` is not trusted): ``npoints`` (parameter points, the
        vertices included), ``max_closed_loop_real`` (largest real part of
        the closed-loop eigenvalues over them), ``lyapunov_max_eig``
        (largest eigenvalue of the diagonally scaled Lyapunov or bounded-real
        inequality with the file's ``P`` and `gamma`, None when the file has
        no ``P``), ``rounding_bound`` (the float64 error bound it was
        compared with) and ``certified`` (True only when that inequality
        holds at every point).
    """

    gains: np.ndarray
    states: tuple[str, ...]
    p_vertices: np.ndarray
    gamma: float | None
    metadata: dict = field(default_factory=dict)
    check: dict = field(default_factory=dict)

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
        Extra JSON-serializable entries, e.g. ``model``: the options of
        `lpv_model` used (``p_bounds``, ``formulation``, ``integral``,
        ``torque_weight``, ``integral_weight``), which `load_gains` uses to
        rebuild the model and compare it with the stored one.

    Returns
    -------
    dict
        Format tag, method, sign convention, states, channels, vertex values
        of ``p`` (ascending) and the gains in that order, ``gamma``,
        ``gamma_opt``, back-off, a certificate summary, and the data to
        re-check the certificate: the Lyapunov matrix ``P`` and the model's
        vertex matrices (``model_data``).

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
    system = design.system
    domain = system.domain
    if list(getattr(domain, "names", ())) != ["p"]:
        raise ValueError("design: expected a design on twomass.lpv_model (parameter p)")
    p_vertices = [float(v[0]) for v in domain.points]
    order = np.argsort(p_vertices)
    gain_order = order if design.scheduled else [0]
    cert = design.certificate
    vertices = system.vertex_data()
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
        "certificate": {
            "verified": bool(cert.verified),
            "worst_lmi": cert.worst_lmi.name,
            "worst_lmi_max_eig": _jsonable(float(cert.worst_lmi.max_eig)),
            "margin": cert.margin,
            "max_closed_loop_real": _jsonable(float(cert.max_closed_loop_real)),
        },
        "P": np.asarray(design.P, dtype=float).tolist(),
        "model_data": {
            "states": list(system.state_labels),
            "inputs": list(system.input_labels),
            "outputs": list(system.output_labels),
            "vertices": [
                dict(zip("ABCD", (np.asarray(M, float).tolist() for M in vertices[i])))
                for i in order
            ],
        },
        **metadata,
    }


def save_gains(design: StateFeedbackDesign, path: str | Path, **metadata) -> Path:
    """Write a two-mass design's gains and certificate data as JSON.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        A design on `lpv_model` (see `gains_document`).
    path : str or path
        File to write (parent folders are created).
    **metadata
        Extra JSON-serializable entries (e.g. ``model``, the options of
        `lpv_model` used).

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
    """Read gains written by `save_gains`, validate them and re-check them.

    Nothing in the file is trusted: the keys, the sign convention, the
    parameter interval and the state names are validated against the
    two-mass model, and the closed loop is recomputed in float64 at the
    vertices and interior points of the interval on the file's model (its
    stored vertex matrices, compared with `lpv_model` of its ``model``
    options when both are present). When the file carries the Lyapunov
    matrix ``P`` (files of this version do), the bounded-real inequality of
    the claimed ``gamma`` (or the Lyapunov inequality without ``gamma``) is
    re-checked at the same points, with a float64 rounding bound. The
    file's ``"verified"`` flag is ignored; see `GainFile.check`.

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
    ValueError
        Naming the file and the key: if the file is not a gain file, a key
        is missing or malformed, the sign convention is unknown, ``p`` lies
        outside ``[-1, 0]`` or does not match the model, the states do not
        match the model's, or the re-check fails (closed loop not stable, or
        the inequality of ``P`` and ``gamma`` does not hold).

    Warns
    -----
    UserWarning
        If the file has no ``P``: only closed-loop stability at the checked
        points is re-checked, not the H-infinity bound.
    """
    path = Path(path)
    try:
        document = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ValueError(f"path: {path} is not valid JSON ({exc})") from None
    except UnicodeDecodeError:
        raise ValueError(f"path: {path} is not a text file") from None
    return _GainReader(path, document).read()


class _GainReader:
    """Validation of one gain document; every error names the file and key."""

    def __init__(self, path: Path, document):
        self.path = path
        self.doc = document

    def fail(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.path}: key {key!r}: {message}")

    def array(self, key: str, ndim: int, source=None) -> np.ndarray:
        value = self.doc[key] if source is None else source
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise self.fail(key, "expected an array of numbers") from None
        if array.ndim != ndim or array.size == 0 or not np.all(np.isfinite(array)):
            raise self.fail(
                key, f"expected a finite {ndim}-d array, got shape {array.shape}"
            )
        return array

    def labels(self, key: str, source=None) -> tuple[str, ...]:
        value = self.doc.get(key) if source is None else source
        if not isinstance(value, list) or not all(isinstance(s, str) for s in value):
            raise self.fail(key, f"expected a list of names, got {value!r}")
        return tuple(value)

    def read(self) -> GainFile:
        doc = self.doc
        if not isinstance(doc, dict) or doc.get("format") != GAIN_FILE_FORMAT:
            raise ValueError(
                f"path: {self.path} is not a ctrl_lpv two-mass gain file "
                f"(expected format {GAIN_FILE_FORMAT!r})"
            )
        for key in _REQUIRED:
            if key not in doc:
                raise ValueError(
                    f"{self.path}: missing key {key!r} (a gain file has the keys "
                    f"{', '.join(_REQUIRED)})"
                )
        sign = doc["sign"]
        if sign not in _SIGNS:
            raise self.fail(
                "sign", f"expected one of {list(_SIGNS)}, got {sign!r} (refused)"
            )
        gains = _SIGNS[sign] * self.array("gains", 3)
        states = self.labels("states")
        p_vertices = self.array("p_vertices", 1)
        self.check_interval(p_vertices)
        if gains.shape[2] != len(states):
            raise self.fail(
                "gains", f"{gains.shape[2]} columns for {len(states)} states"
            )
        if gains.shape[0] not in (1, len(p_vertices)):
            raise self.fail(
                "gains",
                f"{gains.shape[0]} gains: expected 1 (common) or one per vertex "
                f"of p_vertices ({len(p_vertices)})",
            )
        gamma = doc.get("gamma")
        if gamma is not None and not (
            isinstance(gamma, (int, float)) and math.isfinite(gamma) and gamma > 0
        ):
            raise self.fail(
                "gamma", f"expected a positive number or null, got {gamma!r}"
            )
        u = self.labels("u") if "u" in doc else ("Tm",)
        if gains.shape[1] != len(u):
            raise self.fail("gains", f"{gains.shape[1]} rows for the inputs u = {u}")
        model = self.model(p_vertices, states)
        check = self.recheck(model, gains, p_vertices, gamma, u)
        metadata = {
            k: v
            for k, v in doc.items()
            if k not in ("gains", "states", "p_vertices", "gamma")
        }
        return GainFile(gains, states, p_vertices, gamma, metadata, check)

    def check_interval(self, p_vertices: np.ndarray) -> None:
        if len(p_vertices) != 2 or not p_vertices[0] < p_vertices[1]:
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

    def model(self, p_vertices, states) -> dict:
        """The file's model: vertex matrices and labels, validated."""
        doc = self.doc
        rebuilt = None
        options = doc.get("model")
        if options is not None:
            rebuilt = self.rebuild(options, p_vertices)
        stored = doc.get("model_data")
        if stored is not None:
            model = self.stored_model(stored)
        elif rebuilt is not None:
            model = rebuilt
        else:  # an older file without either: the default tracking model
            integral = "int_e_l" in states
            model = self.rebuild(
                {"p_bounds": p_vertices.tolist(), "formulation": "tracking",
                 "integral": integral},
                p_vertices,
            )  # fmt: skip
        if rebuilt is not None and stored is not None:
            same = len(rebuilt["vertices"]) == len(model["vertices"]) and all(
                np.shape(a) == np.shape(b) and np.allclose(a, b, rtol=1e-9, atol=0)
                for va, vb in zip(rebuilt["vertices"], model["vertices"])
                for a, b in zip(va, vb)
            )
            if not same or rebuilt["states"] != model["states"]:
                raise self.fail(
                    "model_data",
                    "does not match lpv_model of the file's 'model' options",
                )
        if tuple(states) != model["states"]:
            raise self.fail(
                "states",
                f"{list(states)} do not match the model's states "
                f"{list(model['states'])}",
            )
        return model

    def rebuild(self, options, p_vertices) -> dict:
        if not isinstance(options, dict):
            raise self.fail(
                "model", f"expected a dict of lpv_model options, got {options!r}"
            )
        known = {
            "p_bounds",
            "formulation",
            "integral",
            "torque_weight",
            "integral_weight",
        }
        unknown = set(options) - known
        if unknown:
            raise self.fail("model", f"unknown options {sorted(unknown)}")
        bounds = options.get("p_bounds", p_vertices.tolist())
        try:
            system = lpv_model(
                None,
                tuple(bounds),
                options.get("formulation", "tracking"),
                bool(options.get("integral", False)),
                torque_weight=options.get("torque_weight", TORQUE_WEIGHT),
                integral_weight=options.get("integral_weight", INTEGRAL_WEIGHT),
            )
        except (TypeError, ValueError) as exc:
            raise self.fail("model", str(exc)) from None
        model_p = sorted(float(v[0]) for v in system.domain.points)
        if not np.allclose(model_p, p_vertices, rtol=0, atol=1e-12):
            raise self.fail(
                "p_vertices",
                f"{p_vertices.tolist()} differ from the model's p_bounds {model_p}",
            )
        order = np.argsort([float(v[0]) for v in system.domain.points])
        data = system.vertex_data()
        return {
            "inputs": tuple(system.input_labels),
            "outputs": tuple(system.output_labels),
            "states": tuple(system.state_labels),
            "vertices": [tuple(np.asarray(M, float) for M in data[i]) for i in order],
        }

    def stored_model(self, stored) -> dict:
        key = "model_data"
        if not isinstance(stored, dict) or not isinstance(stored.get("vertices"), list):
            raise self.fail(key, "expected inputs, outputs and vertices")
        states = self.labels(key, stored.get("states", self.doc["states"]))
        inputs = self.labels(key, stored.get("inputs"))
        outputs = self.labels(key, stored.get("outputs"))
        vertices = []
        for vertex in stored["vertices"]:
            if not isinstance(vertex, dict) or set(vertex) != set("ABCD"):
                raise self.fail(key, "every vertex needs A, B, C and D")
            A, B, C, D = (self.array(key, 2, vertex[k]) for k in "ABCD")
            n = A.shape[0]
            if (
                A.shape != (n, n)
                or n != len(states)
                or B.shape != (n, len(inputs))
                or C.shape != (len(outputs), n)
                or D.shape != (len(outputs), len(inputs))
            ):
                raise self.fail(key, "vertex matrices of inconsistent shapes")
            vertices.append((A, B, C, D))
        if len(vertices) != 2 or vertices[0][0].shape != vertices[1][0].shape:
            raise self.fail(key, "expected two vertices of the same size")
        return {
            "inputs": inputs,
            "outputs": outputs,
            "states": states,
            "vertices": vertices,
        }

    def indices(self, key, names, labels) -> list[int]:
        missing = [s for s in names if s not in labels]
        if missing:
            raise self.fail(
                key, f"{missing} are not signals of the model {list(labels)}"
            )
        return [labels.index(s) for s in names]

    def recheck(self, model, gains, p_vertices, gamma, u) -> dict:
        """Closed loop and (with P) the certificate's inequality in float64."""
        doc = self.doc
        n = model["vertices"][0][0].shape[0]
        if gains.shape[2] != n:
            raise self.fail(
                "gains", f"{gains.shape[2]} columns for a model of {n} states"
            )
        iu = self.indices("u", u, model["inputs"])
        iw = self.indices("w", self.labels("w") if "w" in doc else (), model["inputs"])
        iz = self.indices("z", self.labels("z") if "z" in doc else (), model["outputs"])
        P = None
        if doc.get("P") is not None:
            P = self.array("P", 2)
            if P.shape != (n, n) or not np.allclose(P, P.T, rtol=1e-12, atol=0):
                raise self.fail("P", f"expected a symmetric {n} x {n} matrix")
            P = 0.5 * (P + P.T)
            if np.linalg.eigvalsh(P)[0] <= 0:
                raise self.fail("P", "is not positive definite")
        (A0, B0, C0, D0), (A1, B1, C1, D1) = model["vertices"]
        worst_real, worst_lmi, worst_bound = -np.inf, -np.inf, 0.0
        for s in np.linspace(0.0, 1.0, _CHECK_POINTS):
            A, B, C, D = ((1 - s) * X0 + s * X1 for X0, X1 in
                          ((A0, A1), (B0, B1), (C0, C1), (D0, D1)))  # fmt: skip
            K = gains[0] if gains.shape[0] == 1 else (1 - s) * gains[0] + s * gains[1]
            Acl = A - B[:, iu] @ K
            real = float(np.linalg.eigvals(Acl).real.max())
            p = (1 - s) * p_vertices[0] + s * p_vertices[1]
            if not real < 0:
                raise self.fail(
                    "gains",
                    f"the closed loop is not stable at p = {p:.6g} "
                    f"(max Re of the eigenvalues {real:.4g}) on the file's model",
                )
            worst_real = max(worst_real, real)
            if P is None:
                continue
            absK = np.abs(K)
            lmi, bound = _certificate_inequality(
                P,
                Acl,
                B[:, iw],
                C[iz] - D[np.ix_(iz, iu)] @ K,
                D[np.ix_(iz, iw)],
                gamma,
                np.abs(A) + np.abs(B[:, iu]) @ absK,
                np.abs(C[iz]) + np.abs(D[np.ix_(iz, iu)]) @ absK,
            )
            if not lmi < -bound:
                what = "bounded-real" if gamma is not None else "Lyapunov"
                raise self.fail(
                    "P",
                    f"the {what} inequality of P"
                    + (f" and gamma = {gamma:.6g}" if gamma is not None else "")
                    + f" fails at p = {p:.6g} (largest scaled eigenvalue {lmi:.3g}, "
                    f"float64 bound {bound:.3g}): the file's certificate is not valid",
                )
            if lmi > worst_lmi:
                worst_lmi, worst_bound = lmi, bound
        if P is None:
            warnings.warn(
                f"{self.path}: no Lyapunov matrix P in the file: only closed-loop "
                f"stability at {_CHECK_POINTS} points was re-checked, not the "
                "H-infinity bound",
                UserWarning,
                stacklevel=4,
            )
        return {
            "npoints": _CHECK_POINTS,
            "max_closed_loop_real": worst_real,
            "lyapunov_max_eig": None if P is None else float(worst_lmi),
            "rounding_bound": None if P is None else float(worst_bound),
            "certified": P is not None,
        }


def _certificate_inequality(P, A, Bw, C, D, gamma, absA, absC) -> tuple[float, float]:
    """Largest eigenvalue of the scaled certificate inequality, and its error.

    ``[[A'P + P A, C', P Bw], [C, -gamma^2 I, D], [Bw' P, D', -I]] < 0`` (the
    bounded-real lemma, the form of Lemma 2 and Theorem 2 in ``P = W^-1``)
    or ``A'P + P A < 0`` without `gamma`. The matrix is scaled by a positive
    diagonal congruence to unit diagonal (same inertia); the second value
    bounds the 2-norm of the float64 rounding error of the scaled matrix,
    from the magnitudes `absA` (of ``|A_model| + |B_u| |K|``) and `absC`
    (of ``|C_z| + |D_zu| |K|``) of the closed-loop data.
    """
    n = A.shape[0]
    PA = P @ A
    top = PA + PA.T
    err = np.abs(P) @ absA
    err = err + err.T
    if gamma is None:
        M, E = top, err
    else:
        nz, nw = C.shape[0], Bw.shape[1]
        PB = P @ Bw
        M = np.block(
            [
                [top, C.T, PB],
                [C, -(gamma**2) * np.eye(nz), D],
                [PB.T, D.T, -np.eye(nw)],
            ]
        )
        E = np.zeros_like(M)
        E[:n, :n] = err
        E[n : n + nz, :n] = absC
        E[n + nz :, :n] = (np.abs(P) @ np.abs(Bw)).T
        E[:n, n:] = E[n:, :n].T
        E[n:, n:] = np.abs(M[n:, n:])
    if np.any(np.diag(M) >= 0):
        return float(np.max(np.diag(M))), 0.0
    d = 1.0 / np.sqrt(-np.diag(M))
    S = d[:, None] * M * d[None, :]
    ES = d[:, None] * E * d[None, :]
    size = M.shape[0]
    bound = 4 * size * np.finfo(float).eps * (np.linalg.norm(ES, 2) + 1.0)
    return float(np.linalg.eigvalsh(0.5 * (S + S.T))[-1]), float(bound)
