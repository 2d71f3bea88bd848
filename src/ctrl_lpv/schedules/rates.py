"""The largest certified parameter rate: a bisection of certified LMI solves.

Both kinds of closed loops (`certify` on polytopic and on gridded plants)
pose a rate-bounded Lyapunov problem with the rate box ``|dp_k/dt| <=
nu_k`` as a parameter of one LMI problem; `RateSearch` solves it for given
rates and finds the largest uniform rate by bisection.
"""

from __future__ import annotations

import math

import numpy as np

from ..certificate import Certificate, Check
from ..exceptions import SynthesisError

__all__ = ["RateSearch"]


class RateSearch:
    """`rate_bounded` and `largest_rate` over `_rate_problem`.

    Subclasses provide ``_rate_problem(margin)`` (an `LMIProblem` with the
    parameter ``"nu"``), ``names``, ``plant`` (with a box domain), ``Acl``
    (closed-loop matrices, for the scale of the first rate tried), and the
    texts `region` and `lyapunov_form` of the certificate's statement.
    """

    region = "in the points' convex hull"
    lyapunov_form = "P(p) affine on each cell, continuous"

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
