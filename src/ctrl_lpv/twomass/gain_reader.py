"""Reading two-mass gain files: validated, rebuilt and re-checked.

`load_gains` trusts nothing in a file written by
`ctrl_lpv.twomass.gain_files.save_gains` (format in that module): it
validates every key, rebuilds the model from the file's `lpv_model`
options, and recomputes the certificate of the gains on that model.
"""

from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np

from .._design_files import _UNCHECKED
from ..persistence import DocumentReader, read_json
from ..synthesis import Hinf, StateFeedbackDesign
from ..synthesis.recheck import recheck
from ..synthesis.results import ORIGINAL_UNITS_TOL
from .gain_files import (
    FORMAT_1,
    GAIN_FILE_FORMAT,
    MODEL_KEYS,
    REQUIRED,
    SIGNS,
    GainFile,
)
from .model import INTEGRAL_WEIGHT, TORQUE_WEIGHT, lpv_model
from .parameters import Parameters

__all__ = ["load_gains"]


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
            FORMAT_1,
        ):
            raise ValueError(
                f"path: {self.path} is not a ctrl_lpv two-mass gain file "
                f"(expected format {GAIN_FILE_FORMAT!r})"
            )
        for key in REQUIRED:
            if key not in doc:
                why = (
                    " (it says which plant the gains were certified for: without "
                    "it they cannot be re-certified)"
                    if key == "model"
                    else ""
                )
                raise ValueError(
                    f"{self.path}: missing key {key!r}{why} (a gain file has the "
                    f"keys {', '.join(REQUIRED)})"
                )
        sign = doc["sign"]
        if not isinstance(sign, str) or sign not in SIGNS:
            raise self.fail(
                "sign", f"expected one of {list(SIGNS)}, got {sign!r} (refused)"
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
        version1 = doc["format"] == FORMAT_1
        u = self.labels(doc.get("u", ["Tm"] if version1 else None), "u")
        iu = self.indices("u", u, model.physical_inputs)
        raw = doc["gains"]
        count = len(raw) if isinstance(raw, list) else 0
        if count not in (1, 2):
            raise self.fail(
                "gains", "expected 1 (common) or one gain per vertex of p_vertices"
            )
        gains = SIGNS[sign] * self.array(raw, "gains", (count, len(iu), len(states)))
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
        unknown = set(options) - set(MODEL_KEYS)
        if unknown:
            raise self.fail("model", f"unknown options {sorted(unknown)}")
        if self.doc["format"] == FORMAT_1:  # format 1 had the defaults below
            if "params" in options:
                raise self.fail("model", "format 1 has no params")
            options = {"params": {}, "p_bounds": p_vertices.tolist(),
                       "formulation": "tracking", "integral": False,
                       "torque_weight": TORQUE_WEIGHT,
                       "integral_weight": INTEGRAL_WEIGHT} | options  # fmt: skip
        for key in MODEL_KEYS:
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
