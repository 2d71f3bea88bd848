"""The ``design`` section of a design file, per design type (not public).

Each type has a writer (design -> JSON object) and a reader (validated
JSON object + rebuilt plant -> design, re-checked in float64); see
`ctrl_lpv.persistence` for the file and `DESIGN_TYPES` for the table.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ._sector_checks import sector_checks, sector_statement
from .persistence import DocumentReader, _matrix
from .reachability import Ellipsoid, EllipsoidCertificate
from .regions import LMIRegion
from .saturation import SaturatedDesign
from .synthesis import H2, Hinf, StateFeedbackDesign
from .synthesis.channels import resolve_channels
from .synthesis.recheck import recheck
from .synthesis.region import region_size
from .synthesis.results import DesignCertificate

_SPECS = {"Hinf": Hinf, "H2": H2}

# A design that has not been checked yet (replaced before it is returned):
# no checks, not verified.
_UNCHECKED = DesignCertificate()

# Relative agreement required between a stated and a recomputed level.
_CLAIM_RTOL = 1e-9


# ----------------------------------------------------------------------
# StateFeedbackDesign
# ----------------------------------------------------------------------
def _performance(design) -> list:
    """``(spec, value)`` of every claimed bound, the objective first."""
    for spec in design.bounds:
        if type(spec) not in _SPECS.values():
            raise ValueError(
                f"design: its {type(spec).__name__} claim rests on multipliers the "
                "design does not keep, so it could not be re-checked on load; "
                "saving such a design is not supported"
            )
    specs = list(design.bounds.items())
    if design.gamma is not None and not specs:  # built without `synthesize`
        specs = [(Hinf(design.w, design.z), design.gamma)]
    return specs


def _channel(value):
    return None if value is None else list(value)


def write_state_feedback(design) -> dict:
    """The ``design`` section of a `StateFeedbackDesign`."""
    affine = design.lyapunov == "affine"
    return {
        "method": design.method,
        "u": list(design.u),
        "w": list(design.w),
        "z": list(design.z),
        "gains": [_matrix(K) for K in design.gains],
        "lyapunov": design.lyapunov,
        "P": [_matrix(P) for P in design.P] if affine else _matrix(design.P),
        "rate_bounds": design.rate_bounds,
        "primal": design.primal,
        "rational": None
        if design.rational is None
        else {
            "Z": [_matrix(Z) for Z in design.rational[0]],
            "W": [_matrix(W) for W in design.rational[1]],
        },  # fmt: skip
        "gamma": design.gamma,
        "gamma_opt": design.gamma_opt,
        "backoff": design.backoff,
        "specs": [
            {
                "type": type(spec).__name__,
                "w": _channel(spec.w),
                "z": _channel(spec.z),
                "bound": spec.bound,
                "value": float(value),
            }
            for spec, value in _performance(design)
        ],  # fmt: skip
        "regions": [
            {"L": _matrix(r.L), "M": _matrix(r.M), "description": r.description}
            for r in design.regions
        ],
    }


def _signals(reader, value, key):
    """A spec's ``w``/``z``: null, or a list of names or indices."""
    if value is None:
        return None
    if not isinstance(value, list) or not all(
        isinstance(v, str) or (isinstance(v, int) and not isinstance(v, bool))
        for v in value
    ):
        raise reader.fail(
            key, f"expected null or a list of names or indices, got {value!r}"
        )
    return tuple(value)


