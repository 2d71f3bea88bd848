"""Two-mass drive with variable backlash: the paper's application.

* `Parameters`: the drive data (defaults: the paper's table);
* `plant`: exact (Nordin, Galic, Gutman) and dead-zone backlash models as
  python-control I/O systems;
* `lpv_model`: the affine LPV model (30) as a `PolytopicStateSpace`;
* `paper_gain`: the published gain in python-control's sign.
"""

from .model import PAPER_GAIN, PAPER_GAMMA, lpv_model, paper_gain
from .parameters import Parameters
from .plant import plant

__all__ = [
    "Parameters",
    "plant",
    "lpv_model",
    "paper_gain",
    "PAPER_GAIN",
    "PAPER_GAMMA",
]
