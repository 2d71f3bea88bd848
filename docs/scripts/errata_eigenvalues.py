"""Closed-loop eigenvalues of the published gain on the model (30).

Run from the repository root::

    PYTHONPATH=src python docs/scripts/errata_eigenvalues.py
"""

import numpy as np

from ctrl_lpv import twomass

sys = twomass.lpv_model(p_bounds=(-1.0, 0.0))  # formulation="paper"
K = twomass.paper_gain()  # u = -K x, K = -K_paper
iu = sys.input_labels.index("Tm")
for p in (-1.0, -0.95, 0.0):
    G = sys.at(p)
    poles = np.linalg.eigvals(G.A - G.B[:, [iu]] @ K)
    poles = poles[np.argsort(-poles.real)]
    print(f"p = {p:+.2f}: {np.array2string(poles, precision=4)}")
