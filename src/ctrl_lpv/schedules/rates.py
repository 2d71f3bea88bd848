"""The largest certified parameter rate, and bounds under a rate bound.

Both kinds of closed loops (`certify` on polytopic and on gridded plants)
pose a rate-bounded Lyapunov problem with the rate box ``|dp_k/dt| <=
nu_k`` as a parameter of one LMI problem; `RateSearch` solves it for given
rates, finds the largest uniform rate by bisection, and bounds a channel's
L2 gain under given rates.

On a piece of the parameter domain (a schedule simplex, or a grid cell
within one) both reduce to one **family**: nonnegative coordinates ``l``
summing to one in which the loop is ``sum_a l_a M_a``, the Lyapunov matrix
``P = sum_a l_a P_a`` and its derivative along a rate vertex ``dP/dt =
sum_a l_a D_a``; with a channel also ``B_w``, ``C_z`` and ``D_zw`` are
``sum_a l_a (.)_a``. `family_lmis` poses the homogeneous quadratic form in
``l`` (``dV/dt``, or the bounded-real matrix of ``dV/dt + z'z/g - g w'w``)
through its diagonal terms and the sums of its pairwise terms, each
negative definite: sufficient, as ``l >= 0``.
"""

from __future__ import annotations

import math

import numpy as np

from ..certificate import Certificate, Check
from ..exceptions import SynthesisError

__all__ = ["RateSearch", "family_lmis", "rate_variables"]


def rate_variables(lmi, indices, n, k, bounded=False):
    """Declare ``P_i > 0`` for `indices` (``n x n``), the rates ``nu`` (`k`),
    and with `bounded` the L2 gain ``g``; without it ``P_i <= I`` fixes the
    scale (the Lyapunov LMIs are homogeneous in ``P``)."""
    for i in indices:
        lmi.variable(f"P{i}", (n, n), symmetric=True)
        lmi.add(f"P{i} > 0", lambda v, i=i: [[-getattr(v, f"P{i}")]])
        if not bounded:
            lmi.add(f"P{i} <= I", lambda v, i=i: [[getattr(v, f"P{i}") - np.eye(n)]],
                    strict=False, normalization=True)  # fmt: skip
    if bounded:
        lmi.variable("g", (1, 1))
    lmi.parameter("nu", (k,), value=np.zeros(k), nonneg=True)


def _sym(X):
    return X + X.T


def family_lmis(lmi, where, names, M, P, D, channel=None):
    """Add the LMIs of one family (see the module docstring).

    Parameters
    ----------
    lmi : `ctrl_lpv.lmi.LMIProblem`
        With the variables read by `P` and `D` (and ``g``, the bound, with
        a `channel`).
    where : str
        The family's label (cell, rate vertex) in the LMIs' names.
    names : sequence
        The label of each member (a point or corner index).
    M : sequence of ndarray
        The loops ``M_a``.
    P, D : callable
        ``P(v, a)`` and ``D(v, a)``: ``P_a`` and ``D_a`` of the point `v`.
    channel : tuple of sequences, optional
        ``(B_w, C_z, D_zw)`` of each member: the bounded-real LMIs of the L2
        gain ``g`` (variable ``g``) instead of the Lyapunov ones.
    """

    def block(v, terms):
        top = sum(_sym(M[a].T @ P(v, b)) + D(v, a) for a, b in terms)
        if channel is None:
            return [[top]]
        Bw, Cz, Dzw = channel
        c = len(terms) * v.g[0, 0]
        PB = sum(P(v, b) @ Bw[a] for a, b in terms)
        C = sum(Cz[a] for a, _ in terms)
        Dd = sum(Dzw[a] for a, _ in terms)
        return [[top], [PB.T, -c * np.eye(PB.shape[1])], [C, Dd, -c * np.eye(len(C))]]

    for a in range(len(M)):
        lmi.add(f"{where} point {names[a]}", lambda v, a=a: block(v, [(a, a)]))
    for a in range(len(M)):
        for b in range(a + 1, len(M)):
            lmi.add(f"{where} pair {names[a]},{names[b]}",
                    lambda v, a=a, b=b: block(v, [(a, b), (b, a)]))  # fmt: skip


