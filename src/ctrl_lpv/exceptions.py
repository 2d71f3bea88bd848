"""Exceptions raised by ctrl_lpv.

A refusal is a statement about the problem, so the two classes say different
things and neither is a subclass of the other:

* `InfeasibleError`: no solution exists, and the library has a proof of it
  (a vertex with an uncontrollable unstable mode in balanced coordinates, or
  a dual (Farkas) certificate of the LMIs verified in float64), or no
  certifiable one exists (a verified dual bounds the relative margin of
  every point below what the certificate accepts, in every rung left);
* `CertificationError`: no certified solution was found, with what was
  tried. The problem may well be feasible.

Both derive from `SynthesisError`, which catches either.
"""

__all__ = [
    "SynthesisError",
    "InfeasibleError",
    "CertificationError",
    "ProblemSizeWarning",
    "NominalPointWarning",
    "ParameterClipWarning",
]


class SynthesisError(RuntimeError):
    """No design was returned (base of the two refusals).

    Attributes
    ----------
    attempts : tuple
        The solver attempts (`ctrl_lpv.lmi.SolveAttempt`) made, if any.
    farkas : `ctrl_lpv.lmi.FarkasCertificate` or None
        The best dual certificate of infeasibility found: the proof of an
        `InfeasibleError`, or what a `CertificationError` could verify
        (too weak to prove infeasibility).
    """

    def __init__(self, message: str, attempts=(), farkas=None):
        super().__init__(message)
        self.attempts = tuple(attempts)
        self.farkas = farkas


class InfeasibleError(SynthesisError):
    """The problem provably has no solution.

    Raised only with a proof, stated in the message: a vertex of the
    polytope that is not stabilizable (the vertex, the uncontrollable mode
    and its PBH residual in balanced coordinates), or a dual certificate of
    infeasibility of the LMIs verified in float64 (`farkas` holds it).

    For homogeneous LMIs (a Lyapunov inequality: their solutions form a
    cone) the dual proves a bound on the margin of every point relative
    to its norm. When that bound is below the relative margin that any
    point the certificate accepts must have (its margin, within the bounds
    the stage puts on the variables), in every prescaling the ladder would
    try, the message says "no certifiable design exists" and gives both
    numbers per prescaling: a solution with a smaller relative margin is
    not excluded, but no design or Lyapunov matrix can be certified.

    Attributes
    ----------
    attempts : tuple
        The solver attempts (`ctrl_lpv.lmi.SolveAttempt`) made, if any.
    farkas : `ctrl_lpv.lmi.FarkasCertificate` or None
        The verified dual certificate, if the proof is one.
    """


class CertificationError(SynthesisError):
    """No certified solution was found; the problem may be feasible.

    Every point the solvers returned failed its independent float64
    certificate, or no solver returned a point, and no proof of
    infeasibility could be verified. The message says what was tried.

    Attributes
    ----------
    attempts : tuple
        The solver attempts (`ctrl_lpv.lmi.SolveAttempt`), none of them
        certified, each with the reason.
    """


class ProblemSizeWarning(UserWarning):
    """An LMI problem is large enough to take minutes or much memory.

    Parameters
    ----------
    message : str
        The number of LMIs, their size and the estimated memory of the
        compiled problem.
    """


class NominalPointWarning(UserWarning):
    """A python-control linear tool read a polytopic system at its nominal point.

    A `ctrl_lpv.PolytopicStateSpace` is a `control.StateSpace` whose ``A, B,
    C, D`` are the frozen system at ``sys.nominal`` (default: the domain's
    center). Linear tools (`control.poles`, `control.bode_plot`,
    `control.lqr`, ``sys(s)``, ...) therefore analyse that single frozen
    system, not the LPV system; this warning, issued once per call, names
    the nominal point. Use ``sys.at(p)`` to choose the point (no warning),
    or filter the category::

        warnings.simplefilter("ignore", ctrl_lpv.NominalPointWarning)

    Parameters
    ----------
    message : str
        Names the call, the system and the nominal point.
    """


class ParameterClipWarning(UserWarning):
    """A scheduled parameter value outside the domain was projected onto it.

    Issued once per simulation by a `ctrl_lpv.PolytopicStateSpace` scheduled
    by its inputs or by a callable, naming the parameter, the value and the
    time; the system then uses a point of its domain instead (for a box,
    each parameter clipped to its bounds: a saturated scheduling signal),
    never an extrapolation.

    Parameters
    ----------
    message : str
        Names the system, the scheduling source, the parameter, its value
        and the time.
    """
