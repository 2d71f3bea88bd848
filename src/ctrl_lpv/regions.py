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

from ._checks import real_number
from .lmi import assemble, normalized_max_eig

__all__ = ["LMIRegion", "halfplane", "disk", "sector"]


def region_blocks(L, M, W, q):
    """The lower block triangle of ``kron(L, W) + kron(M, q) + kron(M', q')``.

    With ``q = A_cl W`` this is the region's LMI (see
    `ctrl_lpv.lmi.assemble` for the form: a diagonal block stands for its
    symmetric part). Written from scalar multiples of ``W`` and ``q``, so
    that ``L`` may be a parameter of the problem.
    """
    k = M.shape[0]

    def block(a, b):
        out = L[a, b] * W
        if a == b:
            return out + 2 * M[a, a] * q if M[a, a] else out
        if M[a, b]:
            out = out + M[a, b] * q
        if M[b, a]:
            out = out + M[b, a] * q.T
        return out

    return [[block(a, b) for b in range(a + 1)] for a in range(k)]


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

    Notes
    -----
    As a constraint of `~ctrl_lpv.synthesize` a region is a spec like the
    others (`~ctrl_lpv.synthesis.constraints.PoleRegion` poses its LMI,
    `region_blocks`, at each coefficient of the relaxation); `residual`
    checks a frozen closed loop in the model's units.
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

    def __str__(self) -> str:
        return self.description

    def residual(self, loop, continuous) -> float:
        """Largest excess of the region's statements at a frozen loop.

        The region LMI with the design's ``W = P^-1`` (Jacobi-normalised
        eigenvalue) and, for every closed-loop eigenvalue ``s``, the largest
        eigenvalue of ``L + M s + M' conj(s)``, relative to the size of its
        terms.
        """
        M = assemble(region_blocks(self.L, self.M, loop.W, loop.Acl @ loop.W))
        worst = normalized_max_eig(M[None])
        for s in loop.eig:
            F = self.L + self.M * s + self.M.T * np.conj(s)
            scale = np.abs(self.L).max() + 2 * np.abs(self.M).max() * abs(s)
            worst = max(worst, float(np.linalg.eigvalsh(F)[-1]) / max(scale, 1e-300))
        return worst


def halfplane(decay: float) -> LMIRegion:
    """Half-plane ``Re(s) < -decay`` (a guaranteed decay rate).

    Parameters
    ----------
    decay : float
        Decay rate; ``0`` is the open left half-plane.

    Returns
    -------
    `LMIRegion`
        The region: pass it in ``constraints=[...]`` to `synthesize`, or in
        ``regions=`` to `quadratic_stabilization`,
        `gain_scheduled_stabilization`, `hinf_state_feedback`,
        `gain_scheduled_hinf` and `h2_state_feedback`. Continuous time
        only: an s-plane region is refused for a discrete-time plant
        (use `disk` there).

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
        The region: for ``constraints=`` of `ctrl_lpv.synthesize`, or
        ``regions=`` of the four paper functions and `ctrl_lpv.h2_state_feedback`.

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
        The region: for ``constraints=`` of `ctrl_lpv.synthesize`, or
        ``regions=`` of the four paper functions and `ctrl_lpv.h2_state_feedback`.

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
    """A finite real number (nonnegative unless ``positive=False``)."""
    return real_number(value, name, minimum=0.0 if positive else None)
