"""A small LMI layer with independent float64 certificates.

An LMI is a block function of named variables and parameters
(`LMIProblem.add`); the problem is posed in a solver's sparse conic form
directly (Clarabel and SCS, `ctrl_lpv.lmi.conic`; other solvers through
cvxpy, `ctrl_lpv.lmi.cvxpy_backend`), and every returned point is checked
in float64 with the same block functions (`LMICheck`), or refuted by a
verified dual certificate (`FarkasCertificate`).

Modules, in the order data flow through them: ``blocks`` (block matrices,
affine maps), ``conic`` (conic data, direct solvers), ``cvxpy_backend``,
``solvers`` (chains, options, time limits), ``certificates`` (checks,
dual certificates), ``reading`` (inequalities into conic data), ``dual``
(dual certificates of a stage), ``problem`` (`LMIProblem`).
"""

from .blocks import assemble, normalized_max_eig
from .certificates import (
    INFEASIBLE_RADIUS,
    FarkasCertificate,
    LMICheck,
    LMISolution,
    _certificate,
    schur_norm_bound,
    symmetric_norm_bound,
)
from .problem import LMIProblem
from .solvers import SolveAttempt, default_solvers, solver_chain

__all__ = [
    "LMIProblem",
    "LMISolution",
    "LMICheck",
    "FarkasCertificate",
    "SolveAttempt",
    "assemble",
    "default_solvers",
    "solver_chain",
    "normalized_max_eig",
    "schur_norm_bound",
    "symmetric_norm_bound",
    "INFEASIBLE_RADIUS",
    "_certificate",
]
