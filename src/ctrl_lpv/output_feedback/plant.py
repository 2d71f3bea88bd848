"""The plant of an output-feedback design, partitioned once into w, u, z, y.

After RobustAndOptimalControl.jl's ``ExtendedStateSpace``: every stage reads
the vertex data of ``A, B1, C1, D11`` and the parameter-independent ``B2,
C2, D12, D21`` from one `OutputFeedbackPlant`, resolved and checked here.
A refusal names the assumption that failed (``hinfassumptions``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .._checks import signal_indices
from ..synthesis.channels import require_pss
from ..systems import PolytopicStateSpace

__all__ = ["OutputFeedbackPlant"]


@dataclass(frozen=True, eq=False)
class OutputFeedbackPlant:
    """A polytopic plant split into exogenous, control, performance, measured.

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The plant.
    w, u, z, y : tuple of int
        Input indices (``w``, ``u``) and output indices (``z``, ``y``).
    A, B1, C1, D11 : ndarray
        Stacks over the vertices (first axis).
    B2, C2, D12, D21 : ndarray
        The same at every vertex (checked).
    channels : tuple of `OutputFeedbackPlant`
        Other ``(w, z)`` channels of the same ``u, y`` (the bounds of a
        mixed design, `ctrl_lpv.output_feedback.mixed`), transformed with
        this plant by the prescalings.
    """

    system: PolytopicStateSpace
    w: tuple[int, ...]
    u: tuple[int, ...]
    z: tuple[int, ...]
    y: tuple[int, ...]
    A: np.ndarray
    B1: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    B2: np.ndarray
    C2: np.ndarray
    D12: np.ndarray
    D21: np.ndarray
    channels: tuple = ()

    @classmethod
    def of(cls, sys, w, u, z, y) -> OutputFeedbackPlant:
        """Resolve the signal names of `sys` and check the formulation's data.

        Raises
        ------
        ValueError
            A signal that is unknown, repeated or in two roles (named); a
            ``B2, C2, D12`` or ``D21`` that depends on the parameter (the
            vertex controllers of Apkarian, Gahinet and Becker (1995) are
            then not exact: filter the control inputs or the measurements,
            see :doc:`/output_feedback`); ``D22 != 0``.
        """
        require_pss(sys)
        inputs, outputs = sys.physical_inputs, sys.output_labels
        for name, value in (("u", u), ("y", y)):
            if value is None:
                raise ValueError(f"{name}: name the {_ROLE[name]}")
        iu = signal_indices(u, inputs, "u")
        iy = _outputs(y, sys, "y")
        iw = (
            [i for i in range(len(inputs)) if i not in iu]
            if w is None
            else signal_indices(w, inputs, "w")
        )
        iz = (
            [i for i in range(len(outputs)) if i not in iy]
            if z is None
            else _outputs(z, sys, "z")
        )
        for name, idx in (("w", iw), ("u", iu), ("z", iz), ("y", iy)):
            if not idx:
                raise ValueError(f"{name}: at least one {_ROLE[name]} is required")
        if set(iw) & set(iu):
            raise ValueError("w, u: an input cannot be both exogenous and control")
        if set(iz) & set(iy):
            raise ValueError("z, y: an output cannot be both performance and measured")
        data = sys.vertex_data()

        def stack(f):
            return np.array([f(*d) for d in data], dtype=float)

        B2 = stack(lambda A, B, C, D: B[:, iu])
        C2 = stack(lambda A, B, C, D: C[iy])
        D12 = stack(lambda A, B, C, D: D[np.ix_(iz, iu)])
        D21 = stack(lambda A, B, C, D: D[np.ix_(iy, iw)])
        D22 = stack(lambda A, B, C, D: D[np.ix_(iy, iu)])
        for name, M in (("B2", B2), ("C2", C2), ("D12", D12), ("D21", D21)):
            j = _first_change(M)
            if j is not None:
                raise ValueError(
                    f"sys: {name} (the {_BLOCK[name]}) differs between vertex 0 "
                    f"and {j}: the polytopic output-feedback formulation "
                    "(Apkarian, Gahinet and Becker 1995) needs B2, C2, D12 and "
                    "D21 independent of the parameter; move the dependence "
                    "into the plant with a low-pass filter on the control "
                    "inputs or the measurements"
                )
        if np.any(D22 != 0):
            raise ValueError(
                "sys: D22 (from u to y) must be zero; absorb it by measuring y - D22 u"
            )
        return cls(
            sys, tuple(iw), tuple(iu), tuple(iz), tuple(iy),
            stack(lambda A, B, C, D: A),
            stack(lambda A, B, C, D: B[:, iw]),
            stack(lambda A, B, C, D: C[iz]),
            stack(lambda A, B, C, D: D[np.ix_(iz, iw)]),
            B2[0], C2[0], D12[0], D21[0],
        )  # fmt: skip

    @property
    def nvertices(self) -> int:
        return self.A.shape[0]

    @property
    def n(self) -> int:
        return self.A.shape[1]

    @property
    def continuous(self) -> bool:
        return not self.system.isdtime(strict=True)

    def data(self, weights) -> tuple[np.ndarray, ...]:
        """``(A, B1, C1, D11)`` at the convex coordinates `weights`."""
        w = np.asarray(weights, dtype=float)
        return tuple(np.tensordot(w, M, axes=1) for M in
                     (self.A, self.B1, self.C1, self.D11))  # fmt: skip

    def scaled(self, s: float) -> OutputFeedbackPlant:
        """The plant with its performance outputs z scaled by `s`."""
        return dataclasses.replace(self, C1=s * self.C1, D11=s * self.D11,
                                   D12=s * self.D12)  # fmt: skip

    def names(self, role: str) -> list[str]:
        """Signal names of `role` (``"w"``, ``"u"``, ``"z"`` or ``"y"``)."""
        labels = (
            self.system.physical_inputs if role in "wu" else (self.system.output_labels)
        )
        return [labels[i] for i in getattr(self, role)]


_ROLE = {
    "w": "exogenous input",
    "u": "control input",
    "z": "performance output",
    "y": "measured output",
}
_BLOCK = {
    "B2": "input matrix of u",
    "C2": "output matrix of y",
    "D12": "feedthrough from u to z",
    "D21": "feedthrough from w to y",
}


def _outputs(value, sys, name):
    """Output indices; an input's name in `value` is a clear error."""
    names = [value] if isinstance(value, str) else value
    if isinstance(names, (list, tuple)):
        for item in names:
            if (
                isinstance(item, str)
                and item in sys.physical_inputs
                and (item not in sys.output_labels)
            ):
                raise ValueError(
                    f"{name}: {item!r} is an input of sys, not an output "
                    f"(outputs: {list(sys.output_labels)})"
                )
    return signal_indices(value, sys.output_labels, name)


def _first_change(M):
    for j in range(1, M.shape[0]):
        if not np.array_equal(M[j], M[0]):
            return j
    return None
