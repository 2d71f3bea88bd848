"""The plant partitioned once: which inputs and outputs are w, u, z (and y).

`Partition` is the plant as every stage of the engine reads it, after
RobustAndOptimalControl.jl's ``ExtendedStateSpace``: per vertex ``A``, the
control input matrix ``B2`` and, per performance channel (one per
`~ctrl_lpv.synthesis.spec.Spec` with a channel), ``Bw``, ``Cz``, ``Dzw``
and ``Dzu``. A measured output ``y`` (output feedback) is a further field;
today every state is measured.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import signal_indices
from ..systems import PolytopicStateSpace


def require_pss(sys):
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}; wrap an "
            "LTI system as PolytopicStateSpace([sys])"
        )


def channel_indices(sys, w, u, z):
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    iw = signal_indices(w, inputs, "w")
    iz = signal_indices(z, sys.output_labels, "z")
    return iw, iu, iz


def resolve_channels(sys, w, u, z, hinf):
    require_pss(sys)
    if u is None:
        raise ValueError("u: name the control input(s), e.g. u=['Tm']")
    inputs = sys.physical_inputs
    iu = signal_indices(u, inputs, "u")
    if not iu:
        raise ValueError("u: at least one control input is required")
    if not hinf:
        return [], iu, []
    iw = (
        [i for i in range(len(inputs)) if i not in iu]
        if w is None
        else signal_indices(w, inputs, "w")
    )
    iz = (
        list(range(sys.noutputs))
        if z is None
        else signal_indices(z, sys.output_labels, "z")
    )
    if not iw:
        raise ValueError("w: at least one exogenous input is required")
    if not iz:
        raise ValueError("z: at least one performance output is required")
    if set(iw) & set(iu):
        raise ValueError("w, u: an input cannot be both exogenous and control")
    return iw, iu, iz


def spectral_norm(M) -> float:
    return float(np.linalg.norm(M, 2)) if M.size else 0.0


def _frozen(array):
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True, eq=False)
class Channel:
    """One performance channel ``w -> z``: indices and vertex data.

    ``Bw``, ``Cz``, ``Dzw``, ``Dzu`` are stacks over the vertices (first
    axis), read-only.
    """

    w: tuple[int, ...]
    z: tuple[int, ...]
    Bw: np.ndarray
    Cz: np.ndarray
    Dzw: np.ndarray
    Dzu: np.ndarray

    @property
    def nw(self) -> int:
        return self.Bw.shape[2]

    @property
    def nz(self) -> int:
        return self.Cz.shape[1]


@dataclass(frozen=True, eq=False)
class Partition:
    """A polytopic plant split into ``A``, ``B2`` and performance channels.

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The plant.
    u : tuple of int
        Control inputs (physical input indices).
    A, B2 : ndarray
        Stacks over the vertices, read-only.
    channels : tuple of `Channel`
        One per performance spec, in the order of the specs.
    y : tuple of int or None
        Measured outputs; None: every state is measured.
    """

    system: PolytopicStateSpace
    u: tuple[int, ...]
    A: np.ndarray
    B2: np.ndarray
    channels: tuple[Channel, ...]
    y: tuple[int, ...] | None = None

    @classmethod
    def of(cls, sys, iu, channels=()) -> Partition:
        """Split `sys` at the control inputs `iu` and ``(iw, iz)`` pairs."""
        data = sys.vertex_data()
        iu = tuple(int(i) for i in iu)
        A = _frozen([d[0] for d in data])
        B2 = _frozen([d[1][:, list(iu)] for d in data])
        out = []
        for iw, iz in channels:
            iw, iz = list(iw), list(iz)
            out.append(Channel(
                tuple(iw), tuple(iz),
                _frozen([B[:, iw] for _, B, _, _ in data]),
                _frozen([C[iz] for _, _, C, _ in data]),
                _frozen([D[np.ix_(iz, iw)] for *_, D in data]),
                _frozen([D[np.ix_(iz, list(iu))] for *_, D in data]),
            ))  # fmt: skip
        return cls(sys, iu, A, B2, tuple(out))

    @property
    def n(self) -> int:
        return self.A.shape[1]

    @property
    def m(self) -> int:
        return self.B2.shape[2]

    @property
    def N(self) -> int:
        return self.A.shape[0]

    def six(self, i=None) -> list:
        """``(A, Bw, B2, Cz, Dzw, Dzu)`` per vertex of channel `i` (None:
        no channel, empty ``w`` and ``z``), for the prescalings."""
        n, m = self.n, self.m
        if i is None:
            return [(A, np.zeros((n, 0)), B, np.zeros((0, n)), np.zeros((0, 0)),
                     np.zeros((0, m))) for A, B in zip(self.A, self.B2)]  # fmt: skip
        c = self.channels[i]
        return list(zip(self.A, c.Bw, self.B2, c.Cz, c.Dzw, c.Dzu))
