"""Rate-bounded state feedback on a gridded plant: gains at the grid points.

The Lyapunov function is ``V = x' X(p)^-1 x`` with ``X(p)`` multilinear on
each grid cell, its values ``X_g`` at the grid points (continuous across
cells; independent of a parameter whose rate is unbounded), as in Wu, Yang,
Packard and Becker (1996), whose gridded rate-bounded synthesis LPVTools'
``lpvsyn`` implements. Unlike theirs, the conditions hold between the grid
points too, not only at them, and the gains are python-control's.

The gains are those of `control.create_statefbk_iosystem` with
``gainsched_method="linear"``: ``K_g`` at the grid points, affine on the
Delaunay triangles. ``K(p) = -Z(p) X(p)^-1`` (the dual variables of a
constant ``W``) is rational in ``p`` and not of that form, so the slack
(extended) inequality of the projection lemma is used, with a constant
slack ``G``: ``K(p) = -Y(p) G^-1``, where ``Y`` interpolates like ``K``
(``K_g = -Y_g G^-1``). With ``A_cl = A - B_u K`` (and ``C_cl = C_z - D_zu
K``), ``A_cl G = A G + B_u Y`` and

.. math::

    \\begin{bmatrix} -\\dot X + \\mathrm{He}(A_{cl} G) & \\star \\\\
    X - G + \\epsilon G' A_{cl}' & -\\epsilon (G + G') \\end{bmatrix} < 0

gives, multiplied by ``[I, A_cl]`` on the left and its transpose on the
right, ``A_cl X + X A_cl' - dX/dt < 0``: ``dV/dt < 0`` (Pipeleers,
Demeulenaere and Swevers 2009; Apkarian, Tuan and Bernussou 2001). With an
`Hinf` objective the slack enters the dual bounded-real inequality alike
(``C_cl X`` becomes ``C_cl G``; `_block`). The scalar ``epsilon`` is
searched on a few values. With a constant ``X`` and ``G = X`` and a small
``epsilon`` the inequality is the constant-``W`` one: the search starts
there.

On a piece of a grid cell (`ctrl_lpv.schedules.gridded`) the plant is
multilinear in the cell's weights ``w``, ``Y`` is too (``Y~_a``, its affine
extension to the corners), ``X`` and ``dX/dt`` are linear in ``w`` and
``dX/dt`` affine in the rates: the inequality is a form of degree two in
``w`` (one when ``B_u`` and ``D_zu`` are constant on the cell, or the gain
common), imposed on its coefficients (`ctrl_lpv.schedules.cellrates`) at
the vertices of the rate box. The design is then certified by
`ctrl_lpv.certify` (``P(p)`` multilinear, an independent family).
"""

from __future__ import annotations

from functools import partial

import numpy as np

from .._checks import signal_indices
from ..exceptions import CertificationError, SynthesisError

__all__ = ["rate_bounded_gains"]

# epsilon times the data's scale, in the order tried: the constant-W limit
# first, then slacks that let X(p) vary more.
EPSILONS = (0.03, 0.3, 3.0)


