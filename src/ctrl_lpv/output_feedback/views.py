"""What an output-feedback spec reads: the views the design hands it.

The output-feedback forms are `ctrl_lpv.synthesis.spec.Spec` subclasses
(`ctrl_lpv.output_feedback.objectives`, `.regions`, `.mixed`): the design
reads them only through the spec protocol, with these views in place of
the state-feedback engine's `~ctrl_lpv.synthesis.terms.Terms`:

`Declare`
    ``variables(declare)``: the LMI problem's ``variable``/``parameter`` and
    the plant whose sizes the spec's variables take.
`VertexTerms`
    ``lmis(t, continuous)`` and ``problem_lmis(t)``: the plant, the vertex
    ``j`` (None for what is posed once) and the controller variables after
    the change of variables at that vertex, ``t.hats(v)``.
`FrozenLoop`
    ``residual(loop, continuous)``: the closed loop of a controller at one
    frozen point of the polytope (convex coordinates ``delta``), in the
    plant's units, with the Lyapunov matrix ``P`` and the spec's values.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .reconstruct import closed_loop

__all__ = ["Declare", "VertexTerms", "FrozenLoop", "declare_specs"]


@dataclass(frozen=True, eq=False)
class Declare:
    """``declare`` of `Spec.variables` for an output-feedback problem."""

    lmi: object
    plant: object

    def variable(self, name, shape, symmetric=False) -> None:
        self.lmi.variable(name, shape, symmetric=symmetric)

    def parameter(self, name, shape=(), **attributes) -> None:
        self.lmi.parameter(name, shape, **attributes)

    def on(self, plant) -> Declare:
        """The same declarer on another channel's plant."""
        return dataclasses.replace(self, plant=plant)


@dataclass(frozen=True, eq=False)
class VertexTerms:
    """``t`` of `Spec.lmis` for an output-feedback problem.

    Blocks are functions of the point ``v`` (the LMI layer evaluates them
    on its variables to build the problem and in float64 to check it):
    ``t.hats(v)`` gives ``(Ah, Bh, Ch, Dh)`` at vertex `j`.
    """

    plant: object
    j: int | None
    controller: object  # (v, j) -> (Ah, Bh, Ch, Dh)

    def hats(self, v):
        return self.controller(v, self.j)

    def on(self, plant) -> VertexTerms:
        """The same vertex on another channel's plant (same u, y, A)."""
        return dataclasses.replace(self, plant=plant)


@dataclass(frozen=True, eq=False)
class FrozenLoop:
    """``loop`` of `Spec.residual`: one frozen closed loop, model units.

    `delta` are the convex coordinates of the point, `controller` the
    controller's ``(Ak, Bk, Ck, Dk)`` there, `P` the closed loop's Lyapunov
    matrix and `values` the spec's variables at the vertices (a value per
    vertex, such as the H2 bounds ``Q_j``, is interpolated with `delta`).
    """

    plant: object
    delta: np.ndarray
    controller: tuple
    P: np.ndarray
    values: dict

    def matrices(self, plant=None):
        """``(Acl, Bcl, Ccl, Dcl)`` of `plant`'s channel (default the
        design's own)."""
        plant = self.plant if plant is None else plant
        return closed_loop(plant, plant.data(self.delta), self.controller)

    def at(self, names) -> np.ndarray:
        """The values ``names[j]`` interpolated with `delta`."""
        return sum(d * np.asarray(self.values[name]) for d, name in
                   zip(self.delta, names))  # fmt: skip

    @classmethod
    def of(cls, plant, delta, controllers, P, values) -> FrozenLoop:
        """The loop of the vertex `controllers` interpolated at `delta`."""
        delta = np.asarray(delta, dtype=float)
        K = tuple(np.tensordot(delta, np.array(M), axes=1) for M in zip(*controllers))
        return cls(plant, delta, K, P, values)


def declare_specs(lmi, plant, specs) -> None:
    """Each spec's variables and the LMIs it poses once, in turn (in this
    order, so that the problem's rows are those of the specs' order)."""
    for spec in specs:
        spec.variables(Declare(lmi, plant))
        for name, blocks, strict in spec.problem_lmis(VertexTerms(plant, None, None)):
            lmi.add(name, blocks, strict=strict)
