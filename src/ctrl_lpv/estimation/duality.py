"""The dual (transposed) plant of an observer design, and its specs.

An observer ``x_hat' = A x_hat + B_u u + L (y - C_y x_hat - D_yu u)`` of
the plant ``x' = A x + B_u u + B_w w``, ``y = C_y x + D_yu u + D_yw w``
has the estimation error ``e = x - x_hat``:

    e' = (A - L C_y) e + (B_w - L D_yw) w,    z_e = C_z e,

(``e[k+1]`` in discrete time). Its transpose is the state-feedback loop
``u_d = -K x_d``, ``K = L'``, of the *dual plant*

    x_d' = A' x_d + C_z' w_d + C_y' u_d,    z_d = B_w' x_d + D_yw' u_d,

so the one state-feedback engine (`ctrl_lpv.synthesize`) designs ``L``
with the measured outputs as the dual's control inputs. H-infinity and H2
norms are invariant under transposition and ``eig(A') = eig(A)``, so the
objective, its bound and the pole regions carry over unchanged. The
engine's certificate is about the dual; `ctrl_lpv.estimation.checks`
re-checks the error system itself.

With one gain per vertex the dual's product ``C_y(p)' K(p)`` is affine in
the convex coordinates only when ``C_y`` does not depend on the parameter
(the dual of the state-feedback requirement on ``B_u``); the same holds
for ``D_yw`` (the error's input matrix) and ``D_yu`` (the estimator's
input matrix).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import signal_indices
from ..systems import PolytopicStateSpace

# Names of the dual plant's signals (internal: the dual never leaves the
# design; they cannot collide with the plant's names, which they replace).
_WD, _YD, _ZD = "obs_dual_w", "obs_dual_y", "obs_dual_z"


@dataclass(frozen=True)
class ObserverChannels:
    """Which outputs are measured, which inputs known or exogenous.

    Attributes
    ----------
    y, u, w, z : tuple of int
        Measured outputs, known inputs, exogenous inputs (physical input
        indices) and weighted-error outputs (output indices; empty: the
        error is every state).
    """

    y: tuple[int, ...]
    u: tuple[int, ...]
    w: tuple[int, ...]
    z: tuple[int, ...]

    @classmethod
    def resolve(cls, sys, y, u, w, z, performance: bool) -> ObserverChannels:
        """Resolve and check the signal arguments of `ctrl_lpv.observer`."""
        if y is None:
            raise ValueError("y: name the measured output(s), e.g. y=['theta_m']")
        iy = signal_indices(y, sys.output_labels, "y")
        if not iy:
            raise ValueError("y: at least one measured output is required")
        inputs = sys.physical_inputs
        iu = signal_indices(u, inputs, "u") if u is not None else []
        if w is None:
            iw = [i for i in range(len(inputs)) if i not in iu] if performance else []
        else:
            iw = signal_indices(w, inputs, "w")
        if set(iw) & set(iu):
            raise ValueError("w, u: an input cannot be both exogenous and known")
        if performance and not iw:
            raise ValueError("w: the objective needs at least one exogenous input")
        if not performance and (w is not None or z is not None):
            raise ValueError(
                "w, z: name them with an objective (Hinf() or H2()); without one "
                "the observer is designed for stability (and pole regions) alone"
            )
        iz = signal_indices(z, sys.output_labels, "z") if z is not None else []
        if z is not None and not iz:
            raise ValueError("z: at least one output, or None for every state")
        return cls(tuple(iy), tuple(iu), tuple(iw), tuple(iz))

    def error_names(self, sys) -> list[str]:
        """Names of the weighted error ``z_e``: ``<output>_err`` or
        ``<state>_err``."""
        if self.z:
            return [f"{sys.output_labels[i]}_err" for i in self.z]
        return [f"{s}_err" for s in sys.state_labels]


@dataclass(frozen=True)
class ErrorData:
    """The estimation-error system's data per vertex (stacks, first axis).

    ``A``, ``Cy``, ``Bw``, ``Dyw``, ``Cz`` (``Bw`` and ``Dyw`` with zero
    columns without exogenous inputs; ``Cz = I`` when the error is every
    state).
    """

    A: np.ndarray
    Cy: np.ndarray
    Bw: np.ndarray
    Dyw: np.ndarray
    Cz: np.ndarray

    @classmethod
    def of(cls, sys, ch: ObserverChannels) -> ErrorData:
        data = sys.vertex_data()
        n = sys.nstates
        iy, iw, iz = list(ch.y), list(ch.w), list(ch.z)
        return cls(
            np.array([d[0] for d in data]),
            np.array([d[2][iy] for d in data]),
            np.array([d[1][:, iw] for d in data]).reshape(len(data), n, len(iw)),
            np.array([d[3][np.ix_(iy, iw)] for d in data]).reshape(
                len(data), len(iy), len(iw)
            ),
            np.array([d[2][iz] if iz else np.eye(n) for d in data]),
        )

    def at(self, delta, L):
        """``(A - L C_y, B_w - L D_yw, C_z)`` at convex coordinates `delta`
        with the gain `L` (already interpolated)."""
        stacks = (self.A, self.Cy, self.Bw, self.Dyw, self.Cz)
        A, Cy, Bw, Dyw, Cz = (np.tensordot(delta, M, axes=1) for M in stacks)
        return A - L @ Cy, Bw - L @ Dyw, Cz


def require_parameter_independent(sys, ch: ObserverChannels) -> None:
    """For one gain per vertex: ``C_y``, ``D_yu`` and ``D_yw`` constant.

    Raises
    ------
    ValueError
        Naming `y` and the matrix that varies over the vertices.
    """
    data = sys.vertex_data()
    iy, iu, iw = list(ch.y), list(ch.u), list(ch.w)
    parts = {
        "C_y": [d[2][iy] for d in data],
        "D_yu": [d[3][np.ix_(iy, iu)] for d in data],
        "D_yw": [d[3][np.ix_(iy, iw)] for d in data],
    }
    for label, stack in parts.items():
        first = stack[0]
        for j, M in enumerate(stack[1:], start=1):
            scale = max(np.abs(first).max(initial=0.0), 1.0)
            if np.abs(M - first).max(initial=0.0) > 1e-12 * scale:
                measured = [sys.output_labels[i] for i in iy]
                raise ValueError(
                    f"y: {label} of the measured outputs {measured} "
                    f"depends on the parameter (vertex {j} differs from vertex 0), so "
                    "gains='scheduled' (one L per vertex, L(p) C_y(p) not affine in "
                    "the convex coordinates) has no exact dual; use gains='common'"
                )


def dual_plant(sys, ch: ObserverChannels) -> PolytopicStateSpace:
    """The dual plant (module docstring) over the same domain and timebase.

    Inputs ``[w_d (one per error output), u_d (one per measured output)]``,
    outputs ``z_d`` (one per exogenous input; the states when there is
    none, for a plant with outputs), states those of `sys`.
    """
    err = ErrorData.of(sys, ch)
    n, ny = sys.nstates, len(ch.y)
    nz = err.Cz.shape[1] if ch.w else 0
    vertices = []
    for j in range(sys.nvertices):
        A, Cy, Bw, Dyw, Cz = (M[j] for M in (err.A, err.Cy, err.Bw, err.Dyw, err.Cz))
        if ch.w:
            B = np.hstack([Cz.T, Cy.T])
            C = Bw.T
            D = np.hstack([np.zeros((len(ch.w), nz)), Dyw.T])
        else:
            B, C, D = Cy.T, np.eye(n), np.zeros((n, ny))
        vertices.append((A.T, B, C, D))
    nout = len(ch.w) if ch.w else n
    return PolytopicStateSpace(
        vertices,
        sys.domain,
        inputs=dual_names(_ZD, nz) + dual_names(_YD, ny),
        outputs=dual_names(_WD, nout),
        states=list(sys.state_labels),
        name=f"{sys.name}_dual",
        dt=sys.dt,
    )


def dual_names(prefix: str, k: int) -> list[str]:
    return [f"{prefix}{i}" for i in range(k)]


def dual_signals(ch: ObserverChannels, nz: int):
    """``(u, w, z)`` names of the dual: the measured outputs' duals are its
    control inputs, the error outputs' its exogenous inputs, the exogenous
    inputs' its performance outputs."""
    return dual_names(_YD, len(ch.y)), dual_names(_ZD, nz), dual_names(_WD, len(ch.w))


def dual_spec(spec, w, z):
    """The objective or bound `spec` on the dual channel ``w_d -> z_d``
    (same type and bound: the norms are transpose-invariant)."""
    return type(spec)(w=w, z=z, bound=spec.bound)
