"""`OutputFeedbackDesign`: a certified dynamic output-feedback controller."""

from __future__ import annotations

from dataclasses import dataclass, field

import control as ct
import numpy as np

from ..certificate import Certificate
from ..systems import PolytopicStateSpace
from .plant import OutputFeedbackPlant
from .reconstruct import closed_loop

__all__ = ["OutputFeedbackDesign"]


@dataclass(frozen=True, eq=False)
class OutputFeedbackDesign:
    """A certified output-feedback design (`ctrl_lpv.hinf_output_feedback`).

    Attributes
    ----------
    plant : `ctrl_lpv.output_feedback.OutputFeedbackPlant`
        The plant with its w/u/z/y partition.
    objective : `ctrl_lpv.Hinf` or `ctrl_lpv.H2`
        The norm from w to z that `gamma` bounds (with the plant's names).
    limits : tuple of `ctrl_lpv.Hinf` or `ctrl_lpv.H2`
        The bounds of other channels the design met (a mixed design's
        constraints, with the plant's names), certified with the same
        closed-loop Lyapunov matrix.
    controllers : tuple of (Ak, Bk, Ck, Dk)
        The controller at each vertex: ``xk' = Ak xk + Bk y``, ``u = Ck xk
        + Dk y``; interpolated with the plant's convex coordinates.
    gamma : float
        The certified bound of the objective: the L2 gain from w to z for
        every parameter trajectory in the polytope (`ctrl_lpv.Hinf`), or the
        H2 norm at every frozen parameter value (`ctrl_lpv.H2`).
    gamma_opt : float
        The minimum bound the LMIs reached (an estimate from above of the
        optimum of the formulation); ``gamma / gamma_opt - 1`` is the
        back-off.
    P : ndarray
        The closed loop's Lyapunov matrix (plant states first). When the
        certificate's rows say "P-normalised", the matrix they prove is
        ``R' R``, ``R = diag(s)^1/2 V'`` from ``P = V diag(s) V'`` (equal
        to ``P`` to rounding; `ctrl_lpv.output_feedback.checks`).
    values : dict
        The certified level (``"level"``: gamma, or gamma^2 for H2) and the
        objective's other certificate variables (H2: ``"Q<j>"``).
    certificate : `ctrl_lpv.Certificate`
        Float64 checks on the closed loop with the returned controller.
    condition : float
        Condition number of ``I - X Y`` (the controller's reconstruction),
        in the prescaled coordinates the LMIs were posed in
        (`ctrl_lpv.output_feedback.prescale`).
    timing : dict
        Seconds spent, with the keys of `ctrl_lpv.StateFeedbackDesign.timing`:
        "build" (argument checks, partition, stabilizability and
        detectability), "compile" (reading the LMIs into conic data),
        "solve" (solver calls and the rest of the ladder) and "verify"
        (rebuilding controllers and their float64 closed-loop
        certificates).
    ladder : tuple of str
        The rungs passed over before this design certified and why (empty
        when the first rung's point did).
    """

    plant: OutputFeedbackPlant
    objective: object
    limits: tuple
    controllers: tuple
    gamma: float
    gamma_opt: float
    P: np.ndarray
    values: dict
    certificate: Certificate
    condition: float
    timing: dict = field(default_factory=dict)
    ladder: tuple = ()

    @property
    def bounds(self) -> dict:
        """``{spec: bound}`` certified: the objective's `gamma` and each bound
        of `limits`, as `ctrl_lpv.StateFeedbackDesign.bounds`."""
        return {self.objective: self.gamma} | {s: s.bound for s in self.limits}

    def controller(self, name: str = "controller") -> PolytopicStateSpace:
        """The controller as a python-control I/O system.

        Inputs: the measured outputs ``y`` (the plant's names), then one per
        parameter (named after it; a vertex-scheduled controller); outputs:
        the control inputs ``u`` (the plant's names), so that
        `control.interconnect` connects it to the plant by name, with no
        sign convention to remember; states ``<name>_x[i]``. ``.at(p)`` is
        the frozen controller.

        Parameters
        ----------
        name : str, optional
            System name (default ``"controller"``).

        Returns
        -------
        `PolytopicStateSpace`
        """
        sys = self.plant.system
        nk = self.controllers[0][0].shape[0]
        return PolytopicStateSpace(
            [tuple(K) for K in self.controllers],
            domain=sys.domain,
            scheduling="inputs",
            inputs=self.plant.names("y"),
            outputs=self.plant.names("u"),
            states=[f"{name}_x[{i}]" for i in range(nk)],
            name=name,
            dt=sys.dt,
        )

    def closed_loop(self, p=None) -> ct.StateSpace:
        """Frozen closed loop from w to z at parameter value `p`.

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value (for a simplex domain: the convex coordinates);
            default the plant's nominal point.

        Returns
        -------
        `control.StateSpace`
            With the plant's names of w and z; states: the plant's, then
            the controller's.
        """
        sys = self.plant.system
        weights = sys.weights(sys.nominal if p is None else p)
        K = tuple(np.tensordot(weights, np.array(M), axes=1)
                  for M in zip(*self.controllers))  # fmt: skip
        A, B, C, D = closed_loop(self.plant, self.plant.data(weights), K)
        nk = K[0].shape[0]
        return ct.ss(
            A, B, C, D, sys.dt,
            inputs=self.plant.names("w"), outputs=self.plant.names("z"),
            states=list(sys.state_labels) + [f"controller_x[{i}]" for i in range(nk)],
        )  # fmt: skip
