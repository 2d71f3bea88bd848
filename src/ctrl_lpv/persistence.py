"""Saving designs to JSON and loading them back, re-certified.

``design.save(path)`` writes one JSON document; `load` reads it, rebuilds
the plant from the matrices in the file (checked: finite, consistent
shapes, signal names), rebuilds the design and re-checks its certificate
in float64 against that plant, trusting nothing the file says about
itself. A design whose check fails is refused (`ValueError` naming the
file, the key and the failed statement): a loaded design is always
verified.

File format ``"ctrl_lpv.design/1"``, a JSON object:

``format``
    ``"ctrl_lpv.design/1"``.
``type``
    ``"StateFeedbackDesign"`` or ``"SaturatedDesign"``.
``plant``
    ``name``, ``dt`` (0, true or the sampling period), ``inputs`` (the
    physical inputs), ``outputs``, ``states``, ``domain`` (``{"type":
    "box", "names", "lower", "upper"}``, ``{"type": "simplex", "names"}``
    or ``{"type": "polytope", "names", "points"}``), ``nominal``,
    ``scheduling`` (null or ``"inputs"``; a callable is not saved),
    ``integral_signals`` (``{state: signal}`` of `integral_augmentation`,
    or null) and ``vertices`` (one ``{"A", "B", "C", "D"}`` per vertex of
    the domain, in its order).
``design``
    What the design holds: gains (``u = -K x``), the Lyapunov matrix
    ``P`` and the claimed bounds with their specs, signal names (see
    `design_document`).
``certificate``
    The certificate as it was when saved (``summary`` and
    `ctrl_lpv.certificate.Certificate.to_dict`: ``statement``,
    ``verified``, ``checks``): informative only, never read.
``library``
    The ``ctrl_lpv`` version that wrote the file.

Writes are atomic: the document goes to a temporary file in the target's
folder, which then replaces the target (`os.replace`), so an interrupted
save leaves either the old file or the new one.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ._checks import real_number
from ._output import staged_file

__all__ = ["save", "load", "read_json", "write_json", "DocumentReader"]

#: Identifies the layout written by `save`.
DESIGN_FORMAT = "ctrl_lpv.design/1"


# ----------------------------------------------------------------------
# Files
# ----------------------------------------------------------------------
def as_path(path, name: str = "path") -> Path:
    """`path` as a `pathlib.Path`, or a `TypeError`/`ValueError` naming `name`."""
    if isinstance(path, bytes) or not isinstance(path, (str, os.PathLike)):
        raise TypeError(
            f"{name}: expected a file name (str or path-like), got {path!r}"
        )
    path = Path(path)
    if str(path) in ("", "."):
        raise ValueError(f"{name}: empty file name")
    return path


def _refuse_constant(token):
    raise ValueError(f"non-finite number {token} (JSON has none)")


def read_json(path, name: str = "path"):
    """Read a JSON file: ``(Path, document)``, errors naming `name`.

    Non-finite numbers (``NaN``, ``Infinity``) and documents nested beyond
    the parser's recursion limit are refused with a `ValueError`.
    """
    path = as_path(path, name)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ValueError(f"{name}: no such file: {path}") from None
    except IsADirectoryError:
        raise ValueError(f"{name}: {path} is a folder, not a file") from None
    except UnicodeDecodeError:
        raise ValueError(f"{name}: {path} is not a UTF-8 text file") from None
    except OSError as exc:
        raise ValueError(f"{name}: cannot read {path} ({exc.strerror})") from None
    try:
        return path, json.loads(text, parse_constant=_refuse_constant)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{name}: {path} is not valid JSON ({exc})") from None
    except RecursionError:
        raise ValueError(
            f"{name}: {path} is nested too deeply to be a design file"
        ) from None
    except ValueError as exc:
        raise ValueError(f"{name}: {path}: {exc}") from None


def write_json(path, document, name: str = "path") -> Path:
    """Write `document` as JSON to `path` atomically (`_output.staged_file`).

    The folder must exist. Non-finite numbers are refused (`ValueError`).
    """
    path = as_path(path, name)
    folder = path.parent
    if not folder.is_dir():
        raise ValueError(f"{name}: the folder {folder} does not exist")
    if path.is_dir():
        raise ValueError(f"{name}: {path} is a folder")
    try:
        text = json.dumps(document, indent=1, allow_nan=False) + "\n"
    except ValueError as exc:
        raise ValueError(
            f"{name}: the document has a non-finite number ({exc})"
        ) from None
    with staged_file(path) as work:
        work.write_text(text, encoding="utf-8")
    return path


# ----------------------------------------------------------------------
# Strict reading of a document: every error names the file and the key
# ----------------------------------------------------------------------
# `DocumentReader.section`'s default: the entry of the document itself (a
# nested ``null`` must not fall back to it).
_TOP_LEVEL = object()


class DocumentReader:
    """Typed access to a JSON document; every error names file and key."""

    def __init__(self, path: Path, document):
        self.path = path
        self.doc = document

    def fail(self, key: str, message: str) -> ValueError:
        return ValueError(f"{self.path}: key {key!r}: {message}")

    def section(self, key: str, value=_TOP_LEVEL) -> dict:
        """`value` as a JSON object; by default the document's entry `key`."""
        if value is _TOP_LEVEL:
            value = self.doc.get(key)
        if not isinstance(value, dict):
            raise self.fail(key, f"expected a JSON object, got {_short(value)}")
        return value

    def get(self, section: dict, key: str, prefix: str = ""):
        if key not in section:
            raise self.fail(prefix + key, "missing")
        return section[key]

    def array(self, value, key: str, shape) -> np.ndarray:
        """A finite float array of `shape` (JSON numbers only, no booleans)."""
        if not _numeric_lists(value, len(shape)):
            raise self.fail(
                key, f"expected a {len(shape)}-d array of numbers, got {_short(value)}"
            )
        try:
            array = np.array(value, dtype=float)
        except (ValueError, OverflowError):
            raise self.fail(key, "expected a rectangular array of numbers") from None
        if array.size == 0 and int(np.prod(shape)) == 0:
            array = np.zeros(shape)
        if array.shape != tuple(shape):
            raise self.fail(key, f"expected shape {tuple(shape)}, got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise self.fail(key, "entries must be finite")
        return array

    def number(self, value, key: str, **limits) -> float | None:
        """A real number (not a bool or a string), with `real_number`'s limits."""
        try:
            return real_number(value, key, **limits)
        except (TypeError, ValueError) as exc:
            raise self.fail(key, str(exc).split(": ", 1)[-1]) from None

    def boolean(self, value, key: str) -> bool:
        if not isinstance(value, bool):
            raise self.fail(key, f"expected true or false, got {_short(value)}")
        return value

    def string(self, value, key: str, choices=None) -> str:
        if not isinstance(value, str) or (choices is not None and value not in choices):
            expected = "a string" if choices is None else f"one of {list(choices)}"
            raise self.fail(key, f"expected {expected}, got {_short(value)}")
        return value

    def labels(self, value, key: str) -> tuple[str, ...]:
        if not isinstance(value, list) or not all(isinstance(s, str) for s in value):
            raise self.fail(key, f"expected a list of names, got {_short(value)}")
        if len(set(value)) != len(value):
            raise self.fail(key, f"repeated names in {value}")
        return tuple(value)

    def symmetric(self, value, key: str, n: int) -> np.ndarray:
        P = self.array(value, key, (n, n))
        if not np.allclose(P, P.T, rtol=1e-12, atol=0):
            raise self.fail(key, f"expected a symmetric {n} x {n} matrix")
        return 0.5 * (P + P.T)


def _numeric_lists(value, ndim: int) -> bool:
    """Nested lists `ndim` deep whose leaves are JSON numbers (not booleans)."""
    if ndim == 0:
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    return isinstance(value, list) and all(_numeric_lists(v, ndim - 1) for v in value)


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _matrix(M) -> list:
    return np.asarray(M, dtype=float).tolist()


# ----------------------------------------------------------------------
# The plant
# ----------------------------------------------------------------------
def plant_document(sys) -> dict:
    """The JSON description of a `PolytopicStateSpace` (see module doc)."""
    from .polytope import ParameterBox, Simplex

    domain = sys.domain
    if isinstance(domain, ParameterBox):
        dom = {
            "type": "box",
            "names": list(domain.names),
            "lower": domain.lower.tolist(),
            "upper": domain.upper.tolist(),
        }
    elif isinstance(domain, Simplex):
        dom = {"type": "simplex", "names": list(domain.names)}
    else:
        dom = {"type": "polytope", "names": list(domain.names),
               "points": _matrix(domain.points)}  # fmt: skip
    dt = sys.dt
    return {
        "name": sys.name,
        "dt": dt if dt is True else float(dt),
        "inputs": list(sys.physical_inputs),
        "outputs": list(sys.output_labels),
        "states": list(sys.state_labels),
        "domain": dom,
        "nominal": np.asarray(sys.nominal, float).tolist(),
        "scheduling": "inputs" if sys.scheduling == "inputs" else None,
        "integral_signals": dict(getattr(sys, "integral_signals", None) or {}) or None,
        "vertices": [
            dict(zip("ABCD", (_matrix(M) for M in data))) for data in sys.vertex_data()
        ],
    }


def read_plant(reader: DocumentReader, section: dict, key: str = "plant"):
    """Rebuild the plant of a document, validated (a `PolytopicStateSpace`)."""
    from .polytope import ParameterBox, Polytope, Simplex
    from .systems import PolytopicStateSpace

    def item(name):
        return reader.get(section, name, f"{key}.")

    inputs = reader.labels(item("inputs"), f"{key}.inputs")
    outputs = reader.labels(item("outputs"), f"{key}.outputs")
    states = reader.labels(item("states"), f"{key}.states")
    n, m, ny = len(states), len(inputs), len(outputs)
    if n == 0:
        raise reader.fail(f"{key}.states", "the plant has no states")
    dom = reader.section(f"{key}.domain", item("domain"))
    kind = reader.string(
        dom.get("type"), f"{key}.domain.type", ("box", "simplex", "polytope")
    )
    names = reader.labels(dom.get("names"), f"{key}.domain.names")
    k = len(names)
    try:
        if kind == "box":
            lower = reader.array(dom.get("lower"), f"{key}.domain.lower", (k,))
            upper = reader.array(dom.get("upper"), f"{key}.domain.upper", (k,))
            domain = ParameterBox(dict(zip(names, zip(lower, upper))))
        elif kind == "simplex":
            domain = Simplex(k, names)
        else:
            pts = dom.get("points")
            rows = len(pts) if isinstance(pts, list) else 0
            domain = Polytope(
                reader.array(pts, f"{key}.domain.points", (rows, k)), names
            )
    except (TypeError, ValueError) as exc:
        raise reader.fail(f"{key}.domain", str(exc)) from None
    raw = item("vertices")
    if not isinstance(raw, list) or len(raw) != domain.nvertices:
        raise reader.fail(
            f"{key}.vertices",
            f"expected a list of {domain.nvertices} vertices (one per vertex of the "
            f"domain), got {_short(raw)}",
        )
    vertices = []
    shapes = {"A": (n, n), "B": (n, m), "C": (ny, n), "D": (ny, m)}
    for j, vertex in enumerate(raw):
        where = f"{key}.vertices[{j}]"
        vertex = reader.section(where, vertex)
        if set(vertex) != set("ABCD"):
            raise reader.fail(where, "expected the matrices A, B, C and D")
        vertices.append(
            tuple(reader.array(vertex[M], f"{where}.{M}", shapes[M]) for M in "ABCD")
        )
    dt = item("dt")
    if not (dt is True or (not isinstance(dt, bool) and dt == 0)):
        dt = reader.number(dt, f"{key}.dt", positive=True)
    nominal = reader.array(item("nominal"), f"{key}.nominal", (k,))
    scheduling = section.get("scheduling")
    if scheduling is not None:
        reader.string(scheduling, f"{key}.scheduling", ("inputs",))
    name = reader.string(item("name"), f"{key}.name")
    try:
        plant = PolytopicStateSpace(
            vertices, domain, nominal=nominal, scheduling=scheduling,
            inputs=list(inputs), outputs=list(outputs), states=list(states),
            name=name, dt=dt,
        )  # fmt: skip
    except (TypeError, ValueError) as exc:
        raise reader.fail(key, str(exc)) from None
    integrals = section.get("integral_signals")
    if integrals is not None:
        integrals = reader.section(f"{key}.integral_signals", integrals)
        signals = set(states) | set(outputs)
        for state, signal in integrals.items():
            if (
                state not in states
                or not isinstance(signal, str)
                or signal not in signals
            ):
                raise reader.fail(
                    f"{key}.integral_signals",
                    f"{state!r}: {_short(signal)} is not a state integrating a state "
                    "or output of the plant",
                )
        plant.integral_signals = dict(integrals)
    return plant


def same_plant(a, b, rtol: float = 1e-9) -> str | None:
    """None if `a` and `b` are the same polytopic plant, else what differs."""
    from .systems.timebase import same_dt as _same_dt

    if type(a.domain) is not type(b.domain) or a.domain != b.domain:
        return f"the parameter domains differ ({a.domain!r}, {b.domain!r})"
    for what in ("physical_inputs", "output_labels", "state_labels"):
        if tuple(getattr(a, what)) != tuple(getattr(b, what)):
            return f"the {what.replace('_', ' ')} differ"
    if not _same_dt(a.dt, b.dt):
        return f"the timebases differ (dt = {a.dt!r}, {b.dt!r})"
    for j, (va, vb) in enumerate(zip(a.vertex_data(), b.vertex_data())):
        for label, Ma, Mb in zip("ABCD", va, vb):
            scale = max(np.abs(Ma).max(initial=0.0), np.abs(Mb).max(initial=0.0))
            if np.abs(Ma - Mb).max(initial=0.0) > rtol * scale:
                return f"vertex {j}: the {label} matrices differ"
    return None


# ----------------------------------------------------------------------
# Public functions
# ----------------------------------------------------------------------
def save(design, path) -> Path:
    """Write a design and its plant to a JSON file, atomically.

    Parameters
    ----------
    design : `StateFeedbackDesign` or `SaturatedDesign`
        The design to save.
    path : str or path-like
        The file; its folder must exist.

    Returns
    -------
    `pathlib.Path`
        The file written.

    Raises
    ------
    TypeError
        If `design` is of another type or `path` is not a file name.
    ValueError
        If the folder does not exist, or the design holds a claim that
        could not be re-checked from the file (a `Peak` or `Saturation`
        spec of `synthesize`, whose multipliers the design does not keep).
    """
    from . import __version__
    from ._design_files import DESIGN_TYPES

    path = as_path(path)
    kind = next((k for k, t in DESIGN_TYPES.items() if type(design) is t[0]), None)
    if kind is None:
        raise TypeError(
            f"design: expected one of {sorted(DESIGN_TYPES)}, got "
            f"{type(design).__name__}"
        )
    document = {
        "format": DESIGN_FORMAT,
        "type": kind,
        "library": __version__,
        "plant": plant_document(design.system),
        "design": DESIGN_TYPES[kind][1](design),
        "certificate": {
            "summary": design.certificate.summary,
            **design.certificate.to_dict(),
        },  # fmt: skip
    }
    return write_json(path, document)


def load(path, plant=None):
    """Read a design saved with ``design.save(path)`` and re-certify it.

    The plant is rebuilt from the file (validated: finite matrices of
    consistent shapes, signal names, domain, ``dt``), the design from the
    file's gains and Lyapunov matrices, and the certificate is recomputed
    in float64 against the plant (closed-loop stability, the Lyapunov and
    bound inequalities at the vertices and interior points; for a
    `SaturatedDesign` the sector, inclusion and level checks). The file's
    own certificate is not read.

    Parameters
    ----------
    path : str or path-like
        A file written by `StateFeedbackDesign.save` or
        `SaturatedDesign.save`.
    plant : `PolytopicStateSpace`, optional
        The plant the design is for. The file's plant must match it
        (domain, signal names, ``dt``, vertex matrices to a relative 1e-9),
        and the certificate is then re-checked against `plant` itself.

    Returns
    -------
    `StateFeedbackDesign` or `SaturatedDesign`
        With a recomputed, verified ``certificate``; solver attempts,
        timings and the ladder are not saved (empty).

    Raises
    ------
    TypeError
        If `path` is not a file name or `plant` not a `PolytopicStateSpace`.
    ValueError
        Naming the file and the key: not a design file, a missing or
        malformed entry, a plant that differs from `plant`, or a
        certificate that does not hold on the rebuilt plant (which
        statement, where).
    """
    from ._design_files import DESIGN_TYPES
    from .systems import PolytopicStateSpace

    if plant is not None and not isinstance(plant, PolytopicStateSpace):
        raise TypeError(
            f"plant: expected a PolytopicStateSpace, got {type(plant).__name__}"
        )
    path, document = read_json(path)
    if not isinstance(document, dict) or document.get("format") != DESIGN_FORMAT:
        raise ValueError(
            f"path: {path} is not a ctrl_lpv design file (expected format "
            f"{DESIGN_FORMAT!r})"
        )
    reader = DocumentReader(path, document)
    kind = reader.string(document.get("type"), "type", tuple(DESIGN_TYPES))
    rebuilt = read_plant(reader, reader.section("plant"))
    if plant is not None:
        difference = same_plant(rebuilt, plant)
        if difference is not None:
            raise ValueError(
                f"plant: the file {path} is for another plant: {difference}"
            )
        rebuilt = plant
    return DESIGN_TYPES[kind][2](reader, reader.section("design"), rebuilt)
