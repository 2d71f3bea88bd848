"""Dynamic output feedback of polytopic LPV plants, certified.

Data flow one way: `plant` (the w/u/z/y partition, checked) -> `lmis` (the
bounded-real inequalities after the change of variables) -> `design` (the
stages on the certified LMI layer) -> `reconstruct` (controller matrices) ->
`checks` (the closed-loop certificate) -> `results`.
"""

from .design import hinf_output_feedback
from .plant import OutputFeedbackPlant
from .results import OutputFeedbackDesign

__all__ = ["hinf_output_feedback", "OutputFeedbackDesign", "OutputFeedbackPlant"]
