"""The objectives of an output-feedback design: one small `Spec` each.

The design (`ctrl_lpv.output_feedback.design`) and the certificate
(`ctrl_lpv.output_feedback.checks`) read an objective only through the
spec protocol (`ctrl_lpv.synthesis.spec.Spec`, with the views of
`ctrl_lpv.output_feedback.views`): the variables it declares
(`Spec.variables`), its LMIs after the change of variables at a vertex
(`Spec.lmis`) and those posed once (`Spec.problem_lmis`), its float64
residual at a frozen closed loop (`Spec.residual`); beside them the same
inequalities on a closed loop in float64 for the certificate and the
frozen norm that cross-checks its bound. Both minimise a "level" that is
linear in the variables: ``gamma`` for `HinfObjective`, ``gamma^2`` for
`H2Objective`.
"""

from __future__ import annotations

import control as ct
import numpy as np

from ..certificate import Check, negative_definite, rounding_bound
from ..lmi import normalized_max_eig
from ..synthesis.spec import Spec
from . import lmis

__all__ = ["HinfObjective", "H2Objective"]


class _Objective(Spec):
    """What both objectives share: the constraints posed with them, and the
    names of their variables.

    `constraints` are the parts posed with the objective on the same
    ``(X, Y)`` (`ctrl_lpv.output_feedback.regions.RegionConstraint`,
    `ctrl_lpv.output_feedback.mixed.BoundConstraint`); their closed-loop
    checks join the certificate. `tag` suffixes the objective's variable
    names (``level<tag>``, ``Q<tag><j>``), so that the same objective can
    also be a constraint of another (a mixed design).
    """

    #: A performance channel w -> z (the design's own, or a constraint's).
    channel = True

    def spec(self, plant, bound=None):
        """The public spec of this channel, `ctrl_lpv.Hinf` or `ctrl_lpv.H2`
        (the key of ``bounds``)."""
        return self.named(plant.names("w"), plant.names("z"), bound)

    def __init__(self, constraints=(), tag=""):
        self.constraints = tuple(constraints)
        self.tag = tag

    def __str__(self) -> str:
        return f"{type(self).__name__}({self.tag!r})" if self.tag else self.name

    def prescale(self, frame, dims) -> dict:
        """No constants: the design prescales the plant itself
        (`ctrl_lpv.output_feedback.prescale`) and renormalises ``z``
        (`rescaled`)."""
        return {}

    def coefficient_lmis(self, t, continuous) -> list:
        """None: the output-feedback LMIs are per vertex (`lmis`)."""
        return []

    def to_model(self, g, frame, i) -> float:
        """The level as the bound (the plant's units: see `rescaled`)."""
        return self.bound(g)

    def to_scaled(self, bound, frame, i) -> float:
        return self.level(bound)

    @property
    def level_name(self) -> str:
        return f"level{self.tag}"

    def parts(self):
        """The objective and its constraints: everything with LMIs."""
        return (self, *self.constraints)

    def plant_of(self, plant):
        """The plant whose channel the LMIs read: the design's own."""
        return plant

    @property
    def proper(self) -> bool:
        """Whether every part allows a feedthrough ``Dk`` in the controller."""
        return not any(part.strictly_proper for part in self.parts())

    @property
    def homogeneous(self) -> bool:
        """Whether every constraint holds for any positive scale of ``P``
        (then the objective's renormalisation of ``z`` keeps them)."""
        return all(c.homogeneous for c in self.constraints)

    def constraint_statement(self) -> str:
        return "".join(f"; {c.statement()}" for c in self.constraints)