class RateSearch:
    """`rate_bounded` and `largest_rate` over `_rate_problem`.

    Subclasses provide ``_rate_problem(margin, channel=None)`` (an
    `LMIProblem` with the parameter ``"nu"``, and with a channel the
    variable ``g``, by `family_lmis`), ``rate_channel(objective)`` (the
    channel's matrices per family, or a `ValueError` saying why there are
    none), ``names``, ``plant`` (with a box domain), ``Acl`` (closed-loop
    matrices, for the scale of the first rate tried), and the texts
    `region` and `lyapunov_form` of the certificate's statement.
    """

    region = "in the points' convex hull"
    lyapunov_form = "P(p) affine on each cell, continuous"
    #: Whether a parameter may be left out of the rates.
    unbounded_rates = False

    def rate_bounded(self, nu, margin, lmi=None, solvers=None):
        """The certificate with rates `nu` (one per parameter), or None.

        `lmi` is the problem of `_rate_problem` to re-solve (``nu`` is a
        parameter of it: the bisection builds it once); `solvers` the
        chain (default `ctrl_lpv.lmi.default_solvers`).
        """
        lmi = self._rate_problem(margin) if lmi is None else lmi
        lmi.set_parameter("nu", nu)
        try:
            sol = lmi.solve(solvers=solvers)
        except SynthesisError:
            return None
        checks = tuple(
            Check.from_lmi_check(c, group="rate-bounded") for c in sol.checks
        )
        rates = ", ".join(f"|d{n}/dt| <= {v:.4g}" for n, v in zip(self.names, nu))
        return Certificate(
            checks,
            statement=(
                f"stable for parameter trajectories {self.region} with {rates} "
                f"({self.lyapunov_form})"
            ),
        )

    def largest_rate(self, margin):
        """``(nu, certificate)``: the largest uniform rate certified.

        The steps after the first use the first solver of the default chain
        only: near the largest rate a refused step otherwise falls through
        to SCS, measured at 35 s a step on a 3 x 2 grid against 2 s; a step
        refused that another solver would have certified only lowers the
        rate found (each certified step is still checked in float64).
        """
        from ..lmi import default_solvers

        width = float(np.max(self.plant.domain.upper - self.plant.domain.lower))
        rate = 1e-3 * width * max(1.0, float(np.abs(self.Acl).max()))
        ones = np.ones(len(self.names))
        lmi = self._rate_problem(margin)
        best, certificate = 0.0, self.rate_bounded(0.0 * ones, margin, lmi)
        if certificate is None:
            return 0.0, None
        first = default_solvers()[:1]
        lo, hi = 0.0, None
        for _ in range(40):  # expand, then bisect to 5 %
            trial = rate if hi is None else 0.5 * (lo + hi)
            found = self.rate_bounded(trial * ones, margin, lmi, first)
            if found is not None:
                lo, best, certificate = trial, trial, found
                rate *= 4.0
                if hi is None and rate > 1e9:
                    return math.inf, certificate
            else:
                hi = trial
            if hi is not None and hi - lo <= 0.05 * hi:
                break
        return best, certificate

    def rate_bound(self, objective, nu, margin):
        """``(bound, certificate)``: the L2 gain of `objective`'s channel for
        parameter trajectories with rates `nu`, or None when no bound is
        certified.

        Raises
        ------
        ValueError
            For an objective this analysis does not bound (H2), or loops
            whose channel is not affine on a piece.
        """
        from ..synthesis import Hinf

        if not isinstance(objective, Hinf):
            raise ValueError(
                "objective: under a rate bound only the L2 gain (Hinf) is "
                "bounded; the H2 bound needs arbitrary rates"
            )
        channel, w, z = self.rate_channel(objective)
        lmi = self._rate_problem(margin, channel)
        lmi.set_parameter("nu", np.asarray(nu, float))
        try:
            sol = lmi.solve(lambda v: v.g[0, 0])
        except SynthesisError:
            return None
        bound = float(sol.g[0, 0])
        checks = tuple(
            Check.from_lmi_check(c, group="rate-bounded L2") for c in sol.checks
        )
        rates = ", ".join(f"|d{n}/dt| <= {v:.4g}" for n, v in zip(self.names, nu))
        return bound, Certificate(
            checks,
            statement=(
                f"L2 gain from {list(w)} to {list(z)} below {bound:.6g} for "
                f"parameter trajectories {self.region} with {rates} "
                f"({self.lyapunov_form})"
            ),
        )
