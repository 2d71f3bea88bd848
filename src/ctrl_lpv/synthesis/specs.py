"""Specifications of `synthesize`: one class per objective or constraint.

Each performance spec holds its LMI blocks, written once for continuous and
discrete time in the dual variables ``W = P^-1`` and ``Z = -K W``, and its
own float64 residual check in the model's units with the primal ``P``.
The blocks read the vertex data through a `~ctrl_lpv.synthesis.terms.Terms`
object, which evaluates each parameter-dependent product at one coefficient
of the relaxation (see `ctrl_lpv.synthesis.parametric`):

======  =====================================================================
spec    LMIs (continuous time; ``sym(X) = X + X'``)
======  =====================================================================
Hinf    ``[[sym(A W + B2 Z) - dW/dt, *, *], [Bw', -I, *], [Cz W + Dzu Z, Dzw, -g I]] < 0``
H2      ``[[sym(A W + B2 Z) - dW/dt, *], [Cz W + Dzu Z, -I]] < 0``,
        ``[[Y, Bw'], [Bw, W]] > 0``, ``trace Y < h``
======  =====================================================================

and in discrete time, with ``W+`` the Lyapunov matrix at the next sample,
``[[-W, *, *, *], [0, -g I, *, *], [A W + B2 Z, Bw, -W+, *],
[Cz W + Dzu Z, Dzw, 0, -I]] < 0`` (H-infinity; Schur complements of the
primal bounded-real inequality ``M' diag(P+, I) M < diag(P, g I)``) and
``[[-W, *, *], [A W + B2 Z, -W+, *], [Cz W + Dzu Z, 0, -I]] < 0``,
``[[-Y, *, *], [Bw, -W+, *], [Dzw, 0, -I]] < 0`` (H2). The certified bound
is ``sqrt(g)`` or ``sqrt(h)``.

With a common gain and a parameter-dependent ``W`` the blocks are the
extended ones (see `_extended`): ``A_cl W`` becomes ``A_cl G`` with a
constant slack ``G`` and ``K = -Z G^-1``, which keeps them affine in the
parameter. Discrete time: ``[[W - G - G', *], [A_cl G, -W+]] < 0``
(de Oliveira, Bernussou and Geromel 1999; Daafouz and Bernussou 2001),
and likewise in the H-infinity and H2 blocks.

For time-varying parameters the H-infinity bound bounds the L2 gain over
every admissible parameter trajectory; the H2 bound the output energy of
every impulse (the energy of ``z`` for ``w = e_i delta(t)``, summed over
``i``), so for frozen parameters it bounds the H2 norm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import real_number
from .verification import normalized_max_eig


def _channel(value, name):
    """A signal selection as a hashable tuple (None stays None)."""
    if value is None:
        return None
    if isinstance(value, (str, int, np.integer)):
        return (value,)
    try:
        return tuple(value)
    except TypeError:
        raise TypeError(
            f"{name}: expected a signal name, an index or a sequence of them, got "
            f"{value!r}"
        ) from None


@dataclass(frozen=True)
class _Performance:
    w: tuple | None = None
    z: tuple | None = None
    bound: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "w", _channel(self.w, "w"))
        object.__setattr__(self, "z", _channel(self.z, "z"))
        bound = real_number(
            self.bound, "bound", allow_none=True, positive=True, below=1e150
        )
        object.__setattr__(self, "bound", bound)

    def __str__(self) -> str:
        w = "default" if self.w is None else list(self.w)
        z = "default" if self.z is None else list(self.z)
        bound = "" if self.bound is None else f", bound={self.bound:g}"
        return f"{type(self).__name__}(w={w}, z={z}{bound})"

    def check_data(self, channels, continuous) -> None:
        """Refuse data the spec cannot bound (a `ValueError`)."""


@dataclass(frozen=True)
class Hinf(_Performance):
    """H-infinity (L2-gain) specification from `w` to `z`.

    Parameters
    ----------
    w : str, int or sequence, optional
        Exogenous inputs; default every physical input that is not a
        control input.
    z : str, int or sequence, optional
        Performance outputs; default all outputs.
    bound : float, optional
        Required bound, met strictly; None (only for the objective) asks for
        the smallest one.

    Examples
    --------
    >>> Hinf(w="d", z=["e", "u"], bound=2.0)
    Hinf(w=('d',), z=('e', 'u'), bound=2.0)
    """

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient (see the module docstring)."""
        nw, nz = t.nw(self), t.nz(self)
        Bw, Dzw, CW = t.data(self, "Bw"), t.data(self, "Dzw"), t.CW(self)
        g = t.const(t.g(self)[0, 0] * np.eye(nz))
        if t.slack:
            AG, CG = t.AG(), t.CG(self)
            if continuous:
                return [("H-infinity", [
                    *_extended(t),
                    [Bw.T, 0, -t.rho(self, "w") * t.identity(nw)],
                    [CG, t.eps() * CG, Dzw, -g],
                ])]  # fmt: skip
            return [("H-infinity", [
                [t.W() - 2 * t.G()],
                [0, -t.const(t.g(self)[0, 0] * np.eye(nw))],
                [AG, Bw, -t.W_moved()],
                [CG, Dzw, 0, -t.rho(self, "z") * t.identity(nz)],
            ])]  # fmt: skip
        if continuous:
            blocks = [
                [2 * t.AW() - t.W_moved()],
                [Bw.T, -t.rho(self, "w") * t.identity(nw)],
                [CW, Dzw, -g],
            ]
        else:
            blocks = [
                [-t.W()],
                [0, -t.const(t.g(self)[0, 0] * np.eye(nw))],
                [t.AW(), Bw, -t.W_moved()],
                [CW, Dzw, 0, -t.rho(self, "z") * t.identity(nz)],
            ]
        return [("H-infinity", blocks)]

    def residual(self, frozen, gamma, continuous) -> float:
        """Largest normalised eigenvalue of the primal bounded-real inequality."""
        A, Bw, Cz, Dzw, P, P_moved = frozen
        nw, nz = Bw.shape[1], Cz.shape[0]
        if continuous:
            M = np.block([
                [A.T @ P + P @ A + P_moved, P @ Bw, Cz.T],
                [Bw.T @ P, -np.eye(nw), Dzw.T],
                [Cz, Dzw, -gamma**2 * np.eye(nz)],
            ])  # fmt: skip
        else:
            AB = np.hstack([A, Bw])
            CD = np.hstack([Cz, Dzw])
            M = AB.T @ P_moved @ AB + CD.T @ CD
            M[: A.shape[0], : A.shape[0]] -= P
            M[A.shape[0] :, A.shape[0] :] -= gamma**2 * np.eye(nw)
        return normalized_max_eig(M[None])