def rate_bounded_gains(sys, iu, objective, scheduled, nu, backoff, margin,
                       solvers) -> list:  # fmt: skip
    """The gains ``K_g`` at the grid points (see the module).

    Parameters
    ----------
    sys : `ctrl_lpv.GriddedStateSpace`
        The plant (continuous time).
    iu : list of int
        Its control inputs.
    objective : `Hinf` or None
    scheduled : bool
        Gains at the grid points, or one.
    nu : ndarray
        The rate bound of each parameter (``inf``: arbitrarily fast).
    backoff, margin, solvers
        As for `ctrl_lpv.synthesis.gridded.synthesize_gridded`.

    Returns
    -------
    list of ndarray
        ``K_g`` in the order of ``sys.grid.points`` (not yet certified).

    Raises
    ------
    CertificationError
        When no ``epsilon`` gives a certified solution.
    """
    from ..lmi import LMIProblem
    from ..schedules.cellrates import CellRates, lyapunov_index
    from ..schedules.gridded import GriddedLoops, _constant
    from ..schedules.rates import form_lmis
    from ..schedules.schedule import schedule_of

    grid, points = sys.grid, sys.grid.points
    n, m = sys.nstates, len(iu)
    zero = np.zeros((len(points), m, n))
    loops = GriddedLoops(schedule_of((zero, points), names=sys.param_names),
                         points, sys, iu)  # fmt: skip
    data = sys.vertex_data()
    A, B = loops.A, loops.B
    inputs = [B]
    channel = None
    if objective is not None:
        iw = signal_indices(objective.w, sys.physical_inputs, "objective.w")
        iz = signal_indices(objective.z, sys.output_labels, "objective.z")
        channel = (np.array([d[1][:, iw] for d in data]),
                   np.array([d[2][iz] for d in data]),
                   np.array([d[3][np.ix_(iz, iu)] for d in data]),
                   np.array([d[3][np.ix_(iz, iw)] for d in data]))  # fmt: skip
        inputs.append(channel[2])
    unbounded = tuple(int(d) for d in np.flatnonzero(np.isinf(nu)))
    rates = np.where(np.isinf(nu), 0.0, nu)
    index = lyapunov_index(grid, unbounded)
    scale = max(1.0, max(float(np.linalg.norm(X, 2)) for X in A))
    lmi = LMIProblem(margin=margin * scale)
    for q in sorted(set(index.tolist())):
        lmi.variable(f"X{q}", (n, n), symmetric=True)
        lmi.add(f"X{q} > 0", lambda v, q=q: [[-getattr(v, f"X{q}")]])
        if objective is None:
            lmi.add(f"X{q} <= I", lambda v, q=q: [[getattr(v, f"X{q}") - np.eye(n)]],
                    strict=False, normalization=True)  # fmt: skip
    lmi.variable("G", (n, n))
    for g in range(len(points) if scheduled else 1):
        lmi.variable(f"Y{g}", (m, n))
    if objective is not None:
        lmi.variable("g", (1, 1), symmetric=True)
    lmi.parameter("eps", (), value=EPSILONS[0] / scale, pos=True)

    def X(v, i):
        return getattr(v, f"X{index[i]}")

    seen = set()
    for piece in loops.pieces:
        c, Gb = loops._barycentric_map(piece.simplex)
        lam = c[None, :] + points[piece.corners] @ Gb.T  # (2**k, k + 1)
        at = [int(j) for j in piece.points]
        corners = [int(i) for i in piece.corners]
        key = (tuple(corners), lam.round(14).tobytes(), tuple(at))
        if key in seen:
            continue
        seen.add(key)
        cell = CellRates.of(grid, corners, unbounded)
        linear = not scheduled or all(_constant(M[corners]) for M in inputs)

        def Yt(v, b, lam=lam, at=at):
            """``Y~`` at corner position `b`."""
            if not scheduled:
                return v.Y0
            return sum(x * getattr(v, f"Y{j}") for x, j in zip(lam[b], at))

        def term(v, order, signs, corners=corners, cell=cell, Yt=Yt):
            """The coefficient of ``w_order``: plant and X at the first
            corner, the gain's extension at the last."""
            a, b = order[0], order[-1]
            i = corners[a]
            Xdot = cell.derivative(lambda e: X(v, corners[e]), a, signs, rates)
            return _block(v, A[i], B[i], Yt(v, b), X(v, i), Xdot, channel, i)

        for signs in cell.vertices():
            where = f"cell {list(piece.cell)} simplex {piece.simplex} rates {signs}"
            form_lmis(lmi, where, corners, 1 if linear else 2,
                      partial(term, signs=signs))  # fmt: skip
    # The gains' size, K_g X_g K_g' <= kappa I (implied by the LMI below,
    # as G' X^-1 G >= G + G' - X), minimised in a second stage with the
    # bound backed off from its optimum.
    lmi.variable("kappa", (1, 1), symmetric=True)
    lmi.parameter("cap", (), value=np.array(0.0), nonneg=True)
    for g in range(len(points) if scheduled else 1):

        def size(v, g=g):
            Y = getattr(v, f"Y{g}")
            return [[-v.kappa[0, 0] * np.eye(m)], [-Y.T, X(v, g) - v.G - v.G.T]]

        lmi.add(f"Y{g} (G + G' - X{g})^-1 Y{g}' <= kappa I", size, strict=False,
                stages=["backoff"])  # fmt: skip
    if objective is not None:
        lmi.add("g <= cap", lambda v: [[v.g - v.cap * np.eye(1)]], strict=False,
                stages=["backoff"])  # fmt: skip
    solution = _search(lmi, objective is not None, backoff, scale, solvers)
    Ginv = np.linalg.inv(solution.G)
    return [-getattr(solution, f"Y{g if scheduled else 0}") @ Ginv
            for g in range(len(points))]  # fmt: skip


