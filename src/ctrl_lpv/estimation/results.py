"""`ObserverDesign`: a certified observer and its estimator system."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from control import StateSpace

from .._checks import signal_name
from ..certificate import Certificate
from ..regions import LMIRegion
from ..systems import PolytopicStateSpace
from .checks import interpolated_gain
from .duality import ErrorData, ObserverChannels


@dataclass(frozen=True)
class ObserverDesign:
    """A certified LPV observer (output-injection gains) for a polytopic plant.

    The estimator (`estimator`) is, in continuous time,

    .. math::

        \\dot{\\hat x} = A(p) \\hat x + B_u(p) u
        + L(p) (y - C_y(p) \\hat x - D_{yu}(p) u),

    and in discrete time the *predictor* form ``x_hat[k+1] = A x_hat[k] +
    B_u u[k] + L (y[k] - C_y x_hat[k] - D_yu u[k])`` (``x_hat[k]`` uses the
    measurements up to ``k - 1``). The estimation error ``e = x - x_hat``
    obeys ``e' = (A - L C_y) e + (B_w - L D_yw) w`` whatever the known
    inputs; its weighted value ``z_e = C_z e`` is what the bound is about.

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The plant.
    L : tuple of ndarray
        ``n x ny`` gains: one common gain, or one per vertex (``L(p) =
        sum_j delta_j(p) L_j``).
    gamma : float or None
        Certified bound of the objective (H-infinity: L2 gain from `w` to
        the weighted error; H2); None for stability alone.
    gamma_opt : float or None
        An estimate of the optimum from above (not certified), as in
        `ctrl_lpv.StateFeedbackDesign`.
    bounds : dict
        ``{objective: gamma}``.
    certificate : `ctrl_lpv.Certificate`
        The float64 checks on the error system
        (`ctrl_lpv.estimation.checks`).
    P : ndarray or tuple of ndarray
        The Lyapunov matrix of the certificate, ``V(e) = e' P e`` (the
        inverse of the dual design's ``P``); for ``lyapunov="affine"`` the
        vertex matrices of ``P(p) = sum_j delta_j(p) P_j`` (see
        `lyapunov_matrix`).
    y, u, w, z : tuple of str
        Measured outputs, known inputs, exogenous inputs, and the outputs
        whose estimation error is weighted (empty: every state).
    dual : `ctrl_lpv.StateFeedbackDesign`
        The design of the dual plant (``K_j = L_j'``), with its own
        certificate and the solver attempts.
    regions : tuple of `ctrl_lpv.LMIRegion`
        Pole regions of the error dynamics.
    lyapunov : {"constant", "affine"}
        The Lyapunov function of the certificate.
    rate_bounds : dict or None
        For ``lyapunov="affine"``, the rate bounds ``{name: nu}`` the
        certificate holds for (a parameter not listed may vary arbitrarily
        fast).
    channels : `ctrl_lpv.estimation.duality.ObserverChannels`
        The signal indices.
    """

    system: PolytopicStateSpace
    L: tuple
    gamma: float | None
    gamma_opt: float | None
    bounds: dict
    certificate: Certificate
    P: np.ndarray
    y: tuple[str, ...]
    u: tuple[str, ...]
    w: tuple[str, ...]
    z: tuple[str, ...]
    dual: object = None
    regions: tuple[LMIRegion, ...] = ()
    lyapunov: str = "constant"
    rate_bounds: dict | None = None
    channels: ObserverChannels | None = field(default=None, repr=False)

    @property
    def scheduled(self) -> bool:
        """Whether the design has one gain per vertex."""
        return len(self.L) > 1

    def gain(self, p=None) -> np.ndarray:
        """``L(p)``: the ``n x ny`` output-injection gain at parameter `p`
        (ignored for a common gain)."""
        if not self.scheduled:
            return self.L[0].copy()
        if p is None:
            raise ValueError("p: a scheduled observer needs the parameter value")
        return interpolated_gain(self.L, self.system.weights(p))

    def lyapunov_matrix(self, p=None) -> np.ndarray:
        """``P(p)`` of ``V(e) = e' P(p) e`` (`p` ignored for a constant one).

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value, needed for ``lyapunov="affine"``.

        Returns
        -------
        ndarray
            ``n x n``, positive definite.
        """
        if self.lyapunov == "constant":
            return self.P.copy()
        if p is None:
            raise ValueError("p: an affine Lyapunov function needs the parameter value")
        delta = self.system.weights(p)
        return sum(d * Pj for d, Pj in zip(delta, self.P))

    def closed_loop(self, p=None) -> StateSpace:
        """The frozen estimation-error system at parameter value `p`.

        `p` may be omitted for a plant with one vertex (an LTI plant).

        ``e' = (A - L C_y) e + (B_w - L D_yw) w``, ``z_e = C_z e``; inputs
        named after `w` (after the measured outputs, as additive sensor
        errors, without `w`), outputs ``<output>_err`` (``<state>_err``),
        states the plant's.
        """
        err = ErrorData.of(self.system, self.channels)
        if p is None and self.system.nvertices == 1:
            delta = np.ones(1)
            p = self.system.domain.points[0]
        elif p is None:
            raise ValueError("p: the plant has several vertices; give the parameter")
        else:
            delta = self.system.weights(p)
        A, B, Cz = err.at(delta, self.gain(p))
        names = self.channels.error_names(self.system)
        inputs = list(self.w)
        if not inputs:
            B, inputs = -self.gain(p), [f"{s}_noise" for s in self.y]
        return StateSpace(
            A, B, Cz, np.zeros((Cz.shape[0], B.shape[1])),
            inputs=inputs, outputs=names, states=list(self.system.state_labels),
            name=f"{self.system.name}_error", dt=self.system.dt,
            remove_useless_states=False,
        )  # fmt: skip

    def estimator(self, name: str = "estimator") -> PolytopicStateSpace:
        """The estimator as a python-control I/O system.

        As with `control.create_estimator_iosystem`: inputs the measured
        outputs (named as the plant's `y`) and the known inputs (`u`), then,
        for a plant with more than one vertex, one scheduling input per
        parameter named after it (the plant's ``scheduling="inputs"``
        convention); outputs and states ``<state>_hat``. So
        ``control.interconnect([plant, estimator], ...)`` connects it by
        name.

        Parameters
        ----------
        name : str, optional
            System name (default ``"estimator"``).

        Returns
        -------
        `PolytopicStateSpace`
            Vertex ``j``: ``(A_j - L_j C_y,j, [L_j, B_u,j - L_j D_yu,j], I,
            0)``; exact between the vertices (a common ``L``, or ``C_y`` and
            ``D_yu`` constant, which `ctrl_lpv.observer` requires for vertex
            gains). Same timebase as the plant.

        Raises
        ------
        TypeError
            If `name` is not a non-empty string.
        """
        signal_name(name, "name")
        sys, ch = self.system, self.channels
        n = sys.nstates
        iy, iu = list(ch.y), list(ch.u)
        vertices = []
        for j, (A, B, C, D) in enumerate(sys.vertex_data()):
            Lj = self.L[j] if self.scheduled else self.L[0]
            Cy, Bu, Dyu = C[iy], B[:, iu], D[np.ix_(iy, iu)]
            vertices.append((
                A - Lj @ Cy, np.hstack([Lj, Bu - Lj @ Dyu]),
                np.eye(n), np.zeros((n, len(iy) + len(iu))),
            ))  # fmt: skip
        hats = [f"{s}_hat" for s in sys.state_labels]
        return PolytopicStateSpace(
            vertices, sys.domain,
            scheduling="inputs" if sys.nvertices > 1 else None,
            inputs=list(self.y) + list(self.u), outputs=hats, states=hats,
            name=name, dt=sys.dt,
        )  # fmt: skip

    def __str__(self) -> str:
        lines = [
            f"ObserverDesign ({'vertex gains' if self.scheduled else 'common gain'}"
            f", {'discrete' if self.system.isdtime(strict=True) else 'continuous'}"
            " time)",
            f"  system: {self.system.name}, {self.system.nvertices} vertices, "
            f"{self.system.nstates} states",
            f"  y = {list(self.y)}, u = {list(self.u)}, w = {list(self.w)}, "
            f"z = {list(self.z) or 'states'}",
        ]
        if self.gamma is not None:
            lines.append(f"  gamma = {self.gamma:.5g} certified")
        with np.printoptions(precision=5, linewidth=100):
            for j, L in enumerate(self.L):
                label = f"L[{j}]" if self.scheduled else "L"
                lines.append(f"  {label} = {np.array2string(L, prefix='  L = ')}")
        lines.append(f"  certificate: {self.certificate.summary}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        gamma = "" if self.gamma is None else f", gamma={self.gamma:.5g}"
        return (
            f"<ObserverDesign: {len(self.L)} gain(s){gamma}, "
            f"verified={self.certificate.verified}>"
        )
