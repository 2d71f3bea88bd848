"""Mixed objectives of an output-feedback design: bounds on other channels.

Scherer, Gahinet and Chilali (1997) pose several specifications on one
Lyapunov pair ``(X, Y)`` and one set of controller variables: here an `Hinf`
or `H2` spec *with a bound* among the ``constraints`` (e.g. minimise the H2
norm from noise to error subject to an L2 gain below 2 from a disturbance to
the control effort). Each is a `BoundConstraint`: its channel's plant
(``w``, ``z`` its own; ``u``, ``y``, ``A`` the design's) rides along the
design's plant (``OutputFeedbackPlant.channels``, transformed with it by the
prescalings), its objective's LMIs use their own variables (``level_c<i>``
below the bound, ``Q_c<i><j>`` for H2), and its closed-loop inequalities on
the rebuilt controller join the certificate. One ``P`` for every part is
the price: the bounds are those of that common ``P`` (the usual
conservatism of mixed designs, SGC97 Sec. V).
"""

from __future__ import annotations

import dataclasses

from ..synthesis.spec import Spec
from ..synthesis.specs import H2, Hinf
from .objectives import H2Objective, HinfObjective
from .plant import OutputFeedbackPlant
from .regions import region_constraints

__all__ = ["BoundConstraint", "output_feedback_constraints"]


def output_feedback_constraints(constraints, sys, u, y, continuous):
    """``(parts, channels)``: the constraints as parts of the design, and
    the channel plants the bound constraints read.

    Raises
    ------
    ValueError
        An `Hinf` or `H2` without a bound, or another spec (not implemented
        here); a channel that does not fit the plant (named).
    TypeError
        Anything else than pole regions and specs.
    """
    if constraints is None:
        return (), ()
    if isinstance(constraints, Spec) or not hasattr(constraints, "__iter__"):
        constraints = (constraints,)
    bounds, regions = [], []
    for item in constraints:
        if isinstance(item, (Hinf, H2)):
            if item.bound is None:
                raise ValueError(
                    f"constraints: {item!r} has no bound; a constraint is a "
                    "spec with bound=... (the objective is minimised)"
                )
            bounds.append(item)
        else:
            regions.append(item)
    parts = list(region_constraints(regions, continuous))
    channels = []
    for item in bounds:
        index = len(channels)
        kind = HinfObjective if isinstance(item, Hinf) else H2Objective
        channel = OutputFeedbackPlant.of(sys, item.w, u, item.z, y)
        channels.append(channel)
        names = (channel.names("w"), channel.names("z"))
        parts.append(BoundConstraint(kind(tag=f"_c{index}"), index, item.bound, names))
    return tuple(parts), tuple(channels)


class BoundConstraint(Spec):
    """A bound on another channel's norm, posed with the design (module
    docstring)."""

    channel = True
    #: The bound is not kept under a rescaling of P (a renormalised z).
    homogeneous = False

    def __init__(self, objective, index: int, bound: float, names):
        self.objective = objective
        self.index = index
        self.bound = float(bound)
        self.names = names  # (w, z) of the channel

    @property
    def strictly_proper(self) -> bool:
        return self.objective.strictly_proper

    @property
    def level(self) -> float:
        return self.objective.level(self.bound)

    def plant_of(self, plant):
        """The channel's plant, riding along the design's `plant`."""
        return plant.channels[self.index]

    @property
    def spec(self):
        """The spec with its bound (a key of the design's ``bounds``)."""
        return self.objective.named(*self.names, bound=self.bound)

    def check(self, plant) -> None:
        self.objective.check(self.plant_of(plant))

    def __str__(self) -> str:
        return self.statement()

    def variables(self, declare) -> None:
        self.objective.variables(declare.on(self.plant_of(declare.plant)))

    def prescale(self, frame, dims) -> dict:
        """No constants (the bound is in the plant's units)."""
        return {}

    def problem_lmis(self, t) -> list:
        """The channel objective's, and its level at most the bound."""
        name, level = self.objective.level_name, self.level
        return [
            *self.objective.problem_lmis(t.on(self.plant_of(t.plant))),
            (f"{name} <= bound", lambda v: [[getattr(v, name) - level]], False),
        ]

    def lmis(self, t, continuous):
        return self.objective.lmis(t.on(self.plant_of(t.plant)), continuous)

    def coefficient_lmis(self, t, continuous) -> list:
        return []

    def residual(self, loop, continuous) -> float:
        """The channel's residual at the bound itself (see `loop_checks`)."""
        values = dict(loop.values, **{self.objective.level_name: self.level})
        loop = dataclasses.replace(loop, plant=self.plant_of(loop.plant),
                                   values=values)  # fmt: skip
        return self.objective.residual(loop, continuous)

    def loop_checks(self, loop, P, values, j, continuous, margin=0.0, what=""):
        """The channel's inequalities at the bound itself (they hold there
        if they hold at the solver's level, which is below it)."""
        values = dict(values, **{self.objective.level_name: self.level})
        return self.objective.loop_checks(loop, P, values, j, continuous,
                                          margin=margin, what=what)  # fmt: skip

    def loop_lmis(self, loop, j, continuous):
        return self.objective.loop_lmis(loop, j, continuous)

    def frozen_check(self, plant, controllers):
        from .checks import frozen_norms

        what = f" {self.channel_norm}_{self._norm}"
        return frozen_norms(self.plant_of(plant), self.objective, controllers,
                            self.bound, what=what)  # fmt: skip

    def statement(self) -> str:
        return f"{self.channel_norm}_{self._norm} < {self.bound:.6g} with the same P"

    @property
    def channel_norm(self) -> str:
        w, z = self.names
        return f"||T({', '.join(w)} -> {', '.join(z)})||"

    @property
    def _norm(self) -> str:
        return self.objective.norm
