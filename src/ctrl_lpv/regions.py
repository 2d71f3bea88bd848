"""LMI pole regions (Chilali and Gahinet, 1996).

A region is ``{s : L + M s + M' conj(s) < 0}``. A closed-loop matrix ``A_cl``
has all its eigenvalues in the region if there is ``W > 0`` with
``kron(L, W) + kron(M, A_cl W) + kron(M', (A_cl W)') < 0``; with
``A_cl W = A W + B Z`` this is an LMI in ``(W, Z)``. Intersections of
regions are imposed by listing several regions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LMIRegion", "halfplane", "disk", "sector"]


@dataclass(frozen=True)
class LMIRegion:
    """An LMI region ``{s : L + M s + M' conj(s) < 0}``.

    Parameters
    ----------
    L : ndarray
        Symmetric real matrix.
    M : ndarray
        Real matrix of the same size.
    description : str
        Human-readable description.
    """

    L: np.ndarray
    M: np.ndarray
    description: str

    def __post_init__(self):
        L = np.atleast_2d(np.asarray(self.L, float))
        M = np.atleast_2d(np.asarray(self.M, float))
        if L.shape != M.shape or L.shape[0] != L.shape[1]:
            raise ValueError("L, M: must be square matrices of the same size")
        if not np.allclose(L, L.T):
            raise ValueError("L: must be symmetric")
        object.__setattr__(self, "L", L)
        object.__setattr__(self, "M", M)

    def contains(self, s) -> np.ndarray:
        """Whether the complex number(s) `s` lie in the region."""
        s = np.atleast_1d(np.asarray(s, complex))
        out = []
        for value in s:
            F = self.L + self.M * value + self.M.T * np.conj(value)
            out.append(np.linalg.eigvalsh(F)[-1] < 0)
        return np.array(out)

    def time_scaled(self, factor: float) -> LMIRegion:
        """The region for the time-scaled variable ``s / factor``."""
        return LMIRegion(self.L / factor, self.M, self.description)

    def __str__(self) -> str:
        return self.description


def halfplane(decay: float) -> LMIRegion:
    """Half-plane ``Re(s) < -decay`` (a guaranteed decay rate).

    Parameters
    ----------
    decay : float
        Decay rate; ``0`` is the open left half-plane.

    Returns
    -------
    `LMIRegion`
        The region, for the ``regions`` argument of the synthesis functions.

    Examples
    --------
    >>> halfplane(2.0).contains([-3.0, -1.0]).tolist()
    [True, False]
    """
    decay = _finite(decay, "decay")
    return LMIRegion([[2.0 * decay]], [[1.0]], f"Re(s) < {-decay:g}")


def disk(radius: float, center: float = 0.0) -> LMIRegion:
    """Disk ``|s - center| < radius`` (bounds the natural frequencies).

    Parameters
    ----------
    radius : float
        Radius, positive.
    center : float, optional
        Real center, default 0.

    Returns
    -------
    `LMIRegion`
        The region, for the ``regions`` argument of the synthesis functions.

    Raises
    ------
    ValueError
        If the argument is not finite or out of range.
    """
    radius = _finite(radius, "radius")
    center = _finite(center, "center", positive=False)
    if radius <= 0:
        raise ValueError(f"radius: must be positive, got {radius}")
    return LMIRegion(
        [[-radius, -center], [-center, -radius]],
        [[0.0, 1.0], [0.0, 0.0]],
        f"|s - {center:g}| < {radius:g}",
    )


def sector(angle: float) -> LMIRegion:
    """Conic sector ``|arg(-s)| < angle`` (a minimum damping ``cos(angle)``).

    Parameters
    ----------
    angle : float
        Half-angle in radians, in ``(0, pi/2)``.

    Returns
    -------
    `LMIRegion`
        The region, for the ``regions`` argument of the synthesis functions.

    Raises
    ------
    ValueError
        If the argument is not finite or out of range.
    """
    angle = _finite(angle, "angle")
    if not 0 < angle < np.pi / 2:
        raise ValueError(f"angle: must be in (0, pi/2) radians, got {angle}")
    sin, cos = np.sin(angle), np.cos(angle)
    return LMIRegion(
        np.zeros((2, 2)),
        [[sin, cos], [-cos, sin]],
        f"damping > {cos:.3g} (|arg(-s)| < {np.degrees(angle):.3g} deg)",
    )


def _finite(value, name: str, positive: bool = True) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(value) or (positive and value < 0):
        raise ValueError(f"{name}: expected a finite nonnegative number, got {value}")
    return value
