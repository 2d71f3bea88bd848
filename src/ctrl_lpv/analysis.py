"""Analysis of polytopic closed loops for given gains."""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import control as ct
import numpy as np

from ._checks import real_number, signal_indices
from .budget import DEFAULT_TIME_LIMIT, time_budget
from .certificate import Certificate
from .exceptions import InfeasibleError
from .lmi import LMICheck
from .systems import PolytopicStateSpace

__all__ = [
    "QuadraticStability",
    "L2GainBound",
    "H2Bound",
    "h2_bound",
    "FrozenSweep",
    "quadratic_stability",
    "l2_gain_bound",
    "frozen_sweep",
]


class _LyapunovResult:
    """``lyapunov_matrix(p)`` of the analysis results."""

    def lyapunov_matrix(self, p=None) -> np.ndarray:
        """The Lyapunov matrix ``P(p)`` of ``V = x' P(p) x``.

        Constant, or for ``lyapunov="affine"`` in continuous time
        ``P(p) = sum_j delta_j(p) P_j``, multi-affine in the box parameters;
        in discrete time ``P(p) = W(p)^-1`` with ``W(p) = sum_j delta_j(p)
        P_j^-1`` multi-affine (the dual parametrization of
        `ctrl_lpv.synthesize`).

        Parameters
        ----------
        p : array_like or mapping, optional
            Parameter value; ignored for a constant ``P``.

        Returns
        -------
        ndarray
        """
        if not isinstance(self.P, tuple):
            return self.P.copy()
        if p is None:
            raise ValueError("p: an affine Lyapunov function needs the parameter value")
        delta = self.system.weights(p)
        if not self.system.isdtime(strict=True):
            return sum(d * Pj for d, Pj in zip(delta, self.P))
        P = np.linalg.inv(sum(d * np.linalg.inv(Pj) for d, Pj in zip(delta, self.P)))
        return 0.5 * (P + P.T)


@dataclass(frozen=True)
class QuadraticStability(_LyapunovResult):
    """A Lyapunov function for every vertex (constant or parameter-dependent).

    Attributes
    ----------
    P : ndarray or tuple of ndarray
        ``P > 0`` with ``A_j' P + P A_j < 0`` at every vertex ``j``; for an
        affine Lyapunov function the vertex values of ``P(p)`` (see
        `lyapunov_matrix`).
    checks : tuple of `ctrl_lpv.lmi.LMICheck`
        Float64 checks of the LMIs at ``P``.
    system : `PolytopicStateSpace` or None
        The analysed system (for `lyapunov_matrix`).
    certificate : `ctrl_lpv.synthesis.results.DesignCertificate` or None
        The engine's whole certificate (`checks` are its ``"LMI"`` group;
        the ``"closed loop"`` group checks the frozen loops in the model's
        units); ``print`` shows it as a table.
    """

    P: np.ndarray
    checks: tuple[LMICheck, ...]
    system: PolytopicStateSpace | None = None
    certificate: Certificate | None = None


@dataclass(frozen=True)
class L2GainBound(_LyapunovResult):
    """Certified bound on the L2 gain of a polytopic closed loop.

    Attributes
    ----------
    gamma : float
        ``||z||_2 < gamma ||w||_2`` for every parameter trajectory in the
        domain (quadratic H-infinity performance with a common ``P``).
    P : ndarray or tuple of ndarray
        The common Lyapunov matrix, or the vertex values of an affine one
        (see `lyapunov_matrix`).
    checks : tuple of `ctrl_lpv.lmi.LMICheck`
        Float64 checks of the LMIs.
    system : `PolytopicStateSpace` or None
        The analysed system (for `lyapunov_matrix`).
    certificate : `ctrl_lpv.synthesis.results.DesignCertificate` or None
        The engine's whole certificate (`checks` are its ``"LMI"`` group;
        the ``"closed loop"`` group checks the frozen loops in the model's
        units); ``print`` shows it as a table.
    """

    gamma: float
    P: np.ndarray
    checks: tuple[LMICheck, ...]
    system: PolytopicStateSpace | None = None
    certificate: Certificate | None = None


