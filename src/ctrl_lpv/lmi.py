"""A small LMI layer on cvxpy with independent float64 certificates.

An LMI is written once, as a function of its variables that returns the lower
block triangle (the paper's ``*`` are left as ``None``). The same function is
evaluated on cvxpy variables to build the problem and on the float64 values of
the returned point to certify it, so the certificate checks exactly the
inequality that was posed, without trusting the solver's status.

All inequalities have the form ``F(v) <= 0``; a strict one is posed as
``F(v) <= -margin * I`` and certified when ``lambda_max(F) <= -margin / 2``
(half the margin is what is left after the solver's own tolerance).

Each stage is one cvxpy problem, built and compiled once; data that change
between solves are cvxpy parameters, so a re-solve only applies the new
parameter values (DPP) and calls the solver. `LMIProblem.compile` does the
compilation ahead of the first solve so that its cost can be measured apart.
"""

from __future__ import annotations

import functools
import logging
import re
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace

import cvxpy as cp
import numpy as np
import scipy.sparse as sp

from . import _farkas, budget
from .exceptions import CertificationError, InfeasibleError

__all__ = [
    "LMIProblem",
    "LMISolution",
    "LMICheck",
    "FarkasCertificate",
    "SolveAttempt",
    "assemble",
    "default_solvers",
    "solver_chain",
]

logger = logging.getLogger(__name__)

BlockFunction = Callable[[SimpleNamespace], Sequence[Sequence[object]]]

# The fraction of the nominal margin that a certified point must keep.
_CERTIFIED_FRACTION = 0.5
# Non-strict side constraints (bounds, normalisations) pass their check with
# ``lambda_max(F) <= _SIDE_TOLERANCE * max(1, max |F_ij|)``.
_SIDE_TOLERANCE = 1e-6
# Rounding of a float64 check of ``lambda_max(F)`` (assembly and eigvalsh)
# is bounded by this many ``size * eps * ||F||_2`` (generously: LAPACK's
# backward error is a small multiple of it).
_CHECK_ROUNDING = 100.0
# Retries with a larger margin after a point misses its certificate on
# strict LMIs only: at most this many, each margin at most this factor up.
_MARGIN_RETRIES = 2
_MAX_RETRY_FACTOR = 1e4
# What a verified dual certificate must show before `LMIProblem.solve`
# calls the LMIs infeasible: no solution, even with margin 0, within this
# radius (scaled units).
INFEASIBLE_RADIUS = 1e8


def _retry_factor(checks, margin) -> float | None:
    """Margin factor that should absorb a solver's miss, or None.

    Only a point that misses strict LMIs alone (the side constraints hold)
    is worth a retry: the solver's tolerance ate the margin, so pose one
    about four times the miss, a power of ten, at least ten times larger.
    """
    failed = [c for c in checks if not c.passed]
    if not failed or not all(c.strict for c in failed):
        return None
    miss = max(c.max_eig for c in failed) + margin
    factor = 10.0 ** np.ceil(np.log10(max(10.0, 4 * miss / margin)))
    return min(float(factor), _MAX_RETRY_FACTOR)


@dataclass(frozen=True)
class SolveAttempt:
    """One solver attempt: solver, status, time and whether it certified.

    Attributes
    ----------
    solver : str
        cvxpy solver name.
    status : str
        Status the solver reported (not trusted: see `certified`).
    seconds : float
        Wall time of the attempt.
    certified : bool
        Whether the returned point passed its float64 certificate.
    message : str
        Why it did not certify, or which retry it was.
    compile_seconds : float
        Part of `seconds` spent in cvxpy before the solver ran: the
        compilation, or only the application of new parameter values when
        the problem was already compiled for this solver.
    """

    solver: str
    status: str
    seconds: float
    certified: bool
    message: str = ""
    compile_seconds: float = 0.0


@dataclass(frozen=True)
class LMICheck:
    """Float64 check of one LMI at a point.

    Attributes
    ----------
    name : str
        LMI name.
    max_eig : float
        Largest eigenvalue of the symmetric block matrix ``F(v)``.
    required : float
        Bound that `max_eig` must not exceed to pass.
    strict : bool
        Whether the LMI is a strict inequality (part of the certificate).
    """

    name: str
    max_eig: float
    required: float
    strict: bool

    @property
    def passed(self) -> bool:
        """Whether ``max_eig <= required``."""
        return bool(self.max_eig <= self.required)


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
        rounding = _CHECK_ROUNDING * self.size * np.finfo(float).eps * self.spread
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
    attempts: list[SolveAttempt] = field(default_factory=list)
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


