"""Specifications of `synthesize`: one class per objective or constraint.

Each performance spec holds its LMI blocks, written once for continuous and
discrete time in the dual variables ``W = P^-1`` and ``Z = -K W``, and its
own float64 residual check in the model's units with the primal ``P``.
The blocks read the vertex data through a `~ctrl_lpv.synthesis.terms.Terms`
object, which evaluates each parameter-dependent product at one coefficient
of the relaxation (see `ctrl_lpv.synthesis.parametric`):

In continuous time, with ``sym(X) = X + X'`` and ``*`` the symmetric
completion:

* Hinf: ``[[sym(A W + B2 Z) - dW/dt, *, *], [Bw', -I, *],
  [Cz W + Dzu Z, Dzw, -g I]] < 0``;
* H2: ``[[sym(A W + B2 Z) - dW/dt, *], [Bw', -I]] < 0``,
  ``[[Y, Cz W + Dzu Z], [*, W]] > 0`` and ``trace Y < h``;

and in discrete time, with ``W+`` the Lyapunov matrix at the next sample,
``[[-W+, *, *, *], [(A W + B2 Z)', -W, *, *], [Bw', 0, -I, *],
[0, Cz W + Dzu Z, Dzw, -g I]] < 0`` (the dual bounded-real inequality) and
``[[-W+, *, *], [(A W + B2 Z)', -W, *], [Bw', 0, -I]] < 0``,
``[[-Y, *, *], [(Cz W + Dzu Z)', -W, *], [Dzw', 0, -I]] < 0`` (H2). The
certified bound is ``sqrt(g)`` or ``sqrt(h)``. The H2 LMIs are the
controllability (Gramian) form, whose ``W`` bounds the state covariance
under white noise; with the dual bounded-real inequality it shares the
``Bw Bw'`` term, so that mixed H2/H-infinity designs with one ``W`` are not
more conservative than necessary (Khargonekar and Rotea 1991; Scherer,
Gahinet and Chilali 1997).

With a common gain and a parameter-dependent ``W`` the blocks are the
extended ones (`~ctrl_lpv.synthesis.spec.extended`): ``A_cl W`` becomes
``A_cl G`` with a constant slack ``G`` and ``K = -Z G^-1``, which keeps
them affine in the parameter. Discrete time: ``[[W - G - G', *], [A_cl G, -W+]] < 0``
(de Oliveira, Bernussou and Geromel 1999; Daafouz and Bernussou 2001),
and likewise in the H-infinity and H2 blocks.

For time-varying parameters the H-infinity bound bounds the L2 gain over
every admissible parameter trajectory; the H2 bound the steady-state
output variance ``E z'z`` under unit white noise ``w`` for every admissible
trajectory (the covariance stays below ``W``), so for frozen parameters it
bounds the H2 norm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import per_input, positive_levels, real_number, signal_selection
from ..lmi import normalized_max_eig
from ..lmi.blocks import normalized_max_eigs
from .spec import Spec, extended, unit

# The decays of a `Peak` spec tried: prescaled time units in continuous
# time, where the data are of order one; the contraction of V per sample in
# discrete time, up to 0.999 because with |w| <= 1 the bound tends to the
# exact one as lambda tends to 1 (for x+ = w it is 1 / sqrt(lambda)).
LAMBDAS = {
    True: tuple(10.0 ** np.arange(-3.0, 2.01, 0.5)),
    False: (0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 0.9, 0.97, 0.99, 0.999),
}


@dataclass(frozen=True)
class _Performance(Spec):
    """A bound on a channel ``w -> z`` (the common part of the three)."""

    channel = True
    # What the residual checks, for messages ("the ... inequality").
    inequality = ""

    w: tuple | None = None
    z: tuple | None = None
    bound: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "w", signal_selection(self.w, "w"))
        object.__setattr__(self, "z", signal_selection(self.z, "z"))
        bound = real_number(
            self.bound, "bound", allow_none=True, positive=True, below=1e150
        )
        object.__setattr__(self, "bound", bound)

    def __str__(self) -> str:
        w = "default" if self.w is None else list(self.w)
        z = "default" if self.z is None else list(self.z)
        bound = "" if self.bound is None else f", bound={self.bound:g}"
        return f"{type(self).__name__}(w={w}, z={z}{bound})"

    def variables(self, declare) -> None:
        """None beyond the channel's bound (the engine's)."""

    def prescale(self, frame, dims) -> dict:
        """No constants beyond the channel's data (the engine's)."""
        return {}

    def coefficient_lmis(self, t, continuous):
        """None independent of the rate."""
        return []

    # Squared bounds scale like ``W`` (times ``sz^2``), and the
    # H-infinity one also like time (see `Hinf`).
    _per_time = False

    def _factor(self, frame, i) -> float:
        factor = frame.kappa * frame.sz(i) ** 2
        return factor / frame.a if self._per_time else factor

    def to_model(self, g: float, frame, i: int) -> float:
        """``sqrt(g~ kappa sz^2)`` (``/ a`` for H-infinity)."""
        return float(np.sqrt(g * self._factor(frame, i)))

    def to_scaled(self, bound: float, frame, i: int) -> float:
        """The inverse of `to_model`."""
        return bound**2 / self._factor(frame, i)


@dataclass(frozen=True)
class Hinf(_Performance):
    """H-infinity (L2-gain) specification from `w` to `z`.

    Parameters
    ----------
    w : str, int or sequence, optional
        Exogenous inputs; default every physical input that is not a
        control input.
    z : str, int or sequence, optional
        Performance outputs; default all outputs.
    bound : float, optional
        Required bound, met strictly; None (only for the objective) asks for
        the smallest one.

    Examples
    --------
    >>> Hinf(w="d", z=["e", "u"], bound=2.0)
    Hinf(w=('d',), z=('e', 'u'), bound=2.0)
    """

    inequality = "bounded-real"
    paper_case = True
    _per_time = True

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient (see the module docstring)."""
        Bw, Dzw = t.data("Bw"), t.data("Dzw")
        g = t.const(t.g()[0, 0] * np.eye(t.nz()))
        eye_w = t.rho() * t.identity(t.nw())
        if t.slack:
            AX, CX, X = t.AG(), t.CG(), 2 * t.G() - t.W()
        else:
            AX, CX, X = t.AW(), t.CW(), t.W()
        if continuous and t.slack:
            blocks = [*extended(t), [Bw.T, 0, -eye_w], [CX, t.eps_CG(), Dzw, -g]]
        elif continuous:
            blocks = [[2 * AX - t.W_moved()], [Bw.T, -eye_w], [CX, Dzw, -g]]
        else:
            blocks = [
                [-t.W_moved()],
                [AX.T, -X],
                [Bw.T, 0, -eye_w],
                [0, CX, Dzw, -g],
            ]
        return [("H-infinity", blocks)]

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the bounded-real inequality.

        At a `~ctrl_lpv.synthesis.frozen.FrozenLoop` with this spec's
        channel; continuous time the primal form with ``P``, discrete time
        the dual form with ``W`` and its next value ``W+`` (`residuals`
        of the one loop).
        """
        return float(self.residuals([loop], continuous)[0])

    def residuals(self, loops, continuous) -> np.ndarray:
        """`residual` of each loop, in one stacked evaluation."""

        def stack(field):
            return np.stack([getattr(loop, field) for loop in loops])

        A, Bw, Cz, Dzw = stack("Acl"), stack("Bw"), stack("Cz"), stack("Dzw")
        gamma = np.array([loop.bound for loop in loops], float)[:, None, None]
        k, n, nw, nz = A.shape[0], A.shape[1], Bw.shape[2], Cz.shape[1]
        At, Bwt, Czt, Dzwt = (np.swapaxes(X, 1, 2) for X in (A, Bw, Cz, Dzw))
        eye_w = np.broadcast_to(np.eye(nw), (k, nw, nw))
        bound = gamma**2 * np.eye(nz)
        if continuous:
            P, P_moved = stack("P"), stack("P_moved")
            M = _block([
                [At @ P + P @ A + P_moved, P @ Bw, Czt],
                [Bwt @ P, -eye_w, Dzwt],
                [Cz, Dzw, -bound],
            ])  # fmt: skip
        else:
            W, W_moved = stack("W"), stack("W_moved")
            M = _block([
                [-W_moved, A @ W, Bw, np.zeros((k, n, nz))],
                [W @ At, -W, np.zeros((k, n, nw)), W @ Czt],
                [Bwt, np.zeros((k, nw, n)), -eye_w, Dzwt],
                [np.zeros((k, nz, n)), Cz @ W, Dzw, -bound],
            ])  # fmt: skip
        return normalized_max_eigs(M)


@dataclass(frozen=True)
class H2(_Performance):
    """H2 specification from `w` to `z` (see the module docstring).

    Parameters
    ----------
    w : str, int or sequence, optional
        Exogenous inputs; default every physical input that is not a
        control input.
    z : str, int or sequence, optional
        Performance outputs; default all outputs.
    bound : float, optional
        Required bound, met strictly; None (only for the objective) asks for
        the smallest one.

    Notes
    -----
    In continuous time the feedthrough from `w` to `z` must be zero (the H2
    norm is infinite otherwise); a `ValueError` says so.
    """

    inequality = "H2 (Gramian)"
    # Attained (a Riccati solution); not H-infinity (often an infimum of
    # gains tending to infinity) nor a peak bound (which reads W's scale).
    shapeable = True

    def variables(self, declare) -> None:
        """``Y``, the bound on ``C_cl W C_cl'``."""
        declare.variable("Y", (declare.nz, declare.nz), symmetric=True)

    def check_data(self, channels, continuous) -> None:
        if not continuous:
            return
        for j, channel in enumerate(channels):
            rows, cols = np.nonzero(channel["Dzw"])
            if rows.size:
                w, z = _pair_names(channel, rows[0], cols[0])
                raise ValueError(
                    f"{self}: the feedthrough from w {w} to z {z} is "
                    f"{channel['Dzw'][rows[0], cols[0]]:.6g} at vertex {j} (not "
                    "zero), so the continuous-time H2 norm is infinite; leave "
                    f"{z} out of z (or {w} out of w), or use Hinf"
                )

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient (see the module docstring)."""
        Bw, Dzw, Y = t.data("Bw"), t.data("Dzw"), t.const(t.var("Y"))
        eye_w = t.rho() * t.identity(t.nw())
        if t.slack:
            # W(delta) only through its inverse's lower bound G + G' - W.
            AX, CX, X = t.AG(), t.CG(), 2 * t.G() - t.W()
        else:
            AX, CX, X = t.AW(), t.CW(), t.W()
        if continuous:
            gramian = extended(t) + [[Bw.T, 0, -eye_w]] if t.slack else [
                [2 * AX - t.W_moved()], [Bw.T, -eye_w]]  # fmt: skip
            trace = [[-Y], [CX.T, -X]]
        else:
            gramian = [[-t.W_moved()], [AX.T, -X], [Bw.T, 0, -eye_w]]
            trace = [[-Y], [CX.T, -X], [Dzw.T, 0, -eye_w]]
        return [("H2 Gramian", gramian), ("H2 trace", trace)]

    def problem_lmis(self, t):
        """``trace Y < h`` (``h`` the channel's squared bound)."""
        Y = t.var("Y")
        trace = sum(Y[k : k + 1, k : k + 1] for k in range(t.nz()))
        return [("trace Y < h", [[trace - t.g()]], True)]

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the Gramian inequalities.

        ``A W + W A' - dW/dt + Bw Bw' < 0`` (or ``A W A' - W+ + Bw Bw' < 0``)
        and the trace bound ``trace(Cz W Cz') < gamma^2`` (plus
        ``trace(Dzw Dzw')`` in discrete time), as a relative excess.
        """
        A, Bw, Cz, Dzw, gamma = loop.Acl, loop.Bw, loop.Cz, loop.Dzw, loop.bound
        W, W_moved = loop.W, loop.W_moved
        if continuous:
            M = A @ W + W @ A.T - W_moved + Bw @ Bw.T
            energy = np.trace(Cz @ W @ Cz.T)
        else:
            M = A @ W @ A.T - W_moved + Bw @ Bw.T
            energy = np.trace(Cz @ W @ Cz.T + Dzw @ Dzw.T)
        excess = (energy - gamma**2) / gamma**2
        return max(normalized_max_eig(M[None]), excess)


@dataclass(frozen=True)
class Peak(_Performance):
    """Peak bound on `z` under peak-bounded `w` (an invariant ellipsoid).

    For every ``w`` with ``|w_i(t)| <= w_max_i`` at all times and every
    admissible parameter trajectory, the ellipsoid ``E = {x : x' P x <= 1}``
    of the design's ``P`` is invariant, and on it ``|z| <= bound`` (the
    Euclidean norm of ``z(t)``): from ``x(0)`` in ``E`` (for example 0),
    ``|z(t)| <= bound`` for all ``t``. The bound is an upper bound of the
    peak-to-peak gain (the ``*``-norm bound of Abedor, Nagpal and Poolla,
    1996) and of the ultimate size of ``z``.

    Parameters
    ----------
    w : str, int or sequence, optional
        Exogenous inputs; default every physical input that is not a
        control input.
    z : str, int or sequence, optional
        Performance outputs; default all outputs.
    bound : float, optional
        Required bound, met strictly; None (only for the objective) asks for
        the smallest one.
    w_max : float or sequence of float, optional
        Peak of each input of `w` (one value for all), default 1.

    Notes
    -----
    With ``W = P^-1``, ``Z = -K W``, a decay ``lambda > 0`` and multipliers
    ``mu_i >= 0``: ``V' <= -lambda V + sum_i mu_i (w_i / w_max_i)^2`` with
    ``sum_i mu_i <= lambda`` makes ``E`` invariant. The LMIs are

    ``[[sym(A W + B2 Z) - dW/dt + lambda W, *], [Bw', -diag(mu / w_max^2)]]
    < 0`` (continuous time), ``[[-W+, *, *], [(A W + B2 Z)', -(1 - lambda)
    W, *], [Bw', 0, -diag(mu / w_max^2)]] < 0`` (discrete time, ``0 <
    lambda < 1``), ``sum(mu) <= lambda`` and ``[[g I, *], [(Cz W + Dzu
    Z)', W]] >= 0`` with ``bound^2 = g``. For a fixed ``lambda`` they are
    LMIs; `synthesize` searches ``lambda`` (a grid, refined around the best
    raw optimum; Nazin, Polyak and Topunov 2007 give the same one-parameter
    family). With a `Saturation` constraint the disturbance also enters
    its sector inequality, so that ``E`` is invariant for the *saturated*
    loop. The feedthrough from `w` to `z` must be zero (a `ValueError`
    says so). At most one `Peak` spec per design, with a constant
    Lyapunov matrix or scheduled gains.
    """

    inequality = "peak (invariance)"
    unique = True

    w_max: tuple = (1.0,)

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "w_max", positive_levels(self.w_max, "w_max"))

    def validate(self, context) -> None:
        if not (context.constant or context.scheduled):
            raise ValueError(
                "constraints: Peak with a common gain and lyapunov='affine' is not "
                "implemented (the extended LMIs have no invariance form here); use "
                "gains='scheduled' or a constant Lyapunov matrix"
            )

    def variables(self, declare) -> None:
        """The multipliers ``mu`` and the parameters ``lam`` (the decay, which
        the engine searches) and ``weights`` (``rho a / w_max^2``)."""
        declare.variable("mu", (declare.nw, 1))
        declare.parameter("lam", (), nonneg=True)
        declare.parameter("weights", (declare.nw,), nonneg=True)

    def prescale(self, frame, dims) -> dict:
        """The ``(w, w)`` block's weights ``rho a / w_max^2``: congruent to
        the model's as `Hinf`'s identity block (weight ``rho``), with ``mu =
        a mu~`` for the prescaled variable ``mu~``."""
        rho = frame.rho(dims.i)
        return {"weights": self.weights(dims.nw) * rho * frame.a}

    def decays(self, continuous):
        """The decay grid (see `LAMBDAS`)."""
        return LAMBDAS[continuous]

    def __str__(self) -> str:
        return super().__str__()[:-1] + f", w_max={list(self.w_max)})"

    def check_data(self, channels, continuous) -> None:
        if any(np.any(d["Dzw"] != 0) for d in channels):
            raise ValueError(
                f"{self}: the feedthrough from w to z is not zero; the peak bound "
                "is written for z = Cz x + Dzu u"
            )
        self.weights(channels[0]["Dzw"].shape[1])

    def weights(self, nw: int) -> np.ndarray:
        """``1 / w_max_i^2``, one per input of `w`."""
        return 1.0 / per_input(self.w_max, nw, "w_max", "inputs w") ** 2

    def disturbance(self, t):
        """``(lambda, Bw, -diag(mu / w_max^2))`` in prescaled units."""
        weights, mu = t.var("weights"), t.var("mu")
        nw = t.nw()
        D = sum(weights[i] * mu[i, 0] * unit(nw, i) for i in range(nw))
        return t.var("lam"), t.data("Bw"), -t.const(D)

    def lmis(self, t, continuous):
        """The invariance inequality at one coefficient and rate."""
        lam, Bw, D = self.disturbance(t)
        AX, W = t.AW(), t.W()
        if continuous:
            blocks = [[2 * AX - t.W_moved() + lam * W], [Bw.T, D]]
        else:
            blocks = [[-t.W_moved()], [AX.T, -(1 - lam) * W], [Bw.T, 0, D]]
        return [("peak invariance", blocks)]

    def coefficient_lmis(self, t, continuous):
        """The peak of ``z`` on ``E``: ``[[g I, *], [C_cl W', W]] >= 0``."""
        g = t.const(t.g()[0, 0] * np.eye(t.nz()))
        return [("peak output", [[-g], [t.CW().T, -t.W()]])]

    def problem_lmis(self, t):
        """``sum(mu) <= lambda`` (non-strict)."""
        ones = np.ones((1, t.nw()))
        return [("sum(mu) <= lambda",
                 [[ones @ t.var("mu") - t.var("lam") * np.eye(1)]], False)]  # fmt: skip

    def loop_fields(self, here) -> dict:
        """The disturbance input ``Bd``, the decay ``lam`` and ``mu_w = mu /
        w_max^2`` in the model's units (``mu = a mu~``, ``lambda = a
        lambda~``), which a `Saturation` sector also reads."""
        nw = here.nw
        return {
            "Bd": here.mix("Bw"),
            "lam": float(here.var("lam")) * here.frame.a,
            "mu_w": here.frame.a * np.ravel(here.var("mu")) * self.weights(nw),
        }

    def residual(self, loop, continuous) -> float:
        """Largest excess of the invariance and peak inequalities.

        At a `~ctrl_lpv.synthesis.frozen.FrozenLoop` with this spec's
        channel, its disturbance ``Bd`` and the model-unit ``lam`` and
        ``mu_w = mu / w_max^2``: the
        primal invariance inequality with ``P`` (Jacobi-normalised), the
        relative excess of ``sum(mu) <= lambda`` and of ``Cz W Cz' <=
        bound^2 I``.
        """
        Cz, lam = loop.Cz, loop.lam
        mu = loop.mu_w / self.weights(loop.Bd.shape[1])
        peak = np.linalg.eigvalsh(Cz @ loop.W @ Cz.T)[-1] / loop.bound**2 - 1
        return max(self.invariance(loop, continuous), float(mu.sum() / lam - 1), peak)

    @staticmethod
    def invariance(loop, continuous) -> float:
        """Largest normalised eigenvalue of the primal invariance inequality
        (with ``P``, the model-unit ``lam`` and ``mu_w``) at a frozen loop."""
        A, Bw, P, lam = loop.Acl, loop.Bd, loop.P, loop.lam
        Mw = np.diag(loop.mu_w)
        if continuous:
            M = np.block([
                [A.T @ P + P @ A + loop.P_moved + lam * P, P @ Bw],
                [Bw.T @ P, -Mw],
            ])  # fmt: skip
        else:
            Pn = loop.P_moved
            M = np.block([
                [A.T @ Pn @ A - (1 - lam) * P, A.T @ Pn @ Bw],
                [Bw.T @ Pn @ A, Bw.T @ Pn @ Bw - Mw],
            ])  # fmt: skip
        return normalized_max_eig(M[None])


def _pair_names(channel, row, col) -> tuple[str, str]:
    """The names (or positions) of input `col` of w and output `row` of z."""
    w = channel.get("w")
    z = channel.get("z")
    return (
        repr(w[col]) if w else f"number {col}",
        repr(z[row]) if z else f"number {row}",
    )


def _block(rows) -> np.ndarray:
    """`numpy.block` of stacked blocks (a leading axis over the points)."""
    return np.concatenate([np.concatenate(row, axis=2) for row in rows], axis=1)
