"""State feedback for a gridded plant: gains at the grid points.

`synthesize` on a `ctrl_lpv.GriddedStateSpace` designs gains ``K_g`` at the
grid points, interpolated as python-control's
`control.create_statefbk_iosystem` (``gainsched_method="linear"``)
interpolates them: linearly between the points of one parameter, on the
Delaunay triangles of the grid for several. So the design is the table a
python-control user passes on (`GriddedDesign.table`), and it is certified
by `ctrl_lpv.certify` on the same plant, whose bound it reports.

The LMIs are those of `ctrl_lpv.schedules.gridded`, in the dual variables
``W = P^-1`` and ``Z_g = -K_g W``: on a piece (a grid cell intersected with
a triangle) the gain extended to the cell's corners, ``K~_a = sum_j
l_j(v_a) K_j``, is ``-Z~_a W^-1`` with ``Z~_a = sum_j l_j(v_a) Z_j``,
linear in the ``Z``; the closed-loop terms ``(A_i - B_i K~_a) W = A_i W +
B_i Z~_a`` and the pairs of terms of `ctrl_lpv.schedules.gridded` enter the
Lyapunov inequality ``sym(A_cl W) < 0`` or the dual bounded-real one
(``[[sym(A_cl W), *, *], [B_w', -I, *], [C_cl W, D_zw, -g I]] < 0``, bound
``sqrt(g)``), which are affine in the terms. One ``W`` for every piece:
valid for arbitrarily fast parameters.

With ``lyapunov="affine"`` and ``rate_bounds`` the Lyapunov matrix depends
on the parameters (multilinear on the grid, continuous) and the rates are
bounded: `ctrl_lpv.synthesis.gridded_rates` (a slack form that keeps the
gains python-control's). Either way the design is returned only when
`ctrl_lpv.certify` certifies it, with the same rates.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from .._checks import checked_rates, real_number, signal_indices
from ..exceptions import CertificationError, SynthesisError
from ..lmi import solver_chain
from .gridded_rates import rate_bounded_gains

__all__ = ["GriddedDesign", "synthesize_gridded"]


@dataclass(frozen=True)
class GriddedDesign:
    """A certified gain schedule on the points of a gridded plant.

    Attributes
    ----------
    system : `ctrl_lpv.GriddedStateSpace`
        The plant.
    u : tuple of str
        The control inputs (``u = -K(p) x``).
    gains : tuple of ndarray
        ``K_g`` at the grid points, in the order of ``system.grid.points``.
    points : ndarray
        The grid points, ``(N, k)``.
    gamma : float or None
        The certified bound of the objective (L2 gain for `Hinf`), from
        `ctrl_lpv.certify` on the plant (for the rates of ``rate_bounds``
        when given); None without an objective.
    certificate : `ctrl_lpv.ScheduleCertificate`
        The verdict of `ctrl_lpv.certify` on the plant (its float64 checks
        in ``.certificate``).
    """

    system: object
    u: tuple
    gains: tuple
    points: np.ndarray
    gamma: float | None
    certificate: object

    @property
    def table(self) -> tuple[list, np.ndarray]:
        """``(gains, points)``, for `control.create_statefbk_iosystem`."""
        return list(self.gains), self.points

    def gain(self, p) -> np.ndarray:
        """``K(p)``, interpolated as python-control does (see the module)."""
        from ..schedules import schedule_of

        names = self.system.param_names
        return schedule_of(self.table, names=names).gain(
            self.system.domain._as_point(p)
        )


def synthesize_gridded(sys, u, *, y=None, objective=None, constraints=(),
                       gains=None, lyapunov="constant", rate_bounds=None,
                       backoff=0.2, margin=1e-6,
                       solvers=None) -> GriddedDesign:  # fmt: skip
    """`ctrl_lpv.synthesize` on a `GriddedStateSpace` (see the module).

    Parameters
    ----------
    sys : `ctrl_lpv.GriddedStateSpace`
        The plant (continuous time).
    u : str, int or list
        Control inputs.
    y, constraints
        Not implemented on grids: None, ().
    objective : `Hinf` or None
        The channel whose L2 gain to minimise, or None for stability.
    gains : {"scheduled", "common"}, optional
        Gains at the grid points (default) or one gain.
    lyapunov : {"constant", "affine"}, optional
        One Lyapunov matrix, valid for arbitrarily fast parameters
        (default), or one multilinear on each grid cell with its values at
        the grid points (needs `rate_bounds`; continuous time). With an
        objective the constant-matrix design is computed too (certified
        for arbitrary rates) and the one with the smaller certified bound
        returned; without one it is the fallback when the rate-bounded
        design fails.
    rate_bounds : mapping of str to float, optional
        ``{parameter: nu}``, ``|dp/dt| <= nu`` (``nu = 0``: a constant
        parameter). A parameter not listed (or ``inf``) may vary
        arbitrarily fast: the Lyapunov matrix does not depend on it. The
        design and its bound (`GriddedDesign.gamma`) are certified for
        these rates, on every grid cell (not only at the grid points).
    backoff : float, optional
        The L2 bound is relaxed by this fraction from its optimum to
        minimise the gains' size (default 0.2; 0 keeps the optimum, up to
        the solver's tolerance); without an objective the gains' size is
        minimised among the stabilising ones.
    margin : float, optional
        Margin of the strict LMIs, relative to the data's scale.
    solvers : optional
        As for `ctrl_lpv.synthesize`.

    Returns
    -------
    `GriddedDesign`

    Raises
    ------
    ValueError, TypeError
        Options not implemented on grids, a discrete-time plant, rate
        bounds naming an unknown parameter or negative (named).
    SynthesisError
        When no design is found, or the one found is not certified by
        `ctrl_lpv.certify` (`CertificationError`).

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import ctrl_lpv as lpv
    >>> G = lpv.gss(lambda a: ct.ss([[a, 1.0], [0.0, -1.0]], [[0.0], [1.0]],
    ...                             np.eye(2), 0, inputs="u"),
    ...             {"a": [0.0, 0.5, 1.0]})
    >>> design = lpv.synthesize(G, "u", lyapunov="affine",
    ...                         rate_bounds={"a": 0.5})
    >>> design.certificate.certified
    True
    """
    from .specs import Hinf

    if y is not None:
        raise ValueError("y: output feedback is not implemented on gridded plants")
    if constraints not in ((), None, []):
        raise ValueError("constraints: not implemented on gridded plants")
    if lyapunov not in ("constant", "affine"):
        raise ValueError(f"lyapunov: expected 'constant' or 'affine', got {lyapunov!r}")
    if lyapunov == "constant" and rate_bounds is not None:
        raise ValueError(
            "rate_bounds: only used with lyapunov='affine' (a constant Lyapunov "
            "matrix holds for any rate)"
        )
    if lyapunov == "affine":
        if rate_bounds is None:
            raise ValueError(
                "rate_bounds: lyapunov='affine' needs the rate bounds {name: nu}"
            )
        nu = checked_rates(rate_bounds, sys.param_names)
    gains = "scheduled" if gains is None else gains
    if gains not in ("common", "scheduled"):
        raise ValueError(f"gains: expected 'common' or 'scheduled', got {gains!r}")
    if objective is not None and not (
        isinstance(objective, Hinf) and objective.bound is None
        and objective.w is not None and objective.z is not None
    ):  # fmt: skip
        raise TypeError(
            "objective: on gridded plants, None or Hinf(w=..., z=...) without a "
            f"bound; got {objective!r}"
        )
    if sys.isdtime(strict=True):
        raise ValueError("sys: synthesis on gridded plants is continuous-time only")
    margin = real_number(margin, "margin", positive=True, below=1.0)
    solvers = solver_chain(solvers)
    backoff = real_number(0.0 if backoff is None else backoff, "backoff",
                          minimum=0.0)  # fmt: skip
    iu = signal_indices(u, sys.physical_inputs, "u")
    scheduled = gains == "scheduled"
    if lyapunov == "constant":
        K = _constant_gains(sys, iu, objective, scheduled, backoff, margin, solvers)
        return _certified(sys, iu, K, objective, None, margin)
    # The constant-W design holds for any rate and is no slack form: it can
    # be the better one (a bound the slack's scale search does not reach,
    # e.g. with large gains), or the only one found.
    # It is certified for arbitrary rates (so for any bounded ones too).
    designs, errors = [], []
    methods = (
        (lambda: rate_bounded_gains(sys, iu, objective, scheduled, nu, backoff,
                                    margin, solvers), rate_bounds),
        (lambda: _constant_gains(sys, iu, objective, scheduled, backoff, margin,
                                 solvers), None),
    )  # fmt: skip
    for method, rates in methods:
        if designs and objective is None:
            break
        try:
            designs.append(_certified(sys, iu, method(), objective, rates, margin))
        except SynthesisError as err:
            errors.append(err)
    if not designs:
        raise errors[0]
    return min(designs, key=lambda d: d.gamma or 0.0)


def _constant_gains(sys, iu, objective, scheduled, backoff, margin, solvers):
    """The gains at the grid points with one ``W`` (see the module)."""
    from ..lmi import LMIProblem
    from ..schedules.gridded import GriddedLoops
    from ..schedules.schedule import schedule_of

    points = sys.grid.points
    n, m = sys.nstates, len(iu)
    # The geometry (pieces, barycentric maps) of python-control's
    # interpolation of gains at the grid points.
    zero = np.zeros((len(points), m, n))
    schedule = schedule_of((zero, points), names=sys.param_names)
    loops = GriddedLoops(schedule, points, sys, iu)
    data = sys.vertex_data()
    A, B = loops.A, loops.B
    if objective is not None:
        iw = signal_indices(objective.w, sys.physical_inputs, "objective.w")
        iz = signal_indices(objective.z, sys.output_labels, "objective.z")
        Bw = np.array([d[1][:, iw] for d in data])
        Cz = np.array([d[2][iz] for d in data])
        Dzu = np.array([d[3][np.ix_(iz, iu)] for d in data])
        Dzw = np.array([d[3][np.ix_(iz, iw)] for d in data])
    scale = max(1.0, max(float(np.linalg.norm(X, 2)) for X in A))
    lmi = LMIProblem(margin=margin * scale)
    lmi.variable("W", (n, n), symmetric=True)
    lmi.add("W > 0", lambda v: [[-v.W]])
    for g in range(len(points) if scheduled else 1):
        lmi.variable(f"Z{g}", (m, n))
    if objective is None:
        lmi.add("W <= I", lambda v: [[v.W - np.eye(n)]], strict=False,
                normalization=True)  # fmt: skip
    else:
        lmi.variable("g", (1, 1), symmetric=True)

    def Zt(v, coefficients, at):
        """``Z~`` at a corner: the combination of the Z of the points `at`."""
        if not scheduled:
            return v.Z0
        return sum(c * getattr(v, f"Z{j}") for c, j in zip(coefficients, at))

    def term(v, i, coefficients, at):
        X = A[i] @ v.W + B[i] @ Zt(v, coefficients, at)
        if objective is None:
            return (X,)
        Y = Cz[i] @ v.W + Dzu[i] @ Zt(v, coefficients, at)
        return (X, Bw[i], Y, Dzw[i])

    seen = set()
    for piece in loops.pieces:
        c, G = loops._barycentric_map(piece.simplex)
        lam = c[None, :] + points[piece.corners] @ G.T  # (2**k, k + 1)
        at = [int(j) for j in piece.points]
        corners = [int(i) for i in piece.corners]
        inputs = [B] if objective is None else [B, Dzu]
        constant = all(_constant(M[corners]) for M in inputs)
        pairs = [] if constant or not scheduled else list(
            itertools.combinations(range(len(corners)), 2))  # fmt: skip
        items = [((a, a),) for a in range(len(corners))]
        items += [((a, b), (b, a)) for a, b in pairs]
        for item in items:
            key = tuple((corners[a], lam[b].round(14).tobytes(), tuple(at))
                        for a, b in item)  # fmt: skip
            if key in seen:
                continue
            seen.add(key)

            def F(v, item=item, lam=lam, at=at, corners=corners):
                Ts = [term(v, corners[a], lam[b], at) for a, b in item]
                T = tuple(sum(parts) / len(Ts) for parts in zip(*Ts))
                if len(T) == 1:
                    return [[T[0] + T[0].T]]
                X, Bwi, Y, D = T
                return [[X + X.T], [Bwi.T, -np.eye(Bwi.shape[1])],
                        [Y, D, -v.g[0, 0] * np.eye(Y.shape[0])]]  # fmt: skip

            lmi.add(f"piece {len(seen)}: cell {list(piece.cell)} terms {item}", F)
    # The gains' size, K_g W K_g' <= kappa I, minimised in a second stage
    # with the bound backed off from its optimum (the optimum itself is
    # reached with ever larger gains, as in `synthesize`'s backoff).
    lmi.variable("kappa", (1, 1), symmetric=True)
    lmi.parameter("cap", (), value=np.array(0.0), nonneg=True)
    for g in range(len(points) if scheduled else 1):

        def size(v, g=g):
            return [[-v.W], [-getattr(v, f"Z{g}"), -v.kappa[0, 0] * np.eye(m)]]

        lmi.add(f"Z{g} W^-1 Z{g}' <= kappa I", size, strict=False,
                stages=["backoff"])  # fmt: skip
    if objective is not None:
        lmi.add("g <= cap", lambda v: [[v.g - v.cap * np.eye(1)]], strict=False,
                stages=["backoff"])  # fmt: skip
        # An estimate of the optimum (the backed-off point is certified).
        optimal = lmi.solve(lambda v: v.g[0, 0], stage="optimal", solvers=solvers,
                            certify=False)  # fmt: skip
        lmi.set_parameter("cap", (1.0 + backoff) ** 2 * float(optimal.g[0, 0]))
    solution = lmi.solve(lambda v: v.kappa[0, 0], stage="backoff", solvers=solvers)
    W = solution.W
    Winv = np.linalg.inv(0.5 * (W + W.T))
    K = [-getattr(solution, f"Z{g if scheduled else 0}") @ Winv
         for g in range(len(points))]  # fmt: skip
    return K


def _certified(sys, iu, K, objective, rate_bounds, margin) -> GriddedDesign:
    """The design of gains `K`, certified by `certify` on the plant.

    Raises
    ------
    CertificationError
        When `certify` does not certify it (with its verdict).
    """
    from ..schedules import certify

    names = tuple(sys.physical_inputs[i] for i in iu)
    design = GriddedDesign(sys, names, tuple(K), sys.grid.points, None, None)
    verdict = certify(design, sys, objective=objective, rate_bounds=rate_bounds,
                      margin=margin, counterexample=False)  # fmt: skip
    if not verdict.certified:
        raise CertificationError(
            "the designed gains are not certified by certify on the plant:\n"
            + str(verdict)
        )
    return replace(design, gamma=verdict.bound, certificate=verdict)


def _constant(M) -> bool:
    return all(np.array_equal(M[0], X) for X in M)
