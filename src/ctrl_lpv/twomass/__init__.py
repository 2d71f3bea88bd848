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
  their gain files (validated and re-checked on load);
* `compare`, `reproduce`: the LPV vs backstepping comparison and the whole
  reproduction of the paper (``ctrl-lpv reproduce``);
* `drive_observer`, `drive_estimator`: a certified estimator of the speeds
  and torques from the encoders, the gap handled as a scheduled contact;
  `motor_observer`: the certified mode observers on the motor encoder alone;
* `servo_design`: the torque-limited position servo (planner, feedforward,
  certified feedback, no hunting), its settings (`ServoPlanner`,
  `ServoSynthesis`, `ServoAntiHunting`, `ServoEstimator`) and its comparison
  (`servo_comparison`); `identify_load_inertia`: the load inertia from a
  motor-encoder record, to commission the motor-encoder servo on.

The names are imported lazily, as in `ctrl_lpv`.
"""

from .._lazy import install

#: Public name -> submodule that defines it. To export a name, add it here.
_EXPORTS = {
    "Parameters": "parameters",
    "plant": "plant",
    "lpv_model": "model",
    "paper_gain": "model",
    "PAPER_GAIN": "model",
    "PAPER_GAMMA": "model",
    "lpv_controller": "feedback",
    "backlash_parameter": "feedback",
    "backstepping_controller": "backstepping",
    "closed_loop": "scenarios",
    "simulate": "scenarios",
    "metrics": "scenarios",
    "alpha_step": "scenarios",
    "design": "designs",
    "output_feedback_design": "designs",
    "save_gains": "gain_files",
    "load_gains": "gain_reader",
    "GainFile": "gain_files",
    "compare": "comparison",
    "comparison_designs": "comparison",
    "comparison_scenarios": "comparison",
    "reproduce": "reproduce",
    "errata_findings": "reproduce",
    "sweep": "batch",
    "run_scenario": "batch",
    "lpv_spec": "batch",
    "backstepping_spec": "batch",
    "comparison_specs": "batch",
    "drive_model": "drive_observer",
    "drive_observer": "drive_observer",
    "drive_estimator": "drive_observer",
    "motor_observer": "motor_estimator",
    "servo_design": "servo",
    "ServoDesign": "servo",
    "servo_polytope": "servo",
    "ServoPlanner": "servo_config",
    "ServoSynthesis": "servo_config",
    "ServoAntiHunting": "servo_config",
    "ServoEstimator": "servo_config",
    "ServoStream": "servo_config",
    "ServoInertia": "inertia",
    "identify_load_inertia": "commissioning",
    "LoadInertia": "commissioning",
    "cascade_design": "cascade",
    "CascadeDesign": "cascade",
    "servo_loop": "servo_compare",
    "run_servo_scenario": "servo_compare",
    "servo_metrics": "servo_compare",
    "servo_scenarios": "servo_compare",
    "comparison_controllers": "servo_compare",
    "servo_comparison": "servo_compare",
    "move_duration": "trajectory",
    "rest_to_rest": "trajectory",
    "reference_generator": "trajectory",
}

__all__ = list(_EXPORTS)

__getattr__, __dir__ = install(__name__, _EXPORTS)
del install
