"""Exact power-of-two prescaling of the vertex data, and the prescalings tried."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import matrix_balance

from .channels import spectral_norm


def pow2(x: float) -> float:
    """Nearest power of two, so that scaling is exact in floating point."""
    return float(2.0 ** np.round(np.log2(x))) if x > 0 else 1.0


def channel_scales(vertices, T, Su, a) -> tuple[float, float]:
    """Powers of two ``(sw, sz)`` that normalise a channel's ``B1`` and ``C, D``."""
    nb1 = max(spectral_norm(v[1] / T[:, None]) for v in vertices)
    sw = pow2(a / nb1) if nb1 > 0 else 1.0
    nz = max(
        spectral_norm(np.hstack([v[3] * T, v[4] * sw, v[5] * Su])) for v in vertices
    )
    sz = pow2(nz) if nz > 0 else 1.0
    return sw, sz


@dataclass(frozen=True)
class Scaling:
    """Exact (power-of-two) prescaling; see the module docstring."""

    T: np.ndarray  # state scaling, x = T x~
    Su: np.ndarray  # input scaling, u = Su u~
    sw: float  # w = sw w~
    sz: float  # z = sz z~
    a: float  # time scaling, t~ = a t

    @classmethod
    def of(cls, vertices, balance: bool = True, time_scaling: bool = True) -> Scaling:
        """The prescaling of vertex data ``(A, B1, B2, C, D1, D2)``.

        `time_scaling` False (discrete time) keeps ``a = 1``.
        """
        n = vertices[0][0].shape[0]
        if balance:
            absA = sum(np.abs(v[0]) for v in vertices)
            _, (t, _) = matrix_balance(absA, permute=False, separate=True)
            T = np.array([pow2(x) for x in t])
        else:
            T = np.ones(n)
        a = (
            pow2(max(np.linalg.norm(v[0] * (T / T[:, None]), 2) for v in vertices))
            if time_scaling
            else 1.0
        )
        Su = np.array(
            [
                pow2(a / c) if c > 0 else 1.0
                for c in np.max(
                    [np.linalg.norm(v[2] / T[:, None], axis=0) for v in vertices],
                    axis=0,
                )
            ]
        )
        sw, sz = channel_scales(vertices, T, Su, a)
        return cls(T, Su, sw, sz, a)

    def apply(self, v):
        A, B1, B2, C, D1, D2 = v
        Ti = 1.0 / self.T
        return (
            Ti[:, None] * A * self.T / self.a,
            Ti[:, None] * B1 * self.sw / self.a,
            Ti[:, None] * B2 * self.Su / self.a,
            C * self.T / self.sz,
            D1 * self.sw / self.sz,
            D2 * self.Su / self.sz,
        )

    @property
    def w_factor(self) -> float:
        """W = w_factor * T W~ T and Z = w_factor * Su Z~ T."""
        return self.a / self.sw**2

    def unscale_W(self, Wt):
        return self.w_factor * (self.T[:, None] * Wt * self.T)

    def unscale_P(self, Pt):
        """``P = W^-1`` from ``P~ = W~^-1``, exactly symmetric.

        ``x' P x`` sees only the symmetric part of ``P``, and a float inverse
        is not exactly symmetric: a check of ``P A + A' P'`` with it is not
        the Lyapunov inequality of any storage function (fuzz case 2026:14,
        settled in exact arithmetic by ``benchmarks/study_disputed_brl.py``).
        """
        return 0.5 * (Pt + Pt.T) / (self.w_factor * self.T[:, None] * self.T)

    def unscale_K(self, Kt):
        # u = -K x with u = Su u~, x = T x~ and u~ = -K~ x~.
        return self.Su[:, None] * Kt / self.T

    def unscale_g(self, g):
        return g * (self.sz / self.sw) ** 2


def prescalings(original):
    """Prescalings tried in turn: balanced, time scaling alone, none.

    The last keeps the model's units: a time scaling by the fastest mode
    leaves a mode 1e15 times slower no margin the solvers can see.
    """
    balanced = Scaling.of(original)
    yield "balanced", balanced
    plain = Scaling.of(original, balance=False)
    if not np.array_equal(plain.T, balanced.T):
        yield "unbalanced", plain
    A, _, B2, _, _, _ = original[0]
    none = Scaling(np.ones(A.shape[0]), np.ones(B2.shape[1]), 1.0, 1.0, 1.0)
    if not (
        np.array_equal(none.T, plain.T)
        and np.array_equal(none.Su, plain.Su)
        and (none.sw, none.sz, none.a) == (plain.sw, plain.sz, plain.a)
    ):
        yield "none", none
