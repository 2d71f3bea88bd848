"""Two-mass drive with variable backlash: the paper's application.

* `Parameters`: the drive data (defaults: the paper's table);
* `plant`: exact (Nordin, Galic, Gutman) and dead-zone backlash models as
  python-control I/O systems;
* `lpv_model`: the affine LPV model (30) as a `PolytopicStateSpace`;
* `paper_gain`: the published gain in python-control's sign;
* `lpv_controller`, `backstepping_controller`: position controllers with a
  common interface (measured states and ``theta_r`` in, ``Tm`` out);
* `closed_loop`, `simulate`, `alpha_step`: the paper's scenarios;
* `design`, `save_gains`, `load_gains`: certified designs in one call and
  their gain files;
* `compare`, `reproduce`: the LPV vs backstepping comparison and the whole
  reproduction of the paper (``ctrl-lpv reproduce``);
* `servo_design`: the torque-limited position servo (planner, feedforward,
  certified feedback, anti-hunting) and its comparison helpers.
"""

from .backstepping import backstepping_controller
from .batch import backstepping_spec, comparison_specs, lpv_spec, run_scenario, sweep
from .comparison import compare, comparison_designs, comparison_scenarios
from .designs import GainFile, design, load_gains, save_gains
from .feedback import backlash_parameter, lpv_controller
from .model import PAPER_GAIN, PAPER_GAMMA, lpv_model, paper_gain
from .parameters import Parameters
from .plant import plant
from .reproduce import errata_findings, reproduce
from .scenarios import alpha_step, closed_loop, metrics, simulate
from .servo import ServoDesign, servo_design, servo_polytope
from .servo_compare import (
    comparison_controllers,
    run_servo_scenario,
    servo_comparison,
    servo_loop,
    servo_metrics,
    servo_scenarios,
)
from .trajectory import move_duration, reference_generator, rest_to_rest

__all__ = [
    "Parameters",
    "plant",
    "lpv_model",
    "paper_gain",
    "PAPER_GAIN",
    "PAPER_GAMMA",
    "lpv_controller",
    "backlash_parameter",
    "backstepping_controller",
    "closed_loop",
    "simulate",
    "metrics",
    "alpha_step",
    "design",
    "save_gains",
    "load_gains",
    "GainFile",
    "compare",
    "comparison_designs",
    "comparison_scenarios",
    "reproduce",
    "errata_findings",
    "sweep",
    "run_scenario",
    "lpv_spec",
    "backstepping_spec",
    "comparison_specs",
    "servo_design",
    "ServoDesign",
    "servo_polytope",
    "servo_loop",
    "run_servo_scenario",
    "servo_metrics",
    "servo_scenarios",
    "comparison_controllers",
    "servo_comparison",
    "move_duration",
    "rest_to_rest",
    "reference_generator",
]
