"""Prescaling of an output-feedback problem: exact, and gamma-invariant.

The LMIs are posed on the plant in new coordinates ``x = T x~``, ``u = su
u~``, ``y = sy y~`` (``T = diag(t)``; every factor a power of two, so that
applying and undoing them is exact in floating point). A state similarity
and scalings of the control inputs and measurements change neither the
closed loops nor their norms: the controller ``K~`` of the scaled plant is
``K = diag(su) K~ diag(1 / sy)`` of the plant (same states), and the
closed-loop Lyapunov matrix is ``P = D P~ D``, ``D = diag(1 / t, I)``.
Scalings of ``w`` or ``z`` are not used: they change an H-infinity norm
unless they are one common factor.

The state scaling balances the two halves of the problem. In the change of
variables (`ctrl_lpv.output_feedback.lmis`) ``X`` is the state-feedback
half (about the inverse of the control Riccati solution) and ``Y`` the
estimation half (about the inverse of the filter Riccati solution); a
mode that is nearly unobservable from ``y`` but excited by ``w`` (a weight's
integrator) makes ``Y`` tiny along it while ``X`` stays moderate, and the
pair ``[[X, I], [I, Y]]`` then spans ten decades. ``x = T x~`` maps ``X``
to ``T^-1 X T^-1`` and ``Y`` to ``T Y T`` (``X Y`` is only similar): ``t_i
= (X_ii / Y_ii)^(1/4)`` equalises their diagonals, a diagonal analogue of
a balanced realization. ``X`` and ``Y`` are estimated before any LMI from
the H2 (LQR and Kalman) Riccati equations of the centre of the polytope,
regularised as in the state-feedback engine
(``ctrl_lpv.synthesis.scaling.lqr_riccati``). Then ``su`` normalises the
columns of ``[B2; D12]`` and ``sy`` the rows of ``[C2, D21]``.

The prescaled problem only shapes the solver's data: the certificate is
computed on the returned controller and the plant in its own coordinates
(`ctrl_lpv.output_feedback.checks`).
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from ..synthesis.scaling import lqr_riccati, pow2

__all__ = ["Prescaling", "prescalings"]


@dataclass(frozen=True)
class Prescaling:
    """``x = diag(t) x~``, ``u = diag(su) u~``, ``y = diag(sy) y~``."""

    name: str
    t: np.ndarray
    su: np.ndarray
    sy: np.ndarray

    @classmethod
    def of(cls, kind: str, plant) -> Prescaling:
        """``"Riccati"`` (the identity where it has no solution) or ``"none"``."""
        return (kind == "Riccati" and cls.riccati(plant)) or cls.identity(plant)

    @classmethod
    def identity(cls, plant) -> Prescaling:
        m, p = plant.B2.shape[1], plant.C2.shape[0]
        return cls("none", np.ones(plant.n), np.ones(m), np.ones(p))

    @classmethod
    def riccati(cls, plant) -> Prescaling | None:
        """The balancing of the Riccati estimates (module docstring), or
        None when either Riccati equation has no usable solution."""
        A, B1, C1, _ = plant.data(np.full(plant.nvertices, 1.0 / plant.nvertices))
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                Xc, _ = lqr_riccati(A, plant.B2, C1, plant.D12, plant.continuous)
                # The filter equation is the control equation of the dual.
                Yf, _ = lqr_riccati(A.T, plant.C2.T, B1.T, plant.D21.T,
                                    plant.continuous)  # fmt: skip
                x = np.diag(np.linalg.inv(Xc))
                y = np.diag(np.linalg.inv(Yf))
        except (ValueError, np.linalg.LinAlgError):
            return None
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            return None
        if not (np.all(x > 0) and np.all(y > 0)):
            return None
        t = np.array([pow2(r) for r in (x / y) ** 0.25])
        columns = np.linalg.norm(np.vstack([plant.B2 / t[:, None], plant.D12]), axis=0)
        rows = np.linalg.norm(np.hstack([plant.C2 * t, plant.D21]), axis=1)
        su = np.array([pow2(1.0 / c) if c > 0 else 1.0 for c in columns])
        sy = np.array([pow2(r) if r > 0 else 1.0 for r in rows])
        return cls("Riccati-balanced", t, su, sy)

    def apply(self, plant):
        """The plant in the new coordinates (names and system unchanged)."""
        t, su, sy = self.t, self.su, self.sy
        return dataclasses.replace(
            plant,
            A=plant.A * (t[None, None, :] / t[None, :, None]),
            B1=plant.B1 / t[None, :, None],
            C1=plant.C1 * t[None, None, :],
            B2=plant.B2 / t[:, None] * su[None, :],
            C2=plant.C2 * t[None, :] / sy[:, None],
            D12=plant.D12 * su[None, :],
            D21=plant.D21 / sy[:, None],
            channels=tuple(self.apply(c) for c in plant.channels),
        )

    def controller(self, K):
        """``(Ak, Bk, Ck, Dk)`` for the plant from the scaled plant's."""
        Ak, Bk, Ck, Dk = K
        su, sy = self.su, self.sy
        return (Ak, Bk / sy[None, :], Ck * su[:, None],
                Dk * su[:, None] / sy[None, :])  # fmt: skip

    def lyapunov(self, P):
        """The closed loop's ``P`` for the plant from the scaled plant's."""
        d = np.concatenate([1.0 / self.t, np.ones(P.shape[0] - self.t.size)])
        return P * d[:, None] * d[None, :]


def prescalings(plant) -> list[str]:
    """The kinds tried in turn: the Riccati balancing, then (where it
    differs) the plant's own data."""
    first = Prescaling.riccati(plant)
    if first is None or (np.all(first.t == 1) and np.all(first.su == 1)
                         and np.all(first.sy == 1)):  # fmt: skip
        return ["none"]
    return ["Riccati", "none"]
