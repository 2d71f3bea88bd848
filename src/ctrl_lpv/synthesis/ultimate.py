"""The ultimate bound as a spec: a `Peak` bound per output, at its level.

`OutputPeaks` is the analysis spec of `ctrl_lpv.ultimate_bound`: the
invariance inequality of `~ctrl_lpv.synthesis.specs.Peak` (a decay
``lambda``, multipliers ``mu_i`` of the peak bounds ``|w_i| <= w_max_i``),
with the size of the ellipsoid measured along each output row separately
instead of by the Euclidean norm of ``z``, and the ellipsoid taken at its
own level ``rho = sum(mu) / lambda`` (``<= 1``):
``d(x'Px)/dt <= -lambda (x'Px - rho)`` for every admissible input, so
``{x : x'Px <= rho}`` is invariant and attractive and on it ``|z_k| <=
sqrt(rho z_k W z_k')`` (``W = P^-1``, ``z_k`` the row of output ``k``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import positive_levels
from .specs import Peak


@dataclass(frozen=True)
class OutputPeaks(Peak):
    """Ultimate bound of every output of `z` under peak-bounded `w`.

    As `Peak` (same invariance LMIs, same decay search by the engine),
    with ``[[g, *], [(z_k W)', W]] >= 0`` for each row ``z_k`` of the
    closed loop's output instead of one block for all: the certified bound
    is ``max_k sqrt(rho z_k W z_k')``, and each output's own bound is
    ``sqrt(rho z_k W z_k')`` with the level ``rho = sum(mu) / lambda``
    (`model_values` reports ``decay``, ``mu`` and ``level``).

    Parameters
    ----------
    w, z, bound, w_max
        As `Peak`.
    lambdas : sequence of float, optional
        The decays searched, in the model's units (1/s in continuous time,
        the contraction per sample in discrete time); default `Peak`'s grid.
    """

    lambdas: tuple | None = None

    def __post_init__(self):
        super().__post_init__()
        if self.lambdas is not None:
            lambdas = positive_levels(self.lambdas, "lambdas")
            object.__setattr__(self, "lambdas", lambdas)

    def decays(self, continuous):
        """`lambdas` (model units), or `Peak`'s grid."""
        return self.lambdas if self.lambdas is not None else super().decays(continuous)

    def decay_grid(self, continuous, frame):
        """`lambdas` in the frame's time units (``lambda~ = lambda / a``)."""
        if self.lambdas is None:
            return super().decays(continuous)
        return tuple(lam / frame.a for lam in self.lambdas)

    def coefficient_lmis(self, t, continuous):
        """``[[g, *], [(z_k W)', W]] >= 0`` for every row ``k`` of ``z``."""
        g = t.const(t.g()[0, 0] * np.eye(1))
        CW, W = t.CW(), t.W()
        return [(f"peak of z[{k}]", [[-g], [CW[k : k + 1].T, -W]])
                for k in range(t.nz())]  # fmt: skip

    def residual(self, loop, continuous) -> float:
        """Largest excess of the invariance inequality and of ``rho z_k W
        z_k' <= bound^2`` (relative) at a frozen loop."""
        mu = loop.mu_w / self.weights(loop.Bd.shape[1])
        level = float(mu.sum() / loop.lam)
        rows = np.einsum("ij,jk,ik->i", loop.Cz, loop.W, loop.Cz)
        peak = level * float(rows.max()) / loop.bound**2 - 1
        return max(self.invariance(loop, continuous), peak)

    def model_values(self, frame, read) -> dict:
        """``decay`` (``lambda``), ``mu`` (the multipliers of ``w_i /
        w_max_i``) and ``level`` (``sum(mu) / lambda``), model units."""
        decay = float(read("lam")) * frame.a
        mu = frame.a * np.ravel(read("mu")).astype(float)
        return {"decay": decay, "mu": mu, "level": float(mu.sum() / decay)}
