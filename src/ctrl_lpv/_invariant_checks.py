"""Helpers of the hand-built invariant-set LMIs of `ctrl_lpv.saturation`.

`ctrl_lpv.reachability.ultimate_bound` runs on the one engine; these are
what `ctrl_lpv.saturation` still reads (re-exported by
`ctrl_lpv.reachability`, where it imports them from): the ellipsoid
certificate of its own checks, the power-of-two rounding, the two float64
checks and the decay line search.
"""

from __future__ import annotations

import numpy as np

from .certificate import Certificate, Check, negative_definite

# Line search: coarse grid points, then golden-section iterations.
_GRID = 9
_GOLDEN_ITERS = 8

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


def _line_search(f, grid):
    """Minimise ``f(x) -> (value, payload)`` over a grid, then golden section.

    The golden-section refinement works on ``log x`` in the bracket of the
    best grid point. Returns ``(x, value, payload, [(x, value), ...])``;
    ``payload`` is None when every value is infinite.
    """
    grid = np.asarray(grid, float)
    search, best = [], (np.inf, None, None)
    values = []
    for x in grid:
        val, payload = f(x)
        values.append(val)
        search.append((float(x), val))
        if val < best[0]:
            best = (val, payload, float(x))
    if best[1] is None:
        return float(grid[0]), np.inf, None, search
    k = int(np.argmin(values))
    lo = np.log(grid[max(k - 1, 0)])
    hi = np.log(grid[min(k + 1, len(grid) - 1)])
    g = (np.sqrt(5) - 1) / 2

    def at(y):
        val, payload = f(np.exp(y))
        search.append((float(np.exp(y)), val))
        return val, payload

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    (f1, s1), (f2, s2) = at(x1), at(x2)
    for y, fy, sy in ((x1, f1, s1), (x2, f2, s2)):
        if fy < best[0]:
            best = (fy, sy, float(np.exp(y)))
    for _ in range(_GOLDEN_ITERS):
        if f1 <= f2:
            hi, x2, f2, s2 = x2, x1, f1, s1
            x1 = hi - g * (hi - lo)
            f1, s1 = at(x1)
            y, fy, sy = x1, f1, s1
        else:
            lo, x1, f1, s1 = x1, x2, f2, s2
            x2 = lo + g * (hi - lo)
            f2, s2 = at(x2)
            y, fy, sy = x2, f2, s2
        if fy < best[0]:
            best = (fy, sy, float(np.exp(y)))
    return best[2], best[0], best[1], search
