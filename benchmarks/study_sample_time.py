"""Which sample times the sampled servo's design certifies (issue 22).

For each sample time ``dt`` the sampled servo on encoders with one sample of
delay is designed (``twomass.servo_design(dt=dt, delay=1,
sensors="encoders")``: the drive observer and the discrete-time H-infinity
gain, each certified, then the rest certificate of the loop that runs,
`ctrl_lpv.twomass.servo_rest`). A row prints whether the design was
returned or refused (and why), the tuning the rule chose
(`ctrl_lpv.twomass.sampled_tuning`: the torque weight and the drive
observer's shaft- and load-torque intensities), its certified rest bounds
(load error, torque ripple), the load torque above which they hold
(``min_load_torque``), the certified time constant of their approach and
the design's wall time. The last line states the
largest sample time of the list whose certified rest covers the paper's
load torque of 8 Nm, approached with a certified time constant of at most
1 s.

``--scan`` prints, per sample time, the certified floor and ripple of every
pair of intensities of a small grid with both torque weights (the numbers
behind the rule).

Usage::

    python benchmarks/study_sample_time.py [--dt 1e-3,2e-3,4e-3]
"""

from __future__ import annotations

import argparse
import itertools
import math
import time

import numpy as np

from ctrl_lpv import hinf_state_feedback, twomass
from ctrl_lpv.twomass.drive_observer import drive_observer, observer_matrices
from ctrl_lpv.twomass.sampled_tuning import (
    FLOOR_TARGET,
    MAX_TIME_CONSTANT,
    sampled_tuning,
)
from ctrl_lpv.twomass.servo import servo_polytope
from ctrl_lpv.twomass.servo_rest import rest_bound
from ctrl_lpv.twomass.servo_sampled import SampledServo

DEFAULT = "1e-3,2e-3,3e-3,4e-3,6e-3,8e-3,12e-3,20e-3"


def row(dt: float) -> tuple[str, float, float]:
    start = time.perf_counter()
    try:
        design = twomass.servo_design(dt=dt, delay=1, sensors="encoders")
    except Exception as exc:  # a refusal is a result here
        why = str(exc).splitlines()[0][:100]
        text = f"{dt * 1e3:6.3g}  refused: {type(exc).__name__}: {why}"
        return text, math.inf, math.inf
    seconds = time.perf_counter() - start
    c = design.certificate
    floor = c.rest.min_load_torque
    return (
        f"{dt * 1e3:6.3g}  certified  {_weight(dt):7.1e}  {_rates(design):>12s}  "
        f"{c.rest_error_bound:10.3g}  {c.rest_ripple_bound:10.3g}  {floor:10.3g}  "
        f"{c.rest.time_constant:7.3g}  {seconds:6.1f}",
        floor,
        c.rest.time_constant,
    )


def _weight(dt: float) -> float:
    """The torque weight of the rule at `dt`."""
    return sampled_tuning(dt).torque_weight


def _rates(design) -> str:
    """The rule's intensities the design kept, found by their model."""
    chosen = np.asarray(design.observer.system.at([1.0]).B)
    for shaft, load in sampled_tuning(design.dt).rates:
        model = twomass.drive_model(
            dt=design.dt, shaft_torque_rate=shaft, load_torque_rate=load
        )
        if np.allclose(np.asarray(model.at([1.0]).B), chosen, rtol=1e-12, atol=0.0):
            return f"{shaft:g}/{load:g}"
    return "?"


def scan(dt: float) -> None:
    """Certified floor and ripple over a grid of intensities and weights."""
    params = twomass.Parameters()
    gains = {}
    for weight in (5e-4, 2e-3):
        model = servo_polytope(params, torque_weight=weight).sample(dt)
        feedback = hinf_state_feedback(model, w=["Td"], u=["Tm"])
        gains[weight] = np.asarray(feedback.gains[0], float).reshape(1, -1)
    for shaft, load in itertools.product(
        (100.0, 300.0, 1000.0, 3000.0), (2.0, 5.0, 20.0)
    ):
        observer = drive_observer(
            params, dt=dt, shaft_torque_rate=shaft, load_torque_rate=load
        )
        Phi, Gamma, M = observer_matrices(observer)
        sampling = SampledServo(
            dt=dt, delay=1, Phi=Phi, Gamma=Gamma, M=M, reference="plan",
            stream_gain=None, measured=("theta_m", "theta_l"), estimator=None,
        )  # fmt: skip
        for weight, K in gains.items():
            try:
                rest = rest_bound(
                    params, K, sampling, Jl_range=(0.8, 1.2), flank_width=0.5,
                    contact_torque=1.5, latch_torque=2.0,
                )  # fmt: skip
                text = (
                    f"floor {rest.min_load_torque:9.3g}  ripple "
                    f"{rest.ripple_bound:9.3g}  |e| {rest.error_bound:9.3g}  "
                    f"tau {rest.time_constant:7.3g}"
                )
            except Exception as exc:  # a refusal is a result here
                text = f"refused: {type(exc).__name__}"
            print(f"{dt * 1e3:6.3g}  {weight:7.1e}  {shaft:6g}/{load:<4g}  {text}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", default=DEFAULT, help="sample times in s, with commas")
    parser.add_argument("--scan", action="store_true", help="the grid behind the rule")
    args = parser.parse_args()
    times = [float(x) for x in args.dt.split(",")]
    if args.scan:
        print("dt (ms)  weight   Ts/Td rates  certified rest")
        for dt in times:
            scan(dt)
        return
    print(
        "dt (ms)  design     weight   Ts/Td rates   |e| (rad)  ripple (Nm)  "
        "floor (Nm)  tau (s)  design s"
    )
    covered = []
    for dt in times:
        text, floor, tau = row(dt)
        print(text, flush=True)
        if floor <= FLOOR_TARGET and tau <= MAX_TIME_CONSTANT:
            covered.append(dt)
    if covered:
        print(
            f"largest sample time whose certified rest covers |Td| >= "
            f"{FLOOR_TARGET:g} Nm with a time constant <= {MAX_TIME_CONSTANT:g} s: "
            f"{max(covered) * 1e3:g} ms"
        )
    else:
        print(f"no sample time's certified rest covers |Td| >= {FLOOR_TARGET:g} Nm")


if __name__ == "__main__":
    main()