@dataclass(frozen=True)
class H2Bound(_LyapunovResult):
    """Certified H2 bound of a polytopic closed loop.

    Attributes
    ----------
    gamma : float
        Bound on the H2 norm of every frozen closed loop (and on the impulse
        output energy for admissible parameter trajectories).
    P : ndarray or tuple of ndarray
        The Lyapunov matrix (vertex matrices for an affine one).
    checks : tuple of `ctrl_lpv.lmi.LMICheck`
        Float64 checks of the LMIs.
    system : `PolytopicStateSpace` or None
        The analysed system (for `lyapunov_matrix`).
    certificate : `ctrl_lpv.synthesis.results.DesignCertificate` or None
        The engine's whole certificate (`checks` are its ``"LMI"`` group;
        the ``"closed loop"`` group checks the frozen loops in the model's
        units); ``print`` shows it as a table.
    """

    gamma: float
    P: object
    checks: tuple[LMICheck, ...]
    system: PolytopicStateSpace | None = None
    certificate: Certificate | None = None


@dataclass(frozen=True)
class FrozenSweep:
    """Closed-loop poles and H-infinity norms at frozen parameter values.

    Attributes
    ----------
    points : ndarray
        Parameter values, shape ``(M, k)``.
    poles : ndarray
        Closed-loop eigenvalues, shape ``(M, n)`` (z-plane in discrete
        time).
    max_real : ndarray
        Largest real part per point, shape ``(M,)``: the stability test in
        continuous time (``< 0``); in discrete time it is still the largest
        real part of the z-plane eigenvalues, which does not decide
        stability (use `spectral_radius`).
    hinf : ndarray or None
        H-infinity norm from `w` to `z` per point (``inf`` where unstable),
        None if no channels were given. In discrete time the norm of the
        discrete closed loop (``sup`` over the unit circle, with the
        system's ``dt``).
    spectral_radius : ndarray
        Largest eigenvalue modulus per point, shape ``(M,)``: the stability
        test in discrete time (``< 1``).
    dt : 0, True or float
        Timebase of the system.
    """

    points: np.ndarray
    poles: np.ndarray
    max_real: np.ndarray
    hinf: np.ndarray | None
    spectral_radius: np.ndarray | None = None
    dt: float | bool = 0

    @property
    def stable(self) -> np.ndarray:
        """Whether each frozen closed loop is stable (Hurwitz or Schur)."""
        if self.dt:
            return self.spectral_radius < 1.0
        return self.max_real < 0.0


def _as_closed_loop_data(sys, gains, u):
    """Vertex data and per-vertex gains as (A, B, C, D) and K arrays."""
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(f"sys: expected a PolytopicStateSpace, got {type(sys)!r}")
    if not isinstance(gains, (list, tuple)):
        gains = [gains]
    gains = [np.asarray(K, float) for K in gains]
    iu = signal_indices(u, sys.physical_inputs, "u") if gains else []
    shape = (len(iu), sys.nstates)
    for j, K in enumerate(gains):
        if K.shape != shape or not np.all(np.isfinite(K)):
            raise ValueError(
                f"gains[{j}]: expected a finite {shape} matrix, got {K.shape}"
            )
    if len(gains) not in (1, sys.nvertices):
        raise ValueError(
            f"gains: expected one common gain or {sys.nvertices} vertex gains, "
            f"got {len(gains)}"
        )
    return gains, iu


@time_budget
def quadratic_stability(
    sys: PolytopicStateSpace,
    margin: float = 1e-6,
    *,
    lyapunov: str = "constant",
    rate_bounds=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
):
    """Find a Lyapunov function for the autonomous part of the polytope.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Autonomous part ``A(delta)`` is analysed (e.g. a closed loop);
        continuous or discrete time.
    margin : float, optional
        Margin of the strict LMIs, relative to ``max_j ||A_j||``.
    lyapunov : {"constant", "affine"}, optional
        One ``P`` for every vertex (quadratic stability, any parameter
        rate), or ``P(p)`` multi-affine in the box parameters with
        `rate_bounds` (see `ctrl_lpv.synthesize`).
    rate_bounds : mapping of str to float, optional
        ``{name: nu}`` bounds on the parameter rates, for
        ``lyapunov="affine"``; ``nu = 0`` for time-invariant parameters.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `QuadraticStability`

    Raises
    ------
    InfeasibleError
        If a vertex has an eigenvalue with ``Re >= 0`` (then no ``P > 0``
        has ``A' P + P A < 0``), or if a dual certificate verified in
        float64 shows that every common Lyapunov matrix has a relative
        margin below what the certificate accepts (no certifiable one
        exists; the message gives both numbers).
    CertificationError
        If no certified common Lyapunov matrix was found otherwise.
    """
    margin = real_number(margin, "margin", positive=True, below=1.0)
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(f"sys: expected a PolytopicStateSpace, got {type(sys)!r}")
    As = [d[0] for d in sys.vertex_data()]
    _require_stable_vertices(sys, As)
    # The one engine with no input and no objective: its stability stage.
    _, P, cert = _general_analysis(_autonomous(sys, As), None, lyapunov,
                                   rate_bounds, margin)  # fmt: skip
    return QuadraticStability(P, cert.lmi_checks, sys, cert)