def assemble(blocks, xp=np):
    """Symmetric matrix from its lower block triangle.

    Only the symmetric part is ever used, so a diagonal block may be given
    as ``2 Q`` for ``Q + Q'`` (half the expression for cvxpy to compile).

    Parameters
    ----------
    blocks : sequence of sequences
        Row ``i`` holds blocks ``(i, 0), ..., (i, i)``; entries above the
        diagonal may be omitted or ``None`` (symmetric completion). A scalar
        ``0`` is a zero block of the size implied by the diagonal blocks.
    xp : module, optional
        ``numpy`` for a float matrix, ``cvxpy`` for an expression.

    Returns
    -------
    ndarray or cvxpy expression
        ``(M + M.T) / 2`` of the completed block matrix ``M``; with cvxpy
        a matrix with the same symmetric part (cvxpy's ``<<`` and ``>>``
        constrain the symmetric part).
    """
    nrows = len(blocks)
    sizes = []
    for i in range(nrows):
        diag = blocks[i][i]
        shape = np.shape(diag) if xp is np else diag.shape
        if len(shape) != 2 or shape[0] != shape[1]:
            raise ValueError(f"block ({i}, {i}) must be a square matrix, got {shape}")
        sizes.append(shape[0])

    def zero(i, j):
        return np.zeros((sizes[i], sizes[j]))

    def block(i, j):
        if j <= i:
            item = blocks[i][j]
            transpose = False
        else:
            item = blocks[j][i]
            transpose = True
        if isinstance(item, (int, float)) and item == 0:
            return zero(i, j)
        return item.T if transpose else item

    if xp is np and nrows == 1:
        # One block (most LMIs here): np.block would only copy it.
        full = np.asarray(blocks[0][0])
        return 0.5 * (full + full.T)
    if xp is not np:
        # cvxpy's PSD constraints act on the symmetric part (M + M')/2, so
        # the lower triangle with doubled off-diagonal blocks is the same
        # constraint as the full matrix, and compiles each block once.
        def lower(i, j):
            if j > i:
                return zero(i, j)
            return block(i, j) if j == i else 2 * block(i, j)

        return cp.bmat([[lower(i, j) for j in range(nrows)] for i in range(nrows)])
    full = np.block([[block(i, j) for j in range(nrows)] for i in range(nrows)])
    return 0.5 * (full + full.T)


def normalized_max_eig(M) -> float:
    """Largest ``lambda_max(D M D)`` over a stack, ``D = |diag M|^-1/2``.

    The Jacobi normalisation makes the test scale-free; a nonnegative
    diagonal entry (no strict inequality possible) gives ``inf``.
    """
    diag = np.diagonal(M, axis1=1, axis2=2)
    if not np.all(diag < 0):
        return float("inf")
    d = 1.0 / np.sqrt(-diag)
    return float(np.linalg.eigvalsh(M * d[:, :, None] * d[:, None, :])[:, -1].max())


@functools.cache
def _installed_solvers() -> frozenset[str]:
    # cvxpy probes every solver it knows by importing it, about 10 ms a
    # call: too much to repeat before every re-solve.
    return frozenset(cp.installed_solvers())


def default_solvers() -> list[tuple[str, dict]]:
    """Solver chain: Clarabel, SCS with tight tolerances, then CVXOPT, MOSEK.

    Only installed solvers are listed (probed once per process). Clarabel
    runs without its chordal decomposition: the LMIs here are small dense
    blocks that it would only split at the zeros of their identity blocks,
    and with it the gain stage of the two-mass design stalled in a
    numerical error (measured on the two-mass model and random polytopes:
    no such failure without it, and less time).
    """
    installed = _installed_solvers()
    chain = [
        ("CLARABEL", {"chordal_decomposition_enable": False}),
        ("SCS", {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 20_000}),
        ("CVXOPT", {}),
        ("MOSEK", {}),
    ]
    return [(name, opts) for name, opts in chain if name in installed]


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


def _recording_namespace(values, read: set, names) -> SimpleNamespace:
    """A namespace of `values` that adds to `read` the `names` looked up."""

    class Recording(SimpleNamespace):
        def __getattribute__(self, name):
            if name in names or name == "__dict__":
                read.add(name)
            return super().__getattribute__(name)

    return Recording(**values)


def _is_symmetric(expression) -> bool:
    # `LMIProblem.variable` builds symmetric variables as expressions of a
    # vector of free entries; plain variables are cvxpy Variables.
    return not isinstance(expression, cp.Variable)