class HinfObjective(_Objective):
    """The L2 gain (H-infinity norm) from w to z; level ``gamma``."""

    name = "Hinf"
    label = "H-infinity"
    strictly_proper = False

    #: The norm's subscript in statements.
    norm = "inf"

    @staticmethod
    def named(w, z, bound=None):
        """The `ctrl_lpv.Hinf` spec of the channel ``w -> z``."""
        from ..synthesis import Hinf

        return Hinf(w=w, z=z, bound=bound)

    def check(self, plant) -> None:
        """Nothing to add to the plant's own checks."""

    def bound(self, level: float) -> float:
        return float(level)

    def level(self, bound: float) -> float:
        return float(bound)

    def variables(self, declare) -> None:
        declare.variable(self.level_name, (1, 1), symmetric=True)

    def rescaled(self, P, values, s):
        """``(P, values)`` for the plant whose z the design scaled by `s`.

        The bounded-real inequality of ``s z`` with ``(P, gamma)`` is, divided
        by ``s``, that of ``z`` with ``(P / s, gamma / s)``.
        """
        return P / s, dict(values, level=values["level"] / s)

    def _level(self, v):
        return getattr(v, self.level_name)[0, 0]

    def lmis(self, t, continuous):
        """``(name, block function, performance rows)`` at vertex ``t.j``.

        ``t.hats(v)`` gives the controller variables at the vertex; the
        decay margin is the parameter ``v.decay``. The third item lists the
        blocks of the performance channels (``-gamma I``), which the design
        weighs against the state blocks (`ctrl_lpv.output_feedback.problem`).
        """
        plant, j = t.plant, t.j
        perf = (2, 3) if continuous else (2, 5)
        return [(f"bounded real{self.tag} vertex {j}", lambda v: lmis.bounded_real(
            plant, j, v, t.hats(v), self._level(v), v.decay[()]), perf)]  # fmt: skip

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the closed loop's bounded-real
        inequality at the frozen point, at the level ``values[level]``."""
        A, B, C, D = loop.matrices(self.plant_of(loop.plant))
        g = float(loop.values[self.level_name])
        F = lmis.bounded_real_loop(A, B, C, D, loop.P, g, continuous)
        return normalized_max_eig(F[None])

    def loop_checks(self, loop, P, values, j, continuous, margin=0.0, what=""):
        """Float64 checks of the closed loop at vertex `j` (each inequality
        with `margin`: ``F < -margin I``)."""
        g = values[self.level_name]
        F = lmis.bounded_real_loop(*loop, P, g, continuous)
        F_abs = np.abs(lmis.bounded_real_loop(*_abs(*loop, P), g, continuous))
        return [negative_definite(F, margin=margin, absolute=F_abs,
                                  what=f"bounded real{self.tag} (closed loop{what})",
                                  where=f"vertex {j}", group="LMI")]  # fmt: skip

    def loop_lmis(self, loop, j, continuous):
        """``(name, block function)`` of the closed loop in a variable ``P``."""

        def blocks(v):
            return [[lmis.bounded_real_loop(*loop, v.P, self._level(v), continuous)]]

        return [(f"bounded real{self.tag} vertex {j}", blocks)]

    def frozen_norm(self, sys) -> float:
        return float(ct.linfnorm(sys)[0])

    def statement(self, bound: float) -> str:
        return (
            f"||T_zw||_inf < {bound:.6g} for every parameter trajectory in the "
            "polytope, with one quadratic Lyapunov function of the closed loop"
            + self.constraint_statement()
        )


class H2Objective(_Objective):
    """The H2 norm from w to z; level ``gamma^2``, strictly proper controller.

    ``trace(C P^-1 C') < gamma^2`` with ``P^-1`` above the controllability
    Gramian (``Q_j`` per vertex bounds ``C_j P^-1 C_j'``). For a time-
    varying parameter the bound holds for the frozen systems and, with the
    common ``P``, for the energy of the response to impulses (the usual LPV
    reading of H2). Needs ``D11 = 0``; the controller has ``Dk = 0``.
    """

    name = "H2"
    label = "H2"
    strictly_proper = True

    norm = "2"

    @staticmethod
    def named(w, z, bound=None):
        """The `ctrl_lpv.H2` spec of the channel ``w -> z``."""
        from ..synthesis import H2

        return H2(w=w, z=z, bound=bound)

    def check(self, plant) -> None:
        if np.any(plant.D11 != 0):
            raise ValueError(
                "sys: the H2 norm needs no feedthrough from w to z (D11 = 0)"
            )

    def bound(self, level: float) -> float:
        return float(np.sqrt(level))

    def level(self, bound: float) -> float:
        return float(bound) ** 2

    def variables(self, declare) -> None:
        """The level ``gamma^2`` and a bound ``Q_j`` of ``C_j P^-1 C_j'`` per
        vertex."""
        plant = declare.plant
        declare.variable(self.level_name, (1, 1), symmetric=True)
        nz = plant.C1.shape[1]
        for j in range(plant.nvertices):
            declare.variable(self._q(j), (nz, nz), symmetric=True)

    def problem_lmis(self, t) -> list:
        """``trace Q_j <= gamma^2`` (non-strict), one per vertex."""
        level = self.level_name
        return [
            (f"trace {Q} <= {level}",
             lambda v, Q=Q: [[np.trace(getattr(v, Q)) - getattr(v, level)]], False)
            for Q in map(self._q, range(t.plant.nvertices))
        ]  # fmt: skip

    def _q(self, j) -> str:
        return f"Q{self.tag}{j}"

    def rescaled(self, P, values, s):
        """``(P, values)`` for the plant whose z the design scaled by `s`:
        ``[[P, s C'], [s C, Q]] > 0`` is ``[[P, C'], [C, Q / s^2]] > 0``."""
        out = {k: x / s**2 for k, x in values.items() if k[0] == "Q"}
        return P, dict(values, **out, level=values["level"] / s**2)

    def lmis(self, t, continuous):
        """The Gramian and output LMIs at vertex ``t.j`` (as `HinfObjective`)."""
        plant, j = t.plant, t.j
        return [
            (f"H2 Gramian{self.tag} vertex {j}",
             lambda v: lmis.h2_gramian(plant, j, v, t.hats(v), v.decay[()]),
             (2,) if continuous else (4,)),
            (f"H2 output{self.tag} vertex {j}",
             lambda v: lmis.h2_output(plant, j, v, t.hats(v), getattr(v, self._q(j))),
             (2,)),
        ]  # fmt: skip

    def residual(self, loop, continuous) -> float:
        """Largest excess at the frozen point: the normalised eigenvalues of
        the Gramian and output inequalities, with ``Q`` interpolated from
        the vertices' (the output inequality is affine in ``(C, Q)``), and
        ``trace Q - gamma^2`` relative to ``gamma^2``; ``D = 0`` needed."""
        A, B, C, D = loop.matrices(self.plant_of(loop.plant))
        if np.any(D != 0):
            return np.inf
        Q = loop.at([self._q(j) for j in range(loop.plant.nvertices)])
        g = float(loop.values[self.level_name])
        return max(
            normalized_max_eig(lmis.h2_gramian_loop(A, B, loop.P, continuous)[None]),
            normalized_max_eig(lmis.h2_output_loop(C, loop.P, Q)[None]),
            (float(np.trace(Q)) - g) / g,
        )

    def loop_checks(self, loop, P, values, j, continuous, margin=0.0, what=""):
        A, B, C, D = loop
        Q = values[self._q(j)]
        F = lmis.h2_gramian_loop(A, B, P, continuous)
        F_abs = np.abs(lmis.h2_gramian_loop(*_abs(A, B, P), continuous))
        G = lmis.h2_output_loop(C, P, Q)
        G_abs = np.abs(G)
        trace = float(np.trace(Q))
        return [
            negative_definite(F, margin=margin, absolute=F_abs,
                              what=f"H2 Gramian{self.tag} (closed loop{what})",
                              where=f"vertex {j}", group="LMI"),
            negative_definite(G, margin=margin, absolute=G_abs,
                              what=f"H2 output{self.tag} (closed loop{what})",
                              where=f"vertex {j}", group="LMI"),
            Check(f"trace Q{self.tag} <= gamma^2", trace, values[self.level_name],
                  strict=False,
                  rounding=rounding_bound(Q.shape[0], np.abs(Q).sum()),
                  where=f"vertex {j}", group="LMI"),
            Check("no feedthrough w -> z", float(np.abs(D).max(initial=0.0)), 0.0,
                  where=f"vertex {j}", group="LMI"),
        ]  # fmt: skip

    def loop_lmis(self, loop, j, continuous):
        A, B, C, _ = loop
        return [
            (f"H2 Gramian{self.tag} vertex {j}",
             lambda v: [[lmis.h2_gramian_loop(A, B, v.P, continuous)]]),
            (f"H2 output{self.tag} vertex {j}",
             lambda v: [[lmis.h2_output_loop(C, v.P, getattr(v, self._q(j)))]]),
        ]  # fmt: skip

    def frozen_norm(self, sys) -> float:
        return float(ct.norm(sys, p=2))

    def statement(self, bound: float) -> str:
        return (
            f"||T_zw||_2 < {bound:.6g} at every frozen parameter value, with one "
            "quadratic Lyapunov function of the closed loop"
            + self.constraint_statement()
        )


def _abs(*matrices):
    return tuple(np.abs(M) for M in matrices)
