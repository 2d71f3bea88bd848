"""Dynamic output feedback of polytopic LPV plants, certified.

Data flow one way: `plant` (the w/u/z/y partition, checked) -> `lmis` and
`objectives` (the inequalities after the change of variables and on the
closed loop, per objective) -> `design` (the
stages on the certified LMI layer) -> `reconstruct` (controller matrices) ->
`checks` (the closed-loop certificate) -> `results`.
"""

from .design import h2_output_feedback, hinf_output_feedback
from .plant import OutputFeedbackPlant
from .results import OutputFeedbackDesign

__all__ = [
    "hinf_output_feedback",
    "h2_output_feedback",
    "OutputFeedbackDesign",
    "OutputFeedbackPlant",
]
