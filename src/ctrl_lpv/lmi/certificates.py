"""What a point of an LMI problem shows: float64 checks and dual certificates."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..certificate import ROUNDING, Check

__all__ = [
    "FarkasCertificate",
    "INFEASIBLE_RADIUS",
    "LMICheck",
    "LMISolution",
    "schur_norm_bound",
    "symmetric_norm_bound",
]

# The fraction of the nominal margin that a certified point must keep.
_CERTIFIED_FRACTION = 0.5
# Non-strict side constraints (bounds, normalisations) pass their check with
# ``lambda_max(F) <= _SIDE_TOLERANCE * max(1, max |F_ij|)``.
_SIDE_TOLERANCE = 1e-6
# Rounding of a float64 check of ``lambda_max(F)`` (assembly and eigvalsh)
# is bounded by this many ``size * eps * ||F||_2`` (generously: LAPACK's
# backward error is a small multiple of it).
# What a verified dual certificate must show before `LMIProblem.solve`
# calls the LMIs infeasible: no solution, even with margin 0, within this
# radius (scaled units).
INFEASIBLE_RADIUS = 1e8


# A check of an LMI at a point is the library's one check type.
LMICheck = Check


@dataclass(frozen=True)
class FarkasCertificate:
    """A dual certificate of infeasibility, verified in float64.

    With ``Y_i >= 0`` (one per inequality ``F_i(x) <= -m_i I``, ``m_i`` the
    margin of a strict one, 0 otherwise) scaled to ``sum_i tr Y_i = 1``,
    the affine function ``sum_i <F_i(x), Y_i> = b + g'x`` is evaluated in
    float64 (``b`` at ``x = 0``, ``g`` one entry of the variables at a time,
    both with bounds on their rounding). Here ``x`` is the vector of the
    free entries of the variables (a symmetric matrix's upper triangle,
    each entry once), in the units the LMIs are posed in. Any point has
    ``max_i lambda_max(F_i(x)) >= b + g'x``, so:

    * no point with ``||x|| < b / ||g||`` (`radius`) satisfies the
      inequalities, even with margin 0;
    * every point has a margin ``-max_i lambda_max(F_i(x))`` of at most
      ``||g|| ||x|| - b``: for homogeneous LMIs (``b = 0``, such as a
      Lyapunov inequality), whose solutions form a cone, the margin
      relative to ``||x||`` is at most ``||g||`` (`relative_margin`).

    A point that passes `LMIProblem.check` has a margin of at least
    ``margin / 2`` less the check's rounding; if the side constraints of
    the stage also bound its variables, its relative margin is at least
    `accepted_relative_margin`, and `excludes` compares the two.

    Attributes
    ----------
    stage : str
        The stage whose inequalities the certificate refutes.
    offset : float
        ``b`` less its rounding bound.
    slope : float
        ``||g||_2`` plus its rounding bound.
    normalized : bool
        Whether the certificate uses the inequalities added with
        ``normalization=True``: it then refutes the stage with its
        normalisations, not the LMIs alone.
    slopes : tuple of (str, float)
        Per variable that an inequality the certificate weighs reads (the
        others do not enter them), ``||g_v||_2`` (its entries of ``g``)
        plus the whole rounding bound.
    strict_only : bool
        Whether every inequality the certificate weighs is strict.
    homogeneous : bool
        Whether every inequality it weighs has ``F_i(0) = 0`` exactly.
    size : int
        Largest size of an inequality it weighs.
    spread : float
        ``max_i sum |M_i|`` over them: ``||F_i(x)||_2 <= spread ||x||``
        for a homogeneous one (the rounding of a check scales with it).
    duals : list of ndarray
        The polished ``Y_i``, one per active inequality of the stage (zero
        for those the certificate drops): a start for `LMIProblem.farkas`
        on the same stage with other data.
    """

    stage: str
    offset: float
    slope: float
    normalized: bool = False
    slopes: tuple = ()
    strict_only: bool = False
    homogeneous: bool = False
    size: int = 0
    spread: float = 0.0
    duals: list = field(default_factory=list, compare=False, repr=False)

    @property
    def radius(self) -> float:
        """No point with ``||x||_2`` below it satisfies the inequalities."""
        if self.offset <= 0:
            return 0.0
        return np.inf if self.slope == 0 else self.offset / self.slope

    @property
    def relative_margin(self) -> float:
        """Bound on ``margin / ||x||`` of any point (homogeneous LMIs)."""
        return self.slope

    @property
    def proves_infeasible(self) -> bool:
        """Whether no solution exists: none within `INFEASIBLE_RADIUS`.

        A bound on the relative margin is not a proof: homogeneous LMIs
        whose only solutions have relative margins near the rounding level
        (modes whose time scales differ by 1e18) give the same bound as
        infeasible ones. It proves only that no point passes the check
        within given bounds on the variables (`excludes`).
        """
        return self.radius >= INFEASIBLE_RADIUS

    @property
    def variables(self) -> tuple[str, ...]:
        """The variables the inequalities it weighs read (``x`` of
        `used_relative_margin`)."""
        return tuple(name for name, _ in self.slopes)

    def _reach(self, bounds) -> float:
        return float(
            np.sqrt(sum(float(bounds.get(v, np.inf)) ** 2 for v in self.variables))
        )

    def used_relative_margin(self) -> float:
        """Bound on ``margin / ||x||`` with ``x`` over `variables` only."""
        per_variable = np.sqrt(sum(value**2 for _, value in self.slopes))
        return float(min(self.slope, per_variable))

    def accepted_relative_margin(self, margin: float, bounds) -> float:
        """Least relative margin of a point that passes the check.

        A point whose strict inequalities pass `LMIProblem.check` with
        `margin` has ``max_i lambda_max(F_i(x)) <= -margin / 2`` as
        computed, so at most the check's rounding above it in exact
        arithmetic; with ``||x_v||_2 <= bounds[v]`` for each of
        `variables` (a variable without a bound: no claim, 0.0), its
        margin relative to ``||x||`` (over `variables`) is at least the
        value returned. Meaningful for a homogeneous certificate only.
        """
        reach = self._reach(bounds)
        if not np.isfinite(reach):
            return 0.0
        if reach == 0:
            return np.inf
        rounding = ROUNDING * self.size * np.finfo(float).eps * self.spread
        return max(0.0, _CERTIFIED_FRACTION * margin / reach - rounding)

    def excludes(self, margin: float, bounds) -> bool:
        """Whether no point within `bounds` passes the check with `margin`.

        True when the certificate weighs strict homogeneous inequalities
        only, without the normalisations, and its `used_relative_margin`
        is below `accepted_relative_margin`: every point has a relative
        margin below what a point that passes the check must have.
        """
        return (
            self.strict_only
            and self.homogeneous
            and not self.normalized
            and self.used_relative_margin()
            < self.accepted_relative_margin(margin, bounds)
        )

    def exclusion(self, margin: float, bounds) -> str:
        """The statement `excludes` proves, in words and numbers."""
        names = ", ".join(self.variables) or "none"
        reach = self._reach(bounds)
        return (
            f"a dual certificate verified in float64 shows that every point "
            f"of the '{self.stage}' LMIs has a margin of at most "
            f"{self.used_relative_margin():.2g} ||x|| (x: the free entries "
            f"of {names}, in the units the LMIs are posed in), while a point "
            f"passes the certificate only with a margin of "
            f"{_CERTIFIED_FRACTION * margin:.3g} at ||x|| <= {reach:.4g}, a "
            f"relative margin of at least "
            f"{self.accepted_relative_margin(margin, bounds):.2g}"
        )

    def __str__(self) -> str:
        if self.radius >= INFEASIBLE_RADIUS:
            claim = f"no point with ||x|| < {self.radius:.3g} satisfies them"
        else:
            claim = (
                "no point satisfies them with a margin above "
                f"{self.relative_margin:.2g} ||x|| - {self.offset:.2g}"
            )
        scope = " with their normalisation" if self.normalized else ""
        return (
            f"a dual certificate verified in float64 refutes the "
            f"'{self.stage}' LMIs{scope}: {claim}"
        )


def symmetric_norm_bound(w_max: float, n: int) -> float:
    """Bound on ``||x_W||_2`` of ``W > 0`` that passed ``W - w_max I <= 0``.

    `LMIProblem.check` passes the side constraint when ``lambda = lambda_max
    (W) <= w_max + t max(1, max|W - w_max I|)`` (``t`` its tolerance,
    doubled here for the check's own rounding), and ``max|W - w_max I| <=
    max(lambda, w_max)`` for ``W > 0``; so ``lambda <= (w_max + t max(1,
    w_max)) / (1 - t)``, and the free entries have ``||x_W|| <= ||W||_F <=
    sqrt(n) lambda``.
    """
    t = 2 * _SIDE_TOLERANCE
    return float(np.sqrt(n) * (w_max + t * max(1.0, w_max)) / (1 - t))


def schur_norm_bound(z_max: float, shape) -> float:
    """Bound on ``||Z||_F`` of a ``Z`` that passed ``[[-z_max I, Z'], [Z, -I]]
    <= 0``.

    With ``zeta = ||Z||_2`` and the check's tolerance ``tau <= t max(1,
    z_max, zeta)`` (``t`` doubled for rounding), ``zeta^2 <= (z_max + tau)
    (1 + tau)`` (Schur complement); if ``zeta <= max(1, z_max)`` this is
    ``zeta^2 <= (z_max + tau0) (1 + tau0)`` with ``tau0 = t max(1, z_max)``,
    otherwise ``zeta < (1 + t) / (1 - t - t^2)``. ``||Z||_F <= sqrt(min(m,
    n)) zeta``.
    """
    t = 2 * _SIDE_TOLERANCE
    tau0 = t * max(1.0, z_max)
    zeta = max(np.sqrt((z_max + tau0) * (1 + tau0)), (1 + t) / (1 - t - t * t))
    return float(np.sqrt(min(shape)) * zeta)


@dataclass
class LMISolution:
    """A point of an `LMIProblem` with its float64 checks.

    Variables are available as attributes (``solution.W``).

    Attributes
    ----------
    values : dict of str to ndarray
        Variable values.
    objective : float or None
        Objective value the solver reported.
    checks : tuple of `LMICheck`
        Float64 checks of every active LMI at the point.
    attempts : list of `SolveAttempt`
        The attempts made by the solve that returned it.
    nominal : `LMISolution` or None
        When the point certified only after a retry with a larger margin:
        the solver's (uncertified) point at the nominal margin, the better
        estimate of an optimal value.
    """

    values: dict[str, np.ndarray]
    objective: float | None
    checks: tuple[LMICheck, ...]
    attempts: list = field(default_factory=list)
    nominal: LMISolution | None = None

    @property
    def certified(self) -> bool:
        """Whether every LMI passed its float64 check."""
        return all(c.passed for c in self.checks)

    def __getattr__(self, name):
        try:
            return self.__dict__["values"][name]
        except KeyError:
            raise AttributeError(name) from None


def _stronger(proof, other) -> bool:
    """Whether `proof` beats `other`: proving infeasibility first, then not
    needing the normalisations, then the radius and the margin bound."""

    def rank(p):
        return (p.proves_infeasible, not p.normalized, p.radius, -p.slope)

    return rank(proof) > rank(other)


def _certificate(
    stage, amap, y, members, sizes, normalizing, strict, groups
) -> FarkasCertificate:
    """The `FarkasCertificate` of a polished dual point `y` of `amap`.

    `members` are the indices, among the stage's active inequalities
    (of sizes `sizes`), of those `amap` holds; `normalizing` and `strict`
    mark the active ones.
    """
    offset, slope = amap.bound(y)
    weighed = amap.nonzero(y)
    size, base, spread = amap.evaluation_bounds(y)
    per_variable = amap.block_slopes(y, [group for _, group in groups])
    # One matrix per active inequality (zero for those the variant drops),
    # as `LMIProblem.farkas` takes them: a start for another prescaling.
    duals = [np.zeros((d, d)) for d in sizes]
    for k, i in enumerate(members):
        d = int(amap.sizes[k])
        duals[i] = y[amap.offsets[k] : amap.offsets[k + 1]].reshape(d, d)
    return FarkasCertificate(
        stage,
        offset,
        slope,
        normalized=bool(np.any(weighed & normalizing[members])),
        slopes=tuple(
            (name, value)
            for (name, _), value in zip(groups, per_variable)
            if value is not None
        ),
        strict_only=bool(np.all(strict[members][weighed])),
        homogeneous=base == 0.0,
        size=size,
        spread=spread,
        duals=duals,
    )