def _read_specs(reader, raw, plant, u, continuous):
    """``(spec, (iw, iz), value)`` of each claimed bound, validated."""
    if not isinstance(raw, list):
        raise reader.fail("design.specs", "expected a list")
    out = []
    data = plant.vertex_data()
    for i, entry in enumerate(raw):
        key = f"design.specs[{i}]"
        entry = reader.section(key, entry)
        cls = _SPECS[reader.string(entry.get("type"), f"{key}.type", tuple(_SPECS))]
        w = _signals(reader, entry.get("w"), f"{key}.w")
        z = _signals(reader, entry.get("z"), f"{key}.z")
        bound = reader.number(entry.get("bound"), f"{key}.bound", allow_none=True,
                              positive=True)  # fmt: skip
        value = reader.number(entry.get("value"), f"{key}.value", positive=True)
        if bound is not None and not value < bound:
            raise reader.fail(
                f"{key}.value", f"{value:g} does not meet its bound {bound:g}"
            )
        try:
            spec = cls(w, z, bound=bound)
            iw, _, iz = resolve_channels(plant, spec.w, list(u), spec.z, hinf=True)
            spec.check_data([{"Dzw": D[np.ix_(iz, iw)]} for *_, D in data], continuous)
        except (TypeError, ValueError) as exc:
            raise reader.fail(key, str(exc)) from None
        out.append((spec, (iw, iz), value))
    return out


def _read_lyapunov(reader, section, n, N):
    lyapunov = reader.string(section.get("lyapunov"), "design.lyapunov",
                             ("constant", "affine"))  # fmt: skip
    raw = section.get("P")
    if lyapunov == "constant":
        return lyapunov, reader.symmetric(raw, "design.P", n), None
    if not isinstance(raw, list) or len(raw) != N:
        raise reader.fail("design.P", f"expected {N} vertex matrices (affine)")
    P = tuple(reader.symmetric(Pj, f"design.P[{j}]", n) for j, Pj in enumerate(raw))
    rates = reader.section("design.rate_bounds", section.get("rate_bounds"))
    rates = {
        str(k): reader.number(v, f"design.rate_bounds.{k}", minimum=0.0)
        for k, v in rates.items()
    }
    return lyapunov, P, rates


def _read_rational(reader, raw, m, n, N):
    if raw is None:
        return None
    raw = reader.section("design.rational", raw)
    Z = reader.array(raw.get("Z"), "design.rational.Z", (N, m, n))
    W = reader.array(raw.get("W"), "design.rational.W", (N, n, n))
    return tuple(Z), tuple(W)


def _require_vertex_gains(reader, design) -> None:
    """With a rational gain, `gains` must be its vertex values (the
    controller uses the rational form, other code the vertex gains)."""
    if design.rational is None:
        return
    for j, K in enumerate(design.gains):
        at_vertex = design.gain_at(np.eye(len(design.gains))[j])
        if not np.allclose(K, at_vertex, rtol=1e-9, atol=1e-12 * np.abs(K).max()):
            raise reader.fail(
                f"design.gains[{j}]", "differs from the rational gain at its vertex"
            )


