"""Which sample times the sampled servo's design certifies (issue 22).

For each sample time ``dt`` the sampled servo on encoders with one sample of
delay is designed (``twomass.servo_design(dt=dt, delay=1,
sensors="encoders")``: the drive observer and the discrete-time H-infinity
gain, each certified, then the rest certificate of the loop that runs,
`ctrl_lpv.twomass.servo_rest`). A row prints whether the design was
returned or refused (and why), its certified rest bounds (load error, torque
ripple) and the load torque above which they hold (``min_load_torque``),
and the design's wall time.

Usage::

    python benchmarks/study_sample_time.py [--dt 1e-3,2e-3,4e-3]
"""

from __future__ import annotations

import argparse
import time

from ctrl_lpv import twomass

DEFAULT = "1e-3,2e-3,3e-3,4e-3,6e-3,8e-3,12e-3,20e-3"


def row(dt: float) -> str:
    start = time.perf_counter()
    try:
        design = twomass.servo_design(dt=dt, delay=1, sensors="encoders")
    except Exception as exc:  # a refusal is a result here
        why = str(exc).splitlines()[0][:100]
        return f"{dt * 1e3:6.3g}  refused: {type(exc).__name__}: {why}"
    seconds = time.perf_counter() - start
    c = design.certificate
    floor = c.rest.min_load_torque
    return (
        f"{dt * 1e3:6.3g}  certified  {c.rest_error_bound:10.3g}  "
        f"{c.rest_ripple_bound:10.3g}  {floor:10.3g}  {seconds:6.1f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dt", default=DEFAULT, help="sample times in s, with commas")
    args = parser.parse_args()
    print("dt (ms)  design     |e| (rad)   ripple (Nm)  floor (Nm)  design s")
    for dt in (float(x) for x in args.dt.split(",")):
        print(row(dt), flush=True)


if __name__ == "__main__":
    main()
