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
