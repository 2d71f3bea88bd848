"""Solving one stage of a rung, and what a verified dual refutes.

`solve_stage` calls the solver chain on one stage of a rung's problem and
turns a verified infeasibility certificate into either a proof
(`~ctrl_lpv.InfeasibleError`, when the stage poses the user's problem
itself) or a refutation of the rung (`RungRefuted`, when it excludes every
point the rung could accept); `Refutations` collects them over the
prescalings and refuses once every prescaling is refuted. `meets_lmis` and
`reached_optimum` say what a solver's point is worth as an estimate.
"""

from __future__ import annotations

import time

import numpy as np

from ..exceptions import CertificationError, InfeasibleError


def meets_lmis(sol) -> bool:
    """Whether a solver's point meets its stage's LMIs, non-strictly, in float64.

    The objective of such a point is never below the problem's infimum
    (the strict LMIs' feasible set has the non-strict one as its
    closure), so it may be reported as an estimate of the optimum; a point
    that misses them may report anything (measured: 95 % below the
    Riccati optimum of an H2 problem).
    """
    return sol is not None and all(
        c.max_eig <= 0.0 if c.strict else c.passed for c in sol.checks
    )


def reached_optimum(sol) -> bool:
    """Whether a solver's point is its optimum: solved to the solver's full
    accuracy (`~ctrl_lpv.lmi.SolveAttempt.converged`), at the nominal margin.

    An "optimal_inaccurate" point far from convergence may certify and
    still lie far above the optimum (measured: 3.5 times the Riccati H2
    optimum).
    """
    return (
        sol is not None
        and sol.nominal is None
        and bool(sol.attempts)
        and sol.attempts[-1].converged
    )


def solve_stage(job, stage, objective, certify=True, proof=False):
    """Solve one stage of a ladder job; None if it gave no certified point.

    `job` has ``lmi``, ``chain``, ``deadline``, ``attempts`` and ``notes``.
    A verified infeasibility proof that needs no normalisation is re-raised
    when `proof` is set (the stage poses the user's problem itself, with
    its variables bounded by the data); otherwise it only ends this branch,
    and the note says what it proved.
    """
    try:
        sol = job.lmi.solve(
            objective, stage=stage, solvers=job.chain, certify=certify,
            deadline=job.deadline,
        )  # fmt: skip
    except InfeasibleError as exc:
        job.attempts.extend(exc.attempts)
        if proof and not exc.farkas.normalized:
            raise
        refute(job, stage, exc.farkas)
        job.notes.append(f"{stage}: {exc.farkas}")
        return None
    except CertificationError as exc:
        job.attempts.extend(exc.attempts)
        refute(job, stage, exc.farkas)
        job.notes.append(f"{stage}: {exc}")
        return None
    job.attempts.extend(sol.attempts)
    return sol


class RungRefuted(Exception):
    """No point a rung's stage could accept exists (a verified dual shows it).

    Raised by `refute` out of a ladder job, so that its rung ends at once;
    the ladder then skips every rung with the same prescaling.

    Attributes
    ----------
    farkas : `ctrl_lpv.lmi.FarkasCertificate`
        The certificate.
    margin : float
        The smallest margin any rung of the prescaling tries.
    bounds : dict of str to float
        Bounds on the variables of an accepted point (`gate_bounds`).
    """

    def __init__(self, farkas, margin, bounds, scaling):
        super().__init__(farkas.exclusion(margin, bounds))
        self.farkas = farkas
        self.margin = margin
        self.bounds = bounds
        self.scaling = scaling


def refute(job, stage, farkas) -> None:
    """Raise `RungRefuted` if `farkas` leaves `stage` nothing to accept.

    The stage must be the job's gate (``job.gate_bounds(stage)`` bounds
    the variables of every point it accepts), and the certificate must
    exclude every point within them at the smallest margin that any rung
    with the job's prescaling tries (``job.floor_margin``): the LMIs of
    those rungs differ only by their margin, so none of them can return
    a design (`ctrl_lpv.lmi.FarkasCertificate.excludes`).
    """
    bounds = job.gate_bounds(stage)
    if farkas is None or bounds is None:
        return
    if farkas.excludes(job.floor_margin, bounds):
        raise RungRefuted(farkas, job.floor_margin, bounds, job.scaling.matrix)


