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
extended ones (see `_extended`): ``A_cl W`` becomes ``A_cl G`` with a
constant slack ``G`` and ``K = -Z G^-1``, which keeps them affine in the
parameter. Discrete time: ``[[W - G - G', *], [A_cl G, -W+]] < 0``
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


@dataclass(frozen=True)
class _Performance:
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

    def check_data(self, channels, continuous) -> None:
        """Refuse data the spec cannot bound (a `ValueError`)."""


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

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient (see the module docstring)."""
        Bw, Dzw = t.data(self, "Bw"), t.data(self, "Dzw")
        g = t.const(t.g(self)[0, 0] * np.eye(t.nz(self)))
        eye_w = t.rho(self) * t.identity(t.nw(self))
        if t.slack:
            AX, CX, X = t.AG(), t.CG(self), 2 * t.G() - t.W()
        else:
            AX, CX, X = t.AW(), t.CW(self), t.W()
        if continuous and t.slack:
            blocks = [*_extended(t), [Bw.T, 0, -eye_w], [CX, t.eps() * CX, Dzw, -g]]
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
        the dual form with ``W`` and its next value ``W+``.
        """
        A, Bw, Cz, Dzw, gamma = loop.Acl, loop.Bw, loop.Cz, loop.Dzw, loop.bound
        P, P_moved, W, W_moved = loop.P, loop.P_moved, loop.W, loop.W_moved
        n, nw, nz = A.shape[0], Bw.shape[1], Cz.shape[0]
        if continuous:
            M = np.block([
                [A.T @ P + P @ A + P_moved, P @ Bw, Cz.T],
                [Bw.T @ P, -np.eye(nw), Dzw.T],
                [Cz, Dzw, -gamma**2 * np.eye(nz)],
            ])  # fmt: skip
        else:
            M = np.block([
                [-W_moved, A @ W, Bw, np.zeros((n, nz))],
                [W @ A.T, -W, np.zeros((n, nw)), W @ Cz.T],
                [Bw.T, np.zeros((nw, n)), -np.eye(nw), Dzw.T],
                [np.zeros((nz, n)), Cz @ W, Dzw, -gamma**2 * np.eye(nz)],
            ])  # fmt: skip
        return normalized_max_eig(M[None])


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
        rho = t.rho(self)
        Bw, Dzw, Y = t.data(self, "Bw"), t.data(self, "Dzw"), t.const(t.Y(self))
        eye_w = rho * t.identity(t.nw(self))
        if t.slack:
            # W(delta) only through its inverse's lower bound G + G' - W.
            AX, CX, X = t.AG(), t.CG(self), 2 * t.G() - t.W()
        else:
            AX, CX, X = t.AW(), t.CW(self), t.W()
        if continuous:
            gramian = _extended(t) + [[Bw.T, 0, -eye_w]] if t.slack else [
                [2 * AX - t.W_moved()], [Bw.T, -eye_w]]  # fmt: skip
            trace = [[-Y], [CX.T, -X]]
        else:
            gramian = [[-t.W_moved()], [AX.T, -X], [Bw.T, 0, -eye_w]]
            trace = [[-Y], [CX.T, -X], [Dzw.T, 0, -eye_w]]
        return [("H2 Gramian", gramian), ("H2 trace", trace)]

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

    w_max: tuple = (1.0,)

    def __post_init__(self):
        super().__post_init__()
        object.__setattr__(self, "w_max", positive_levels(self.w_max, "w_max"))

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

    def prescale(self, scaling, n: int, m: int) -> dict:
        """The time scaling: ``mu~ = mu / a`` and ``lambda~ = lambda / a``."""
        return {"a": scaling.a}

    def disturbance(self, t):
        """The ``(w, w)`` block ``-diag(mu / w_max^2)`` in prescaled units.

        Congruent to the model's as `Hinf`'s identity block (weight
        ``rho``), with ``mu = a mu~`` for the prescaled variable ``mu~``.
        """
        weights = self.weights(t.nw(self)) * t.rho(self) * t.prescaled(self)["a"]
        mu = t.v.mu
        D = sum(weights[i] * mu[i, 0] * unit(len(weights), i)
                for i in range(len(weights)))  # fmt: skip
        return -t.const(D)

    def lmis(self, t, continuous):
        """The invariance inequality at one coefficient and rate."""
        Bw, lam = t.data(self, "Bw"), t.v.lam
        AX, W = t.AW(), t.W()
        if continuous:
            blocks = [[2 * AX - t.W_moved() + lam * W], [Bw.T, self.disturbance(t)]]
        else:
            blocks = [
                [-t.W_moved()],
                [AX.T, -(1 - lam) * W],
                [Bw.T, 0, self.disturbance(t)],
            ]
        return [("peak invariance", blocks)]

    def coefficient_lmis(self, t, continuous):
        """The peak of ``z`` on ``E``: ``[[g I, *], [C_cl W', W]] >= 0``."""
        g = t.const(t.g(self)[0, 0] * np.eye(t.nz(self)))
        return [("peak output", [[-g], [t.CW(self).T, -t.W()]])]

    def residual(self, loop, continuous) -> float:
        """Largest excess of the invariance and peak inequalities.

        At a `~ctrl_lpv.synthesis.frozen.FrozenLoop` with this spec's
        channel, its disturbance ``Bd`` and the model-unit ``lam`` and
        ``mu_w = mu / w_max^2``: the
        primal invariance inequality with ``P`` (Jacobi-normalised), the
        relative excess of ``sum(mu) <= lambda`` and of ``Cz W Cz' <=
        bound^2 I``.
        """
        A, Bw, Cz, P, lam = loop.Acl, loop.Bd, loop.Cz, loop.P, loop.lam
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
        mu = loop.mu_w / self.weights(Bw.shape[1])
        peak = np.linalg.eigvalsh(Cz @ loop.W @ Cz.T)[-1] / loop.bound**2 - 1
        return max(normalized_max_eig(M[None]), float(mu.sum() / lam - 1), peak)


def _pair_names(channel, row, col) -> tuple[str, str]:
    """The names (or positions) of input `col` of w and output `row` of z."""
    w = channel.get("w")
    z = channel.get("z")
    return (
        repr(w[col]) if w else f"number {col}",
        repr(z[row]) if z else f"number {row}",
    )


def unit(m, i):
    """The ``m x m`` matrix with a one at ``(i, i)`` (builds diagonal
    multipliers from scalar variables, which cvxpy's ``diag`` would not keep
    DPP)."""
    E = np.zeros((m, m))
    E[i, i] = 1.0
    return E


PERFORMANCE = (Hinf, H2, Peak)


class Stability:
    """Lyapunov stability alone: the objective ``None`` of `synthesize`.

    Continuous time ``sym(A W + B2 Z) - dW/dt < 0``; discrete time
    ``[[-W, *], [A W + B2 Z, -W+]] < 0``.
    """

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient."""
        if t.slack:
            if continuous:
                return [("Lyapunov", _extended(t))]
            return [("Lyapunov", [[t.W() - 2 * t.G()], [t.AG(), -t.W_moved()]])]
        if continuous:
            return [("Lyapunov", [[2 * t.AW() - t.W_moved()]])]
        return [("Lyapunov", [[-t.W()], [t.AW(), -t.W_moved()]])]

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the primal Lyapunov inequality."""
        A, P, P_moved = loop.Acl, loop.P, loop.P_moved
        if continuous:
            M = A.T @ P + P @ A + P_moved
        else:
            M = A.T @ P_moved @ A - P
        return normalized_max_eig(M[None])


def _extended(t):
    """The first two block rows of the continuous-time extended LMIs.

    ``[[sym(A_cl G) - dW/dt, *], [W - G + eps (A_cl G)', -eps sym(G)]]``:
    with the slack ``G`` and a fixed ``eps > 0`` this is the projection of
    the dual inequality (Pipeleers, Demeulenaere, Swevers and Vandenberghe
    2009; Apkarian, Tuan and Bernussou 2001), which lets a common gain
    ``K = -Z G^-1`` go with a parameter-dependent ``W``.
    """
    AG, eps = t.AG(), t.eps()
    return [[2 * AG - t.W_moved()], [t.W() - t.G() + eps * AG.T, -2 * eps * t.G()]]
