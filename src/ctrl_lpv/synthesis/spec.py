"""The spec protocol: what every objective and constraint of `synthesize` is.

Every objective and constraint of `ctrl_lpv.synthesize` is a `Spec`, as
every cvxpy constraint is a ``cvxpy.constraints.Constraint``: one small
class that knows its own variables, its LMI blocks, its prescaling, its
data check, its units and its float64 residual. The engine
(`ctrl_lpv.synthesis.general` and the modules it calls) reads a spec only
through this protocol and never asks for its class.

Blocks are written in the dual variables ``W = P^-1`` and ``Z = -K W`` and
read everything through a `~ctrl_lpv.synthesis.terms.Terms` view bound to
the spec: the homogenised products at one coefficient of the relaxation
(`ctrl_lpv.synthesis.parametric`) and one vertex of the rate box, the
spec's channel data, its own variables and parameters (declared by
`Spec.variables`, valued by `Spec.prescale`). The same block functions
build the problem and check a point in float64.

A block list is the lower block triangle of a symmetric matrix ``F``
(see `ctrl_lpv.lmi.assemble`); every block list returned is an LMI
``F < 0`` (strict, certified with the margin) unless it says otherwise.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from ..lmi import normalized_max_eig

__all__ = [
    "DesignContext",
    "Spec",
    "Stability",
    "lyapunov_residual",
    "unit",
    "with_stability",
]


class DesignContext:
    """What a spec may need to know to refuse a design (`Spec.validate`).

    Attributes
    ----------
    continuous : bool
        Continuous time (else discrete).
    scheduled : bool
        One gain per vertex (else a common gain).
    constant : bool
        A constant Lyapunov matrix (else parameter-dependent).
    n, m : int
        Numbers of states and control inputs.
    """

    def __init__(self, continuous, scheduled, constant, n, m):
        self.continuous = continuous
        self.scheduled = scheduled
        self.constant = constant
        self.n = n
        self.m = m


class Spec(ABC):
    """Base class of the specs of `synthesize` (see the module docstring).

    Class attributes
    ----------------
    channel : bool
        A performance channel ``w -> z`` with a bound (`bound`, None to
        minimise): the engine gives it the channel's prescaled data, a
        squared-bound variable and its units (`to_model`, `to_scaled`).
    unique : bool
        At most one per design (its multipliers are shared by the others).
    paper_case : bool
        Within the paper's Lemmas 1-2 and Theorems 1-2 (with a constant
        Lyapunov matrix in continuous time, a design of such specs only is
        named after them).
    shapeable : bool
        As the objective, its optimum is attained by a finite gain whose
        ``W`` alone sets the bound, so the raw optimum may be posed again
        where its ``W`` is the identity (`ctrl_lpv.synthesis.stages`).
    """

    channel = False
    unique = False
    paper_case = False
    shapeable = False

    # -- boundary checks ----------------------------------------------------
    def validate(self, context: DesignContext) -> None:
        """Refuse a design this spec cannot be part of.

        Raises
        ------
        ValueError
            Naming ``constraints``, with what is not implemented or wrong.
        """
        return None

    def check_data(self, channels, continuous) -> None:
        """Refuse channel data the spec cannot bound (a `ValueError`).

        `channels` holds one dict per vertex with ``"Dzw"`` (and the names
        ``"w"``, ``"z"`` where known).
        """
        return None

    def structure(self) -> tuple:
        """What fixes this spec's blocks beyond the problem's sizes.

        Everything else is a parameter of the compiled problem (its
        `prescale` values), so that one compiled problem serves every
        spec with the same structure.
        """
        return (type(self).__qualname__,)

    # -- the LMIs ------------------------------------------------------------
    @abstractmethod
    def variables(self, declare) -> None:
        """Declare the spec's own variables and parameters.

        ``declare.variable(name, shape, symmetric=False)`` and
        ``declare.parameter(name, shape, nonneg=False)``; the names are
        local to the spec (the view ``t.var(name)`` reads them back).
        ``declare`` also has the sizes ``n``, ``m``, ``nZ`` (gain
        variables) and, for a channel spec, ``nw`` and ``nz``.
        """

    @abstractmethod
    def prescale(self, frame, dims) -> dict:
        """Values of the spec's parameters in a rung's prescaled units.

        `frame` is the rung's `ctrl_lpv.synthesis.scaling.Frame`; `dims`
        has the sizes ``n``, ``m``, ``nZ`` and the spec's channel ``i``,
        ``nw``, ``nz`` (as ``declare`` in `variables`).
        """

    @abstractmethod
    def lmis(self, t, continuous) -> list:
        """``(name, blocks)`` at one coefficient and one rate vertex.

        The blocks that contain the Lyapunov matrix's rate of change.
        """

    @abstractmethod
    def coefficient_lmis(self, t, continuous) -> list:
        """``(name, blocks)`` at one coefficient (independent of the rate)."""

    def problem_lmis(self, t) -> list:
        """``(name, blocks, strict)`` posed once (not per coefficient)."""
        return []

    def decay_lmis(self, t, continuous) -> list:
        """``(name, blocks)`` of the stabilization stage at one coefficient
        and rate: the blocks whose decay ``t.decay()`` that stage maximises
        (non-strict, a shape of the point, not part of the certificate)."""
        return []

    def disturbance(self, t):
        """A peak-bounded disturbance other specs must be invariant under.

        None, or ``(lam, Bw, D)``: the decay multiplying ``W``, the
        disturbance input (degree one) and its ``(w, w)`` block.
        """
        return None

    def decays(self, continuous):
        """The grid of a decay to search (in the spec's units), or None."""
        return None

    def decay_grid(self, continuous, frame):
        """`decays` in `frame`'s prescaled units (what a rung searches).

        Default: `decays` as it is (a grid written in prescaled units); a
        spec whose grid is in the model's units divides it by ``frame.a``.
        """
        return self.decays(continuous)

    # -- reading a point back ------------------------------------------------
    def to_model(self, g: float, frame, i: int) -> float:
        """A scaled squared bound as the bound in the model's units."""
        raise NotImplementedError(f"{self} has no bound")

    def to_scaled(self, bound: float, frame, i: int) -> float:
        """A bound in the model's units as a scaled squared bound."""
        raise NotImplementedError(f"{self} has no bound")

    def loop_fields(self, here) -> dict:
        """Fields of a `~ctrl_lpv.synthesis.frozen.FrozenLoop` from this spec.

        `here` is the frozen point (`~ctrl_lpv.synthesis.frozen.Here`).
        """
        return {}

    @abstractmethod
    def residual(self, loop, continuous) -> float:
        """Largest excess of the spec's statements at a frozen loop.

        In the model's units (a `~ctrl_lpv.synthesis.frozen.FrozenLoop`),
        below rounding for a certified design.
        """

    def residuals(self, loops, continuous) -> np.ndarray:
        """`residual` of each of a sequence of frozen loops.

        The engine asks for every point of a verification at once; a spec
        whose residual is a few products and an eigenvalue may evaluate
        them stacked. Default: one `residual` per loop.
        """
        return np.array([self.residual(loop, continuous) for loop in loops], float)

    def reported(self, P):
        """A value the design reports for this spec at ``P`` (or None)."""
        return None

    def model_values(self, frame, read) -> dict:
        """The spec's own values at a point, in the model's units.

        `read(name)` gives a variable or parameter the spec declared in
        `variables` (prescaled, as solved); the design reports the dict
        as ``values[spec]`` (`StateFeedbackDesign.values`). Default none.
        """
        return {}

    # -- what the engine adapts to ---------------------------------------------
    def state_scaling(self, n: int):
        """State scales ``x_i = s_i x~_i`` (model units) the spec is posed
        in, or None: the engine's first prescaling when given (a region's
        reference set fixes units the plant's data do not show)."""
        return None

    @property
    def gain_limit(self) -> float | None:
        """A bound on the gains' spectral norm (model units), if any."""
        return None

    @property
    def fixes_scale(self) -> bool:
        """Whether the spec fixes the scale of ``W`` (``W <= I`` may exclude
        every point it accepts)."""
        return False

    @property
    def region(self):
        """The `~ctrl_lpv.regions.LMIRegion` this spec imposes, if any."""
        return None


class Stability(Spec):
    """Lyapunov stability alone: the objective ``None`` of `synthesize`.

    Continuous time ``sym(A W + B2 Z) - dW/dt < 0``; discrete time
    ``[[-W, *], [A W + B2 Z, -W+]] < 0``.
    """

    def __str__(self) -> str:
        return "Stability()"

    def variables(self, declare) -> None:
        """None of its own."""

    def prescale(self, frame, dims) -> dict:
        """No constants."""
        return {}

    def lmis(self, t, continuous):
        """The Lyapunov inequality at one coefficient and rate."""
        return [("Lyapunov", self._blocks(t, continuous))]

    def decay_lmis(self, t, continuous):
        """The Lyapunov inequality with the decay ``t`` on its diagonal: with
        ``W <= I``, ``sym(A_cl W) <= -t I`` guarantees a decay rate ``t / 2``
        (maximising it picks a well-damped point, not one on the boundary)."""
        blocks = [list(row) for row in self._blocks(t, continuous)]
        for k, row in enumerate(blocks):
            size = row[k].shape[0]
            row[k] = row[k] + t.decay() * t.identity(size)
        return [("decay", blocks)]

    def _blocks(self, t, continuous):
        if t.slack:
            if continuous:
                return extended(t)
            return [[t.W() - 2 * t.G()], [t.AG(), -t.W_moved()]]
        if continuous:
            return [[2 * t.AW() - t.W_moved()]]
        return [[-t.W()], [t.AW(), -t.W_moved()]]

    def coefficient_lmis(self, t, continuous):
        """None independent of the rate."""
        return []

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the primal Lyapunov inequality."""
        return lyapunov_residual(loop, continuous)


def lyapunov_residual(loop, continuous) -> float:
    """Largest normalised eigenvalue of ``A' P + P A + dP/dt`` (continuous)
    or ``A' P+ A - P`` (discrete) at a frozen loop."""
    A, P, P_moved = loop.Acl, loop.P, loop.P_moved
    if continuous:
        M = A.T @ P + P @ A + P_moved
    else:
        M = A.T @ P_moved @ A - P
    return normalized_max_eig(M[None])


def with_stability(specs) -> tuple:
    """`specs`, led by `Stability` when none of them bounds a channel (the
    objective None: the bound specs' inequalities imply stability)."""
    specs = tuple(specs)
    return specs if any(s.channel for s in specs) else (Stability(), *specs)


def extended(t):
    """The first two block rows of the continuous-time extended LMIs.

    ``[[sym(A_cl G) - dW/dt, *], [W - G + eps (A_cl G)', -eps sym(G)]]``:
    with the slack ``G`` and a fixed ``eps > 0`` this is the projection of
    the dual inequality (Pipeleers, Demeulenaere, Swevers and Vandenberghe
    2009; Apkarian, Tuan and Bernussou 2001), which lets a common gain
    ``K = -Z G^-1`` go with a parameter-dependent ``W``.
    """
    return [
        [2 * t.AG() - t.W_moved()],
        [t.W() - t.G() + t.eps_AG().T, -2 * t.eps() * t.G()],
    ]


def unit(m, i):
    """The ``m x m`` matrix with a one at ``(i, i)`` (builds diagonal
    multipliers from scalar variables)."""
    E = np.zeros((m, m))
    E[i, i] = 1.0
    return E