def carry(job, stage, source) -> None:
    """Judge another prescaling's refutation on this job's LMIs (`refute`).

    The LMIs of two prescalings are congruent: ``x = T x~`` turns each
    block of ``n`` rows of the stabilization LMIs by ``T^-1`` (up to
    positive factors), so the dual ``Y`` of prescaling ``T_r`` becomes
    ``K' Y K``, ``K = kron(I, T_r^-1 T_s)``, in prescaling ``T_s``. That is
    only a start: `ctrl_lpv.lmi.LMIProblem.farkas` polishes it and bounds
    it on this job's own LMIs in float64, so the claim is this rung's own,
    whatever the start (a block whose size is not a multiple of ``n`` is
    left as it is). Costs no solver call.
    """
    if source is None or job.gate_bounds(stage) is None:
        return
    R = np.linalg.solve(source.scaling, job.scaling.matrix)
    n = R.shape[0]
    duals = []
    for Y in source.farkas.duals:
        d = Y.shape[0]
        K = np.kron(np.eye(d // n), R) if d % n == 0 else np.eye(d)
        duals.append(K.T @ Y @ K)
    try:
        proof = job.lmi.farkas(duals, stage)
    except ValueError:  # another stage structure: nothing to carry
        return
    refute(job, stage, proof)


class Refutations:
    """The prescalings of a ladder refuted so far; the refusal once all are.

    Parameters
    ----------
    method : str
        Names the call in the message.
    names : list of str
        Every prescaling the ladder tries (each rung uses one of them).
    attempts : list
        The ladder's solver attempts (kept by the refusal).
    """

    def __init__(self, method, names, attempts):
        self.method = method
        self.names = list(names)
        self.attempts = attempts
        self.found: dict[str, RungRefuted] = {}

    def __contains__(self, name) -> bool:
        return name in self.found

    @property
    def last(self) -> RungRefuted | None:
        """The latest refutation (a start for the next prescaling), if any."""
        return next(reversed(self.found.values()), None)

    def brief(self, name) -> str:
        """Short form: the two relative margins of one prescaling."""
        exc = self.found[name]
        needed = exc.farkas.accepted_relative_margin(exc.margin, exc.bounds)
        return (
            f"relative margin at most {exc.farkas.used_relative_margin():.2g}, "
            f"the certificate needs {needed:.2g}"
        )

    def complete(self, prescalings, judge, deadline=None) -> None:
        """Judge the latest refutation on every prescaling not refuted.

        `prescalings` are ``(name, item)`` pairs; `judge(item, carried)`
        loads a rung of that prescaling and `carry`-es the refutation
        `carried` on its LMIs without a solver call, raising `RungRefuted`
        if it holds there. Raises `InfeasibleError` if that refutes every
        prescaling.
        """
        for name, item in prescalings:
            if self.last is None or name in self:
                continue
            if deadline is not None and time.perf_counter() > deadline:
                return
            try:
                judge(item, self.last)
            except RungRefuted as exc:
                self.add(name, exc)

    def add(self, name, exc: RungRefuted) -> None:
        """Record a refuted prescaling; raise `InfeasibleError` once every
        prescaling is refuted."""
        self.found[name] = exc
        if any(other not in self.found for other in self.names):
            return
        first = self.found[self.names[0]]
        per_scaling = "; ".join(f"{n}: {self.brief(n)}" for n in self.names)
        what = "Lyapunov matrix" if self.method == "analysis" else "design"
        raise InfeasibleError(
            f"{self.method}: no certifiable {what} exists (a dual certificate "
            f"verified in float64, in every prescaling tried)\nA dual certificate "
            f"verified in float64 bounds the relative margin (-max lambda_max "
            f"/ ||x||, x the free entries of {', '.join(first.farkas.variables)} "
            f"in the prescaled units) of every point of the "
            f"'{first.farkas.stage}' LMIs below the least one the certificate "
            f"accepts (a margin of {first.margin / 2:.3g} at the smallest margin "
            f"tried, {first.margin:g}, within the stage's bounds on the "
            f"variables), in every prescaling tried: {per_scaling}. A solution "
            f"with a smaller relative margin is not excluded, but none could "
            f"pass the certificate",
            self.attempts,
            first.farkas,
        )