@dataclass(frozen=True)
class H2(_Performance):
    """H2 specification from `w` to `z` (see the module docstring).

    Parameters
    ----------
    w : str, int or sequence, optional
        Exogenous inputs; default every physical input that is not a
        control input.
    z : str, int or sequence, optional
        Performance outputs; default all outputs.
    bound : float, optional
        Required bound, met strictly; None (only for the objective) asks for
        the smallest one.

    Notes
    -----
    In continuous time the feedthrough from `w` to `z` must be zero (the H2
    norm is infinite otherwise); a `ValueError` says so.
    """

    def check_data(self, channels, continuous) -> None:
        if continuous and any(np.any(d["Dzw"] != 0) for d in channels):
            raise ValueError(
                f"{self}: the feedthrough from w to z is not zero, so the "
                "continuous-time H2 norm is infinite"
            )

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient (see the module docstring)."""
        nz, rho = t.nz(self), t.rho(self, "z")
        Bw, CW, Y = t.data(self, "Bw"), t.CW(self), t.const(t.Y(self))
        if t.slack:
            CG = t.CG(self)
            if continuous:
                return [
                    ("H2 Lyapunov", [*_extended(t), [CG, t.eps() * CG, -rho * t.identity(nz)]]),
                    ("H2 trace", [[-Y], [Bw, -t.W()]]),
                ]  # fmt: skip
            Dzw = t.data(self, "Dzw")
            return [
                ("H2 Lyapunov", [[t.W() - 2 * t.G()], [t.AG(), -t.W_moved()],
                                 [CG, 0, -rho * t.identity(nz)]]),
                ("H2 trace", [[-Y], [Bw, -t.W_moved()], [Dzw, 0, -rho * t.identity(nz)]]),
            ]  # fmt: skip
        if continuous:
            return [
                (
                    "H2 Lyapunov",
                    [[2 * t.AW() - t.W_moved()], [CW, -rho * t.identity(nz)]],
                ),
                ("H2 trace", [[-Y], [Bw, -t.W()]]),
            ]
        Dzw = t.data(self, "Dzw")
        return [
            (
                "H2 Lyapunov",
                [[-t.W()], [t.AW(), -t.W_moved()], [CW, 0, -rho * t.identity(nz)]],
            ),
            ("H2 trace", [[-Y], [Bw, -t.W_moved()], [Dzw, 0, -rho * t.identity(nz)]]),
        ]

    def residual(self, frozen, gamma, continuous) -> float:
        """Largest normalised eigenvalue of the primal H2 inequalities.

        ``A'P + P A + dP/dt + C'C < 0`` (or ``A'P+ A - P + C'C < 0``) and the
        trace bound ``trace(Bw' P Bw) < gamma^2`` (``Bw' P+ Bw + Dzw' Dzw``
        in discrete time), as a relative excess.
        """
        A, Bw, Cz, Dzw, P, P_moved = frozen
        if continuous:
            M = A.T @ P + P @ A + P_moved + Cz.T @ Cz
            energy = np.trace(Bw.T @ P @ Bw)
        else:
            M = A.T @ P_moved @ A - P + Cz.T @ Cz
            energy = np.trace(Bw.T @ P_moved @ Bw + Dzw.T @ Dzw)
        excess = (energy - gamma**2) / gamma**2
        return max(normalized_max_eig(M[None]), excess)


@dataclass(frozen=True)
class GainBound:
    """Bound on the spectral norm of every gain, in the model's units.

    Parameters
    ----------
    bound : float
        Upper bound on ``||K||_2`` (every vertex gain when scheduled).

    Notes
    -----
    Imposed by convex-concave iterations from the first certified point (a
    sufficient condition); a design whose gain stays above the bound is
    not returned.
    """

    bound: float

    def __post_init__(self):
        object.__setattr__(
            self, "bound", real_number(self.bound, "bound", positive=True)
        )

    def __str__(self) -> str:
        return f"GainBound({self.bound:g})"


PERFORMANCE = (Hinf, H2)


class Stability:
    """Lyapunov stability alone: the objective ``None`` of `synthesize`.

    Continuous time ``sym(A W + B2 Z) - dW/dt < 0``; discrete time
    ``[[-W, *], [A W + B2 Z, -W+]] < 0``.
    """

    def lmis(self, t, continuous):
        """The LMI blocks at one coefficient."""
        if t.slack:
            if continuous:
                return [("Lyapunov", _extended(t))]
            return [("Lyapunov", [[t.W() - 2 * t.G()], [t.AG(), -t.W_moved()]])]
        if continuous:
            return [("Lyapunov", [[2 * t.AW() - t.W_moved()]])]
        return [("Lyapunov", [[-t.W()], [t.AW(), -t.W_moved()]])]

    def residual(self, frozen, gamma, continuous) -> float:
        """Largest normalised eigenvalue of the primal Lyapunov inequality."""
        A, _, _, _, P, P_moved = frozen
        if continuous:
            M = A.T @ P + P @ A + P_moved
        else:
            M = A.T @ P_moved @ A - P
        return normalized_max_eig(M[None])


def _extended(t):
    """The first two block rows of the continuous-time extended LMIs.

    ``[[sym(A_cl G) - dW/dt, *], [W - G + eps (A_cl G)', -eps sym(G)]]``:
    with the slack ``G`` and a fixed ``eps > 0`` this is the projection of
    the dual inequality (Pipeleers, Demeulenaere, Swevers and Vandenberghe
    2009; Apkarian, Tuan and Bernussou 2001), which lets a common gain
    ``K = -Z G^-1`` go with a parameter-dependent ``W``.
    """
    AG, eps = t.AG(), t.eps()
    return [[2 * AG - t.W_moved()], [t.W() - t.G() + eps * AG.T, -2 * eps * t.G()]]
