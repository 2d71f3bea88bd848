"""Closed loops of a gain schedule on a polytopic plant, cell by cell.

The schedule's points triangulate the parameter box (the cells of its
interpolation, `ctrl_lpv.schedules.schedule`); on a cell the plant's ``A``
and ``B_u`` are affine in ``p`` (checked) and so is the gain, so the closed
loop ``A(p) - B_u(p) K(p) = sum_ij l_i l_j (A_i - B_i K_j)`` in the cell's
convex coordinates ``l``. `PolytopicLoops` gives `ctrl_lpv.certify` what
it asks of closed loops of any kind: the frozen check, the matrices
spanning the loops (arbitrary rates), the channel's loops for a bound, and
the rate-bounded LMIs (`ctrl_lpv.schedules.rates`). The helpers reading a
schedule against a plant (points, control inputs) serve the gridded loops
too (`gridded_loops`).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import partial

import numpy as np

from ..lmi import LMIProblem
from ..systems import PolytopicStateSpace
from .quadratic import quadratic_certificate
from .rates import RateSearch, form_lmis, rate_variables
from .schedule import GainSchedule

__all__ = ["PolytopicLoops", "gridded_loops"]


def gridded_loops(schedule, plant, controller, parameters):
    """The `GriddedLoops` of a gain schedule on a gridded plant."""
    from .gridded import GriddedLoops

    points = _plant_points(schedule, plant, parameters)
    u = _control_inputs(controller, plant, schedule)
    _check_gain_shape(schedule.gains[0], u, plant.nstates)
    return GriddedLoops(schedule, points, plant, u)


def _check_gain_shape(K, u, n):
    if K.shape != (len(u), n):
        raise ValueError(
            f"controller: gains of shape {K.shape}; expected "
            f"{(len(u), n)} (inputs {u}, the plant's states)"
        )


@dataclass(frozen=True)
class PolytopicLoops(RateSearch):
    """The closed loops at the schedule's points, in the plant's parameters."""

    schedule: GainSchedule
    points: np.ndarray  # (M, k) in plant parameter order
    A: np.ndarray  # (M, n, n): the plant at the points
    B: np.ndarray  # (M, n, m): its input matrix of u
    names: tuple
    continuous: bool
    plant: object

    @property
    def K(self) -> np.ndarray:
        return self.schedule.gains

    @property
    def Acl(self) -> np.ndarray:
        """The closed loops at the points."""
        return self.A - self.B @ self.K

    @property
    def bilinear(self) -> bool:
        """Whether ``B_u(p) K(p)`` is quadratic on a cell (both vary)."""
        return _varies(self.K) and _varies(self.B)

    def segments(self):
        """``(start, end, nodes, loops)``: pairs of points of a cell (the
        loop is affine between them when the rate-bounded analysis
        applies; see `destabilising_trajectory`)."""
        if not self.bilinear:
            return [
                (self.points[a], self.points[b], [0.0, 1.0], [self.Acl[a], self.Acl[b]])
                for cell in self.schedule.cells
                for a, b in itertools.combinations(cell, 2)
            ]
        # B_u(p) K(p) is quadratic along a segment: sampled at 33 nodes, the
        # loop interpolated between them (evidence only; it is simulated).
        nodes = np.linspace(0.0, 1.0, 33)
        out = []
        for c, cell in enumerate(self.schedule.cells):
            for a, b in itertools.combinations(range(len(cell)), 2):
                lams = np.zeros((nodes.size, len(cell)))
                lams[:, a], lams[:, b] = 1.0 - nodes, nodes
                out.append((self.points[cell[a]], self.points[cell[b]], nodes,
                            [self.at(c, lam) for lam in lams]))  # fmt: skip
        return out

    def rate_refusal(self) -> str | None:
        """Why the rate-bounded analysis does not apply (None: it does)."""
        if not self.continuous:
            return "in discrete time"
        return None

    def _channel_loops(self, objective):
        """``(loops, bilinear, w, z)``: the channel's matrices at the points.

        On a cell ``C`` and ``D`` must be affine in ``p`` (checked), as
        ``A`` and ``B_u`` are; `bilinear` says whether ``K`` varies with
        ``B_u`` or ``D_zu`` (then the loop is quadratic on a cell).
        """
        from .objective import channel

        iw, iz, of, dzu = channel(objective, self.plant, self._u)
        data = [tuple(np.asarray(M) for M in _frozen(self.plant, p))
                for p in self.points]  # fmt: skip
        for c, cell in enumerate(self.schedule.cells):
            mid = _frozen(self.plant, self.points[cell].mean(axis=0))
            for name, index in (("C", 2), ("D", 3)):
                mean = np.mean([data[i][index] for i in cell], axis=0)
                M = np.asarray(mid[index])
                tol = 1e-12 * max(1.0, np.abs(M).max())
                if not np.allclose(M, mean, rtol=1e-10, atol=tol):
                    raise ValueError(
                        f"plant: {name} is not affine in the parameters on cell "
                        f"{c} (points {self.points[cell].tolist()}): refine the "
                        "schedule's points"
                    )
        Dzu = np.array([dzu(d) for d in data])
        bilinear = _varies(self.K) and (_varies(self.B) or _varies(Dzu))
        loops = [of(d, K) for d, K in zip(data, self.K)]
        if bilinear:
            for cell in self.schedule.cells:
                for i, j in itertools.combinations(cell, 2):
                    ij, ji = of(data[i], self.K[j]), of(data[j], self.K[i])
                    loops.append(tuple(0.5 * (a + b) for a, b in zip(ij, ji)))
        w = [self.plant.physical_inputs[i] for i in iw]
        z = [self.plant.output_labels[i] for i in iz]
        return loops, bilinear, w, z

    def bound(self, objective, margin):
        """``(bound, certificate)`` of the objective's channel, one P.

        On a cell the channel's matrices are affine in ``p`` (checked) and
        ``K`` too: the loop is ``sum_ij l_i l_j T(i, j)`` with ``T(i, j)``
        the loop of point ``i`` under gain ``j``, a convex combination of
        the ``T(i, i)`` and, when ``K`` and ``B_u`` or ``D_zu`` vary, of the
        ``(T(i, j) + T(j, i)) / 2`` of the cell's pairs.
        """
        from .objective import certified_bound

        loops, _, w, z = self._channel_loops(objective)
        return certified_bound(loops, objective, self.plant.dt, margin, w, z,
                               "in the points' convex hull")  # fmt: skip

    def rate_channel(self, objective):
        """``(B_w, C_z, D_zu, D_zw)`` of each cell's points (open loop: the
        gains enter in `_term`), with ``w`` and ``z``."""
        from .objective import channel

        _, _, w, z = self._channel_loops(objective)  # checks C, D affine
        iw, iz, _, _ = channel(objective, self.plant, self._u)
        data = [tuple(np.asarray(M) for M in _frozen(self.plant, self.points[i]))
                for i in range(len(self.points))]  # fmt: skip
        parts = [(B[:, iw], C[iz], D[np.ix_(iz, self._u)], D[np.ix_(iz, iw)])
                 for _, B, C, D in data]  # fmt: skip
        return [tuple([parts[i][k] for i in cell] for k in range(4))
                for cell in self.schedule.cells], w, z  # fmt: skip

    @classmethod
    def of(cls, schedule, plant, controller, parameters):
        if not isinstance(plant, PolytopicStateSpace) or not hasattr(
            plant.domain, "lower"
        ):
            raise TypeError("plant: expected a PolytopicStateSpace over a box")
        points = _plant_points(schedule, plant, parameters)
        names = list(plant.param_names)
        u = _control_inputs(controller, plant, schedule)
        As, Bs = [], []
        for p, K in zip(points, schedule.gains):
            A, B, _, _ = (np.asarray(M) for M in _frozen(plant, p))
            _check_gain_shape(K, u, A.shape[0])
            As.append(A)
            Bs.append(B[:, u])
        for c, cell in enumerate(schedule.cells):
            mid = _frozen(plant, points[cell].mean(axis=0))
            for name, M, at_points in (("A", mid[0], As), ("B", mid[1][:, u], Bs)):
                mean = np.mean([at_points[i] for i in cell], axis=0)
                tol = 1e-12 * max(1.0, np.abs(M).max())
                if not np.allclose(M, mean, rtol=1e-10, atol=tol):
                    raise ValueError(
                        f"plant: {name} is not affine in the parameters on cell "
                        f"{c} (points {points[cell].tolist()}): refine the "
                        "schedule's points"
                    )
        loops = cls(schedule, points, np.array(As), np.array(Bs), tuple(names),
                    not plant.isdtime(strict=True), plant)  # fmt: skip
        object.__setattr__(loops, "_u", u)
        return loops

    def unstable(self, A) -> complex | None:
        eig = np.linalg.eigvals(A)
        worst = eig[np.argmax(eig.real if self.continuous else np.abs(eig))]
        bad = worst.real >= 0 if self.continuous else abs(worst) >= 1
        return complex(worst) if bad else None

    def at(self, cell, lam) -> np.ndarray:
        """The frozen closed loop ``A(p) - B_u(p) K(p)`` in `cell`."""
        idx = self.schedule.cells[cell]
        A, B, K = (np.tensordot(lam, M[idx], axes=1) for M in (self.A, self.B, self.K))
        return A - B @ K

    def spanning(self) -> np.ndarray:
        """Matrices whose convex hull holds every frozen closed loop.

        On a cell ``A(p) - B_u(p) K(p) = sum_ij l_i l_j (A_i - B_i K_j)``
        in the convex coordinates ``l``: a convex combination of the
        ``M_ii`` (the closed loops at the points) and, when ``B_u`` and
        ``K`` both vary, of the ``(M_ij + M_ji) / 2`` of the cell's pairs.
        """
        out = list(self.Acl)
        if self.bilinear:
            for cell in self.schedule.cells:
                for i, j in itertools.combinations(cell, 2):
                    Mij = self.A[i] - self.B[i] @ self.K[j]
                    Mji = self.A[j] - self.B[j] @ self.K[i]
                    out.append(0.5 * (Mij + Mji))
        return np.array(out)

    def frozen_counterexample(self, samples):
        rng = np.random.default_rng(0)
        k1 = self.points.shape[1] + 1
        for c, cell in enumerate(self.schedule.cells):
            lams = np.vstack([np.eye(k1), np.full((1, k1), 1.0 / k1),
                              rng.dirichlet(np.ones(k1), size=samples)])  # fmt: skip
            for lam in lams:
                bad = self.unstable(self.at(c, lam))
                if bad is not None:
                    p = lam @ self.points[cell]
                    from .certify import FrozenCounterexample

                    return FrozenCounterexample(
                        dict(zip(self.names, p.tolist())), c, bad
                    )
        return None

    def quadratic(self, margin):
        return quadratic_certificate(
            list(self.spanning()),
            self.plant.dt,
            margin,
            "stable for arbitrarily fast parameters in the points' convex hull "
            "(one quadratic Lyapunov function of the closed loops at the points)",
        )

    def _rate_problem(self, margin, channel=None):
        n = self.Acl.shape[1]
        M, k = self.points.shape
        scale = max(1.0, float(max(np.linalg.norm(A, 2) for A in self.Acl)))
        lmi = LMIProblem(margin=margin * scale)
        rate_variables(lmi, range(M), n, k, bounded=channel is not None)
        for c, cell in enumerate(self.schedule.cells):
            grad = _gradients(self.points[cell])  # (k, k+1): dlambda_i/dp
            for signs in itertools.product((-1.0, 1.0), repeat=k):

                def G(v, cell=cell, grad=grad, signs=signs):
                    """dP/dt at the rate vertex `signs` on this cell."""
                    Ps = [getattr(v, f"P{i}") for i in cell]
                    dP = [sum(g * P for g, P in zip(grad[d], Ps)) for d in range(k)]
                    return sum(s * v.nu[d] * dP[d] for d, s in enumerate(signs))

                form_lmis(
                    lmi,
                    f"cell {c} rates {signs}",
                    list(cell),
                    3 if self.bilinear else 2,
                    partial(
                        self._term, cell, G, None if channel is None else channel[c]
                    ),
                )
        return lmi

    def _term(self, cell, G, channel, v, order):
        """The coefficient of ``l_order`` in ``dV/dt`` (with a `channel`,
        in the bounded-real matrix of the L2 gain ``g``).

        ``order`` is ``(i, a)`` for the loop at point ``i``, or ``(i, j,
        a)`` for ``A_i - B_i K_j`` when ``B_u`` and ``K`` both vary (the
        loop is then quadratic on a cell), with ``P`` at point ``a``. The
        output ``C_z - D_zu K`` takes the gain of ``order[1]``: the
        coefficients of ``l_i l_a`` (or of ``l_i l_j l_a``) then add up to
        it whether or not ``D_zu`` and ``K`` vary.
        """
        i, j, a = (order[0], order[0], order[1]) if len(order) == 2 else order
        M = self.A[cell[i]] - self.B[cell[i]] @ self.K[cell[j]]
        Pa = getattr(v, f"P{cell[a]}")
        top = M.T @ Pa + Pa @ M + G(v)
        if channel is None:
            return [[top]]
        Bw, Cz, Dzu, Dzw = (part[i] for part in channel)
        Cz = Cz - Dzu @ self.K[cell[order[1]]]
        g = v.g[0, 0]
        return [[top], [Bw.T @ Pa, -g * np.eye(Bw.shape[1])],
                [Cz, Dzw, -g * np.eye(len(Cz))]]  # fmt: skip


def _plant_points(schedule, plant, parameters):
    """The schedule's points in the plant's parameter order, checked."""
    names = list(plant.param_names)
    if schedule.nvars != len(names):
        raise ValueError(
            f"parameters: the schedule has {schedule.nvars} variables "
            f"{list(schedule.names)}, the plant {len(names)} {names}"
        )
    if parameters is None:
        mapping = (
            dict(zip(schedule.names, schedule.names))
            if set(schedule.names) == set(names)
            else dict(zip(schedule.names, names))
        )
    else:
        mapping = dict(parameters)
        if sorted(mapping) != sorted(schedule.names) or sorted(
            mapping.values()
        ) != sorted(names):
            raise ValueError(
                f"parameters: expected {{scheduling variable: plant "
                f"parameter}} for {list(schedule.names)} -> {names}, got "
                f"{mapping}"
            )
    order = [list(schedule.names).index(s) for s in
             sorted(mapping, key=lambda s: names.index(mapping[s]))]  # fmt: skip
    points = schedule.points[:, order]
    lo, hi = plant.domain.lower, plant.domain.upper
    outside = [
        p.tolist() for p in points if np.any(p < lo - 1e-12) or np.any(p > hi + 1e-12)
    ]
    if outside:
        raise ValueError(f"controller: points {outside} are outside the plant's domain")
    return points


def _gradients(V):
    """``d lambda_i / d p_d`` of the convex coordinates on the simplex `V`."""
    M = (V[1:] - V[0]).T  # k x k
    inv = np.linalg.inv(M)  # lambda[1:] = inv @ (p - V0)
    return np.vstack([-inv.sum(axis=0), inv]).T  # (k, k+1)


def _frozen(plant, p):
    delta = plant.domain._weights(np.asarray(p, float))
    return plant._combine(delta)


def _control_inputs(controller, plant, schedule):
    inputs = list(plant.physical_inputs)
    labels = getattr(controller, "output_labels", None)
    if hasattr(controller, "gains") and hasattr(controller, "u"):
        labels = list(controller.u)  # a StateFeedbackDesign
    if labels is None:
        m = schedule.gains.shape[1]
        return list(range(m))
    missing = [s for s in labels if s not in inputs]
    if missing:
        raise ValueError(f"controller: outputs {missing} are not inputs of the plant")
    return [inputs.index(s) for s in labels]


def _varies(M) -> bool:
    return any(not np.array_equal(M[0], X) for X in M)