def read_state_feedback(reader: DocumentReader, section: dict, plant):
    """A `StateFeedbackDesign` from its ``design`` section, re-checked."""
    continuous = not plant.isdtime(strict=True)
    n, N = plant.nstates, plant.nvertices
    method = reader.string(section.get("method"), "design.method")
    u = reader.labels(section.get("u"), "design.u")
    w = reader.labels(section.get("w"), "design.w")
    z = reader.labels(section.get("z"), "design.z")
    raw_gains = section.get("gains")
    count = len(raw_gains) if isinstance(raw_gains, list) else -1
    if count not in (1, N):
        raise reader.fail(
            "design.gains", f"expected 1 (common) or {N} (one per vertex) gains"
        )
    gains = reader.array(raw_gains, "design.gains", (count, len(u), n))
    lyapunov, P, rates = _read_lyapunov(reader, section, n, N)
    rational = _read_rational(reader, section.get("rational"), len(u), n, N)
    primal = reader.boolean(section.get("primal", False), "design.primal")
    if primal and not (lyapunov == "affine" and continuous):
        raise reader.fail("design.primal", "only for an affine P in continuous time")
    if rational is not None and (lyapunov != "affine" or count == 1):
        raise reader.fail("design.rational", "only for vertex gains with an affine P")
    gamma = reader.number(section.get("gamma"), "design.gamma", allow_none=True,
                          positive=True)  # fmt: skip
    specs = _read_specs(reader, section.get("specs"), plant, u, continuous)
    if gamma is not None:
        if not specs or specs[0][2] != gamma:
            raise reader.fail("design.gamma", "is not the bound of the first spec")
        labels = plant.physical_inputs
        iw, iz = specs[0][1]
        if w != tuple(labels[i] for i in iw) or z != tuple(
            plant.output_labels[i] for i in iz
        ):
            raise reader.fail("design.w", "w and z differ from the objective's channel")
    elif w or z:
        raise reader.fail("design.w", "w and z without a bound gamma")
    regions = []
    for i, entry in enumerate(section.get("regions") or []):
        key = f"design.regions[{i}]"
        entry = reader.section(key, entry)
        size = len(entry.get("L")) if isinstance(entry.get("L"), list) else 0
        try:
            regions.append(LMIRegion(
                reader.array(entry.get("L"), f"{key}.L", (size, size)),
                reader.array(entry.get("M"), f"{key}.M", (size, size)),
                reader.string(entry.get("description"), f"{key}.description"),
            ))  # fmt: skip
        except ValueError as exc:
            raise reader.fail(key, str(exc)) from None
    try:
        design = StateFeedbackDesign(
            system=plant, method=method, gains=tuple(gains), P=P, gamma=gamma,
            gamma_opt=reader.number(section.get("gamma_opt"), "design.gamma_opt",
                                    allow_none=True, positive=True),
            w=w, u=u, z=z, certificate=_UNCHECKED, attempts=(),
            backoff=reader.number(section.get("backoff"), "design.backoff",
                                  allow_none=True, minimum=0.0),
            regions=tuple(regions), lyapunov=lyapunov,
            bounds={spec: value for spec, _, value in specs},
            rational=rational, rate_bounds=rates,
            primal=primal,
        )  # fmt: skip
        result = recheck(design, specs)
    except (TypeError, ValueError) as exc:  # e.g. rate_bounds naming no parameter
        raise reader.fail("design", str(exc)) from None
    _require_vertex_gains(reader, design)
    if not result.verified:
        what, message = (result.failures or (("design", "not verified"),))[0]
        raise reader.fail(f"design.{what}", f"{message}: the certificate does not hold")
    return replace(design, certificate=result.certificate)


# ----------------------------------------------------------------------
# SaturatedDesign
# ----------------------------------------------------------------------
def write_saturated(design) -> dict:
    """The ``design`` section of a `SaturatedDesign`."""
    if design.T is None or design.mu is None:
        raise ValueError(
            "design: its sector multipliers T and mu are not set, so its checks "
            "could not be recomputed on load"
        )
    return {
        "u": list(design.u),
        "u_max": design.u_max.tolist(),
        "gains": [_matrix(K) for K in design.gains],
        "G": [_matrix(G) for G in design.G],
        "P": _matrix(design.P),
        "T": np.diag(design.T).tolist(),
        "mu": np.asarray(design.mu, float).tolist(),
        "decay": design.decay,
        "lam": design.lam,
        "w": list(design.w),
        "w_max": np.asarray(design.w_max, float).tolist(),
        "shape": None if design.shape is None else _matrix(design.shape),
        "points": None if design.points is None else _matrix(design.points),
        "beta": design.beta,
        "beta_opt": design.beta_opt,
        "rho": design.rho,
        "capped": design.capped,
        "designed": design.designed,
    }