def _unit_points(shape, symmetric: bool):
    """Unit points of a variable: one per free entry."""
    if symmetric:
        n = shape[0]
        for a, b in zip(*np.triu_indices(n)):
            E = np.zeros((n, n))
            E[a, b] = E[b, a] = 1.0
            yield E
        return
    for index in np.ndindex(*shape):
        E = np.zeros(shape)
        E[index] = 1.0
        yield E


# Solver options that bound a solve's wall time, in seconds.
_TIME_LIMIT_OPTIONS = {"CLARABEL": "time_limit", "SCS": "time_limit_secs"}


def _with_time_limit(solver, options, deadline):
    """`options` with the solver's own limit set to the time left.

    The time left is that of `deadline` or of the call's budget
    (`ctrl_lpv.budget`), whichever ends first.
    """
    key = _TIME_LIMIT_OPTIONS.get(solver.upper())
    ends = [d for d in (deadline, budget.deadline()) if d is not None]
    if not ends or key is None:
        return options
    left = max(min(ends) - time.perf_counter(), 1e-3)
    return {**options, key: min(float(options.get(key, np.inf)), left)}


# cvxpy's text for any failed solve: it says nothing about this one, and
# repeated once per attempt it made refusals of 10 kB.
_CVXPY_BOILERPLATE = re.compile(
    r"Solver '\w+' failed\.\s*|Try another solver, or solve with verbose=True "
    r"for more information\.\s*"
)


def _solver_message(exc) -> str:
    """What a solver error says beyond cvxpy's boilerplate (often nothing)."""
    lines = str(exc).strip().splitlines()
    return _CVXPY_BOILERPLATE.sub("", lines[0]).strip() if lines else ""


def _summary(attempts) -> str:
    """The attempts of a solve, one clause each, repeats counted."""
    return budget.digest(
        "; ".join(
            f"{a.solver}: {a.status}" + (f" ({a.message})" if a.message else "")
            for a in attempts
        )
    )


def solver_chain(solvers) -> list[tuple[str, dict]] | None:
    """Validate a `solvers` argument: None, a name, or names/(name, options).

    Returns
    -------
    list of (str, dict) or None
        None for the default chain (`default_solvers`).

    Raises
    ------
    ValueError
        For an empty chain, a solver that is not installed (the message
        lists the installed ones), or options the solver rejects (judged by
        the solver on a tiny problem, before any real solve).
    TypeError
        For anything else.
    """
    if solvers is None:
        return None
    if isinstance(solvers, str):
        solvers = [solvers]
    try:
        items = list(solvers)
    except TypeError:
        raise TypeError(
            f"solvers: expected a solver name or a list of names or (name, "
            f"options) pairs, got {solvers!r}"
        ) from None
    if not items:
        raise ValueError("solvers: the list is empty; pass None for the default")
    chain = []
    for item in items:
        if isinstance(item, str):
            name, options = item, {}
        elif (
            isinstance(item, Sequence)
            and len(item) == 2
            and isinstance(item[0], str)
            and isinstance(item[1], dict)
        ):
            name, options = item
        else:
            raise TypeError(
                f"solvers: expected a name or a (name, options) pair, got {item!r}"
            )
        if name.upper() not in _installed_solvers():
            raise ValueError(
                f"solvers: {name!r} is not installed; installed: "
                f"{sorted(_installed_solvers())}"
            )
        _check_options(name.upper(), options)
        chain.append((name.upper(), dict(options)))
    return chain


def _check_options(solver: str, options: dict) -> None:
    """Refuse options `solver` does not accept, before any real solve.

    The solver itself is the judge (no list of names kept here): a tiny
    problem is solved once with the options, as the real solves pass them;
    a `TypeError`/`ValueError` names the option(s) that alone fail.
    """
    if options and _options_error(solver, options) is not None:
        bad = [k for k in options if _options_error(solver, {k: options[k]})]
        bad = bad or sorted(options)
        raise ValueError(
            f"solvers: {solver} rejects the option(s) {', '.join(map(repr, bad))} "
            f"(unknown name or wrong value): "
            f"{_options_error(solver, {k: options[k] for k in bad})}"
        )


def _options_error(solver: str, options: dict) -> str | None:
    """The message of a trial solve with `options` that fails by them."""
    options = {k: v for k, v in options.items() if k != "verbose"}
    x = cp.Variable()
    problem = cp.Problem(cp.Minimize(x), [x >= 1])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            problem.solve(solver=solver, warm_start=False, **options)
    except (TypeError, ValueError, AttributeError, KeyError) as exc:
        return str(exc) or type(exc).__name__
    except cp.error.SolverError:
        return None  # a solve that fails for other reasons: not the options
    return None


