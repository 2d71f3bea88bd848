"""Polytopic LPV systems and certified LMI gain scheduling for python-control.

The data flow is one way: parameter domain (`polytope`) -> polytopic system
(`systems`) -> LMI problem (`lmi`, `regions`) -> certified design
(`synthesis`) -> controller I/O system (`controllers`) -> analysis.
"""

from .analysis import frozen_sweep, l2_gain_bound, quadratic_stability
from .batch import scenario_grid, sweep
from .controllers import integral_augmentation, state_feedback
from .exceptions import (
    CertificationError,
    InfeasibleError,
    ProblemSizeWarning,
    SynthesisError,
)
from .interconnection import interconnect
from .polytope import ParameterBox, Polytope, Simplex, box
from .problem_cache import SynthesisCache, synthesis_cache
from .regions import LMIRegion, disk, halfplane, sector
from .simulation import simulate
from .stabilizability import ModeResidual, check_stabilizability
from .synthesis import (
    Certificate,
    StateFeedbackDesign,
    gain_scheduled_hinf,
    gain_scheduled_stabilization,
    hinf_state_feedback,
    quadratic_stabilization,
)
from .systems import PolytopicStateSpace, pss

__version__ = "0.1.0"

__all__ = [
    "PolytopicStateSpace",
    "pss",
    "ParameterBox",
    "Polytope",
    "Simplex",
    "box",
    "quadratic_stabilization",
    "hinf_state_feedback",
    "gain_scheduled_stabilization",
    "gain_scheduled_hinf",
    "check_stabilizability",
    "StateFeedbackDesign",
    "Certificate",
    "SynthesisCache",
    "synthesis_cache",
    "SynthesisError",
    "InfeasibleError",
    "CertificationError",
    "ProblemSizeWarning",
    "ModeResidual",
    "LMIRegion",
    "halfplane",
    "disk",
    "sector",
    "state_feedback",
    "integral_augmentation",
    "quadratic_stability",
    "l2_gain_bound",
    "frozen_sweep",
    "interconnect",
    "simulate",
    "sweep",
    "scenario_grid",
]