def read_saturated(reader: DocumentReader, section: dict, plant):
    """A `SaturatedDesign` from its ``design`` section, re-checked."""
    from ._checks import signal_indices

    n, N = plant.nstates, plant.nvertices
    inputs = plant.physical_inputs
    u = reader.labels(section.get("u"), "design.u")
    w = reader.labels(section.get("w"), "design.w")
    try:
        iu = signal_indices(list(u), inputs, "u")
        iw = signal_indices(list(w), inputs, "w")
    except ValueError as exc:
        raise reader.fail("design.u", str(exc)) from None
    if not iu or set(iu) & set(iw):
        raise reader.fail("design.u", "need control inputs disjoint from w")
    m, nw = len(iu), len(iw)
    U = reader.array(section.get("u_max"), "design.u_max", (m,))
    wmax = reader.array(section.get("w_max"), "design.w_max", (nw,))
    if np.any(U <= 0) or np.any(wmax <= 0):
        raise reader.fail(
            "design.u_max", "saturation and disturbance levels must be positive"
        )
    raw = section.get("gains")
    count = len(raw) if isinstance(raw, list) else -1
    if count not in (1, N):
        raise reader.fail("design.gains", f"expected 1 or {N} gains")
    Ks = tuple(reader.array(raw, "design.gains", (count, m, n)))
    Gs = tuple(reader.array(section.get("G"), "design.G", (count, m, n)))
    P = reader.symmetric(section.get("P"), "design.P", n)
    Tm = np.diag(reader.array(section.get("T"), "design.T", (m,)))
    mu = reader.array(section.get("mu"), "design.mu", (nw,))
    sigma = reader.number(section.get("decay"), "design.decay", minimum=0.0)
    lam = reader.number(section.get("lam"), "design.lam", minimum=0.0)
    if nw and not lam > 0:
        raise reader.fail("design.lam", "must be positive with disturbances w")
    R = V = None
    if section.get("shape") is not None:
        R = reader.symmetric(section.get("shape"), "design.shape", n)
        if np.linalg.eigvalsh(R)[0] <= 0:
            raise reader.fail("design.shape", "must be positive definite")
    else:
        raw_points = section.get("points")
        rows = len(raw_points) if isinstance(raw_points, list) else 0
        V = reader.array(raw_points, "design.points", (rows, n))
        if rows == 0 or np.any(np.all(V == 0, axis=1)):
            raise reader.fail("design.points", "expected nonzero points (or a shape)")
    if np.linalg.eigvalsh(P)[0] <= 0:
        raise reader.fail("design.P", "is not positive definite")
    W = np.linalg.inv(P)
    data = plant.vertex_data()
    dt = 0.0 if not plant.isdtime(strict=True) else (
        1.0 if plant.dt is True else float(plant.dt))  # fmt: skip
    checks, rho = sector_checks(
        [d[0] for d in data], [d[1][:, iu] for d in data],
        [d[1][:, iw] for d in data] if nw else [], wmax, U, P, 0.5 * (W + W.T),
        Ks, Gs, Tm, mu, sigma, lam, dt,
    )  # fmt: skip
    certificate = EllipsoidCertificate(
        tuple(checks), (), sector_statement(bool(nw), not dt)
    )
    if not certificate.verified:
        raise reader.fail(
            "design.P",
            f"the saturation certificate does not hold ({certificate.summary})",
        )
    beta = region_size(P, R, V)
    for key, stated, recomputed in (("beta", section.get("beta"), beta),
                                    ("rho", section.get("rho"), rho)):  # fmt: skip
        stated = reader.number(stated, f"design.{key}", minimum=0.0)
        if abs(stated - recomputed) > _CLAIM_RTOL * max(abs(recomputed), 1e-300):
            raise reader.fail(
                f"design.{key}",
                f"states {stated:.10g}, the data give {recomputed:.10g}",
            )
    return SaturatedDesign(
        system=plant, u=u, u_max=U, gains=Ks, G=Gs, P=P,
        ellipsoid=Ellipsoid(P, 1.0), ultimate=Ellipsoid(P, rho) if nw else None,
        rho=rho, beta=beta,
        beta_opt=reader.number(section.get("beta_opt"), "design.beta_opt",
                               allow_none=True, minimum=0.0),
        decay=sigma, lam=lam, w=w, w_max=wmax, certificate=certificate,
        capped=reader.boolean(section.get("capped"), "design.capped"),
        designed=reader.boolean(section.get("designed"), "design.designed"),
        T=Tm, mu=mu, shape=R, points=V,
    )  # fmt: skip


#: Design type name -> (class, writer, reader).
DESIGN_TYPES = {
    "StateFeedbackDesign": (
        StateFeedbackDesign,
        write_state_feedback,
        read_state_feedback,
    ),
    "SaturatedDesign": (SaturatedDesign, write_saturated, read_saturated),
}
