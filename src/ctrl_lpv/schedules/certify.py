"""Is a gain schedule stable, and for how fast a parameter?

`certify` takes a scheduled state feedback as python-control builds it (or a
table of gains at points) and a polytopic or gridded plant, and answers
with a `ScheduleCertificate`. For a polytopic plant:

1. **frozen**: the closed loop at every point and at seeded samples inside
   every cell; an unstable one is the counterexample (cell, point,
   eigenvalue), and nothing more is claimed;
2. **arbitrary rates**: one quadratic Lyapunov function for the closed loops
   at the points (`ctrl_lpv.quadratic_stability`). On a cell ``A`` and
   ``B_u`` are affine in ``p`` (checked), so the closed loop is a convex
   combination of the points' closed loops and, when ``B_u`` and ``K`` both
   vary, of the cell's pairwise terms (`_ClosedLoops.spanning`);
3. **rate-bounded** (continuous time, ``B_u`` or ``K`` constant): a
   Lyapunov matrix ``P(p)`` affine on each cell, continuous across cells,
   with ``|dp_k/dt| <= nu_k``; on a cell ``dV/dt`` is a quadratic form in
   the convex coordinates, negative when its diagonal and pairwise terms
   are (the sufficient condition of Tuan, Apkarian and Nguyen, and of
   Oliveira and Peres for polynomial
   parameter dependence). The largest certified ``nu`` (the same scale on
   every parameter's given rate, 1 per time unit by default) is found by
   bisection, each step a certified LMI solve; above it nothing is claimed,
   and `ctrl_lpv.schedules.counterexample` looks for a periodic parameter
   trajectory that destabilises the loop;
4. **objective** (`Hinf` or `H2` of a named channel): the bound with one
   Lyapunov matrix for the channel's terms spanning the loops (arbitrary
   rates; `ctrl_lpv.schedules.objective`). On a gridded plant in
   continuous time, an `Hinf` objective with ``rate_bounds`` is also
   bounded with ``P(p)`` and those rates (the smaller bound is reported).

For a `ctrl_lpv.GriddedStateSpace` the same steps run on the pieces of
grid cells and schedule simplices, with the terms and the multilinear
``P(p)`` of `ctrl_lpv.schedules.gridded` (independent of a parameter
whose rate is not bounded).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from .._checks import checked_rates, real_number
from ..certificate import Certificate
from ..exceptions import SynthesisError
from ..lmi import LMIProblem
from ..systems import GriddedStateSpace, PolytopicStateSpace
from .objective import checked_objective
from .quadratic import quadratic_certificate
from .rates import RateSearch
from .schedule import GainSchedule, schedule_of

__all__ = ["certify", "ScheduleCertificate", "FrozenCounterexample"]


@dataclass(frozen=True)
class FrozenCounterexample:
    """A frozen parameter value whose closed loop is unstable.

    Attributes
    ----------
    point : dict
        The parameter value.
    cell : int
        The schedule's cell containing it.
    eigenvalue : complex
        The closed loop's eigenvalue with the largest real part (modulus in
        discrete time).
    """

    point: dict
    cell: int
    eigenvalue: complex


@dataclass(frozen=True)
class ScheduleCertificate:
    """The verdict of `certify`.

    Attributes
    ----------
    certified : bool
        Stable for every parameter trajectory in the points' convex hull
        (on a gridded plant: in its grid cells within it) with the rates
        asked for (``rate_bounds``; arbitrary rates if None), and with an
        objective its bound certified too.
    rate_bound : dict
        ``{parameter: rate}`` certified; ``inf`` for arbitrary rates, ``0``
        when only frozen stability (or nothing) is established.
    counterexample : `FrozenCounterexample`, `ParameterTrajectory` or None
        Where it fails: an unstable frozen point, or a parameter trajectory
        (above the certified rate) whose simulated state grows.
    certificate : `ctrl_lpv.Certificate`
        The float64 checks of what is certified.
    tried : tuple of str
        What was tried, in order.
    bound : float or None
        With an `objective`: the certified bound of its channel (L2 gain for
        `Hinf`, H2 for `H2`) for the rates of `rate_bound` (arbitrarily
        fast parameters: ``inf``); None otherwise or when it is not
        certified (then `certified` is False).
    """

    certified: bool
    rate_bound: dict
    counterexample: object
    certificate: Certificate
    tried: tuple[str, ...] = field(default=())
    bound: float | None = None

    def __str__(self) -> str:
        rates = ", ".join(f"|d{k}/dt| <= {v:.4g}" for k, v in self.rate_bound.items())
        head = "certified" if self.certified else "not certified"
        lines = [f"{head}; rate bound: {rates or 'none'}"]
        if self.bound is not None:
            lines.append(f"bound: {self.bound:.6g}")
        if self.counterexample is not None:
            lines.append(f"counterexample: {self.counterexample}")
        lines += [f"tried: {t}" for t in self.tried]
        return "\n".join(lines)


def certify(
    controller,
    plant,
    *,
    parameters=None,
    rate_bounds=None,
    objective=None,
    margin: float = 1e-6,
    samples: int = 20,
    counterexample: bool = True,
) -> ScheduleCertificate:
    """Certify a gain schedule on an LPV plant, and find its rate bound.

    Parameters
    ----------
    controller : NonlinearIOSystem, tuple, `StateFeedbackDesign` or `GainSchedule`
        A scheduled state feedback ``u = -K(p) x`` from
        `control.create_statefbk_iosystem` (``gain=(gains, points)``,
        ``gainsched_method="linear"``), a table ``(gains, points)``, a
        design of this library (certified on another plant, e.g. the true
        one), or a `GainSchedule`. Its outputs (for a table: ``u``, the
        plant's inputs in order) are plant inputs; ``K`` acts on the plant's
        states.
    plant : `PolytopicStateSpace` or `GriddedStateSpace`
        The plant over a box of named parameters, or on a grid of them
        (e.g. linearizations at trim points, `ctrl_lpv.gss`); then every
        grid cell within the schedule's points is certified, the gain
        being affine on each simplex of the schedule, the plant
        multilinear on each cell (see `ctrl_lpv.schedules.gridded` for why
        the relaxation is sound).
    parameters : mapping of str to str, optional
        ``{scheduling variable: plant parameter}``; default: the same names,
        or else in order.
    rate_bounds : mapping of str to float, optional
        Rates to certify, ``{parameter: nu}``; default: find the largest
        ``nu`` for every parameter (per time unit). On a gridded plant a
        parameter not listed (or ``inf``) may vary arbitrarily fast; on a
        polytopic plant every parameter needs a finite rate.
    objective : `Hinf` or `H2`, optional
        A channel ``Hinf(w=..., z=...)`` (or `H2`) whose bound to certify
        (L2 gain, or H2), for arbitrarily fast parameters or, for an
        `Hinf` objective on a gridded plant in continuous time with
        `rate_bounds`, for those rates if that gives a smaller bound:
        `certified` then also requires the bound, reported in ``.bound``
        (and the rates it holds for in ``.rate_bound``). Its ``w`` are
        plant inputs, its ``z`` plant outputs; ``bound=`` must be None.
    margin : float, optional
        Relative margin of the strict LMIs.
    samples : int, optional
        Frozen samples per cell besides its vertices (seeded).
    counterexample : bool, optional
        Search a destabilising parameter trajectory above the certified rate.

    Returns
    -------
    `ScheduleCertificate`

    Raises
    ------
    ValueError, TypeError
        A controller that is not a linear gain schedule, parameters that do
        not match, points outside the plant's domain, a polytopic plant
        whose ``A`` or ``B_u`` (with an objective also ``C``, ``D``) is not
        affine in the parameters on a cell, or an objective that is not an
        `Hinf` or `H2` naming its channel.

    Examples
    --------
    >>> import control as ct, numpy as np
    >>> import ctrl_lpv as lpv
    >>> G = lpv.PolytopicStateSpace.from_affine(
    ...     ct.ss([[0.0, 1.0], [-1.0, 0.0]], [[0.0], [1.0]], np.eye(2), 0),
    ...     {"a": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)}, {"a": (0.0, 2.0)})
    >>> gains = [np.array([[1.0, 2.0]]), np.array([[0.5, 2.0]])]
    >>> lpv.certify((gains, [0.0, 2.0]), G).rate_bound
    {'a': inf}

    A gridded plant, with an L2 bound from ``w`` to ``y``:

    >>> G = lpv.gss(lambda a: ct.ss([[-a]], [[1.0, 1.0]], [[1.0]], 0,
    ...                             inputs=["u", "w"], outputs="y"),
    ...             {"a": [1.0, 2.0, 3.0]})
    >>> c = lpv.certify(([[[0.5]], [[0.2]], [[0.1]]], [1.0, 2.0, 3.0]), G,
    ...                 objective=lpv.Hinf(w="w", z="y"))
    >>> c.certified, round(c.bound, 3)
    (True, 0.667)
    """
    if isinstance(controller, GainSchedule):
        schedule = controller
    else:
        # A table's variables are the plant's parameters, in order.
        names = None
        if isinstance(controller, tuple) and hasattr(plant, "param_names"):
            k = np.asarray(controller[1], float).reshape(len(controller[1]), -1)
            names = plant.param_names[: k.shape[1]]
        schedule = schedule_of(controller, names=names)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    objective = checked_objective(objective)
    if isinstance(plant, GriddedStateSpace):
        loops = _gridded_loops(schedule, plant, controller, parameters)
    else:
        loops = _ClosedLoops.of(schedule, plant, controller, parameters)
    nu = None
    if rate_bounds is not None:
        nu = checked_rates(rate_bounds, loops.names)
        if not isinstance(plant, GriddedStateSpace) and np.isinf(nu).any():
            raise ValueError(
                "rate_bounds: on a polytopic plant give a finite rate for every "
                f"parameter {list(loops.names)}"
            )
    tried = []
    frozen = loops.frozen_counterexample(samples)
    tried.append(f"frozen closed loops at {len(schedule.points)} points and "
                 f"{samples} samples per cell")  # fmt: skip
    if frozen is not None:
        return ScheduleCertificate(False, {n: 0.0 for n in loops.names}, frozen,
                                   Certificate(()), tuple(tried))  # fmt: skip
    quadratic = loops.quadratic(margin)
    tried.append("one quadratic Lyapunov function (arbitrary rates)")
    with_rates = (nu is not None and isinstance(plant, GriddedStateSpace)
                  and _is_hinf(objective) and loops.rate_refusal() is None)  # fmt: skip
    if quadratic is not None:
        rates = {n: math.inf for n in loops.names}
        if objective is None:
            return ScheduleCertificate(True, rates, None, quadratic, tuple(tried))
        name = type(objective).__name__
        tried.append(f"{name} bound from {list(objective.w)} to "
                     f"{list(objective.z)}, one Lyapunov matrix")  # fmt: skip
        try:
            bound, certificate = loops.bound(objective, margin)
            found = (rates, bound, quadratic + certificate)
        except SynthesisError as err:
            tried.append(f"{name} bound not certified: {str(err).splitlines()[0]}")
            found = None
        if with_rates:
            # The rates asked for may certify a smaller bound.
            better = _rate_bounded_bound(loops, objective, nu, margin, tried)
            if better is not None and (found is None or better[1] < found[1]):
                found = better
        if found is None:
            return ScheduleCertificate(False, rates, None, quadratic, tuple(tried))
        rates, bound, certificate = found
        return ScheduleCertificate(True, rates, None, certificate, tuple(tried),
                                   bound)  # fmt: skip
    if with_rates:
        found = _rate_bounded_bound(loops, objective, nu, margin, tried)
        if found is not None:
            rates, bound, certificate = found
            return ScheduleCertificate(True, rates, None, certificate,
                                       tuple(tried), bound)  # fmt: skip
        return ScheduleCertificate(False, {n: 0.0 for n in loops.names}, None,
                                   Certificate(()), tuple(tried))  # fmt: skip
    if objective is not None:
        tried.append(
            "the objective's bound: not certified (for arbitrary rates it needs "
            "one Lyapunov matrix, and none exists; with rate_bounds, an Hinf "
            "objective on a gridded plant in continuous time is certified with "
            "P(p))"
        )
        return ScheduleCertificate(False, {n: 0.0 for n in loops.names}, None,
                                   Certificate(()), tuple(tried))  # fmt: skip
    refusal = loops.rate_refusal()
    if refusal is not None:
        tried.append(f"rate-bounded analysis: not implemented {refusal}")
        return ScheduleCertificate(False, {n: 0.0 for n in loops.names},
                                   None, Certificate(()), tuple(tried))  # fmt: skip
    if nu is not None:
        found = loops.rate_bounded(nu, margin)
        tried.append(f"parameter-dependent P(p), rates {nu.tolist()}")
        certificate = Certificate(()) if found is None else found
        rates = dict(zip(loops.names, (nu if found is not None else 0 * nu).tolist()))
        return ScheduleCertificate(found is not None, rates, None, certificate,
                                   tuple(tried))  # fmt: skip
    scale, certificate = loops.largest_rate(margin)
    tried.append("parameter-dependent P(p), bisection on the rate")
    rates = {n: float(scale) for n in loops.names}
    example = None
    if counterexample and scale < math.inf:
        from .counterexample import destabilising_trajectory

        example = destabilising_trajectory(loops, max(scale, 1e-6))
        tried.append("periodic parameter trajectories above the certified rate")
    certificate = certificate or Certificate(())
    return ScheduleCertificate(False, rates, example, certificate, tuple(tried))


def _is_hinf(objective) -> bool:
    from ..synthesis import Hinf

    return isinstance(objective, Hinf)


def _rate_bounded_bound(loops, objective, nu, margin, tried):
    """``(rates, bound, certificate)`` of the `Hinf` bound with rates `nu`,
    or None (what was tried is appended to `tried`)."""
    tried.append(f"Hinf bound with P(p), rates {nu.tolist()}")
    try:
        bound, certificate = loops.rate_bounded_bound(objective, nu, margin)
    except SynthesisError as err:
        tried.append(
            f"rate-bounded Hinf bound not certified: {str(err).splitlines()[0]}"
        )
        return None
    return dict(zip(loops.names, nu.tolist())), bound, certificate


def _gridded_loops(schedule, plant, controller, parameters):
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
class _ClosedLoops(RateSearch):
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

    def bound(self, objective, margin):
        """``(bound, certificate)`` of the objective's channel, one P.

        On a cell the channel's matrices are affine in ``p`` (checked) and
        ``K`` too: the loop is ``sum_ij l_i l_j T(i, j)`` with ``T(i, j)``
        the loop of point ``i`` under gain ``j``, a convex combination of
        the ``T(i, i)`` and, when ``K`` and ``B_u`` or ``D_zu`` vary, of the
        ``(T(i, j) + T(j, i)) / 2`` of the cell's pairs.
        """
        from .objective import certified_bound, channel

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
        loops = [of(d, K) for d, K in zip(data, self.K)]
        Dzu = np.array([dzu(d) for d in data])
        if _varies(self.K) and (_varies(self.B) or _varies(Dzu)):
            for cell in self.schedule.cells:
                for i, j in itertools.combinations(cell, 2):
                    ij, ji = of(data[i], self.K[j]), of(data[j], self.K[i])
                    loops.append(tuple(0.5 * (a + b) for a, b in zip(ij, ji)))
        w = [self.plant.physical_inputs[i] for i in iw]
        z = [self.plant.output_labels[i] for i in iz]
        return certified_bound(loops, objective, self.plant.dt, margin, w, z,
                               "in the points' convex hull")  # fmt: skip

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

    def _rate_problem(self, margin):
        n = self.Acl.shape[1]
        M, k = self.points.shape
        scale = max(1.0, float(max(np.linalg.norm(A, 2) for A in self.Acl)))
        lmi = LMIProblem(margin=margin * scale)
        for i in range(M):
            lmi.variable(f"P{i}", (n, n), symmetric=True)
            lmi.add(f"P{i} > 0", lambda v, i=i: [[-getattr(v, f"P{i}")]])
            lmi.add(f"P{i} <= I", lambda v, i=i: [[getattr(v, f"P{i}") - np.eye(n)]],
                    strict=False, normalization=True)  # fmt: skip
        lmi.parameter("nu", (k,), value=np.zeros(k), nonneg=True)
        A = self.Acl
        for c, cell in enumerate(self.schedule.cells):
            grad = _gradients(self.points[cell])  # (k, k+1): dlambda_i/dp
            for signs in itertools.product((-1.0, 1.0), repeat=k):

                def G(v, cell=cell, grad=grad, signs=signs):
                    """dP/dt at the rate vertex `signs` on this cell."""
                    Ps = [getattr(v, f"P{i}") for i in cell]
                    dP = [sum(g * P for g, P in zip(grad[d], Ps)) for d in range(k)]
                    return sum(s * v.nu[d] * dP[d] for d, s in enumerate(signs))

                if self.bilinear:
                    self._cubic_terms(lmi, c, cell, signs, G)
                    continue
                for i in cell:
                    lmi.add(f"cell {c} vertex {i} rates {signs}",
                            lambda v, i=i, G=G: [[2 * (A[i].T @ getattr(v, f"P{i}"))
                                                  + G(v)]])  # fmt: skip
                for a, b in itertools.combinations(range(len(cell)), 2):
                    i, j = cell[a], cell[b]
                    lmi.add(
                        f"cell {c} pair {i},{j} rates {signs}",
                        lambda v, i=i, j=j, G=G: [[
                            2 * (A[i].T @ getattr(v, f"P{j}"))
                            + 2 * (A[j].T @ getattr(v, f"P{i}")) + 2 * G(v)]],
                    )  # fmt: skip
        return lmi

    def _cubic_terms(self, lmi, c, cell, signs, G):
        """The rate-bounded LMIs of a cell where ``B_u`` and ``K`` both vary.

        With ``M_ij = A_i - B_i K_j`` the loop is ``sum_ij l_i l_j M_ij``
        and ``P = sum_k l_k P_k``, so (``sum l = 1`` making ``dP/dt`` cubic
        too) ``dV/dt = x' (sum_ijk l_i l_j l_k (He(M_ij' P_k) + G)) x``: a
        cubic form in ``l >= 0``, negative when, for every multiset
        ``{i, j, k}`` of the cell's points, the sum of its terms over the
        multiset's distinct orderings is (Oliveira and Peres 2007).
        """
        for triple in itertools.combinations_with_replacement(cell, 3):
            orders = sorted(set(itertools.permutations(triple)))

            def term(v, orders=orders, G=G):
                total = len(orders) * G(v)
                for i, j, k in orders:
                    M = self.A[i] - self.B[i] @ self.K[j]
                    total = total + 2 * (M.T @ getattr(v, f"P{k}"))
                return [[total]]

            lmi.add(f"cell {c} triple {triple} rates {signs}", term)


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
