"""Polytopic LPV systems and certified LMI gain scheduling for python-control.

The data flow is one way: parameter domain (`polytope`) -> polytopic system
(`systems`) -> LMI problem (`lmi`, `regions`) -> certified design
(`synthesis`) -> controller I/O system (`controllers`) -> analysis.

The public names are imported lazily (PEP 562): ``import ctrl_lpv`` loads
none of python-control, cvxpy or matplotlib; a name's module is imported the
first time the name is used.
"""

from ._lazy import install

__version__ = "0.1.0"

#: Public name -> submodule that defines it. To export a name, add it here.
_EXPORTS = {
    "PolytopicStateSpace": "systems",
    "pss": "systems",
    "GriddedStateSpace": "systems",
    "gss": "systems",
    "ParameterGrid": "systems",
    "ParameterBox": "polytope",
    "Polytope": "polytope",
    "Simplex": "polytope",
    "box": "polytope",
    "DiscretizationBound": "discretization",
    "quadratic_stabilization": "synthesis",
    "hinf_state_feedback": "synthesis",
    "gain_scheduled_stabilization": "synthesis",
    "gain_scheduled_hinf": "synthesis",
    "synthesize": "synthesis",
    "h2_state_feedback": "synthesis",
    "hinf_output_feedback": "output_feedback",
    "h2_output_feedback": "output_feedback",
    "OutputFeedbackDesign": "output_feedback",
    "Hinf": "synthesis",
    "H2": "synthesis",
    "GainBound": "synthesis",
    "Saturation": "synthesis",
    "Peak": "synthesis",
    "observer": "estimation",
    "ObserverDesign": "estimation",
    "observer_based": "estimation",
    "ObserverBasedController": "estimation",
    "check_stabilizability": "stabilizability",
    "check_detectability": "stabilizability",
    "ModeResidual": "stabilizability",
    "StateFeedbackDesign": "synthesis",
    "GriddedDesign": "synthesis",
    "Certificate": "synthesis",
    "SynthesisCache": "problem_cache",
    "synthesis_cache": "problem_cache",
    "SynthesisError": "exceptions",
    "InfeasibleError": "exceptions",
    "CertificationError": "exceptions",
    "TimeLimitReached": "budget",
    "ProblemSizeWarning": "exceptions",
    "NominalPointWarning": "exceptions",
    "ParameterClipWarning": "exceptions",
    "LMIRegion": "regions",
    "halfplane": "regions",
    "disk": "regions",
    "sector": "regions",
    "state_feedback": "controllers",
    "integral_augmentation": "controllers",
    "quadratic_stability": "analysis",
    "l2_gain_bound": "analysis",
    "h2_bound": "analysis",
    "frozen_sweep": "analysis",
    "certify": "schedules",
    "ScheduleCertificate": "schedules",
    "GainSchedule": "schedules",
    "saturated_state_feedback": "saturation",
    "saturation_region": "saturation",
    "SaturatedDesign": "saturation",
    "ultimate_bound": "reachability",
    "UltimateBound": "reachability",
    "Ellipsoid": "reachability",
    "interconnect": "interconnection",
    "simulate": "simulation",
    "SimulationError": "simulation",
    "DivergenceError": "simulation",
    "SimulationTimeout": "simulation",
    "sampled_response": "sampled",
    "SampledResponse": "sampled",
    "Encoder": "sensors",
    "Quantizer": "sensors",
    "Noise": "sensors",
    "load": "persistence",
    "sweep": "batch",
    "scenario_grid": "batch",
}

__all__ = list(_EXPORTS)

__getattr__, __dir__ = install(__name__, _EXPORTS)
del install
