"""Exceptions raised by ctrl_lpv."""

__all__ = ["InfeasibleError", "CertificationError"]


class InfeasibleError(RuntimeError):
    """No certified solution exists for an LMI synthesis problem.

    Raised when a vertex of the polytope is not stabilizable (the message
    names the vertex and the uncontrollable mode) or when the solvers report
    the LMIs infeasible. When no returned point passes the independent
    float64 certificate, the subclass `CertificationError` is raised.

    Attributes
    ----------
    attempts : tuple
        The solver attempts (`ctrl_lpv.lmi.SolveAttempt`) made, if any.
    """

    def __init__(self, message: str, attempts=()):
        super().__init__(message)
        self.attempts = tuple(attempts)


class CertificationError(InfeasibleError):
    """Every solver attempt returned a point that failed its certificate.

    A subclass of `InfeasibleError`: the problem may be feasible, but no point
    that the solvers returned could be verified in float64, so no design is
    returned.

    Attributes
    ----------
    attempts : tuple
        The solver attempts (`ctrl_lpv.lmi.SolveAttempt`), none of them
        certified, each with the reason.
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


__all__ += ["NominalPointWarning", "ParameterClipWarning"]
