"""Slow modes that no output-feedback controller moves.

A mode of the plant that is unobservable from the measurements ``y`` or
uncontrollable from the control inputs ``u`` is an eigenvalue of every
closed loop (the controller neither sees it nor acts on it). When it is
stable but slow compared with the rest of the data (typically a weight's
pole placed near the axis, or a slow weight beside fast ones), every
quadratic certificate of the closed loop has a slack along it of the order
of its rate: relative to the data's norm that can be at the level of
float64 rounding or of the LMI margin. A refusal names such modes, so that
the remedy (move the slow pole into the controller, e.g. as an integrator,
or state it with a smaller margin) is clear.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import matrix_balance

__all__ = ["FixedMode", "decay_limit", "describe", "fixed_modes", "slow_fixed_modes"]

#: A mode is slow when ``|Re lambda|`` is below this fraction of ``||A||``.
SLOW = 1e-4
#: PBH residual (relative) below which the mode is unobservable/uncontrollable.
PBH_RTOL = 1e-9


@dataclass(frozen=True)
class FixedMode:
    """One slow fixed mode (an eigenvalue, all its fixed directions) at one
    vertex."""

    vertex: int
    eigenvalue: complex
    why: str  # "unobservable from y" or "uncontrollable from u"
    states: tuple  # the states that carry the mode
    ratio: float  # |Re lambda| / ||A||

    @property
    def text(self) -> str:
        """The mode without its vertex."""
        lam = self.eigenvalue
        val = f"{lam.real:.3g}" if abs(lam.imag) < 1e-12 else f"{lam:.3g}"
        return (
            f"the mode at {val} (states {', '.join(self.states)}) is {self.why} "
            f"and stays in every closed loop, at {self.ratio:.1e} of the data's "
            "rate"
        )

    def __str__(self) -> str:
        return f"{self.text} (vertex {self.vertex})"


def describe(modes) -> str:
    """One sentence per distinct mode, naming its vertices."""
    texts = {}
    for m in modes:
        texts.setdefault(m.text, []).append(m.vertex)
    return "; ".join(
        f"{text} (vertex {', '.join(map(str, v))})" for text, v in texts.items()
    )


def fixed_modes(plant):
    """Every `FixedMode` of each vertex of an `OutputFeedbackPlant`: the
    eigenvalues of ``A_j`` that fail the PBH test of ``(C2, A_j)`` or
    ``(A_j, B2)`` (in balanced coordinates, relative to ``||A_j||``)."""
    labels = list(plant.system.state_labels)
    found = []
    for j, A in enumerate(plant.A):
        _, (t, _) = matrix_balance(A, permute=False, separate=True)
        At = A * (t[None, :] / t[:, None])
        scale = max(np.linalg.norm(At, 2), np.finfo(float).tiny)
        C2 = plant.C2 * t[None, :]
        B2 = plant.B2 / t[:, None]
        seen = []
        for lam in np.linalg.eigvals(At):
            if any(abs(lam - mu) <= 1e-9 * max(abs(mu), scale * 1e-12) for mu in seen):
                continue
            seen.append(lam)
            shifted = At - lam * np.eye(A.shape[0])
            for why, M, right in (
                ("unobservable from y", np.vstack([shifted, _rows(C2, scale)]), True),
                ("uncontrollable from u", np.hstack([shifted, _rows(B2.T, scale).T]),
                 False),
            ):  # fmt: skip
                U, s, Vh = np.linalg.svd(M)
                k = int(np.sum(s <= PBH_RTOL * s[0]))
                if k == 0:
                    continue
                # Its directions in the plant's coordinates (x = T x~).
                basis = (Vh[-k:].conj().T * t[:, None] if right
                         else U[:, -k:] / t[:, None])  # fmt: skip
                weight = np.linalg.norm(basis, axis=1)
                names = tuple(n for n, w in zip(labels, weight)
                              if w > 1e-6 * weight.max())  # fmt: skip
                found.append(
                    FixedMode(j, complex(lam), why, names, abs(lam.real) / scale)
                )
    return found


def slow_fixed_modes(plant, slow=SLOW):
    """The stable `fixed_modes` slower than `slow` of the data's rate.

    Continuous time only (the rates compared are ``Re lambda``); an empty
    list in discrete time.
    """
    if not plant.continuous:
        return []
    return [
        m for m in fixed_modes(plant) if m.eigenvalue.real < 0 and m.ratio <= slow
    ]  # fmt: skip


def decay_limit(plant) -> float:
    """The decay margin no closed loop reaches: its fixed modes stay in it.

    The output-feedback LMIs with a decay margin ``d`` (`~.lmis`) ask every
    closed-loop eigenvalue for ``Re lambda < -d / 2`` (continuous time) or
    ``|lambda|^2 < 1 - d`` (discrete time); a fixed mode caps ``d`` below
    ``-2 Re lambda`` or ``1 - |lambda|^2`` (infinity without fixed modes).
    """
    modes = fixed_modes(plant)
    if plant.continuous:
        return min((-2.0 * m.eigenvalue.real for m in modes), default=np.inf)
    return min((1.0 - abs(m.eigenvalue) ** 2 for m in modes), default=np.inf)


def _rows(M, scale):
    """Rows of `M` normalised to `scale` (zero rows dropped)."""
    norms = np.linalg.norm(M, axis=1)
    return M[norms > 0] * (scale / norms[norms > 0])[:, None]
