"""Polytopic LPV systems as python-control `StateSpace` objects.

One module a concept, imported one way (each only from those above it):

* `timebase`: python-control's ``dt``, checked;
* `vertices`: vertex data, the domain's vertex order, affine vertices;
* `frames`: who reads a system (calling frames) and warnings at the user's line;
* `nominal`: the frozen system python-control's linear tools see;
* `scheduling`: the scheduled (nonlinear I/O) behaviour in simulation;
* `arithmetic`: block-diagram algebra vertex by vertex, or a refusal;
* `sampling`: vertexwise discretization with its error bound;
* `polytopic`: `PolytopicStateSpace` (construction, vertex data, display,
  the bases above) and `pss`;
* `grid`: `ParameterGrid`, a rectangular grid with multilinear interpolation;
* `gridded`: `GriddedStateSpace` (systems at grid points, a union of
  polytopic cells) and `gss`.
"""

from .grid import ParameterGrid
from .gridded import GriddedStateSpace, gss
from .polytopic import PolytopicStateSpace, pss

__all__ = ["PolytopicStateSpace", "pss", "GriddedStateSpace", "gss", "ParameterGrid"]
