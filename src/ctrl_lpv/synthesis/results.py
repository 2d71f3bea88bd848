"""Results of a synthesis: the design and its certificate."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from control import StateSpace

from ..certificate import Certificate, Check
from ..lmi import SolveAttempt
from ..regions import LMIRegion
from ..systems import PolytopicStateSpace
from .channels import channel_indices

# The rounding level of a specification's residual (the largest eigenvalue
# of its Jacobi-normalised inequality, whose size the residual does not
# report): `ctrl_lpv.certificate.rounding_bound` of a 6 x 6 one. Until the
# specs return `ctrl_lpv.certificate.negative_definite` checks; the gain
# files report it (`ctrl_lpv.twomass.load_gains`).
ORIGINAL_UNITS_TOL = 1e-12

#: Groups of a design's checks: the LMIs as posed, the frozen closed loops.
LMI, CLOSED_LOOP = "LMI", "closed loop"
#: Names of the closed-loop checks read by `DesignCertificate`'s properties.
EIGENVALUES, LYAPUNOV = "closed-loop eigenvalues", "Lyapunov inequality"
#: What a design's checks state.
DESIGN_STATEMENT = (
    "the LMIs hold with their margin at the returned point (scaled units, "
    "exactly congruent to the model's); the frozen closed loops in the "
    "model's units, at the vertices and sampled points, are cross-checks"
)


def residual_check(what, value, where, *, cross_check, units="normalised"):
    """A specification's residual (see `ORIGINAL_UNITS_TOL`) as a check."""
    return Check(what, value, 0.0, True, ORIGINAL_UNITS_TOL, cross_check, units,
                 where, CLOSED_LOOP)  # fmt: skip


@dataclass(frozen=True)
class DesignCertificate(Certificate):
    """The `ctrl_lpv.Certificate` of a state-feedback design.

    Its checks: group ``"LMI"``, every LMI as posed to the solver (scaled
    units) at the returned point; group ``"closed loop"``, the frozen
    closed loops at `npoints` parameter points, each check at its worst
    point: the closed-loop eigenvalues, the Lyapunov inequality and each
    specification's inequality with the returned ``P`` and gains.

    Attributes
    ----------
    margin : float
        Margin the strict LMIs were posed with (scaled units).
    npoints : int
        Number of parameter points checked (vertices plus samples).
    lmi_checks : tuple of `ctrl_lpv.certificate.Check`
        The group ``"LMI"``: largest eigenvalue of every LMI at the
        returned point (`Check.max_eig`) and its bound (`Check.required`).
    max_closed_loop_real : float
        Largest real part of the closed-loop eigenvalues over the points
        (modulus minus 1 in discrete time); inf when not checked.
    max_lyapunov_eig : float
        Largest Jacobi-normalised eigenvalue of the Lyapunov inequality over
        the points; inf when not checked.
    max_original_eig : float
        Largest normalised eigenvalue, over the points, of the
        specifications' inequalities (bounded-real with `gamma`, Lyapunov
        without) written with the returned ``P`` and gains in the model's
        units.
    worst_lmi : `ctrl_lpv.certificate.Check` or None
        The strict LMI with the largest eigenvalue.
    """

    margin: float = 0.0
    npoints: int = 0

    @property
    def lmi_checks(self) -> tuple[Check, ...]:
        return self.group(LMI)

    def _closed_loop(self, what) -> float:
        values = [c.value for c in self.group(CLOSED_LOOP) if c.what == what]
        return max(values, default=np.inf)

    @property
    def max_closed_loop_real(self) -> float:
        return self._closed_loop(EIGENVALUES)

    @property
    def max_lyapunov_eig(self) -> float:
        return self._closed_loop(LYAPUNOV)

    @property
    def max_original_eig(self) -> float:
        values = [c.value for c in self.group(CLOSED_LOOP)
                  if c.what not in (EIGENVALUES, LYAPUNOV)]  # fmt: skip
        return max(values, default=self.max_lyapunov_eig)

    @property
    def worst_lmi(self) -> Check | None:
        strict = [c for c in self.lmi_checks if c.strict]
        return max(strict, key=lambda c: c.value, default=None)

    @property
    def summary(self) -> str:
        """One line; for a verified design its worst LMI and closed loop."""
        worst = self.worst_lmi
        if not self.verified or worst is None:
            return super().summary
        eigenvalues = [c for c in self.group(CLOSED_LOOP) if c.what == EIGENVALUES]
        discrete = bool(eigenvalues) and eigenvalues[0].units == "modulus - 1"
        return (
            f"verified: {len(self.lmi_checks)} LMIs, worst {worst.what} "
            f"lambda_max = {worst.value:.3g} (margin {self.margin:.1g}); "
            f"closed loop max {'|z| - 1' if discrete else 'Re'} = "
            f"{self.max_closed_loop_real:.4g} over {self.npoints} points"
        )