@time_budget
def l2_gain_bound(
    sys: PolytopicStateSpace,
    gains,
    w,
    u,
    z,
    margin: float = 1e-6,
    *,
    lyapunov: str = "constant",
    rate_bounds=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> L2GainBound:
    """Certified L2-gain bound of ``sys`` under ``u = -K(delta) x``.

    With vertex gains the closed loop is quadratic in ``delta``; the bound
    uses the same vertex and pairwise relaxation as Theorem 2.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Open-loop plant.
    gains : array_like or sequence of array_like
        One common gain or one per vertex (``u = -K x``).
    w, u, z : str, int or list
        Exogenous inputs, control inputs, performance outputs.
    margin : float, optional
        Strict-LMI margin, relative to the data scale.
    lyapunov : {"constant", "affine"}, optional
        A constant ``P``, or ``P(p)`` multi-affine in the box parameters
        with `rate_bounds` (see `ctrl_lpv.synthesize`).
    rate_bounds : mapping of str to float, optional
        ``{name: nu}`` bounds on the parameter rates, for
        ``lyapunov="affine"``.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `L2GainBound`

    Raises
    ------
    InfeasibleError
        If the closed loop is not quadratically stable with this bound.
    """
    margin = real_number(margin, "margin", positive=True, below=1.0)
    gains, iu = _as_closed_loop_data(sys, gains, u)
    iw = signal_indices(w, sys.physical_inputs, "w")
    iz = signal_indices(z, sys.output_labels, "z")
    from .synthesis import Hinf

    cl = _closed_loop(sys, gains, iw, iu, iz, lyapunov)
    gamma, P, cert = _general_analysis(cl, Hinf(), lyapunov, rate_bounds, margin)
    return L2GainBound(gamma, P, cert.lmi_checks, sys, cert)


@time_budget
def h2_bound(
    sys: PolytopicStateSpace,
    gains,
    w,
    u,
    z,
    margin: float = 1e-6,
    *,
    lyapunov: str = "constant",
    rate_bounds=None,
    time_limit: float | None = DEFAULT_TIME_LIMIT,
) -> H2Bound:
    """Certified H2 bound of ``sys`` under ``u = -K(delta) x``.

    For time-varying parameters the bound is on the output energy of every
    impulse in `w` (summed over the inputs), so for frozen parameters it
    bounds the H2 norm (see `ctrl_lpv.H2`).

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Open-loop plant, continuous (no feedthrough from `w` to `z`) or
        discrete time.
    gains : array_like or sequence of array_like
        One common gain or one per vertex (``u = -K x``).
    w, u, z : str, int or list
        Exogenous inputs, control inputs, performance outputs.
    margin : float, optional
        Strict-LMI margin, relative to the data scale.
    lyapunov : {"constant", "affine"}, optional
        A constant ``P``, or ``P(p)`` multi-affine in the box parameters
        with `rate_bounds`.
    rate_bounds : mapping of str to float, optional
        ``{name: nu}`` bounds on the parameter rates, for
        ``lyapunov="affine"``.
    time_limit : float or None, optional
        Wall-time budget of the call in seconds (default 600,
        `ctrl_lpv.budget.DEFAULT_TIME_LIMIT`; None for no limit). Solvers
        get the time left; when it runs out the call ends with a
        `CertificationError` whose first line is ``time_limit: ... s
        reached`` with the best point reached.

    Returns
    -------
    `H2Bound`

    Raises
    ------
    InfeasibleError
        If a vertex closed loop is unstable.
    CertificationError
        If no certified bound was found.
    """
    margin = real_number(margin, "margin", positive=True, below=1.0)
    from .synthesis import H2

    gains, iu = _as_closed_loop_data(sys, gains, u)
    iw = signal_indices(w, sys.physical_inputs, "w")
    iz = signal_indices(z, sys.output_labels, "z")
    cl = _closed_loop(sys, gains, iw, iu, iz, lyapunov)
    gamma, P, cert = _general_analysis(cl, H2(), lyapunov, rate_bounds, margin)
    return H2Bound(gamma, P, cert.lmi_checks, sys, cert)


def _require_stable_vertices(sys, As) -> None:
    """Refuse an unstable vertex: no Lyapunov function of any kind exists."""
    discrete = sys.isdtime(strict=True)
    for j, A in enumerate(As):
        eig = np.linalg.eigvals(A)
        worst = np.abs(eig).max() if discrete else eig.real.max()
        if worst >= (1 if discrete else 0):
            what = "modulus" if discrete else "real part"
            raise InfeasibleError(
                f"vertex {j} is not asymptotically stable (eigenvalue with {what} "
                f"{worst:.6g}), so no Lyapunov function exists"
            )


def _autonomous(sys, As):
    # One zero input and output: python-control refuses systems without.
    n = sys.nstates
    vertices = [(A, np.zeros((n, 1)), np.zeros((1, n)), np.zeros((1, 1))) for A in As]
    return PolytopicStateSpace(vertices, domain=sys.domain, dt=sys.dt)


def _closed_loop(sys, gains, iw, iu, iz, lyapunov):
    """The closed loop from `w` to `z` as a polytope (exact for the relaxation).

    With vertex gains and an input matrix of ``u`` (``B_u`` or ``D_zu``) that
    depends on the parameter, ``B_u(p) K(p)`` is quadratic in the convex
    coordinates ``d``: the closed loop ``sum_jk d_j d_k M_jk`` (``M_jk`` the
    loop of vertex ``j`` under gain ``k``) is a convex combination of the
    ``M_jj`` and the ``(M_jk + M_kj) / 2``, which are then its vertices
    (one constant Lyapunov matrix only: an affine one would need the convex
    coordinates themselves).
    """
    data = list(sys.vertex_data())
    B2 = [B[:, iu] for _, B, _, _ in data]
    D2 = [D[np.ix_(iz, iu)] for _, _, _, D in data]
    bilinear = len(gains) > 1 and (
        any(not np.array_equal(B2[0], b) for b in B2)
        or any(not np.array_equal(D2[0], d) for d in D2)
    )
    if bilinear and lyapunov != "constant":
        raise ValueError(
            "gains: vertex gains with lyapunov='affine' need an input matrix "
            "of u that does not depend on the parameter (the closed loop is "
            "then affine in it)"
        )

    def loop(j, k):
        A, B, C, D = data[j]
        K = gains[k if len(gains) > 1 else 0]
        return (A - B[:, iu] @ K, B[:, iw], C[iz] - D[np.ix_(iz, iu)] @ K,
                D[np.ix_(iz, iw)])  # fmt: skip

    vertices = [loop(j, j) for j in range(len(data))]
    _require_stable_vertices(sys, [v[0] for v in vertices])
    if not bilinear:
        return PolytopicStateSpace(vertices, domain=sys.domain, dt=sys.dt)
    for j, k in itertools.combinations(range(len(data)), 2):
        vertices.append(tuple(0.5 * (a + b) for a, b in zip(loop(j, k), loop(k, j))))
    return PolytopicStateSpace(vertices, dt=sys.dt)


def _general_analysis(cl, spec, lyapunov, rate_bounds, margin):
    """The bound of `spec` (None: stability) of a closed loop without inputs.

    Returns ``(gamma, P, certificate)``, ``P`` the Lyapunov matrix or its
    vertex matrices (see `_LyapunovResult.lyapunov_matrix`).

    The engine writes its LMIs in the dual variable ``W``. In continuous
    time with ``lyapunov="affine"`` it analyses the transposed loop
    ``(A', C', B', D')``: its dual inequalities in ``W`` are the primal ones
    of the loop in ``P = W`` (bounded-real, Lyapunov, and the H2 bound
    ``trace(B' P B)`` with ``A' P + P A + dP/dt + C' C < 0``), up to the
    sign of ``dP/dt``, which the symmetric rate box ``|dp/dt| <= nu``
    covers. So ``P(p)`` itself is multi-affine, the parametrization of
    Gahinet, Apkarian and Chilali (1996) and of the literature's examples.
    """
    from .synthesis.general import run_analysis
    from .synthesis.parametric import lyapunov_structure
    from .synthesis.specs import Hinf

    lyap = lyapunov_structure(cl, lyapunov, rate_bounds)
    primal = not lyap.constant and not cl.isdtime(strict=True)
    if primal:
        vertices = [(A.T, C.T, B.T, D.T) for A, B, C, D in cl.vertex_data()]
        cl = PolytopicStateSpace(vertices, domain=cl.domain, dt=cl.dt)
    design = run_analysis(cl, spec, lyap, margin)
    P = design.P
    if primal:
        # The transposed loop's dual bounded-real inequality in W is the
        # loop's primal one in P = W / gamma^2 (the identity and gamma^2
        # blocks trade places); the Lyapunov and H2 inequalities need no
        # factor.
        factor = design.gamma**2 if isinstance(spec, Hinf) else 1.0
        P = tuple(_sym(np.linalg.inv(Pj)) / factor for Pj in P)
    return design.gamma, P, design.certificate


def _sym(M):
    return 0.5 * (M + M.T)


def frozen_sweep(
    sys: PolytopicStateSpace,
    gains,
    u,
    points=None,
    w=None,
    z=None,
) -> FrozenSweep:
    """Closed-loop poles (and H-infinity norms) at frozen parameters.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        Open-loop plant.
    gains : array_like or sequence of array_like
        One common gain or one per vertex (``u = -K x``).
    u : str, int or list
        Control inputs.
    points : array_like or int, optional
        Parameter values, shape ``(M, k)``; or an integer ``M >= 2``
        (default 51) for a sample of the domain: for one parameter, ``M``
        equally spaced values from the lower to the upper bound; for
        several, every vertex of the domain plus interior points: on a box,
        the grid of ``max(2, floor(M ** (1/k)))`` equally spaced values per
        parameter (the vertices among them; the center added when that is
        2), on another domain ``max(1, M - N)`` random convex combinations
        of the ``N`` vertices (Dirichlet, seed 0: the same points on every
        call).
    w, z : str, int or list, optional
        If given, the H-infinity norm from `w` to `z` is computed with
        `control.linfnorm` (of the discrete closed loop for a
        discrete-time `sys`).

    Returns
    -------
    `FrozenSweep`
        For a discrete-time `sys` (``dt > 0`` or True), stability is read
        from ``spectral_radius < 1`` (``max_real`` keeps its meaning, the
        largest real part); ``stable`` answers for either timebase.
    """

    def sample(domain, count: int) -> np.ndarray:
        """Default points of `frozen_sweep`: the vertices and interior points."""
        vertices = np.asarray(domain.points, dtype=float)
        k = vertices.shape[1]
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        if k == 1:
            return lo + np.linspace(0.0, 1.0, count)[:, None] * (hi - lo)
        if hasattr(domain, "lower"):  # a ParameterBox
            per_axis = max(2, int(np.floor(count ** (1.0 / k) + 1e-9)))
            axes = [np.linspace(a, b, per_axis) for a, b in zip(lo, hi)]
            grid = np.array(list(itertools.product(*axes)), dtype=float)
            if per_axis == 2:
                grid = np.vstack([grid, (lo + hi) / 2])
            return grid
        rng = np.random.default_rng(0)
        weights = rng.dirichlet(
            np.ones(len(vertices)), size=max(1, count - len(vertices))
        )
        return np.vstack([vertices, weights @ vertices])

    gains, iu = _as_closed_loop_data(sys, gains, u)
    if points is None or np.isscalar(points):
        count = 51 if points is None else points
        if (
            isinstance(count, bool)
            or not isinstance(count, (int, np.integer))
            or count < 2
        ):
            raise ValueError(
                f"points: expected an integer >= 2 or an (M, k) array, got {count!r}"
            )
        points = sample(sys.domain, int(count))
    points = np.atleast_2d(np.asarray(points, float))
    if points.shape[1] != sys.nparams:
        points = points.T
    iw = signal_indices(w, sys.physical_inputs, "w") if w is not None else None
    iz = signal_indices(z, sys.output_labels, "z") if z is not None else None
    Kstack = np.stack(gains)
    discrete = sys.isdtime(strict=True)
    poles, hinf = [], []
    for p in points:
        delta = sys.weights(p)
        frozen = sys.at(p)
        K = np.tensordot(delta, Kstack, axes=1) if len(gains) > 1 else Kstack[0]
        Acl = frozen.A - frozen.B[:, iu] @ K
        eig = np.linalg.eigvals(Acl)
        poles.append(np.sort_complex(eig))
        if iw is not None and iz is not None:
            unstable = np.abs(eig).max() >= 1.0 if discrete else eig.real.max() >= 0
            if unstable:
                hinf.append(np.inf)
            else:
                Ccl = frozen.C[iz] - frozen.D[np.ix_(iz, iu)] @ K
                cl = ct.ss(
                    Acl, frozen.B[:, iw], Ccl, frozen.D[np.ix_(iz, iw)], dt=sys.dt
                )
                hinf.append(float(ct.linfnorm(cl)[0]))
    poles = np.array(poles)
    return FrozenSweep(
        points=points,
        poles=poles,
        max_real=poles.real.max(axis=1),
        hinf=np.array(hinf) if hinf else None,
        spectral_radius=np.abs(poles).max(axis=1),
        dt=sys.dt,
    )