def _search(lmi, bounded, backoff, scale, solvers):
    """The certified solution at the best ``epsilon`` of `EPSILONS`.

    Each ``epsilon`` is tried with the first solver of the chain (the others
    would only spend their iterations on a slack scale that does not fit);
    the whole chain solves at the chosen one, or, when the first solver
    found none, at each ``epsilon`` where it did not report the problem
    infeasible (a failed search otherwise spends minutes in SCS to find
    nothing more).
    """
    from ..lmi.solvers import default_solvers

    chain = solvers or default_solvers()
    failures = []

    infeasible = set()

    def attempt(eps, stage, objective, chain, certify=True):
        lmi.set_parameter("eps", eps / scale)
        try:
            return lmi.solve(objective, stage=stage, solvers=chain, certify=certify)
        except SynthesisError as err:
            failures.append(f"epsilon {eps / scale:.3g}: {str(err).splitlines()[0]}")
            if [a.status for a in err.attempts] == ["infeasible"]:
                infeasible.add(eps)
            return None

    def size(v):
        return v.kappa[0, 0]

    if bounded:
        found = []
        for eps in EPSILONS:
            estimate = attempt(eps, "optimal", lambda v: v.g[0, 0], chain[:1], False)
            if estimate is not None:
                found.append((float(estimate.g[0, 0]), eps))
        retry = [(None, e) for e in EPSILONS if e not in infeasible]
        for value, eps in sorted(found) or retry:
            if value is None:
                estimate = attempt(eps, "optimal", lambda v: v.g[0, 0], chain, False)
                if estimate is None:
                    continue
                value = float(estimate.g[0, 0])
            lmi.set_parameter("cap", (1.0 + backoff) ** 2 * value)
            solution = attempt(eps, "backoff", size, chain)
            if solution is not None:
                return solution
    else:
        for eps in EPSILONS:
            solution = attempt(eps, "backoff", size, chain[:1])
            if solution is not None:
                return solution
        for eps in [e for e in EPSILONS if e not in infeasible]:
            solution = attempt(eps, "backoff", size, chain)
            if solution is not None:
                return solution
    raise CertificationError(
        "rate-bounded synthesis on the grid: no solution for any slack scale "
        "epsilon:\n" + "\n".join(failures)
    )


def _block(v, A, B, Y, X, Xdot, channel, i):
    """The slack inequality of one coefficient (the module's, with the
    dual bounded-real rows of an objective), lower block triangle."""
    AG = A @ v.G + B @ Y
    eps = v.eps
    last = X - v.G + eps * AG.T
    corner = -eps * (v.G + v.G.T)
    top = AG + AG.T - Xdot
    if channel is None:
        return [[top], [last, corner]]
    Bw, Cz, Dzu, Dzw = (M[i] for M in channel)
    CG = Cz @ v.G + Dzu @ Y
    nw, nz = Bw.shape[1], Cz.shape[0]
    return [[top], [Bw.T, -np.eye(nw)], [CG, Dzw, -v.g[0, 0] * np.eye(nz)],
            [last, np.zeros((A.shape[0], nw)), eps * CG.T, corner]]  # fmt: skip
