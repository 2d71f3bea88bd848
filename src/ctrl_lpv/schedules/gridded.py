"""Closed loops of a gain schedule on a gridded plant, piece by piece.

A `ctrl_lpv.GriddedStateSpace` is multilinear on each grid cell (a box)
and a python-control gain schedule is affine on each simplex of its
triangulation. `certify` splits the parameter domain into **pieces**, the
intersections of positive volume of a grid cell with a schedule simplex
(on a grid's own points python-control's Delaunay simplices are halves of
grid cells). On a piece, with ``w`` the cell's multilinear weights of its
``2**k`` corners (nonnegative, summing to one), the plant is ``sum_i w_i
(A_i, B_i)``, and the gain, affine on the simplex, is ``sum_i w_i K~_i`` with
``K~_i`` its affine extension to corner ``i`` (multilinear weights
reproduce affine functions exactly; `GriddedLoops.corner_gains`). So

.. math::

    A(p) - B_u(p) K(p) = \\sum_{i,j} w_i w_j (A_i - B_i \\tilde K_j)
    = \\sum_i w_i^2 M_{ii} + \\sum_{i<j} 2 w_i w_j \\frac{M_{ij} + M_{ji}}{2},

and the coefficients ``w_i^2`` and ``2 w_i w_j`` are nonnegative and sum
to one: the closed loop lies in the convex hull of the ``M_ii`` and the
``(M_ij + M_ji) / 2``. This is why the multilinear plant is handled
soundly: the closed loop is *not* in the hull of the corners' own closed
loops in general (the product ``B(p) K(p)`` is not multilinear), but it is
in the hull of these terms, and so are the channel's matrices ``(A_i -
B_i K~_j, B_wi, C_zi - D_zui K~_j, D_zwi)``, symmetrised alike. When
``B_u`` (and ``D_zu``) are constant on the cell the loop is multilinear,
``sum_i w_i M_ii``, and the ``M_ii`` suffice; when ``K`` is constant on the
piece, the ``A_i - B_i K``.

With one Lyapunov matrix ``P`` for every product (of every piece) the
Lyapunov and bounded-real inequalities, affine in the loop's matrices for
a fixed ``P``, hold on every convex combination: at every frozen point of
every piece, whatever the parameter's rate.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import partial

import numpy as np
from scipy.optimize import linprog

from .quadratic import quadratic_certificate
from .rates import RateSearch, form_lmis

__all__ = ["GriddedLoops"]


@dataclass(frozen=True)
class Piece:
    """A grid cell intersected with a schedule simplex (positive volume)."""

    cell: tuple  # the grid cell's lower corner on each axis
    corners: np.ndarray  # its grid point indices, box order
    simplex: int  # the schedule cell
    points: np.ndarray  # its schedule point indices
    inside: np.ndarray  # a point inside the piece (plant parameter order)


class GriddedLoops(RateSearch):
    """The closed loops of a schedule on a `GriddedStateSpace`, by pieces.

    Rate-bounded analysis (continuous time): ``P(p) = sum_i w_i(p) P_i``
    multilinear on the grid, continuous across cells, with ``dP/dt =
    sum_a w_a D_a`` on a cell (`ctrl_lpv.schedules.cellrates`). When
    ``B_u`` is constant on the cell or the gain on the piece, the loop is
    ``sum_a w_a M_a`` and ``dV/dt = x' (sum_ab w_a w_b Q_ab) x`` with
    ``Q_ab = M_a' P_b + P_b M_a + (D_a + D_b) / 2``, negative when the
    ``Q_aa`` and the ``Q_ab + Q_ba`` are, at the ``2**k`` corners of the
    rate box (the terms are affine in the rates); when both vary, the loop
    is ``sum_ab w_a w_b M_ab`` and ``dV/dt`` a cubic form, imposed on the
    sums over the orderings of each triple of corners (`_rate_problem`).
    With an `Hinf` objective the bounded-real inequality with ``P(p)``
    (`rate_bound`).

    Parameters
    ----------
    schedule : `GainSchedule`
    points : ndarray
        The schedule's points in the plant's parameter order.
    plant : `GriddedStateSpace`
    u : list of int
        The plant inputs the schedule's gains drive.
    """

    def __init__(self, schedule, points, plant, u):
        self.schedule = schedule
        self.points = points
        self.plant = plant
        self.grid = plant.domain
        self.names = tuple(plant.param_names)
        self.continuous = not plant.isdtime(strict=True)
        self.u = list(u)
        data = plant.vertex_data()
        self.A = np.array([d[0] for d in data])
        self.B = np.array([d[1][:, u] for d in data])
        self.K = schedule.gains
        self.pieces = self._pieces()
        if not self.pieces:
            raise ValueError(
                "controller: the schedule's points span no volume of the plant's "
                "grid (nothing to certify)"
            )

    # ------------------------------------------------------------------
    # Geometry
    # ------------------------------------------------------------------
    def _barycentric_map(self, s):
        """``(c, G)`` with ``l = c + G p`` on schedule simplex `s`, or None."""
        V = self.points[self.schedule.cells[s]]
        T = (V[1:] - V[0]).T
        scale = max(1.0, float(np.abs(T).max()))
        if abs(np.linalg.det(T / scale)) < 1e-12:
            return None  # a flat simplex holds no volume
        inv = np.linalg.inv(T)
        G = np.vstack([-inv.sum(axis=0), inv])
        c = np.concatenate([[1.0], np.zeros(len(V) - 1)]) - G @ V[0]
        return c, G

    def _pieces(self):
        grid, k = self.grid, self.grid.nparams
        pieces = []
        for s in range(len(self.schedule.cells)):
            bary = self._barycentric_map(s)
            if bary is None:
                continue
            V = self.points[self.schedule.cells[s]]
            vlo, vhi = V.min(axis=0), V.max(axis=0)
            ranges = []
            for a, lo, hi in zip(grid.axes, vlo, vhi):
                first = max(int(np.searchsorted(a, lo, side="right")) - 1, 0)
                last = min(int(np.searchsorted(a, hi, side="left")), a.size - 1)
                ranges.append(range(first, max(last, first + 1)))
            for cell in itertools.product(*ranges):
                cell = tuple(min(i, n - 2) for i, n in zip(cell, grid.shape))
                lo = np.array([a[i] for a, i in zip(grid.axes, cell)])
                hi = np.array([a[i + 1] for a, i in zip(grid.axes, cell)])
                inside = self._common_point(bary, lo, hi, vlo, vhi, V, k)
                if inside is not None:
                    pieces.append(Piece(cell, grid.corners(cell), s,
                                        self.schedule.cells[s], inside))  # fmt: skip
        return pieces

    @staticmethod
    def _common_point(bary, lo, hi, vlo, vhi, V, k):
        """A point inside both the box and the simplex, or None (no volume)."""
        width = hi - lo
        tol = 1e-9 * width
        if np.all(vlo >= lo - tol) and np.all(vhi <= hi + tol):
            return V.mean(axis=0)  # the simplex lies in the box
        if np.any(np.minimum(hi, vhi) - np.maximum(lo, vlo) <= tol):
            return None
        c, G = bary
        # max t: l(p) >= t, lo + t * width <= p <= hi - t * width.
        A_ub = np.vstack([np.hstack([-G, np.ones((k + 1, 1))]),
                          np.hstack([-np.eye(k), width[:, None]]),
                          np.hstack([np.eye(k), width[:, None]])])  # fmt: skip
        b_ub = np.concatenate([c, -lo, hi])
        res = linprog(np.r_[np.zeros(k), -1.0], A_ub=A_ub, b_ub=b_ub,
                      bounds=[(None, None)] * k + [(None, 1.0)])  # fmt: skip
        if res.status != 0 or -res.fun <= 1e-9:
            return None
        return res.x[:k]

    def weights(self, piece, p):
        """``(w, l)``: the cell's corner weights and the simplex's of `p`."""
        cell = piece.cell
        lam = self.grid.local(cell, p)
        w = np.prod(np.where(self.grid._bits, lam, 1.0 - lam), axis=1)
        c, G = self._barycentric_map(piece.simplex)
        return w, c + G @ np.asarray(p, float)

    def closed_loop(self, piece, p) -> np.ndarray:
        """The frozen closed loop ``A(p) - B_u(p) K(p)`` at `p` in `piece`."""
        w, lam = self.weights(piece, p)
        A = np.tensordot(w, self.A[piece.corners], axes=1)
        B = np.tensordot(w, self.B[piece.corners], axes=1)
        K = np.tensordot(lam, self.K[piece.points], axes=1)
        return A - B @ K

    # ------------------------------------------------------------------
    # The products spanning each piece
    # ------------------------------------------------------------------
    def corner_gains(self, piece) -> np.ndarray:
        """``K~_i``: the simplex's affine gain extended to the cell's corners.

        Multilinear weights reproduce affine functions exactly, so on the
        piece ``K(p) = sum_i w_i(p) K~_i`` (a corner outside the simplex
        gets the extrapolated gain).
        """
        c, G = self._barycentric_map(piece.simplex)
        lam = c[None, :] + self.grid.points[piece.corners] @ G.T
        return np.tensordot(lam, self.K[piece.points], axes=1)

    def products(self, piece, inputs=None):
        """The terms spanning `piece`: ``[(i, a) or ((i, b), (j, a)), ...]``.

        ``(i, a)`` is corner ``i``'s plant under the extended gain of
        corner ``a`` (`corner_gains`, by position in the cell); a pair of
        terms is their mean. `inputs`: the matrices multiplied by ``K`` at
        the grid points (default ``B_u``; with an objective also ``D_zu``).
        """
        inputs = (self.B,) if inputs is None else inputs
        corners = list(piece.corners)
        diagonal = [(i, a) for a, i in enumerate(corners)]
        if _constant(self.K[list(piece.points)]):
            return [(i, 0) for i in corners]
        if all(_constant(M[corners]) for M in inputs):
            return diagonal
        return diagonal + [
            ((corners[a], b), (corners[b], a))
            for a, b in itertools.combinations(range(len(corners)), 2)
        ]

    def spanning(self) -> np.ndarray:
        """Closed-loop matrices whose convex hull holds every frozen loop."""
        out = {}
        for piece in self.pieces:
            K = self.corner_gains(piece)
            for term in self.products(piece):
                (M,) = self._term(
                    term, lambda i, a, K=K: (self.A[i] - self.B[i] @ K[a],)
                )
                out.setdefault(M.tobytes(), M)
        return np.array(list(out.values()))

    @staticmethod
    def _term(term, of):
        """The matrices (a tuple) of a term ``(i, a)``, or the mean of a pair."""
        if isinstance(term[0], tuple):
            return tuple(0.5 * (a + b) for a, b in zip(of(*term[0]), of(*term[1])))
        return of(*term)

    @property
    def Acl(self) -> np.ndarray:
        return self.spanning()

    region = "on the plant's grid cells within the schedule's points"
    lyapunov_form = "P(p) multilinear on each grid cell, continuous"

    def rate_refusal(self) -> str | None:
        """Why the rate-bounded analysis does not apply (None: it does)."""
        if not self.continuous:
            return "in discrete time"
        return None

    def families(self):
        """``[(piece, K~)]``: each piece with its gains extended to the
        cell's corners (`corner_gains`), pieces with the same cell and
        gains once."""
        out, seen = [], set()
        for piece in self.pieces:
            K = self.corner_gains(piece)
            key = (piece.cell, K.tobytes())
            if key not in seen:
                seen.add(key)
                out.append((piece, K))
        return out

    def segments(self):
        """``(start, end, nodes, loops)``: grid lines across a simplex.

        Along one axis, the grid points of a line that lie in one schedule
        simplex (a run, the simplex being convex): there the gain is affine
        and the plant piecewise affine between the grid points, so the loop
        is the linear interpolation of its values at them (``nodes``, the
        relative positions from 0 to 1; see `destabilising_trajectory`).
        When ``B_u`` and the gain both vary, the loop is quadratic between
        grid points and this interpolation approximates it: the trajectory
        is evidence to confirm by simulation (sampling 8 points per grid
        step instead took 35 times longer on a rotating-input example and
        found nothing more).
        """
        grid, out = self.grid, {}
        for s in {piece.simplex for piece in self.pieces}:
            c, G = self._barycentric_map(s)
            points = self.schedule.cells[s]
            inside = np.all(grid.points @ G.T + c >= -1e-12, axis=1)
            index = np.flatnonzero(inside)
            if index.size < 2:
                continue
            multi = np.array(np.unravel_index(index, grid.shape)).T
            for d in range(grid.nparams):
                lines = {}
                for i, m in zip(index, multi):
                    lines.setdefault(tuple(np.delete(m, d)), []).append((m[d], i))
                for line in lines.values():
                    if len(line) < 2:
                        continue
                    run = [i for _, i in sorted(line)]
                    lam = grid.points[run] @ G.T + c
                    K = np.tensordot(lam, self.K[points], axes=(1, 0))
                    M = [self.A[i] - self.B[i] @ Ki for i, Ki in zip(run, K)]
                    ends = grid.points[[run[0], run[-1]]]
                    span = ends[1][d] - ends[0][d]
                    nodes = (grid.points[run][:, d] - ends[0][d]) / span
                    key = b"".join(x.tobytes() for x in M)
                    out.setdefault(key, (ends[0], ends[1], nodes, M))
        return list(out.values())

    def rate_bounded(self, nu, margin, lmi=None, solvers=None):
        """`RateSearch.rate_bounded`; an infinite rate makes ``P``
        independent of its parameter (`ctrl_lpv.schedules.cellrates`)."""
        nu = np.asarray(nu, float)
        if lmi is None:
            lmi = self._rate_problem(margin, tuple(np.flatnonzero(np.isinf(nu))))
        return super().rate_bounded(
            np.where(np.isinf(nu), 0.0, nu), margin, lmi, solvers
        )

    #: A parameter may be left out of the rates (its P does not depend on it).
    unbounded_rates = True

    def rate_bound(self, objective, nu, margin):
        """``(bound, certificate)``: the `Hinf` bound with rates `nu`, or
        None when it is not certified (`RateSearch.rate_bound`).

        ``P(p)`` multilinear on the grid (an infinite rate: independent of
        its parameter), the bounded-real inequality with ``dP/dt`` at the
        vertices of the rate box, minimising the bound.
        """
        from ..certificate import Certificate, Check
        from ..exceptions import SynthesisError
        from ..synthesis import Hinf

        if not isinstance(objective, Hinf):
            raise ValueError(
                "objective: under a rate bound only the L2 gain (Hinf) is "
                "bounded; the H2 bound needs arbitrary rates"
            )
        nu = np.asarray(nu, float)
        lmi = self._rate_problem(margin, tuple(np.flatnonzero(np.isinf(nu))),
                                 objective)  # fmt: skip
        lmi.set_parameter("nu", np.where(np.isinf(nu), 0.0, nu))
        try:
            sol = lmi.solve(lambda v: v.g[0, 0])
        except SynthesisError:
            return None
        bound = float(np.sqrt(sol.g[0, 0]))
        checks = tuple(Check.from_lmi_check(c, group="rate-bounded L2 gain")
                       for c in sol.checks)  # fmt: skip
        rates = ", ".join(f"|d{n}/dt| <= {v:.4g}" for n, v in zip(self.names, nu))
        statement = (
            f"L2 gain from {list(objective.w)} to {list(objective.z)} below "
            f"{bound:.6g} for parameter trajectories {self.region} with {rates} "
            f"({self.lyapunov_form})"
        )
        return bound, Certificate(checks, statement=statement)

    def _rate_problem(self, margin, unbounded=(), objective=None):
        """The rate-bounded LMIs, with the rates a parameter ``"nu"``.

        On a piece the loop is ``sum_ij w_i w_j M_ij`` (``M_ij = A_i - B_i
        K~_j``; linear, ``sum_i w_i M_ii``, when ``B_u`` is constant on the
        cell or the gain on the piece) and ``P = sum_k w_k P_k``, so
        ``dV/dt`` is a homogeneous form of degree three (two) in ``w``
        with coefficients ``He(M_ij' P_k) + D_k``, imposed through
        `orderings`. With an `Hinf` objective, the bounded-real inequality
        ``[[He(M' P) + dP/dt, *, *], [B_w' P, -I, *], [C_cl, D_zw, -g I]]
        < 0`` (bound ``sqrt(g)``), of the same degree.
        """
        from ..lmi import LMIProblem
        from .cellrates import CellRates, lyapunov_index

        grid, n, k = self.grid, self.A.shape[1], self.grid.nparams
        index = lyapunov_index(grid, unbounded)
        data = self.plant.vertex_data()
        inputs = [self.B]
        if objective is not None:
            from .objective import channel

            iw, iz, _, _ = channel(objective, self.plant, self.u)
            Bw = np.array([d[1][:, iw] for d in data])
            Cz = np.array([d[2][iz] for d in data])
            Dzu = np.array([d[3][np.ix_(iz, self.u)] for d in data])
            Dzw = np.array([d[3][np.ix_(iz, iw)] for d in data])
            inputs.append(Dzu)
        families = self.families()
        scale = max(1.0, max(float(np.linalg.norm(self.A[i] - self.B[i] @ K[a], 2))
                             for piece, K in families
                             for a, i in enumerate(piece.corners)))  # fmt: skip
        lmi = LMIProblem(margin=margin * scale)
        used = sorted({int(index[i]) for p, _ in families for i in p.corners})
        for q in used:
            lmi.variable(f"P{q}", (n, n), symmetric=True)
            lmi.add(f"P{q} > 0", lambda v, q=q: [[-getattr(v, f"P{q}")]])
            if objective is None:
                lmi.add(f"P{q} <= I",
                        lambda v, q=q: [[getattr(v, f"P{q}") - np.eye(n)]],
                        strict=False, normalization=True)  # fmt: skip
        if objective is not None:
            lmi.variable("g", (1, 1), symmetric=True)
        lmi.parameter("nu", (k,), value=np.zeros(k), nonneg=True)

        def sym(X):
            return X + X.T

        for count, (piece, K) in enumerate(families):
            corners = [int(i) for i in piece.corners]
            cell = CellRates.of(grid, corners, unbounded)
            cubic = not _constant(K) and not all(_constant(M[corners]) for M in inputs)
            degree = 3 if cubic else 2

            def P(v, a, corners=corners):
                return getattr(v, f"P{index[corners[a]]}")

            def term(v, order, signs, corners=corners, cell=cell, K=K, P=P):
                """The coefficient of ``w_order``: plant, gain, then P."""
                i, j, a = (order[0], order[0], order[1]) if len(order) == 2 else order
                c = corners[i]
                Pa = P(v, a)
                D = cell.derivative(lambda b: P(v, b), a, signs, v.nu)
                M = self.A[c] - self.B[c] @ K[j]
                top = sym(M.T @ Pa) + D
                if objective is None:
                    return [[top]]
                return [[top], [Bw[c].T @ Pa, -np.eye(Bw.shape[2])],
                        [Cz[c] - Dzu[c] @ K[j], Dzw[c],
                         -v.g[0, 0] * np.eye(Cz.shape[1])]]  # fmt: skip

            for signs in cell.vertices():
                where = f"cell {list(piece.cell)} piece {count} rates {signs}"
                form_lmis(lmi, where, corners, degree, partial(term, signs=signs))
        return lmi

    # ------------------------------------------------------------------
    # Frozen check, arbitrary rates, the channel's bound
    # ------------------------------------------------------------------
    def frozen_counterexample(self, samples):
        from .certify import FrozenCounterexample

        rng = np.random.default_rng(0)
        grid = self.grid
        for piece in self.pieces:
            lo = grid.points[piece.corners[0]]
            hi = grid.points[piece.corners[-1]]
            V = self.points[piece.points]
            random = rng.uniform(lo, hi, size=(samples, len(lo)))
            candidates = np.vstack(
                [grid.points[piece.corners], V, piece.inside, random]
            )
            c, G = self._barycentric_map(piece.simplex)
            tol = 1e-12 * max(1.0, float(np.abs(candidates).max()))
            for p in candidates:
                if np.any(p < lo - tol) or np.any(p > hi + tol):
                    continue
                if np.any(c + G @ p < -1e-12):
                    continue
                eig = self._unstable(self.closed_loop(piece, p))
                if eig is not None:
                    return FrozenCounterexample(dict(zip(self.names, p.tolist())),
                                                piece.cell, eig)  # fmt: skip
        return None

    def _unstable(self, A):
        eig = np.linalg.eigvals(A)
        worst = eig[np.argmax(eig.real if self.continuous else np.abs(eig))]
        bad = worst.real >= 0 if self.continuous else abs(worst) >= 1
        return complex(worst) if bad else None

    def quadratic(self, margin):
        return quadratic_certificate(
            list(self.spanning()),
            self.plant.dt,
            margin,
            "stable for arbitrarily fast parameters on the plant's grid cells "
            "within the schedule's points (one quadratic Lyapunov function of "
            "the closed-loop products spanning every piece)",
        )

    def bound(self, objective, margin):
        """``(bound, certificate)`` of the `Hinf` or `H2` objective, constant P.

        Raises
        ------
        SynthesisError
            When the engine certifies no bound.
        """
        from .objective import certified_bound, channel

        iw, iz, of, dzu = channel(objective, self.plant, self.u)
        data = self.plant.vertex_data()
        Dzu = np.array([dzu(d) for d in data])
        loops = []
        for piece in self.pieces:
            K = self.corner_gains(piece)
            loops += [self._term(term, lambda i, a, K=K: of(data[i], K[a]))
                      for term in self.products(piece, (self.B, Dzu))]  # fmt: skip
        w = [self.plant.physical_inputs[i] for i in iw]
        z = [self.plant.output_labels[i] for i in iz]
        return certified_bound(loops, objective, self.plant.dt, margin, w, z,
                               "on the plant's grid cells within the schedule's "
                               "points")  # fmt: skip


def _constant(M) -> bool:
    return all(np.array_equal(M[0], X) for X in M)
