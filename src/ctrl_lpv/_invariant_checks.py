"""The float64 checks of a saved saturated design, and power-of-two rounding.

`ctrl_lpv.saturation` and `ctrl_lpv.reachability` run on the one engine;
these are what the load-time checks of a saved `SaturatedDesign`
(`ctrl_lpv._sector_checks`) build their certificate from, and the
power-of-two rounding of `ctrl_lpv.reachability`'s Gramian scaling
(re-exported by `ctrl_lpv.reachability`).
"""

from __future__ import annotations

import numpy as np

from .certificate import Certificate, Check, negative_definite

#: One float64 check in original units: ``EllipsoidCheck(name, value,
#: bound)`` passes when ``value <= bound`` (see `ctrl_lpv.certificate.Check`).
EllipsoidCheck = Check


class EllipsoidCertificate(Certificate):
    """All float64 checks of an invariant-ellipsoid result, with numpy.

    A `ctrl_lpv.Certificate` (see `ctrl_lpv.certificate`): the checks in
    original units the statement rests on, and (group ``"LMI"``) the LMIs
    as posed (scaled units) at the returned point.

    Parameters
    ----------
    checks : sequence of `ctrl_lpv.certificate.Check`
        The checks in original units.
    lmi_checks : sequence of `ctrl_lpv.lmi.LMICheck` or `Check`, optional
        The LMIs as posed, at the returned point.
    statement : str, optional
        What the checks prove, in words.

    Attributes
    ----------
    checks : tuple of `ctrl_lpv.certificate.Check`
        Every check (those in original units first).
    lmi_checks : tuple of `ctrl_lpv.certificate.Check`
        The group ``"LMI"``.
    statement : str
    """

    def __init__(self, checks=(), lmi_checks=(), statement=""):
        lmi = tuple(c if isinstance(c, Check) else Check.from_lmi_check(c)
                    for c in lmi_checks)  # fmt: skip
        super().__init__(tuple(checks) + lmi, statement)

    @property
    def lmi_checks(self) -> tuple[Check, ...]:
        return self.group("LMI")


def _pow2(x: float) -> float:
    """Nearest power of two (exact scaling in floating point)."""
    return float(2.0 ** np.round(np.log2(x))) if x > 0 and np.isfinite(x) else 1.0


def _strict_check(name: str, M: np.ndarray, M_abs: np.ndarray) -> Check:
    """``M < 0`` in original units (`ctrl_lpv.certificate.negative_definite`:
    Jacobi-normalised; ``M_abs``, the same expression in absolute values,
    bounds the rounding of forming ``M``)."""
    return negative_definite(M, absolute=M_abs, what=name)


def _positive_check(name: str, P: np.ndarray) -> Check:
    """``P > 0`` (``-P < 0``, see `_strict_check`)."""
    return negative_definite(-P, what=name)
