"""Scale-invariant stabilizability test of the vertices (PBH).

The PBH test asks whether ``[A - lambda I, B]`` loses rank at an eigenvalue
``lambda`` with ``Re(lambda) >= 0``. Its smallest singular value depends on
the units of the states and inputs, so an absolute or ``||[A, B]||``-relative
tolerance refuses stabilizable plants whose states differ in scale by many
orders of magnitude. Here it is computed in balanced coordinates:

1. the states are balanced (``T^-1 A T`` by `scipy.linalg.matrix_balance`,
   powers of two, which removes a diagonal scaling of the states);
2. every input column is scaled to the norm of the balanced ``A`` (which
   removes input units, and relates input to state dynamics);
3. the residual ``sigma_min([A - lambda I, B]) / ||[A - lambda I, B]||``
   is scale-free.

A mode is *uncontrollable* only when that residual is at the rounding level
(`UNCONTROLLABLE_RTOL`); between it and `SUSPECT_RTOL` the test is
inconclusive, and the LMIs decide (the mode is reported, not refused).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import matrix_balance

from ._checks import signal_indices
from .exceptions import InfeasibleError
from .systems import PolytopicStateSpace

__all__ = ["ModeResidual", "check_detectability", "check_stabilizability"]

_EPS = np.finfo(float).eps
# Relative PBH residual below which a mode is uncontrollable: rounding of
# the balanced data, per state, with room for the eigenvalue's own error
# (an exactly uncontrollable mode behind a random similarity of condition
# 1e2 measured 5e-13 for n = 5).
UNCONTROLLABLE_RTOL = 1e4 * _EPS
# Below this the test is inconclusive: the mode is reported, the LMIs decide.
SUSPECT_RTOL = 1e-8


@dataclass(frozen=True)
class ModeResidual:
    """A weakly controllable (or uncontrollable) mode of a vertex.

    Attributes
    ----------
    vertex : int
        Vertex index.
    eigenvalue : complex
        Eigenvalue of ``A_j``.
    residual : float
        ``sigma_min([A - lambda I, B]) / ||[A - lambda I, B]||`` in balanced
        coordinates (scale-free; 0 for an exactly uncontrollable mode).
    mode : str
        The combination of the states (left singular vector in the original
        coordinates) that does not respond to the input.
    uncontrollable : bool
        Whether the residual is at the rounding level.
    """

    vertex: int
    eigenvalue: complex
    residual: float
    mode: str
    uncontrollable: bool

    def __str__(self) -> str:
        return (
            f"vertex {self.vertex}: mode {self.mode} at eigenvalue "
            f"{_fmt_complex(self.eigenvalue)}, PBH residual {self.residual:.2e} "
            "(balanced coordinates, relative)"
        )


def check_stabilizability(sys: PolytopicStateSpace, u=None) -> tuple[ModeResidual, ...]:
    """Raise `InfeasibleError` if a vertex is not stabilizable from `u`.

    For every eigenvalue ``lambda`` of ``A_j`` with ``Re(lambda) >= 0`` (to
    rounding), the PBH matrix ``[A_j - lambda I, B_j]`` is tested in
    balanced coordinates with a relative, scale-free residual (module
    documentation). Only a residual at the rounding level is a refusal.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The system.
    u : str, int or list, optional
        Control inputs; default all physical inputs.

    Returns
    -------
    tuple of `ModeResidual`
        The weakly controllable unstable or marginal modes for which the
        test is inconclusive (empty for a clearly stabilizable polytope).

    Raises
    ------
    InfeasibleError
        Naming the vertex, its parameter value, the uncontrollable mode (the
        eigenvalue and the left singular vector written on the states) and
        its residual.

    Examples
    --------
    >>> import ctrl_lpv as lpv
    >>> sys = lpv.pss([([[1.0, 0.0], [1e8, -1.0]], [[1e-4], [0.0]], [[1.0, 0.0]], 0)])
    >>> check_stabilizability(sys)
    ()
    """
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}"
        )
    iu = signal_indices(
        range(len(sys.physical_inputs)) if u is None else u, sys.physical_inputs, "u"
    )
    suspects = []
    for j, (A, B, _, _) in enumerate(sys.vertex_data()):
        for found in _vertex_modes(A, B[:, iu], sys.state_labels, j):
            if found.uncontrollable:
                point = dict(zip(sys.domain.names, sys.domain.points[j].tolist()))
                raise InfeasibleError(
                    f"vertex {j} (p = {point}) is not stabilizable: the mode with "
                    f"eigenvalue {_fmt_complex(found.eigenvalue)} is uncontrollable "
                    f"from u = {[sys.physical_inputs[i] for i in iu]} (PBH "
                    f"residual {found.residual:.1e} in balanced coordinates, "
                    f"relative; rounding level {UNCONTROLLABLE_RTOL:.1e}); the "
                    f"combination {found.mode} of the states does not respond "
                    "to the input. No state feedback moves this eigenvalue into "
                    "the open left half-plane, so the strict LMIs are "
                    "infeasible; shrink the parameter domain away from this "
                    "vertex."
                )
            suspects.append(found)
    return tuple(suspects)


def check_detectability(sys: PolytopicStateSpace, y) -> tuple[ModeResidual, ...]:
    """Raise `InfeasibleError` if a vertex ``(C_y, A_j)`` is not detectable.

    The dual of `check_stabilizability`: the PBH test of ``[A_j' - lambda I,
    C_y']`` in balanced coordinates, for every eigenvalue with ``Re(lambda)
    >= 0`` (continuous time) or ``|lambda| >= 1`` (discrete time), to
    rounding. No output injection ``A - L C_y`` moves an unobservable
    unstable or marginal eigenvalue, so no observer exists.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The system.
    y : str, int or list
        Measured outputs.

    Returns
    -------
    tuple of `ModeResidual`
        The weakly observable unstable or marginal modes for which the test
        is inconclusive.

    Raises
    ------
    InfeasibleError
        Naming the vertex, its parameter value, the unobservable eigenvalue
        and the mode (the eigenvector written on the states).
    """
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}"
        )
    iy = signal_indices(y, sys.output_labels, "y")
    discrete = sys.isdtime(strict=True)
    suspects = []
    for j, (A, _, C, _) in enumerate(sys.vertex_data()):
        for found in _vertex_modes(A.T, C[iy].T, sys.state_labels, j, discrete):
            if found.uncontrollable:
                point = dict(zip(sys.domain.names, sys.domain.points[j].tolist()))
                region = "|lambda| >= 1" if discrete else "Re(lambda) >= 0"
                raise InfeasibleError(
                    f"vertex {j} (p = {point}) is not detectable from y = "
                    f"{[sys.output_labels[i] for i in iy]}: the mode with "
                    f"eigenvalue {_fmt_complex(found.eigenvalue)} ({region}) is "
                    f"unobservable (PBH residual {found.residual:.1e} in balanced "
                    f"coordinates, relative; rounding level "
                    f"{UNCONTROLLABLE_RTOL:.1e}); the combination {found.mode} of "
                    "the states does not reach the measurements. No output "
                    "injection moves this eigenvalue, so no observer converges; "
                    "measure another output or shrink the parameter domain."
                )
            suspects.append(found)
    return tuple(suspects)


def _vertex_modes(A, B, labels, vertex, discrete=False):
    """Unstable or marginal modes of one vertex with a small PBH residual.

    Continuous time: ``Re(lambda) >= 0``; discrete time (`discrete`):
    ``|lambda| >= 1`` (both to rounding).
    """
    n = A.shape[0]
    _, (t, _) = matrix_balance(A, permute=False, separate=True)
    At = A * (t[None, :] / t[:, None])
    Bt = B / t[:, None]
    scale = max(np.linalg.norm(At, 2), np.finfo(float).tiny)
    norms = np.linalg.norm(Bt, axis=0)
    Bt = Bt[:, norms > 0] * (scale / norms[norms > 0])
    marginal = 1e3 * n * _EPS * scale
    for lam in np.linalg.eigvals(At):
        if discrete and abs(lam) < 1.0 - 1e3 * n * _EPS * max(scale, 1.0):
            continue
        if not discrete and lam.real < -marginal:
            continue
        M = np.hstack([At - lam * np.eye(n), Bt])
        U, s, _ = np.linalg.svd(M)
        residual = float(s[-1] / max(s[0], np.finfo(float).tiny)) if n else 0.0
        if residual > SUSPECT_RTOL:
            continue
        # The left singular vector in the original coordinates: w' x with
        # w = T^-1 u (x = T x~).
        mode = _describe(np.real_if_close(U[:, -1] / t), labels)
        yield ModeResidual(
            vertex, complex(lam), residual, mode, residual <= UNCONTROLLABLE_RTOL
        )


def _describe(vector, labels) -> str:
    vector = vector / vector[np.argmax(np.abs(vector))]
    terms = [
        f"{_fmt_complex(c)}*{name}" for c, name in zip(vector, labels) if abs(c) > 1e-9
    ]
    return " + ".join(terms)


def _fmt_complex(value) -> str:
    value = complex(value)
    if abs(value.imag) < 1e-12 * max(1.0, abs(value)):
        return f"{value.real:.6g}"
    return f"{value.real:.6g}{value.imag:+.6g}j"
