"""The largest certified parameter rate, and bounds under a rate bound.

Both kinds of closed loops (`certify` on polytopic and on gridded plants)
pose a rate-bounded Lyapunov problem with the rate box ``|dp_k/dt| <=
nu_k`` as a parameter of one LMI problem; `RateSearch` solves it for given
rates, finds the largest uniform rate by bisection, and bounds a channel's
L2 gain under given rates.

On a piece of the parameter domain (a schedule simplex, a grid cell
within one, a cell of a dynamic controller's loop) every kind reduces to
nonnegative coordinates ``l`` summing to one in which the loop, the
Lyapunov matrix ``P = sum_a l_a P_a`` and its derivative along a rate
vertex are polynomials: ``dV/dt`` (or the bounded-real matrix of ``dV/dt +
z'z/g - g w'w``) is then a homogeneous form in ``l``, posed by `form_lmis`
through the sums of its coefficients over the orderings of each multiset,
each negative definite: sufficient, as ``l >= 0``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..certificate import Certificate, Check
from ..exceptions import SynthesisError

__all__ = ["RateSearch", "form_lmis", "orderings", "rate_variables", "sum_blocks"]


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


def orderings(count: int, degree: int):
    """The coefficients of a homogeneous form of `degree` in `count` weights.

    Yields, for each multiset of `degree` positions, its distinct
    orderings: the form ``sum w_i w_j ... T(i, j, ...)`` is negative on the
    simplex when, for every multiset, the sum of ``T`` over its orderings
    is (a Polya relaxation of degree zero; Oliveira and Peres 2007).
    """
    for multiset in itertools.combinations_with_replacement(range(count), degree):
        yield multiset, sorted(set(itertools.permutations(multiset)))


def sum_blocks(terms):
    """The lower block triangles `terms` added block by block."""
    return [[sum(parts) for parts in zip(*rows)] for rows in zip(*terms)]


def form_lmis(lmi, where, names, degree, term):
    """Add the LMIs of a homogeneous form in the weights of `names`.

    ``term(v, order)`` is the coefficient (a lower block triangle) of the
    monomial of the positions `order`; for every multiset of `degree`
    positions the sum of `term` over its orderings must be negative
    definite (`orderings`): sufficient for the form on the simplex.
    """
    for multiset, orders in orderings(len(names), degree):
        lmi.add(
            f"{where} points {[names[a] for a in multiset]}",
            lambda v, orders=orders: sum_blocks([term(v, o) for o in orders]),
        )


class RateSearch:
    """`rate_bounded` and `largest_rate` over `_rate_problem`.

    Subclasses provide ``_rate_problem(margin, channel=None)`` (an
    `LMIProblem` with the parameter ``"nu"``, and with a channel the
    variable ``g``, by `form_lmis`), ``rate_channel(objective)`` (the
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
