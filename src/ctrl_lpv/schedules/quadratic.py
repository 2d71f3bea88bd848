"""Arbitrary rates: one quadratic Lyapunov function of spanning closed loops."""

from __future__ import annotations

import numpy as np

from ..certificate import Certificate, Check
from ..exceptions import SynthesisError


def quadratic_certificate(matrices, dt, margin, statement: str) -> Certificate | None:
    """`quadratic_stability` of the loops whose hull spans the closed loop.

    Parameters
    ----------
    matrices : sequence of ndarray
        The closed-loop matrices spanning every frozen loop.
    dt : float or None
        Their time base (the plant's).
    margin : float
        Margin of the strict LMIs.
    statement : str
        What the certificate covers, in words.

    Returns
    -------
    `ctrl_lpv.Certificate` or None
        None when the engine certifies no common Lyapunov function.
    """
    from ..analysis import quadratic_stability
    from ..systems import PolytopicStateSpace

    n = matrices[0].shape[0]
    # A zero input and output rather than none: python-control reads an
    # n x 0 input matrix of a one-state system as 0 x 0.
    loop = PolytopicStateSpace(
        [(M, np.zeros((n, 1)), np.zeros((1, n)), np.zeros((1, 1))) for M in matrices],
        dt=dt,
    )
    try:
        result = quadratic_stability(loop, margin)
    except SynthesisError:
        return None
    checks = tuple(Check.from_lmi_check(c, group="quadratic") for c in result.checks)
    return Certificate(checks, statement=statement)
