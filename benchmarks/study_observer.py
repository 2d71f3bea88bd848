"""Observer designs against the Kalman filters and an H-infinity Riccati
bisection (the numbers on docs/observers.rst).

Run: ``PYTHONPATH=src python benchmarks/study_observer.py``. The plants and
references are those of ``tests/test_observer.py``.
"""

import sys
from pathlib import Path

import control as ct
import numpy as np

import ctrl_lpv as lpv

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_observer import (  # noqa: E402
    _hinf_filter_reference,
    _noisy_plant,
    _scheduled_plant,
)


def main():
    print("H2, continuous time, vs control.lqe (sqrt(trace P))")
    for seed, ny in [(1, 1), (2, 2), (3, 1)]:
        plant, A, G, C, y = _noisy_plant(seed, ny=ny)
        _, P, _ = ct.lqe(A, G, C, np.eye(G.shape[1]), np.eye(ny))
        ref = np.sqrt(np.trace(P))
        raw = lpv.observer(plant, y, objective=lpv.H2(), backoff=None)
        dflt = lpv.observer(plant, y, objective=lpv.H2())
        print(
            f"  seed {seed}: lqe {ref:.7g}  raw {raw.gamma:.7g} "
            f"(rel {(raw.gamma - ref) / ref:.1e})  default {dflt.gamma:.5g}"
        )
    print("H2, discrete time (dt = 0.1), vs control.dlqe")
    for seed in (4, 5):
        plant, A, G, C, y = _noisy_plant(seed, dt=0.1)
        _, P, _ = ct.dlqe(A, G, C, np.eye(G.shape[1]), np.eye(1))
        ref = np.sqrt(np.trace(P))
        raw = lpv.observer(plant, y, objective=lpv.H2(), backoff=None)
        print(
            f"  seed {seed}: dlqe {ref:.7g}  raw {raw.gamma:.7g} "
            f"(rel {(raw.gamma - ref) / ref:.1e})"
        )
    print("H-infinity, continuous time, vs Hamiltonian bisection")
    for seed in (1, 6):
        plant, A, G, C, y = _noisy_plant(seed)
        ref = _hinf_filter_reference(A, G, C)
        raw = lpv.observer(plant, y, objective=lpv.Hinf(), backoff=None)
        dflt = lpv.observer(plant, y, objective=lpv.Hinf())
        norm = ct.linfnorm(dflt.closed_loop())[0]
        print(
            f"  seed {seed}: Riccati {ref:.7g}  raw {raw.gamma:.7g} "
            f"(rel {(raw.gamma - ref) / ref:.1e})  default {dflt.gamma:.5g} "
            f"(error norm {norm:.5g})"
        )
    print("Polytopic plant (k in [1, 4]), H-infinity from (d, v) to x - x_hat")
    for dt in (0, 0.1):
        plant = _scheduled_plant(dt)
        for gains in ("scheduled", "common"):
            d = lpv.observer(plant, "pos", u="u", w=["d", "v"],
                             objective=lpv.Hinf(), gains=gains)  # fmt: skip
            worst = max(ct.linfnorm(d.closed_loop({"k": k}))[0]
                        for k in np.linspace(1, 4, 31))  # fmt: skip
            print(
                f"  dt={dt} {gains:9s}: gamma {d.gamma:.5g} "
                f"(gamma* {d.gamma_opt:.5g}), worst frozen norm {worst:.5g}"
            )
    print("Same plant, continuous time, common gain, P(p) affine in k")
    plant = _scheduled_plant()
    for nu in (0.0, 0.5, 5.0):
        d = lpv.observer(plant, "pos", u="u", w=["d", "v"], objective=lpv.Hinf(),
                         gains="common", lyapunov="affine",
                         rate_bounds={"k": nu})  # fmt: skip
        worst = max(ct.linfnorm(d.closed_loop({"k": k}))[0]
                    for k in np.linspace(1, 4, 31))  # fmt: skip
        print(f"  |dk/dt| <= {nu}: gamma {d.gamma:.5g}, worst frozen norm {worst:.5g}")


if __name__ == "__main__":
    main()
