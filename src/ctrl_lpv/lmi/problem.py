"""`LMIProblem`: named variables, parameters and stages, solved and certified.

An LMI is written once, as a function of its variables that returns the lower
block triangle (the paper's ``*`` are left as ``None``). The same function is
evaluated in float64 at the unit points of the variables to pose the problem
(its affine map, `ctrl_lpv.lmi.blocks`) and at the returned point to certify
it, so the certificate checks exactly the inequality that was posed, without
trusting the solver's status.

All inequalities have the form ``F(v) <= 0``; a strict one is posed as
``F(v) <= -margin * I`` and certified when ``lambda_max(F) <= -margin / 2``
(half the margin is what is left after the solver's own tolerance).

The affine map of an inequality is kept until something it reads changes
(a parameter, ``F(0)``): a re-solve with new parameter values reads again
only the inequalities that read them, and a new margin changes one vector
of the conic data.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from .. import budget
from ..certificate import Check, negative_definite_each
from ..exceptions import CertificationError, InfeasibleError
from . import blocks as _blocks
from .certificates import (
    _CERTIFIED_FRACTION,
    _SIDE_TOLERANCE,
    LMISolution,
)
from .conic import PROVED_INFEASIBLE, SOLVED
from .dual import DualCertificates
from .reading import ConicReading
from .solvers import SolveAttempt, default_solvers, run, summary, with_time_limit

__all__ = ["LMIProblem"]

logger = logging.getLogger("ctrl_lpv.lmi")

BlockFunction = Callable[[SimpleNamespace], Sequence[Sequence[object]]]

# Retries with a larger margin after a point misses its certificate on
# strict LMIs only: at most this many, each margin at most this factor up.
_MARGIN_RETRIES = 2
_MAX_RETRY_FACTOR = 1e4


@dataclass(frozen=True)
class _Variable:
    shape: tuple[int, ...]
    symmetric: bool

    @property
    def free(self) -> int:
        n = self.shape[0]
        return n * (n + 1) // 2 if self.symmetric else int(np.prod(self.shape))


@dataclass
class _Parameter:
    value: np.ndarray
    nonneg: bool = False
    pos: bool = False

    @property
    def shape(self) -> tuple[int, ...]:
        return self.value.shape


def _retry_factor(checks, margin) -> float | None:
    """Margin factor that should absorb a solver's miss, or None.

    Only a point that misses strict LMIs alone (the side constraints hold)
    is worth a retry: the solver's tolerance ate the margin, so pose one
    about four times the miss, a power of ten, at least ten times larger.
    """
    failed = [c for c in checks if not c.passed]
    if not failed or not all(c.strict for c in failed):
        return None
    miss = max(c.value + c.rounding for c in failed) + margin
    factor = 10.0 ** np.ceil(np.log10(max(10.0, 4 * miss / margin)))
    return min(float(factor), _MAX_RETRY_FACTOR)


class LMIProblem(ConicReading, DualCertificates):
    """LMI problem with named variables, parameters and stages.

    Parameters
    ----------
    margin : float
        Absolute margin of strict inequalities (``F <= -margin I``); choose
        it relative to the scale of the (prescaled) data.

    Examples
    --------
    Lyapunov stability of ``A``: find ``P > 0`` with ``A'P + PA < 0``.

    >>> A = np.array([[-1.0, 2.0], [0.0, -3.0]])
    >>> lmi = LMIProblem(margin=1e-6)
    >>> lmi.variable("P", (2, 2), symmetric=True)
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
        self._vars: dict[str, _Variable] = {}
        self._params: dict[str, _Parameter] = {}
        self._lmis: list[tuple[str, BlockFunction, bool, frozenset | None]] = []
        self._normalizations: set[str] = set()
        self._objectives: dict[str, Callable] = {}
        self._margin = float(margin)
        # Per inequality, the key its affine map was read with and the map
        # (`_pieces`); per stage and layout, the last conic data built.
        self._columns: dict = {}
        self._conic: dict = {}
        # The exact map of the stage (one unit point at a time), for `farkas`.
        self._exact: dict = {}
        # The variables and parameters each block function reads.
        self._reads: dict[str, frozenset] = {}
        # The names given to `add` as read (kept over new declarations).
        self._given_reads: dict[str, frozenset] = {}
        # Seconds spent verifying dual certificates (`farkas`), all told:
        # a refusal says where its time went.
        self.dual_seconds = 0.0
        self._stacked: dict[str, tuple] = {}
        self._trusted_groups: set[str] = set()
        # The inequalities whose batched reading passed its random-point
        # check (re-read without it), and the variables' unit points.
        self._trusted: set[str] = set()
        self._unit_points: dict | None = None
        # Seconds spent reading maps and assembling conic data (the part of
        # a solve that a re-solve with the same data skips).
        self._reading = 0.0

    @property
    def margin(self) -> float:
        """Absolute margin of strict inequalities."""
        return self._margin

    @margin.setter
    def margin(self, value: float) -> None:
        self._margin = float(value)

    def variable(self, name: str, shape, symmetric: bool = False) -> None:
        """Declare a decision variable (``symmetric=True`` for a square one).

        A symmetric ``n x n`` variable has ``n (n + 1) / 2`` free entries
        (its upper triangle); block functions see it as a full matrix.
        """
        if name in self._vars or name in self._params:
            raise ValueError(f"name: {name!r} is already declared")
        shape = tuple(int(s) for s in shape)
        if symmetric and (len(shape) != 2 or shape[1] != shape[0]):
            raise ValueError(f"shape: a symmetric variable is square, got {shape}")
        self._vars[name] = _Variable(shape, bool(symmetric))
        self._forget()

    def parameter(self, name: str, shape=(), value=None, **attributes) -> None:
        """Declare a parameter: data that can change between solves.

        Parameters
        ----------
        name : str
        shape : tuple of int
        value : array_like, optional
            Initial value (zeros if omitted).
        nonneg, pos : bool, optional
            Sign the values must keep (checked by `set_parameter`).
        """
        if name in self._vars or name in self._params:
            raise ValueError(f"name: {name!r} is already declared")
        unknown = set(attributes) - {"nonneg", "pos"}
        if unknown:
            raise ValueError(f"attributes: unknown {sorted(unknown)}")
        self._params[name] = _Parameter(
            np.zeros(shape), **{k: bool(v) for k, v in attributes.items()}
        )
        if value is not None:
            self.set_parameter(name, value)

    def set_parameter(self, name: str, value) -> None:
        """Set the value of a parameter.

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
            array = np.array(np.broadcast_to(np.asarray(value, float), par.value.shape))
        except ValueError:
            raise ValueError(
                f"{name}: expected shape {par.value.shape}, got {np.shape(value)}"
            ) from None
        if not np.isfinite(array).all():
            raise ValueError(f"{name}: the value must be finite")
        if par.pos and not (array > 0).all():
            raise ValueError(f"{name}: the value must be positive")
        if par.nonneg and not (array >= 0).all():
            raise ValueError(f"{name}: the value must be nonnegative")
        par.value = array

    def add(
        self,
        name: str,
        blocks: BlockFunction,
        strict: bool = True,
        stages: Sequence[str] | None = None,
        normalization: bool = False,
        reads: Collection[str] | None = None,
        stacked: tuple | None = None,
    ) -> None:
        """Add the inequality ``F(v) < 0`` (or ``<= 0`` if not strict).

        Parameters
        ----------
        name : str
            Label used in certificates and error messages.
        blocks : callable
            ``blocks(v)`` returns the lower block triangle of ``F``
            (`ctrl_lpv.lmi.assemble`); ``v`` has the variables and
            parameters as attributes, float64 arrays.
        strict : bool, optional
            Strict inequalities are posed with the margin and certified.
        stages : sequence of str, optional
            Stages in which the inequality applies; default all.
        normalization : bool, optional
            A non-strict constraint that only fixes the scale or shape of
            the point (e.g. ``W <= I`` for homogeneous LMIs): an
            infeasibility proof that does not use it refutes the other
            inequalities alone (`FarkasCertificate.normalized`).
        reads : collection of str, optional
            The names `blocks` reads (more will do), when known: its first
            reading then does not evaluate it once more to learn them.
            Default: learnt at the first reading.
        stacked : (callable, int), optional
            ``(group, k)``: ``group(v)`` is the lower block triangle of a
            stack of inequalities (a leading axis, `Batch`), of which this
            one is number ``k``. `check` evaluates a group once for all its
            members, and keeps the stacked values only where they agree
            with each member's map read from `blocks` (otherwise `blocks`
            at the point, as without a group).
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
        self._forget()
        if reads is not None:
            self._given_reads[name] = frozenset(reads)
        if stacked is not None:
            self._stacked[name] = stacked

    def _forget(self, declarations: bool = True) -> None:
        if declarations:  # a new variable or inequality, or new code paths
            # What a block function reads and whether it batches are of its
            # code, kept over new numbers (`invalidate` with ``same_code``).
            self._reads.clear()
            self._trusted.clear()
            self._trusted_groups.clear()
            self._unit_points = None
        self._columns.clear()
        self._conic.clear()
        self._exact.clear()

    def invalidate(self, stage: str, same_code: bool = False) -> None:
        """Read a stage's inequalities again at its next solve.

        Needed when something its block functions read as a constant (not
        a parameter) has changed.

        Parameters
        ----------
        stage : str
            Stage name.
        same_code : bool, optional
            The changed constants enter the block functions only as numbers
            (no branch, no shape depends on them): the names each function
            reads and whether it reads batched (its batched map checked at
            a random point once) are kept. Default: found again.
        """
        if not same_code:  # new code paths: what a function reads too
            self._given_reads.clear()
        self._forget(declarations=not same_code)

    def _active(self, stage: str):
        return [lmi for lmi in self._lmis if lmi[3] is None or stage in lmi[3]]

    def _numeric(self) -> dict[str, np.ndarray]:
        return {k: p.value for k, p in self._params.items()}

    def compile(
        self,
        stage: str = "default",
        objective: Callable[[SimpleNamespace], object] | None = None,
        solver: str | None = None,
    ) -> float:
        """Read a stage's inequalities into conic data ahead of its solve.

        Solving does it on demand; calling this first separates the cost
        of posing the problem from the solver's in timings.

        Parameters
        ----------
        stage : str, optional
            Stage name.
        objective : callable, optional
            As in `solve` (kept for the stage's later solves).
        solver : str, optional
            Solver whose layout to build; default the first of
            `default_solvers`.

        Returns
        -------
        float
            Seconds spent reading block functions and assembling (0.0 when
            nothing the stage reads has changed since it was last read).
        """
        from .conic import DIRECT

        if objective is not None:
            self._objectives[stage] = objective
        if solver is None:
            chain = default_solvers()
            solver = chain[0][0] if chain else "CLARABEL"
        before = self._reading
        self._conic_data(stage, DIRECT.get(solver.upper(), (None, True))[1])
        return self._reading - before

    def _attempt(self, stage, solver, options, objective, factor=1.0,
                 unconverged=False):  # fmt: skip
        start, before = time.perf_counter(), self._reading
        c = self._objective_vector(objective)
        result = run(
            solver,
            c,
            lambda upper: self._conic_data(stage, upper)[0],
            self.margin * factor,
            options,
        )
        posing = self._reading - before + result.setup_seconds
        status, message = result.status, ""
        values, checks, duals = {}, (), None
        if status in PROVED_INFEASIBLE:
            duals = result.duals  # the solver's Farkas point, judged by `farkas`
        x = result.x if status in SOLVED else None
        if x is None and unconverged and result.iterate is not None:
            x = result.iterate  # checked as any point (`solve`, unconverged)
        if x is not None:
            values = self._values(x)
            checks = self.check(values, stage)
            failed = [c for c in checks if not c.passed]
            if failed:
                worst = min(failed, key=lambda c: c.slack)
                message = (
                    f"{worst.what}: max eigenvalue {worst.value:.3g} above "
                    f"{worst.bound - worst.rounding:.3g}"
                )
        certified = bool(checks) and all(c.passed for c in checks)
        if factor != 1.0:
            message = f"margin x{factor:g}" + (f"; {message}" if message else "")
        seconds = time.perf_counter() - start
        attempt = SolveAttempt(
            solver, status, seconds, certified, message, posing, result.converged
        )
        logger.debug(
            "stage '%s': %s %s in %.3g s (%.3g s posing)%s", stage, solver,
            status, seconds, attempt.compile_seconds, f": {message}" if message else "",
        )  # fmt: skip
        return attempt, values, checks, duals, result.objective

    def check(self, values: dict[str, np.ndarray], stage: str = "default"):
        """Evaluate every active LMI at `values` in float64.

        Returns
        -------
        tuple of `ctrl_lpv.certificate.Check`
        """
        v = SimpleNamespace(**{**self._numeric(), **values})
        active = self._active(stage)
        matrices = self._stacked_values(v, values, active)
        matrices = [_blocks.assemble(blocks(v)) if F is None else F
                    for (_, blocks, _, _), F in zip(active, matrices)]  # fmt: skip
        # The same checks matrix by matrix, with one eigenvalue computation
        # per kind and size (stacked), in the inequalities' order.
        groups: dict[tuple, list[int]] = {}
        for i, ((_, _, strict, _), F) in enumerate(zip(active, matrices)):
            groups.setdefault((strict, F.shape), []).append(i)
        checks: list = [None] * len(active)
        # The margin of the certificate, less the rounding of the eigenvalue
        # (`ctrl_lpv.certificate.negative_definite_each`).
        margin = _CERTIFIED_FRACTION * self.margin
        for (strict, _), members in groups.items():
            stack = np.stack([matrices[i] for i in members])
            names = [active[i][0] for i in members]
            if strict:
                found = negative_definite_each(
                    stack, margin=margin, what=names, where=[""] * len(members),
                    units="scaled", group="LMI",
                )  # fmt: skip
            else:
                # Non-strict side constraints (bounds, normalisations) are kept
                # to the solver's accuracy; they do not enter the certificate.
                top = np.linalg.eigvalsh(stack)[:, -1]
                size = np.abs(stack).max(axis=(1, 2))
                found = [Check(name, float(value), _SIDE_TOLERANCE * max(1.0, float(s)),
                               False, units="scaled", group="LMI")
                         for name, value, s in zip(names, top, size)]  # fmt: skip
            for i, check in zip(members, found):
                checks[i] = check
        return tuple(checks)

    def solve(
        self,
        objective: Callable[[SimpleNamespace], object] | None = None,
        stage: str = "default",
        solvers: Sequence[tuple[str, dict]] | None = None,
        certify: bool = True,
        deadline: float | None = None,
        unconverged: bool = False,
    ) -> LMISolution:
        """Solve, trying each solver in turn until a point certifies.

        Parameters
        ----------
        objective : callable, optional
            ``objective(v)``, a linear function of the variables to
            minimise (evaluated in float64); feasibility if omitted. A
            stage keeps the last objective it was given: later calls with
            the same `stage` and no objective reuse it.
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
        unconverged : bool, optional
            Also read the point a solver stopped at without converging
            (`ctrl_lpv.lmi.conic.ConicResult.iterate`; its status is kept):
            checked in float64 as any point, certified if it passes. For a
            stage that only chooses a point whose use is certified later.

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
        if objective is not None:
            self._objectives[stage] = objective
        objective = self._objectives.get(stage)
        attempts: list[SolveAttempt] = []
        budget.progress("stage '%s'", stage, level=logging.DEBUG, stage=stage)
        try:
            return self._solve(objective, stage, chain, certify, deadline, attempts,
                               unconverged)  # fmt: skip
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

    def _solve(self, objective, stage, chain, certify, deadline, attempts,
               unconverged=False):  # fmt: skip
        """`solve`, recording its attempts in `attempts` as they are made."""

        def check(where):
            budget.check(where)
            if deadline is not None and time.perf_counter() >= deadline:
                raise budget.TimeLimitReached(f"deadline passed before {where}")

        check(f"stage '{stage}'")
        dual_points = []
        estimate = None
        for solver, options in chain:
            check(f"stage '{stage}' with {solver}")
            timed = with_time_limit(solver, options, deadline)
            attempt, values, checks, duals, value = self._attempt(
                stage, solver, timed, objective, unconverged=unconverged
            )
            attempts.append(attempt)
            if duals is not None:
                dual_points.append(duals)
            if objective is None:
                value = None
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
                timed = with_time_limit(solver, options, deadline)
                attempt, values, checks, duals, value = self._attempt(
                    stage, solver, timed, objective, factor, unconverged
                )
                attempts.append(attempt)
                if duals is not None:  # judged without the margin: as good
                    dual_points.append(duals)
            if attempt.certified:
                solution = LMISolution(
                    values, None if objective is None else value, checks, attempts
                )
                if factor != 1.0:
                    solution.nominal = estimate
                return solution
        if not certify and estimate is not None:
            return estimate
        described = summary(attempts)
        if dual_points:
            check(f"the dual certificate of stage '{stage}'")
        proof = self._best_farkas(dual_points, stage)
        if proof is not None and proof.proves_infeasible:
            raise InfeasibleError(
                f"the LMIs are infeasible: {proof} [{described}]", attempts, proof
            )
        if dual_points:
            found = "none verified" if proof is None else str(proof)
            described += f"; not proven infeasible ({found})"
        raise CertificationError(
            f"no certified solution found [{described}]", attempts, farkas=proof
        )