def frozen_loop(system, p, K, iu, iw, iz) -> StateSpace:
    """Named frozen loop ``u = -K x`` of `system` at `p`, from `iw` to `iz`.

    Without `iw` the inputs are the control inputs (an additive ``v`` in
    ``u = -K x + v``), without `iz` the outputs are all the outputs
    (python-control has no state-space system without inputs).
    """
    frozen = system.at(p)
    if not iw:
        iw = iu
    if not iz:
        iz = list(range(system.noutputs))
    inputs = system.physical_inputs
    return StateSpace(
        frozen.A - frozen.B[:, iu] @ K,
        frozen.B[:, iw],
        frozen.C[iz] - frozen.D[np.ix_(iz, iu)] @ K,
        frozen.D[np.ix_(iz, iw)],
        inputs=[inputs[i] for i in iw],
        outputs=[system.output_labels[i] for i in iz],
        states=list(system.state_labels),
        name=f"{system.name}_closed_loop",
        dt=system.dt,
        remove_useless_states=False,
    )


@dataclass(frozen=True)
class StateFeedbackDesign:
    """A certified state-feedback design for a polytopic system.

    Attributes
    ----------
    system : `PolytopicStateSpace`
        The design model.
    method : str
        Which result was used ("Lemma 1", "Lemma 2", "Theorem 1",
        "Theorem 2").
    gains : tuple of ndarray
        ``m x n`` gains for ``u = -K x``: one common gain, or one per vertex.
    P : ndarray or tuple of ndarray
        Lyapunov matrix ``P = W^-1`` of ``V(x) = x' P x`` (original units);
        for an affine Lyapunov function its vertex values.
    gamma : float or None
        Certified bound on the L2 gain from `w` to `z` (None without a
        performance channel).
    gamma_opt : float or None
        An estimate of the minimum ``gamma*`` from above, never below it:
        the smallest bound of a solver point that meets the LMIs in float64
        (non-strictly), or `gamma` when no such point was found (None
        without an objective to minimise). It is not certified (its point
        may miss the strict margin); only `gamma` is.
    w, u, z : tuple of str
        Exogenous inputs, control inputs and performance outputs.
    certificate : `DesignCertificate`
        The float64 verification (a `ctrl_lpv.Certificate`).
    attempts : tuple of `ctrl_lpv.lmi.SolveAttempt`
        Every solver attempt of every stage.
    timing : dict
        Seconds spent: "build" (checks and the stabilizability test),
        "compile" (reading the LMIs' block functions into conic data;
        about 0 when the problem and its maps were reused from
        `synthesis_cache`), "solve" (solver calls,
        parameter application and certificates) and "verify" (closed
        loops).
    backoff : float or None
        Back-off used.
    regions : tuple of `LMIRegion`
        Pole regions the design was constrained to.
    ladder : tuple of str
        What the fallback ladder tried before this design certified (empty
        when the first point did): each rung (prescaling, margin, stage
        bound) and why it was passed over.
    lyapunov : {"constant", "affine"}
        The Lyapunov function: one ``P``, or ``P(p) = W(p)^-1`` with ``W``
        multi-affine in the box parameters (then `P` holds the vertex
        matrices, see `lyapunov_matrix`); with `primal`, ``P(p)`` itself
        multi-affine.
    bounds : dict
        Certified bound of every `ctrl_lpv.Hinf` and `ctrl_lpv.H2` spec of
        the call, keyed by the spec.
    rational : tuple or None
        For a scheduled gain with an affine Lyapunov function, the vertex
        matrices ``(Z_j, W_j)`` (model units) of ``K(p) = -Z(p) W(p)^-1``;
        None when the gain is affine in the convex coordinates.
    rate_bounds : dict or None
        For ``lyapunov="affine"``: the parameter rate bounds ``{name: nu}``
        the certificate holds for (a parameter not listed may vary
        arbitrarily fast); None for a constant Lyapunov matrix.
    primal : bool
        Whether an affine ``P(p)`` is multi-affine itself (the certificate of
        a common gain's analysis, see `ctrl_lpv.synthesize`) rather than its
        inverse.
    values : dict
        A spec's own values at the design's point in the model's units,
        keyed by the spec (`ctrl_lpv.synthesis.spec.Spec.model_values`;
        e.g. the decay and multipliers of an ultimate bound).
    """

    system: PolytopicStateSpace
    method: str
    gains: tuple[np.ndarray, ...]
    P: np.ndarray
    gamma: float | None
    gamma_opt: float | None
    w: tuple[str, ...]
    u: tuple[str, ...]
    z: tuple[str, ...]
    certificate: DesignCertificate
    attempts: tuple[SolveAttempt, ...]
    timing: dict = field(default_factory=dict)
    backoff: float | None = None
    regions: tuple[LMIRegion, ...] = ()
    ladder: tuple[str, ...] = ()
    lyapunov: str = "constant"
    bounds: dict = field(default_factory=dict)
    rational: tuple | None = None
    rate_bounds: dict | None = None
    primal: bool = False
    values: dict = field(default_factory=dict)

    @property
    def scheduled(self) -> bool:
        """Whether the design has one gain per vertex."""
        return len(self.gains) > 1

    @property
    def states(self) -> tuple[str, ...]:
        """State labels (the measured signals of the controller)."""
        return tuple(self.system.state_labels)

    def gain(self, p=None) -> np.ndarray:
        """Gain ``K(delta(p)) = sum_j delta_j K_j`` at parameter value `p`.

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value; ignored (may be omitted) for a common gain.

        Returns
        -------
        ndarray
            ``m x n`` gain for ``u = -K x``.
        """
        if not self.scheduled:
            return self.gains[0].copy()
        if p is None:
            raise ValueError("p: a scheduled design needs the parameter value")
        return self.gain_at(self.system.weights(p))

    def gain_at(self, delta) -> np.ndarray:
        """Gain at convex coordinates `delta` (shape ``(N,)``) of the vertices."""
        if not self.scheduled:
            return self.gains[0].copy()
        if self.rational is not None:
            Z, W = (np.tensordot(delta, np.stack(M), axes=1) for M in self.rational)
            return -np.linalg.solve(W.T, Z.T).T
        return np.tensordot(delta, np.stack(self.gains), axes=1)

    def lyapunov_matrix(self, p=None) -> np.ndarray:
        """The Lyapunov matrix ``P(p)`` of ``V = x' P(p) x`` (model units).

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value; ignored (may be omitted) for a constant ``P``.

        Returns
        -------
        ndarray
            ``n x n``, positive definite.
        """
        if self.lyapunov == "constant":
            return self.P.copy()
        if p is None:
            raise ValueError("p: an affine Lyapunov function needs the parameter value")
        return self.lyapunov_at(self.system.weights(p))

    def lyapunov_at(self, delta) -> np.ndarray:
        """``P`` at convex coordinates `delta`: ``(sum_j delta_j P_j^-1)^-1``,
        or ``sum_j delta_j P_j`` for a `primal` design."""
        if self.lyapunov == "constant":
            return self.P.copy()
        if self.primal:
            P = sum(d * Pj for d, Pj in zip(delta, self.P))
            return 0.5 * (P + P.T)
        W = sum(d * np.linalg.inv(Pj) for d, Pj in zip(delta, self.P))
        P = np.linalg.inv(W)
        return 0.5 * (P + P.T)

    def closed_loop(self, p) -> StateSpace:
        """Frozen closed loop from `w` to `z` at parameter value `p`.

        ``x' = (A - B_u K) x + B_w w``, ``z = (C_z - D_zu K) x + D_zw w``
        with the plant's matrices and the gain ``K(p)`` at `p`.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value (for a simplex domain: the convex coordinates).

        Returns
        -------
        `control.StateSpace`
            Inputs named after `w`, outputs after `z`, states after the
            plant's states; the plant's timebase ``dt``. Its matrices are
            ``ct.ssdata(design.closed_loop(p))``. A design without `w` and
            `z` (stabilization) has no such channel, and python-control no
            system without inputs: its loop is then from an additive input
            ``v`` at the control inputs, ``u = -K x + v`` (named after
            `u`), to every plant output.
        """
        iw, iu, iz = channel_indices(self.system, self.w, self.u, self.z)
        return frozen_loop(self.system, p, self.gain(p), iu, iw, iz)

    def save(self, path) -> Path:
        """Write the design and its plant to a JSON file (atomically).

        `ctrl_lpv.load` reads it back, rebuilds the plant from the file and
        re-checks the certificate in float64 (see
        `ctrl_lpv.persistence` for the format).

        Parameters
        ----------
        path : str or path-like
            File to write; its folder must exist. An existing file is
            replaced only once the new one is complete.

        Returns
        -------
        `pathlib.Path`
            The file written.

        Raises
        ------
        TypeError
            If `path` is not a str or path-like.
        ValueError
            If the folder does not exist, or the design holds a
            specification whose multipliers are not kept in the design
            (`ctrl_lpv.Peak`, `ctrl_lpv.Saturation`), so that its claim
            could not be re-checked on load.
        """
        from ..persistence import save

        return save(self, path)

    def controller(self, *args, **kwargs):
        """State-feedback controller ``u = -K x`` as a python-control I/O system.

        Calls `ctrl_lpv.controllers.state_feedback` on this design; its
        inputs are named after the design model's states, so that
        `control.interconnect` connects it to the plant by name.

        Parameters
        ----------
        scheduling : None, "inputs" or callable, optional
            For vertex gains only (None for a common gain): where the
            parameter comes from. ``"inputs"`` (the default for vertex
            gains) adds one input per parameter, named after it; a callable
            ``p = f(t, x)`` computes it from time and the design model's
            state vector, returning an array or a dict ``{name: value}``.
            The parameter is projected onto the domain.
        reference : bool, optional, keyword-only
            If True, add inputs ``<state>_d`` (desired states) and
            ``<input>_d`` (feedforward): ``u = ud - K (x - xd)``. Default
            False.
        states : sequence of str or mapping, optional, keyword-only
            Names of the measured-state inputs: one per measured state, or
            ``{state label: input name}`` renaming some. Default: the design
            model's state labels.
        integrals : mapping of str to str, optional, keyword-only
            ``{integral state label: integrated signal}`` integrated by the
            controller itself; default those recorded by
            `integral_augmentation` (``{}`` reads every state as an input).
        name : str, optional, keyword-only
            System name.

        Returns
        -------
        `control.NonlinearIOSystem`
            Inputs: the measured states (plus integrated outputs, references
            and parameter inputs as requested); outputs: the control inputs
            ``u``; states: the controller's integral states, if any.

        Raises
        ------
        ValueError
            For a `scheduling` that does not fit the design, `states` of the
            wrong length or with unknown labels, or `integrals` naming
            unknown states or signals.
        TypeError
            If `integrals` is not a mapping.
        """
        from ..controllers import state_feedback

        return state_feedback(self, *args, **kwargs)

    def __str__(self) -> str:
        lines = [
            f"StateFeedbackDesign ({self.method}, "
            f"{'vertex gains' if self.scheduled else 'common gain'}, u = -K x)",
            f"  system: {self.system.name}, {self.system.nvertices} vertices, "
            f"{self.system.nstates} states",
            f"  w = {list(self.w)}, u = {list(self.u)}, z = {list(self.z)}",
        ]
        if self.gamma is not None:
            opt = f"{self.gamma_opt:.5g}" if self.gamma_opt is not None else "n/a"
            backoff = "off" if self.backoff is None else f"{self.backoff:g}"
            lines.append(
                f"  gamma = {self.gamma:.5g} certified (gamma* = {opt}, "
                f"back-off {backoff})"
            )
        if self.regions:
            lines.append(f"  pole regions: {', '.join(map(str, self.regions))}")
        with np.printoptions(precision=5, suppress=False, linewidth=100):
            for j, K in enumerate(self.gains):
                label = f"K[{j}]" if self.scheduled else "K"
                lines.append(f"  {label} = {np.array2string(K, prefix='  K = ')}")
        lines.append(f"  certificate: {self.certificate.summary}")
        solved = [a for a in self.attempts if a.certified]
        solver = solved[-1].solver if solved else "none"
        lines.append(
            f"  solver: {solver}, {len(self.attempts)} attempt(s); time "
            + ", ".join(f"{k} {v:.3f} s" for k, v in self.timing.items())
        )
        return "\n".join(lines)

    def __repr__(self) -> str:
        gamma = "" if self.gamma is None else f", gamma={self.gamma:.5g}"
        return (
            f"<StateFeedbackDesign {self.method}: {len(self.gains)} gain(s)"
            f"{gamma}, verified={self.certificate.verified}>"
        )
