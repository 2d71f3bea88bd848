"""Constraint specs of `synthesize` beyond performance bounds.

`GainBound` bounds the gains; `Saturation` certifies a region of attraction
under input saturation. Pole regions are `ctrl_lpv.regions.LMIRegion`
objects, which follow the same protocol. A constraint spec may have

* ``prescale(scaling, n, m)``: its constants in a job's prescaled units,
  read back by its blocks through ``t.prescaled(spec)``;
* ``variables(lmi, n, m, nZ)``: its own LMI variables;
* ``lmis(t, continuous)``: its blocks at one coefficient of the relaxation
  and one vertex of the rate box (those that contain ``dW/dt``);
* ``coefficient_lmis(t, continuous)``: its blocks at one coefficient (those
  that do not depend on the rate);
* ``residual(loop, continuous)``: the largest excess of its statements at
  one frozen closed loop in the model's units (a `FrozenLoop` of
  `ctrl_lpv.synthesis.frozen`), below rounding for a certified design.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import real_number
from ..lmi import normalized_max_eig
from .specs import Peak, per_input, positive_levels, unit


@dataclass(frozen=True)
class GainBound:
    """Bound on the spectral norm of every gain, in the model's units.

    Parameters
    ----------
    bound : float
        Upper bound on ``||K||_2`` (every vertex gain when scheduled).

    Notes
    -----
    Imposed by convex-concave iterations from the first certified point (a
    sufficient condition); a design whose gain stays above the bound is
    not returned.
    """

    bound: float

    def __post_init__(self):
        object.__setattr__(
            self, "bound", real_number(self.bound, "bound", positive=True)
        )

    def __str__(self) -> str:
        return f"GainBound({self.bound:g})"

    @staticmethod
    def tangent(W, Z, Ginv, Ginv_K, kappa, T, Su):
        """``||K||^2 <= kappa kappa0`` linearised at the previous point.

        With ``K = Su Z W^-1 T^-1`` in prescaled units, the bound is
        ``(Su Z)'(Su Z) <= kappa kappa0 (T W)'(T W)``, whose right side is
        bounded below by its tangent at ``G0 = T W0``; a Schur complement
        and the congruence with ``G0^-1`` give the block returned,
        sufficient everywhere and exact at ``W0``. The gain iterations set
        ``Ginv`` and ``Ginv_K`` at each new point (`ladder.gain_tangent`).

        Parameters
        ----------
        W, Z : ndarray or cvxpy expression
            The prescaled Lyapunov matrix and gain variable.
        Ginv, Ginv_K : ndarray or cvxpy parameter
            ``G0^-1`` and ``G0^-1 / sqrt(kappa0)``.
        kappa : float or cvxpy expression
            The squared gain relative to ``kappa0``, the previous point's.
        T, Su : ndarray
            The state and input scalings (matrices).

        Returns
        -------
        list of list
            The lower-triangular blocks of an LMI ``<= 0``.
        """
        n, m = W.shape[0], Z.shape[0]
        return [
            [-(T @ W @ Ginv + Ginv.T @ W @ T.T - np.eye(n))],
            [Su @ Z @ Ginv_K, -kappa * np.eye(m)],
        ]

    def residual(self, loop, continuous) -> float:
        """Relative excess ``||K||_2 / bound - 1`` of the frozen gain."""
        return float(np.linalg.norm(loop.K, 2)) / self.bound - 1


@dataclass(frozen=True)
class Saturation:
    """Certified region of attraction under actuator saturation.

    The plant sees ``sat(u)``, each input clipped at ``|u_i| <= u_max_i``,
    with ``u = -K x``. The spec certifies that the ellipsoid
    ``E = {x : x' P x <= 1}`` of the design's Lyapunov matrix ``P`` lies in
    the region of attraction of the saturated closed loop (``w = 0``, every
    admissible parameter trajectory), and contains the given `points`.

    Parameters
    ----------
    u_max : float or sequence of float
        Saturation level of each control input (one value for all).
    points : sequence of array_like, optional
        States (model units) that must lie in ``E``: initial conditions
        from which convergence is certified despite saturation.

    Notes
    -----
    The generalized sector condition (Gomes da Silva and Tarbouriech, IEEE
    TAC 50(1), 2005; Tarbouriech, Garcia, Gomes da Silva and Queinnec,
    *Stability and Stabilization of Linear Systems with Saturating
    Actuators*, 2011, chapter 3): with the dead zone ``psi = u - sat(u)``
    and an auxiliary gain ``G``, ``psi' T (psi + G x) <= 0`` for every
    diagonal ``T > 0`` wherever ``|((K - G) x)_i| <= u_max_i``. With
    ``W = P^-1``, ``Z = -K W``, ``Zg = G W`` and ``S = T^-1`` the LMIs are

    ``[[sym(A W + B2 Z) - dW/dt, *], [-S B2' - Zg, -2 S]] < 0`` (decrease of
    ``V = x' P x`` in the sector) and ``[[u_max_i^2, *], [-(Z + Zg)_i', W]]
    > 0`` (``E`` inside the sector's region), ``[[1, *], [x0, W]] > 0`` for
    each point. With a `Peak` spec the sector inequality also carries its
    decay ``lambda W`` and disturbance column, so that ``E`` is invariant for
    the saturated loop under every disturbance of peak ``w_max``: the
    ultimate-bound certificate of the servo. ``E`` shares ``P`` with the
    performance specs: with an
    `Hinf` objective ``E`` is also the set that the linear loop's states
    reach with unit disturbance energy, so a larger region costs gamma.
    Continuous time, with a constant or a scheduled ``W``.
    """

    u_max: tuple
    points: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "u_max", positive_levels(self.u_max, "u_max"))
        try:
            points = tuple(
                tuple(real_number(x, "points", below=1e150) for x in np.ravel(p))
                for p in self.points
            )
        except TypeError:
            raise TypeError(
                f"points: expected a sequence of state vectors, got {self.points!r}"
            ) from None
        object.__setattr__(self, "points", points)

    def __str__(self) -> str:
        return f"Saturation(u_max={list(self.u_max)}, {len(self.points)} points)"

    def check_sizes(self, n: int, m: int) -> np.ndarray:
        """The levels, one per input; refuse sizes that do not fit."""
        out = per_input(self.u_max, m, "u_max", "control inputs")
        for point in self.points:
            if len(point) != n:
                raise ValueError(f"points: a point has {len(point)} entries, not {n}")
        return out

    def prescale(self, scaling, n: int, m: int) -> dict:
        """Levels and points in the prescaled units of a job.

        With ``W = k T W~ T'`` and ``K = Su K~ T^-1`` (``k`` the scaling's
        `w_factor`), ``(K - G) W (K - G)' = k Su (Z~ + Zg~) W~^-1 (.)' Su``
        and ``x0' W^-1 x0 = x~0' W~^-1 x~0 / k`` with ``x~0 = T^-1 x0``.
        """
        k = scaling.w_factor
        levels = self.check_sizes(n, m) ** 2 / (k * scaling.Su**2)
        Ti = np.linalg.inv(scaling.matrix)
        points = [Ti @ np.array(p) / np.sqrt(k) for p in self.points]
        return {"levels": levels, "points": points}

    def variables(self, lmi, n: int, m: int, nZ: int) -> None:
        """``Zg`` (one per gain, the auxiliary gain times ``W``) and the
        diagonal of ``S``."""
        for k in range(nZ):
            lmi.variable(f"Zg{k}", (m, n))
        lmi.variable("S", (m, 1))

    def lmis(self, t, continuous):
        """The sector inequality at one coefficient and rate."""
        m = t.m
        S = t.const(sum(t.v.S[i, 0] * unit(m, i) for i in range(m)))
        sector = [
            [2 * t.AW() - t.W_moved()],
            [-S @ t.B2().T - t.linear("Zg"), -2 * S],
        ]
        peak = next((spec for spec in t.specs if isinstance(spec, Peak)), None)
        if peak is not None:
            # E must be invariant for the saturated loop under the disturbance.
            sector[0][0] = sector[0][0] + t.v.lam * t.W()
            sector.append([t.data(peak, "Bw").T, 0, peak.disturbance(t)])
        return [("saturation sector", sector)]

    def coefficient_lmis(self, t, continuous):
        """``E`` inside the sector's region, and the points inside ``E``."""
        scaled = t.prescaled(self)
        Zsum = t.linear("Z") + t.linear("Zg")
        out = []
        for i, level in enumerate(scaled["levels"]):
            out.append((
                f"saturation level {i}",
                [[-t.const(level * np.eye(1))], [Zsum[i : i + 1, :].T, -t.W()]],
            ))  # fmt: skip
        for q, x0 in enumerate(scaled["points"]):
            out.append((
                f"saturation point {q}",
                [[-t.identity(1)], [t.const(x0[:, None]), -t.W()]],
            ))  # fmt: skip
        return out

    def unscale(self, sol, scaling, nZ):
        """The auxiliary gains ``Zg~`` and the multiplier in model units.

        ``T = (a / w_factor) Su^-1 S~^-1 Su^-1`` (``S~`` the solution's
        diagonal), so that the sector inequality in the model's units is
        congruent to the prescaled one.
        """
        Zg = [getattr(sol, f"Zg{k}") for k in range(nZ)]
        S = np.asarray(sol.S, float).reshape(-1)
        return Zg, np.diag(scaling.a / scaling.w_factor / (scaling.Su**2 * S))

    def level(self, P) -> float | None:
        """The largest ``x0' P x0`` over the points (None without points)."""
        if not self.points:
            return None
        return max(float(np.array(x) @ P @ np.array(x)) for x in self.points)

    def residual(self, loop, continuous) -> float:
        """Largest excess, in the model's units, of the certified statements.

        The sector inequality ``[[sym(P Acl) + dP/dt, -(P B2 + G' T)],
        [*, -2 T]] < 0`` (Jacobi-normalised eigenvalue) with the loop's
        auxiliary gain ``G`` and multiplier ``T``, and the relative excesses
        of ``(K - G)_i W (K - G)_i' <= u_max_i^2`` and ``x0' P x0 <= 1``.
        """
        Acl, B2, K, G, T, P = loop.Acl, loop.B2, loop.K, loop.G, loop.T, loop.P
        m = B2.shape[1]
        M = np.block([
            [Acl.T @ P + P @ Acl + loop.P_moved, -(P @ B2 + G.T @ T)],
            [-(B2.T @ P + T @ G), -2 * T],
        ])  # fmt: skip
        if loop.lam is not None:
            # With a Peak spec: its decay and disturbance (see `lmis`).
            nw = loop.Bd.shape[1]
            M[: len(P), : len(P)] += loop.lam * P
            M = np.block([
                [M, np.vstack([P @ loop.Bd, np.zeros((m, nw))])],
                [loop.Bd.T @ P, np.zeros((nw, m)), -np.diag(loop.mu_w)],
            ])  # fmt: skip
        worst = normalized_max_eig(M[None])
        levels = self.check_sizes(Acl.shape[0], m)
        F = K - G
        for i in range(m):
            worst = max(worst, float(F[i] @ loop.W @ F[i]) / levels[i] ** 2 - 1)
        level = self.level(P)
        return worst if level is None else max(worst, level - 1)
