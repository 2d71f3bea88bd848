"""Effect of eps in p_bounds = (-1 + eps, 0) on Theorem 2 designs.

Run from the repository root::

    PYTHONPATH=src python docs/scripts/errata_epsilon.py
"""

import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv import twomass

CASES = {
    "paper": dict(w=["Td", "theta_r"], u=["Tm"], z=["theta_l"]),
    "tracking": dict(w=["Td"], u=["Tm"], z=["e_l", "Tm_w", "int_e_l_w"]),
}
for formulation, channels in CASES.items():
    suffix = ", integral=True" if formulation == "tracking" else ""
    print(f"formulation={formulation!r}{suffix}")
    for eps in (0.2, 0.1, 0.05, 0.02, 0.01):
        model = twomass.lpv_model(
            p_bounds=(-1.0 + eps, 0.0),
            formulation=formulation,
            integral=formulation == "tracking",
        )
        design = lpv.gain_scheduled_hinf(model, **channels)
        kmax = max(np.linalg.norm(K, 2) for K in design.gains)
        print(
            f"  eps = {eps:<4g}: gamma* = {design.gamma_opt:.4g}, "
            f"gamma = {design.gamma:.4g}, max ||K_j|| = {kmax:.3g}, "
            f"max Re(closed loop) = {design.certificate.max_closed_loop_real:.4g}"
        )
