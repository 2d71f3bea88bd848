"""Certified LPV observers: the dual of state feedback, re-checked on the
estimation-error system.

`duality` builds the transposed plant and specs, `design` the `observer`
call, `checks` the float64 certificate of the error dynamics, `results`
the `ObserverDesign` and its estimator I/O system; `combined` an observer
with a state-feedback design, certified on the combined loop.
"""

from .combined import ObserverBasedController, observer_based
from .design import observer
from .results import ObserverDesign

__all__ = ["observer", "ObserverDesign", "observer_based", "ObserverBasedController"]
