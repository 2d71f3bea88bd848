"""Theorem 2 on the paper's parameter interval p in [-1, 0].

Run from the repository root::

    PYTHONPATH=src python docs/scripts/errata_infeasible.py
"""

import ctrl_lpv as lpv
from ctrl_lpv import twomass

sys = twomass.lpv_model(p_bounds=(-1.0, 0.0))  # formulation="paper"
try:
    lpv.gain_scheduled_hinf(sys, w=["Td", "theta_r"], u=["Tm"], z=["theta_l"])
except lpv.InfeasibleError as exc:
    print(f"{type(exc).__name__}: {exc}")