class LMIProblem:
    """LMI problem on cvxpy with named variables, parameters and stages.

    Parameters
    ----------
    margin : float
        Absolute margin of strict inequalities (``F <= -margin I``); choose
        it relative to the scale of the (prescaled) data. Changing
        `margin` later does not recompile the problem.

    Examples
    --------
    Lyapunov stability of ``A``: find ``P > 0`` with ``A'P + PA < 0``.

    >>> A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    >>> lmi = LMIProblem(margin=1e-6)
    >>> P = lmi.variable("P", (2, 2), symmetric=True)
    >>> lmi.add("P>0", lambda v: [[-v.P]])
    >>> lmi.add("lyap", lambda v: [[A.T @ v.P + v.P @ A]])
    >>> lmi.add("norm", lambda v: [[v.P - np.eye(2)]], strict=False)
    >>> sol = lmi.solve()
    >>> bool(np.all(np.linalg.eigvalsh(A.T @ sol.P + sol.P @ A) < 0))
    True
    """

    def __init__(self, margin: float = 1e-6):
        if not (np.isfinite(margin) and margin > 0):
            raise ValueError(f"margin: must be a positive finite number, got {margin}")
        self._vars: dict[str, cp.Expression] = {}
        self._params: dict[str, cp.Parameter] = {}
        self._lmis: list[tuple[str, BlockFunction, bool, frozenset | None]] = []
        self._normalizations: set[str] = set()
        self._problems: dict[str, cp.Problem] = {}
        # Solver each stage's problem was last compiled for (cvxpy keeps the
        # compiled DPP program of one solver per problem).
        self._compiled: dict[str, str] = {}
        self._margin = cp.Parameter(nonneg=True, name="margin", value=float(margin))
        # Columns of the affine map of each inequality, and the last stacked
        # map of each stage (`_affine_map`).
        self._farkas_columns: dict = {}

    @property
    def margin(self) -> float:
        """Absolute margin of strict inequalities."""
        return float(self._margin.value)

    @margin.setter
    def margin(self, value: float) -> None:
        self._margin.value = float(value)

    def variable(self, name: str, shape, symmetric: bool = False) -> cp.Expression:
        """Declare a decision variable (``symmetric=True`` for a square one).

        A symmetric ``n x n`` variable is returned as the expression
        ``S @ w`` (reshaped) of a vector ``w`` of its ``n (n + 1) / 2``
        free entries, with a constant 0/1 matrix ``S``: the same problem as
        ``cp.Variable(symmetric=True)``, without cvxpy's reduction that
        rewrites symmetric variables at every compilation.
        """
        if name in self._vars or name in self._params:
            raise ValueError(f"name: {name!r} is already declared")
        if symmetric:
            n = shape[0]
            if len(shape) != 2 or shape[1] != n:
                raise ValueError(f"shape: a symmetric variable is square, got {shape}")
            rows, cols = np.triu_indices(n)
            k = np.arange(rows.size)
            # Column-major vec(W): entry (i, j) is row i + n j.
            S = sp.coo_array(
                (
                    np.ones(2 * k.size),
                    (np.concatenate([rows + n * cols, cols + n * rows]), np.tile(k, 2)),
                ),
                shape=(n * n, k.size),
            ).tocsr()
            S.data[:] = 1.0  # the diagonal is listed twice: 1, not 2
            free = cp.Variable(k.size, name=f"{name}_free")
            var = cp.reshape(S @ free, (n, n), order="F")
        else:
            var = cp.Variable(shape, name=name)
        self._vars[name] = var
        return var

    def parameter(self, name: str, shape=(), value=None, **kwargs) -> cp.Parameter:
        """Declare a parameter that can change between solves (DPP)."""
        if name in self._vars or name in self._params:
            raise ValueError(f"name: {name!r} is already declared")
        par = cp.Parameter(shape, name=name, value=value, **kwargs)
        self._params[name] = par
        return par

    def set_parameter(self, name: str, value) -> None:
        """Set the value of a parameter (no recompilation).

        Raises
        ------
        ValueError
            If there is no such parameter, or the value is not finite, has
            the wrong shape or breaks the parameter's sign.
        """
        if name not in self._params:
            raise ValueError(f"name: no parameter {name!r}")
        par = self._params[name]
        try:
            array = np.array(np.broadcast_to(np.asarray(value, float), par.shape))
        except ValueError:
            raise ValueError(
                f"{name}: expected shape {par.shape}, got {np.shape(value)}"
            ) from None
        if not np.isfinite(array).all():
            raise ValueError(f"{name}: the value must be finite")
        attributes = {k for k, v in par.attributes.items() if v is True}
        if attributes - {"nonneg", "pos"}:
            par.value = array  # let cvxpy check other attributes
            return
        if "pos" in attributes and not (array > 0).all():
            raise ValueError(f"{name}: the value must be positive")
        if "nonneg" in attributes and not (array >= 0).all():
            raise ValueError(f"{name}: the value must be nonnegative")
        # cvxpy's setter checks a value by projecting it on the attributes
        # (about 0.4 ms a parameter, a noticeable part of a re-solve with
        # many vertices); the checks above are the same for these ones.
        par.save_value(array)

    def add(
        self,
        name: str,
        blocks: BlockFunction,
        strict: bool = True,
        stages: Sequence[str] | None = None,
        normalization: bool = False,
    ) -> None:
        """Add the inequality ``F(v) < 0`` (or ``<= 0`` if not strict).

        Parameters
        ----------
        name : str
            Label used in certificates and error messages.
        blocks : callable
            ``blocks(v)`` returns the lower block triangle of ``F``; ``v`` has
            the variables and parameters as attributes (cvxpy objects when
            building, float arrays when certifying).
        strict : bool, optional
            Strict inequalities are posed with the margin and certified.
        stages : sequence of str, optional
            Stages in which the inequality applies; default all.
        normalization : bool, optional
            A non-strict constraint that only fixes the scale or shape of
            the point (e.g. ``W <= I`` for homogeneous LMIs): an
            infeasibility proof that does not use it refutes the other
            inequalities alone (`FarkasCertificate.normalized`).
        """
        if normalization and strict:
            raise ValueError("normalization: only a non-strict inequality can be one")
        if any(existing == name for existing, *_ in self._lmis):
            raise ValueError(f"name: an LMI named {name!r} already exists")
        self._lmis.append(
            (name, blocks, strict, None if stages is None else frozenset(stages))
        )
        if normalization:
            self._normalizations.add(name)
        self._problems.clear()
        self._compiled.clear()
        self._farkas_columns.clear()

    def _active(self, stage: str):
        return [lmi for lmi in self._lmis if lmi[3] is None or stage in lmi[3]]

    def _namespace(self, numeric: dict | None = None) -> SimpleNamespace:
        if numeric is not None:
            return SimpleNamespace(**numeric)
        return SimpleNamespace(**self._vars, **self._params)

    def _problem(self, stage: str, objective: Callable | None) -> cp.Problem:
        if stage not in self._problems:
            v = self._namespace()
            constraints = []
            for _, blocks, strict, _ in self._active(stage):
                F = assemble(blocks(v), xp=cp)
                bound = -self._margin * np.eye(F.shape[0]) if strict else 0
                constraints.append(F << bound)
            goal = cp.Minimize(objective(v)) if objective else cp.Minimize(0)
            self._problems[stage] = cp.Problem(goal, constraints)
        return self._problems[stage]

    def compile(
        self,
        stage: str = "default",
        objective: Callable[[SimpleNamespace], object] | None = None,
        solver: str | None = None,
    ) -> float:
        """Build and compile a stage's problem ahead of its first solve.

        Solving compiles on demand; calling this first separates the cost
        of cvxpy's canonicalization from the solver's in timings. Later
        solves with `solver` only apply the new parameter values (DPP).

        Parameters
        ----------
        stage : str, optional
            Stage name.
        objective : callable, optional
            As in `solve` (ignored if the stage is already built).
        solver : str, optional
            Solver to compile for; default the first of `default_solvers`.

        Returns
        -------
        float
            Seconds spent (0.0 if the stage was already compiled for
            `solver`, or if no solver is installed).
        """
        if solver is None:
            chain = default_solvers()
            if not chain:
                return 0.0
            solver = chain[0][0]
        solver = solver.upper()
        if self._compiled.get(stage) == solver:
            return 0.0
        start = time.perf_counter()
        problem = self._problem(stage, objective)
        self._check_compile(problem, stage, solver)
        problem.get_problem_data(solver)
        self._compiled[stage] = solver
        return time.perf_counter() - start

    def invalidate(self, stage: str) -> None:
        """Drop a stage's problem; its next solve builds and compiles it.

        Needed when something its LMIs read as a constant (not a
        parameter) has changed.
        """
        self._problems.pop(stage, None)
        self._compiled.pop(stage, None)
        self._farkas_columns.clear()

    def is_dpp(self, stage: str = "default") -> bool:
        """Whether a built stage re-solves without recompiling (DPP).

        Raises
        ------
        ValueError
            If the stage has not been built (solved or compiled) yet.
        """
        if stage not in self._problems:
            raise ValueError(f"stage: {stage!r} has not been built yet")
        return bool(self._problems[stage].is_dpp())

    def _check_compile(self, problem, stage, solver) -> None:
        """Refuse to compile a stage that would not compile in the time left.

        Raises
        ------
        `ctrl_lpv.budget.TimeLimitReached`
            If the estimate (`ctrl_lpv.budget.compile_seconds`) exceeds the
            time left in the call's budget.
        """
        if self._compiled.get(stage) == solver.upper():
            return
        entries = sum(int(np.prod(c.args[0].shape)) for c in problem.constraints)
        needed = budget.compile_seconds(len(problem.constraints), entries)
        budget.check(f"compiling stage '{stage}' for {solver}", needed)

    def _attempt(self, problem, stage, solver, options, factor=1.0):
        self._check_compile(problem, stage, solver)
        nominal = self.margin
        self._margin.value = nominal * factor
        start = time.perf_counter()
        # cvxpy keeps one compiled program per problem: a solver change
        # recompiles, and a failure may leave it half built.
        self._compiled.pop(stage, None)
        try:
            with warnings.catch_warnings():
                # Inaccurate solutions are judged by the certificate below.
                warnings.simplefilter("ignore", UserWarning)
                # No warm start: cvxpy would otherwise hand the previous
                # solve's solver object (Clarabel's, updated in place) to
                # this one, and a reused problem would not give bit for bit
                # the point a fresh one gives.
                problem.solve(solver=solver, warm_start=False, **options)
            status, message = problem.status, ""
            self._compiled[stage] = solver.upper()
        except cp.error.SolverError as exc:
            status, message = "solver_error", _solver_message(exc)
        finally:
            self._margin.value = nominal
            compile_seconds = float(problem.compilation_time or 0.0)
        seconds = time.perf_counter() - start
        values, checks, duals = {}, (), None
        if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
            # The solver's Farkas point, judged by `farkas`.
            duals = [c.dual_value for c in problem.constraints]
            if any(d is None for d in duals):
                duals = None
        if status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE):
            values = {k: np.array(x.value, dtype=float) for k, x in self._vars.items()}
            checks = self.check(values, stage)
            failed = [c for c in checks if not c.passed]
            if failed:
                worst = max(failed, key=lambda c: c.max_eig - c.required)
                message = (
                    f"{worst.name}: max eigenvalue {worst.max_eig:.3g} above "
                    f"{worst.required:.3g}"
                )
        certified = bool(checks) and all(c.passed for c in checks)
        if factor != 1.0:
            message = f"margin x{factor:g}" + (f"; {message}" if message else "")
        attempt = SolveAttempt(
            solver, status, seconds, certified, message, compile_seconds
        )
        logger.debug(
            "stage '%s': %s %s in %.3g s (%.3g s compiling)%s", stage, solver,
            status, seconds, compile_seconds, f": {message}" if message else "",
        )  # fmt: skip
        return attempt, values, checks, duals

    def check(self, values: dict[str, np.ndarray], stage: str = "default"):
        """Evaluate every active LMI at `values` in float64.

        Returns
        -------
        tuple of `LMICheck`
        """
        numeric = {k: np.asarray(p.value, float) for k, p in self._params.items()}
        numeric.update(values)
        v = self._namespace(numeric)
        checks = []
        for name, blocks, strict, _ in self._active(stage):
            F = assemble(blocks(v), xp=np)
            max_eig = float(np.linalg.eigvalsh(F)[-1])
            if strict:
                required = -_CERTIFIED_FRACTION * self.margin
            else:
                # Non-strict side constraints (bounds, normalisations) are kept
                # to the solver's accuracy; they do not enter the certificate.
                required = _SIDE_TOLERANCE * max(1.0, float(np.abs(F).max()))
            checks.append(LMICheck(name, max_eig, required, strict))
        return tuple(checks)

    def solve(
        self,
        objective: Callable[[SimpleNamespace], object] | None = None,
        stage: str = "default",
        solvers: Sequence[tuple[str, dict]] | None = None,
        certify: bool = True,
        deadline: float | None = None,
    ) -> LMISolution:
        """Solve, trying each solver in turn until a point certifies.

        Parameters
        ----------
        objective : callable, optional
            ``objective(v)``, a cvxpy expression to minimise; feasibility if
            omitted. The problem of a stage is compiled once: later calls
            with the same `stage` reuse it (only parameter values change) and
            ignore `objective`.
        stage : str, optional
            Stage name (selects the LMIs added with ``stages=``).
        solvers : sequence of (name, options), optional
            Default `default_solvers`.
        certify : bool, optional
            If False, a point that the solver called optimal is returned even
            when it fails its certificate (``solution.certified`` is then
            False). Use it only for estimates, e.g. of an optimal value that
            a certified re-solve backs off from.
        deadline : float, optional
            ``time.perf_counter()`` value after which no further solver is
            started; solvers get the time left as their own limit. The
            call's budget (`ctrl_lpv.budget`) applies too, whichever ends
            first.

        Returns
        -------
        `LMISolution`

        Raises
        ------
        InfeasibleError
            If no point certifies and a solver's dual certificate of
            infeasibility verifies in float64 and proves it
            (`FarkasCertificate.proves_infeasible`).
        CertificationError
            If no returned point passes its float64 certificate and no
            infeasibility is proven; `ctrl_lpv.budget.TimeLimitReached`
            (one) when the deadline passes first.
        """
        chain = default_solvers() if solvers is None else list(solvers)
        if not chain:
            raise RuntimeError("no SDP solver installed: install clarabel or scs")
        attempts: list[SolveAttempt] = []
        budget.progress("stage '%s'", stage, level=logging.DEBUG, stage=stage)
        try:
            return self._solve(objective, stage, chain, certify, deadline, attempts)
        except budget.TimeLimitReached as exc:
            exc.attempts = tuple(attempts)
            raise
        finally:
            if attempts:
                last = attempts[-1]
                budget.progress(
                    "stage '%s': %s (%d solver attempts, %.3g s)", stage,
                    "certified" if last.certified else last.status,
                    len(attempts), sum(a.seconds for a in attempts),
                )  # fmt: skip

    def _solve(self, objective, stage, chain, certify, deadline, attempts):
        """`solve`, recording its attempts in `attempts` as they are made."""

        def check(where):
            budget.check(where)
            if deadline is not None and time.perf_counter() >= deadline:
                raise budget.TimeLimitReached(f"deadline passed before {where}")

        check(f"stage '{stage}'")
        if stage not in self._problems:
            budget.check(
                f"building stage '{stage}'",
                budget.compile_seconds(len(self._active(stage)), 0),
            )
        problem = self._problem(stage, objective)
        dual_points = []
        estimate = None
        for solver, options in chain:
            check(f"stage '{stage}' with {solver}")
            attempt, values, checks, duals = self._attempt(
                problem, stage, solver, _with_time_limit(solver, options, deadline)
            )
            attempts.append(attempt)
            if duals is not None:
                dual_points.append(duals)
            value = (
                None if objective is None or problem.value is None else problem.value
            )
            if checks and estimate is None:
                # The nominal-margin point: the best estimate of an optimum.
                estimate = LMISolution(values, value, checks, attempts)
            factor = 1.0
            for _ in range(_MARGIN_RETRIES):
                step = (
                    None
                    if attempt.certified
                    else _retry_factor(checks, self.margin * factor)
                )
                if step is None:
                    break
                # The solver's own tolerance ate the margin: pose a larger one
                # (the certificate still asks for the nominal margin).
                factor *= step
                check(f"stage '{stage}' with {solver}, margin x{factor:g}")
                # The time left now, not at the first attempt.
                timed = _with_time_limit(solver, options, deadline)
                attempt, values, checks, duals = self._attempt(
                    problem, stage, solver, timed, factor
                )
                attempts.append(attempt)
                if duals is not None:  # judged without the margin: as good
                    dual_points.append(duals)
            if attempt.certified:
                value = None if objective is None else problem.value
                solution = LMISolution(values, value, checks, attempts)
                if factor != 1.0:
                    solution.nominal = estimate
                return solution
        if not certify and estimate is not None:
            return estimate
        summary = _summary(attempts)
        if dual_points:
            check(f"the dual certificate of stage '{stage}'")
        proof = self._best_farkas(dual_points, stage)
        if proof is not None and proof.proves_infeasible:
            raise InfeasibleError(
                f"the LMIs are infeasible: {proof} [{summary}]", attempts, proof
            )
        if dual_points:
            found = "none verified" if proof is None else str(proof)
            summary += f"; not proven infeasible ({found})"
        raise CertificationError(
            f"no certified solution found [{summary}]", attempts, farkas=proof
        )

    def _best_farkas(self, dual_points, stage):
        best = None
        for duals in dual_points:
            proof = self.farkas(duals, stage)
            if proof is not None and (best is None or _stronger(proof, best)):
                best = proof
        return best

    def farkas(self, duals, stage: str = "default"):
        """Verify a dual certificate of infeasibility in float64.

        Parameters
        ----------
        duals : sequence of ndarray
            One symmetric matrix per active inequality of `stage`, in the
            order they were added (e.g. cvxpy's dual values after an
            infeasible solve). Each is projected on the PSD cone, then
            polished by alternating projections (PSD cone, null space of the
            adjoint map) and the certificate is evaluated as described in
            `FarkasCertificate`; both signs are tried, with and without the
            duals of the normalisations.
        stage : str, optional
            Stage name.

        Returns
        -------
        `FarkasCertificate` or None
            None if no variant gives a positive trace.
        """
        active = self._active(stage)
        if len(duals) != len(active):
            raise ValueError(
                f"duals: expected {len(active)} matrices, got {len(duals)}"
            )
        full = self._affine_map(active)
        normalizing = np.array([name in self._normalizations for name, *_ in active])
        strict = np.array([is_strict for _, _, is_strict, _ in active])
        groups = self._column_groups()
        symmetric = full.stack(duals)
        # Without the normalisations (their inequalities dropped, so their
        # duals are exactly zero): a certificate that does not need them
        # refutes the LMIs themselves (for homogeneous strict LMIs the
        # normalisations are often what makes the solver's problem
        # infeasible).
        everything = np.arange(len(active))
        variants = [(full, everything, symmetric)]
        if normalizing.any() and not normalizing.all():
            reduced = full.restrict(~normalizing)
            kept = np.flatnonzero(~normalizing[full._owner])
            variants.append((reduced, np.flatnonzero(~normalizing), symmetric[kept]))
        best = None
        for sign in (1.0, -1.0):  # conventions differ
            for amap, members, y0 in variants:
                y = amap.polish(sign * y0)
                if y is None:
                    continue
                proof = _certificate(
                    stage, amap, y, members, full.sizes, normalizing, strict, groups
                )
                if best is None or _stronger(proof, best):
                    best = proof
        return best

    def _column_groups(self) -> list[tuple[str, slice]]:
        """Each variable's columns in the affine map (`_affine_map`)."""
        groups, start = [], 0
        for name, x in self._vars.items():
            n = x.shape[0]
            count = n * (n + 1) // 2 if _is_symmetric(x) else int(np.prod(x.shape))
            groups.append((name, slice(start, start + count)))
            start += count
        return groups

    def _affine_map(self, active) -> _farkas.AffineMap:
        """``F_i(0)`` and the sparse map ``x -> vec(F_i(x) - F_i(0))``.

        Evaluated in float64 with the block functions themselves, one free
        entry of the variables at a time, only for the variables that the
        block function of inequality ``i`` reads. The columns of an
        inequality are kept until the next `add` or `invalidate`, and reused
        while the parameters it reads and ``F_i(0)`` are unchanged (the
        margin is not part of ``F_i``).
        """
        numeric = {k: np.asarray(p.value, float) for k, p in self._params.items()}
        zero = {k: np.zeros(x.shape) for k, x in self._vars.items()}
        units = {
            name: list(_unit_points(x.shape, _is_symmetric(x)))
            for name, x in self._vars.items()
        }
        nfree = sum(len(points) for points in units.values())
        names = frozenset(self._vars) | frozenset(self._params)
        pieces = []
        for name, blocks, _, _ in active:
            # One evaluation per free entry of the variables: long for
            # large problems, so the budget is checked between inequalities.
            budget.check(f"the dual certificate ({name})")

            def evaluate(values, read=None, blocks=blocks):
                namespace = {**numeric, **zero, **values}
                if read is None:
                    v = SimpleNamespace(**namespace)
                else:
                    v = _recording_namespace(namespace, read, names)
                return assemble(blocks(v), xp=np)

            read: set = set()
            F0 = evaluate({}, read)
            if "__dict__" in read:  # the namespace was read as a whole
                read = set(names)
            key = tuple((p, numeric[p].tobytes()) for p in sorted(read & set(numeric)))
            cached = self._farkas_columns.get(name)
            if cached and cached[0] == key and np.array_equal(cached[1], F0):
                part = cached[2]
            else:
                part = _farkas.columns(evaluate, F0, read, units)
                self._farkas_columns[name] = (key, F0, part)
            pieces.append((F0, part))
        # Every inequality as last time (same column objects): the stacked
        # map, with its factored Gram matrix, is the same too.
        parts = tuple(part for _, part in pieces)
        key = ("map", tuple(name for name, *_ in active))
        last = self._farkas_columns.get(key)
        if last and len(last[0]) == len(parts):
            if all(a is b for a, b in zip(last[0], parts)):
                return last[1]
        amap = _farkas.stacked(pieces, nfree)
        self._farkas_columns[key] = (parts, amap)
        return amap
