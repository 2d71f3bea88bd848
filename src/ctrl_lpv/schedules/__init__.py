"""Certify the gain schedules people already have.

`schedule` reads a gain schedule (gains at points, and the cells of its
piecewise-affine interpolation) from a python-control controller or a
table; `certify` answers "is it stable, and for how fast a parameter?";
`counterexample` looks for a destabilising parameter trajectory above the
certified rate; `dynamic` closes a dynamic (output-feedback) controller
with the plant by signal names, for `certify`.
"""

from .certify import FrozenCounterexample, ScheduleCertificate, certify
from .counterexample import ParameterTrajectory
from .schedule import GainSchedule, schedule_of

__all__ = [
    "certify",
    "ScheduleCertificate",
    "FrozenCounterexample",
    "ParameterTrajectory",
    "GainSchedule",
    "schedule_of",
]
