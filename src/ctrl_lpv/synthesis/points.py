"""A solver's point read back in the model's units, and verified.

`check_point` turns an `ctrl_lpv.lmi.LMISolution` of a rung (prescaled
units, its LMIs checked in float64) into a `Point`: the gains, the bounds
of the channel specs and the Lyapunov matrix in the model's units, with
the frozen closed loops checked there
(`~ctrl_lpv.synthesis.frozen.verify_frozen`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .frozen import verify_frozen
from .results import Certificate
from .terms import names


@dataclass(frozen=True)
class Point:
    """A verified point in the model's units (and the rung's frame)."""

    solution: object
    frame: object
    gains: tuple
    certificate: Certificate
    bounds: tuple  # certified bound of every channel spec
    P: object
    rational: tuple | None
    reported: dict  # spec position -> reported value (`Spec.reported`)
    values: dict = field(default_factory=dict)  # `Spec.model_values` by position

    @property
    def value(self) -> float:
        """The objective's certified bound (inf without one)."""
        return self.bounds[0] if self.bounds else np.inf


def Ws(sol) -> list:
    """The Lyapunov vertex matrices ``W_l`` of a solution (prescaled)."""
    out, e = [], 0
    while hasattr(sol, f"W{e}"):
        out.append(getattr(sol, f"W{e}"))
        e += 1
    return out


def check_point(problem, shape, frame, sol, settings, margin, final):
    """``(Point, None)``, or ``(None, why)`` for a point that fails.

    `settings` are the searched parameters the point was solved at (the
    frozen loops read a decay from them), `final` whether a gain bound is
    checked too.
    """
    sc = frame.scaling
    lyap = problem.lyap
    Wl = Ws(sol)
    Zs = [getattr(sol, f"Z{k}") for k in range(problem.nZ)]
    if problem.slack:
        vertex_W = [sol.G]
    else:
        vertex_W = [Wl[lyap.index[j if problem.scheduled else 0]]
                    for j in range(len(Zs))]  # fmt: skip
    gains = tuple(sc.unscale_K(-Z @ np.linalg.inv(W)) for Z, W in zip(Zs, vertex_W))
    if problem.fixed is not None:
        gains = tuple(problem.fixed)
    bounds = tuple(
        spec.to_model(float(getattr(sol, f"g{i}")[0, 0]), frame, i)
        for i, spec in enumerate(problem.bound_specs)
    )
    for spec, value in zip(problem.bound_specs, bounds):
        if spec.bound is not None and not value < spec.bound:
            return None, f"{spec} certified {value:.8g}, not below"
    rational = None
    if not lyap.constant and Zs and not problem.slack:
        rational = (
            tuple(sc.w_factor * (sc.Su[:, None] * (Z @ sc.matrix.T)) for Z in Zs),
            tuple(sc.unscale_W(Wl[lyap.index[j]]) for j in range(len(Zs))),
        )
    solved = dict(sol.values) | settings
    certificate, reported = verify_frozen(
        problem, shape, frame, solved, gains, bounds, margin, sol.checks, final,
    )  # fmt: skip
    if not certificate.verified:
        return None, f"closed-loop verification failed ({certificate.summary})"
    Ps = tuple(sc.unscale_P(np.linalg.inv(W)) for W in Wl)
    N = problem.plant.N
    P = Ps[0] if lyap.constant else tuple(Ps[lyap.index[j]] for j in range(N))
    values = {}
    for q, spec in enumerate(problem.specs):
        own = spec.model_values(frame, lambda name, q=q: solved[names.local(q, name)])
        if own:
            values[q] = own
    return (
        Point(sol, frame, gains, certificate, bounds, P, rational, reported, values),
        None,
    )
