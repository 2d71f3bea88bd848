"""Signal channels of a polytopic plant: which inputs and outputs are w, u, z."""

from __future__ import annotations

import numpy as np

from .._checks import signal_indices
from ..systems import PolytopicStateSpace


def require_pss(sys):
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}; wrap an "
            "LTI system as PolytopicStateSpace([sys])"
        )


def channel_indices(sys, w, u, z):
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    iw = signal_indices(w, inputs, "w")
    iz = signal_indices(z, sys.output_labels, "z")
    return iw, iu, iz


def resolve_channels(sys, w, u, z, hinf):
    require_pss(sys)
    if u is None:
        raise ValueError("u: name the control input(s), e.g. u=['Tm']")
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    if not iu:
        raise ValueError("u: at least one control input is required")
    if not hinf:
        return [], iu, []
    iw = (
        [i for i in range(len(inputs)) if i not in iu]
        if w is None
        else signal_indices(w, inputs, "w")
    )
    iz = (
        list(range(sys.noutputs))
        if z is None
        else signal_indices(z, sys.output_labels, "z")
    )
    if not iw:
        raise ValueError("w: at least one exogenous input is required")
    if not iz:
        raise ValueError("z: at least one performance output is required")
    if set(iw) & set(iu):
        raise ValueError("w, u: an input cannot be both exogenous and control")
    return iw, iu, iz


def spectral_norm(M) -> float:
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def vertex_channels(sys, iw, iu, iz):
    out = []
    for A, B, C, D in sys.vertex_data():
        out.append(
            (
                A,
                B[:, iw],
                B[:, iu],
                C[iz] if iz else np.zeros((0, A.shape[0])),
                D[np.ix_(iz, iw)],
                D[np.ix_(iz, iu)],
            )
        )
    return out
