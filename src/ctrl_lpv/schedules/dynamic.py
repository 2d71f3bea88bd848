"""Closed loops of a dynamic (output-feedback) controller on an LPV plant.

`certify` takes, besides state-feedback schedules, a dynamic controller
``xk' = Ak xk + Bk y``, ``u = Ck xk + Dk y`` (python-control's sign: the
controller outputs ``u`` itself): an LTI `control.StateSpace`, a scheduled
`ctrl_lpv.PolytopicStateSpace` (as `OutputFeedbackDesign.controller`
returns it), an `OutputFeedbackDesign` or an `ObserverBasedController`
(their ``.controller()``). The loop is closed by signal
names, as `control.interconnect` would: the controller's inputs are plant
outputs of the same names, its outputs plant inputs; the loop's state is
``(x, xk)``, its inputs the plant inputs the controller does not drive.

**The loop as a polynomial in the weights.** On a cell of the plant (the
whole polytope, or a grid cell) the plant is ``sum_i w_i G_i`` with
weights ``w`` nonnegative and summing to one, and the controller, whose
value at each corner is ``K_j``, is ``sum_j w_j K_j`` with the same weights
(checked: true for an LTI controller, for one on the plant's own domain,
and for one on a box holding the plant's, multilinear weights reproducing
multilinear functions exactly). With ``D_yu = 0`` (required) every block
of the closed loop is a product of at most three factors: plant factors
on the left (``A, B_u, B_w, C_z, D_zu, D_zw``), the controller, plant
factors on the right (``C_y, D_yw``); e.g. ``A + B_u D_k C_y``. So

.. math::

    T(p) = \\sum_{i,j,k} w_i w_j w_k\\, T(i, j, k),

with ``T(i, j, k)`` the loop of left factors of corner ``i``, controller of
corner ``j``, right factors of corner ``k``: a convex combination of the
``T(i, j, k)``, or (the weights of a monomial summing over its orderings)
of their means over the orderings of each multiset ``{i, j, k}``. A slot
whose factors are constant on the cell drops out (degree ``d <= 3``). One
Lyapunov matrix for all these terms certifies stability, or the channel's
L2 / H2 bound, for arbitrarily fast parameters (the inequalities are
affine in the loop for a fixed ``P``).

**Rates** (continuous time, a box or a grid): ``P(p) = sum_a w_a P_a``,
continuous across cells, with ``dP/dt = sum_a w_a D_a`` (``D_a`` the
differences of ``P`` along the cell's edges through corner ``a``, as in
`ctrl_lpv.schedules.gridded`). Then ``dV/dt`` is a homogeneous form of
degree ``d + 1`` in ``w``, negative when for every multiset of ``d + 1``
corners the sum over its orderings ``(t, a)`` of ``He(T(t)' P_a) + D_a`` is
(Oliveira and Peres 2007), at every corner of the rate box.
"""

from __future__ import annotations

import itertools

import control as ct
import numpy as np

from .._checks import signal_indices
from .quadratic import quadratic_certificate
from .rates import RateSearch, form_lmis, rate_variables

__all__ = ["DynamicLoops", "is_dynamic"]


def _designs():
    """The designs whose ``.controller()`` is a dynamic controller."""
    from ..estimation import ObserverBasedController
    from ..output_feedback import OutputFeedbackDesign

    return OutputFeedbackDesign, ObserverBasedController


def is_dynamic(controller) -> bool:
    """Whether `controller` is a dynamic controller `certify` closes by name."""
    return isinstance(controller, (ct.StateSpace, *_designs()))


def _scheduled(system) -> bool:
    return hasattr(system, "domain") and hasattr(system, "param_names")


class DynamicLoops(RateSearch):
    """The closed loops of a dynamic controller on a polytopic or gridded plant.

    Parameters
    ----------
    controller : dynamic controller
        A `control.StateSpace`, a `PolytopicStateSpace`, or an
        `OutputFeedbackDesign` or `ObserverBasedController` (their
        ``.controller()``).
    plant : `PolytopicStateSpace` or `GriddedStateSpace`
    parameters : mapping of str to str, optional
        ``{controller parameter: plant parameter}``; default the same names.
    """

    def __init__(self, controller, plant, parameters=None):
        from ..systems import GriddedStateSpace, PolytopicStateSpace

        if isinstance(controller, _designs()):
            controller = controller.controller()
        if not isinstance(plant, (PolytopicStateSpace, GriddedStateSpace)):
            raise TypeError(
                "plant: expected a PolytopicStateSpace or a GriddedStateSpace"
            )
        self.plant = plant
        self.controller = controller
        self.names = tuple(plant.param_names)
        self.continuous = not plant.isdtime(strict=True)
        self.gridded = isinstance(plant, GriddedStateSpace)
        _check_timebase(controller, plant)
        self._signals(controller, plant)
        self._rename = self._parameter_map(controller, parameters)
        domain = plant.domain
        self.points = np.asarray(domain.points, float)
        if self.gridded:
            self.cells = [tuple(c) for c in domain.cells()]
            self.corners = [np.asarray(domain.corners(c), int) for c in self.cells]
        else:
            self.cells = [0]
            self.corners = [np.arange(len(self.points))]
        self.box = hasattr(domain, "lower") and hasattr(domain, "_bits")
        self.G = [tuple(np.asarray(M, float) for M in d) for d in plant.vertex_data()]
        self._check_domain()
        self.K = [self._controller_at(p) for p in self.points]
        for i, (_, _, _, D) in enumerate(self.G):
            Dyu = D[np.ix_(self.iy, self.iu)]
            if np.any(Dyu != 0):
                raise ValueError(
                    f"plant: a nonzero feedthrough from the controller's outputs "
                    f"{self.u_names} to its inputs {self.y_names} at point "
                    f"{self.points[i].tolist()} (an algebraic loop) is not "
                    "supported"
                )
        self._check_interpolation()
        self.iw, self.iz = [], []

    # ------------------------------------------------------------------
    # Signals, parameters, the controller at the plant's points
    # ------------------------------------------------------------------
    def _signals(self, controller, plant):
        inputs = list(plant.physical_inputs)
        outputs = list(plant.output_labels)
        ins = list(controller.physical_inputs if _scheduled(controller)
                   else controller.input_labels)  # fmt: skip
        outs = list(controller.output_labels)
        missing = [s for s in outs if s not in inputs]
        if missing:
            raise ValueError(
                f"controller: outputs {missing} are not inputs of the plant "
                f"{inputs} (the loop is closed by signal names)"
            )
        missing = [s for s in ins if s not in outputs]
        if missing:
            raise ValueError(
                f"controller: inputs {missing} are not outputs of the plant "
                f"{outputs} (the loop is closed by signal names)"
            )
        if len(set(outs)) != len(outs):
            raise ValueError(f"controller: repeated outputs {outs}")
        self.u_names, self.y_names = outs, ins
        self.iu = [inputs.index(s) for s in outs]
        self.iy = [outputs.index(s) for s in ins]

    def _parameter_map(self, controller, parameters):
        """``{controller parameter: plant parameter}`` (empty when LTI)."""
        if not _scheduled(controller):
            if parameters is not None:
                raise ValueError("parameters: an LTI controller has no parameters")
            return {}
        own = list(controller.param_names)
        mapping = dict(zip(own, own)) if parameters is None else dict(parameters)
        if sorted(mapping) != sorted(own) or sorted(mapping.values()) != sorted(
            self.names
        ):
            raise ValueError(
                f"parameters: the controller is scheduled on {own}, the plant on "
                f"{list(self.names)}; pass parameters={{controller parameter: "
                "plant parameter}}"
                if parameters is None
                else f"parameters: expected {{controller parameter: plant "
                f"parameter}} for {own} -> {list(self.names)}, got {mapping}"
            )
        return mapping

    def _controller_at(self, p):
        """``(Ak, Bk, Ck, Dk)`` of the controller at the plant's parameter `p`."""
        system = self.controller
        if _scheduled(system):
            value = dict(zip(self.names, np.asarray(p, float).tolist()))
            try:
                system = system.at({c: value[q] for c, q in self._rename.items()})
            except ValueError as err:
                raise ValueError(
                    f"controller: not defined at the plant's parameter value "
                    f"{value} ({str(err).splitlines()[0]})"
                ) from None
        return tuple(np.asarray(M, float) for M in ct.ssdata(system))

    def _check_domain(self):
        """The controller is ``sum_j w_j K_j`` in the plant's weights.

        Exactly so on the plant's own domain (the same weights), and on a
        box holding the plant's box or grid (its multilinear weights are
        multilinear in ``p``, which the plant's multilinear weights
        reproduce on each cell); anything else is refused, since the
        products would not span the loop. The identity is also checked
        numerically at a few points of every cell.
        """
        if not _scheduled(self.controller):
            return
        from ..polytope import ParameterBox

        own, domain = self.controller.domain, self.plant.domain
        inverse = {q: c for c, q in self._rename.items()}
        order = [list(own.names).index(inverse[q]) for q in self.names]
        tol = 1e-12 * max(1.0, float(np.abs(domain.points).max()))
        same = (type(own) is type(domain)
                and own.points.shape == domain.points.shape
                and np.allclose(own.points[:, order], domain.points, rtol=0,
                                atol=tol))  # fmt: skip
        if not same:
            if not isinstance(own, ParameterBox) or not hasattr(domain, "lower"):
                raise ValueError(
                    f"controller: scheduled on {own!r}, the plant on {domain!r}; "
                    "expected the plant's domain, or a box holding the plant's "
                    "box or grid"
                )
            slack = 1e-9 * (domain.upper - domain.lower)
            lower, upper = own.lower[order], own.upper[order]
            if np.any(lower > domain.lower + slack) or np.any(
                upper < domain.upper - slack
            ):
                raise ValueError(
                    f"controller: its box {own!r} does not hold the plant's "
                    f"domain {domain!r}"
                )

    def _check_interpolation(self):
        """`_check_domain`'s identity, numerically at a few points per cell."""
        if not _scheduled(self.controller):
            return
        rng = np.random.default_rng(1)
        for c in range(len(self.cells)):
            for p in self._samples(c, 2, rng)[-3:]:
                w = self.plant.domain._weights(p)
                mixed = [np.tensordot(w, np.array([K[m] for K in self.K]), axes=1)
                         for m in range(4)]  # fmt: skip
                actual = self._controller_at(p)
                for a, b in zip(mixed, actual):
                    scale = max(1.0, float(np.abs(b).max(initial=0.0)))
                    if not np.allclose(a, b, rtol=0.0, atol=1e-9 * scale):
                        raise ValueError(
                            "controller: its interpolation is not the plant's "
                            f"(at {dict(zip(self.names, p.tolist()))} it differs "
                            "from the plant's weights of its values at the "
                            "plant's points); schedule it on the plant's domain, "
                            "or on a box holding it"
                        )

    # ------------------------------------------------------------------
    # The closed loop and the terms spanning it
    # ------------------------------------------------------------------
    def _left(self, G):
        A, B, C, D = G
        iz, iw, iu = self.iz, self.iw, self.iu
        return (A, B[:, iu], B[:, iw], C[iz], D[np.ix_(iz, iu)], D[np.ix_(iz, iw)])

    def _right(self, G):
        _, _, C, D = G
        return C[self.iy], D[np.ix_(self.iy, self.iw)]

    @staticmethod
    def _loop(left, K, right):
        """``(A, B, C, D)`` of the loop from w to z: left plant factors,
        controller `K`, right plant factors (python-control's sign)."""
        A, Bu, Bw, Cz, Dzu, Dzw = left
        Ak, Bk, Ck, Dk = K
        Cy, Dyw = right
        Acl = np.block([[A + Bu @ Dk @ Cy, Bu @ Ck], [Bk @ Cy, Ak]])
        Bcl = np.vstack([Bw + Bu @ Dk @ Dyw, Bk @ Dyw])
        Ccl = np.hstack([Cz + Dzu @ Dk @ Cy, Dzu @ Ck])
        return Acl, Bcl, Ccl, Dzw + Dzu @ Dk @ Dyw

    def frozen_loop(self, p):
        """The frozen closed loop at the plant's parameter `p` (w to z)."""
        A, B, C, D = self.plant._combine(self.plant.domain._weights(np.asarray(p)))
        G = tuple(np.asarray(M, float) for M in (A, B, C, D))
        return self._loop(self._left(G), self._controller_at(p), self._right(G))

    def _slots(self, corners):
        """Which of (left, controller, right) vary on the cell `corners`."""

        def varies(of):
            first = of(corners[0])
            return any(not all(np.array_equal(a, b) for a, b in zip(first, of(i)))
                       for i in corners[1:])  # fmt: skip

        return [varies(lambda i: self._left(self.G[i])),
                varies(lambda j: self.K[j]),
                varies(lambda k: self._right(self.G[k]))]  # fmt: skip

    def _term(self, corners, slots, t):
        """The loop with the varying slots taken at the corner positions `t`."""
        at = iter(t)
        i, j, k = (corners[next(at)] if s else corners[0] for s in slots)
        return self._loop(self._left(self.G[i]), self.K[j], self._right(self.G[k]))

    def terms(self):
        """``[(A, B, C, D)]`` whose convex hull holds every frozen loop."""
        out = {}
        for corners in self.corners:
            slots = self._slots(corners)
            d = sum(slots)
            for m in itertools.combinations_with_replacement(range(len(corners)), d):
                orders = sorted(set(itertools.permutations(m)))
                loops = [self._term(corners, slots, t) for t in orders]
                T = tuple(sum(L[q] for L in loops) / len(loops) for q in range(4))
                out.setdefault(b"".join(M.tobytes() for M in T), T)
        return list(out.values())

    def spanning(self) -> np.ndarray:
        """Closed-loop matrices whose convex hull holds every frozen loop."""
        out = {}
        for T in self.terms():
            out.setdefault(T[0].tobytes(), T[0])
        return np.array(list(out.values()))

    @property
    def Acl(self) -> np.ndarray:
        return self.spanning()

    @property
    def region(self) -> str:
        return "on the plant's grid" if self.gridded else "in the plant's domain"

    lyapunov_form = "P(p) multilinear in the plant's weights, continuous"

    # ------------------------------------------------------------------
    # Frozen check, arbitrary rates, the channel's bound
    # ------------------------------------------------------------------
    def _samples(self, c, samples, rng):
        """Parameter values in cell `c`: its corners, its centre, random ones."""
        V = self.points[self.corners[c]]
        if self.box:
            random = rng.uniform(V.min(axis=0), V.max(axis=0), (samples, V.shape[1]))
        else:  # a simplex or polytope domain: convex combinations
            random = rng.dirichlet(np.ones(len(V)), size=samples) @ V
        return np.vstack([V, V.mean(axis=0), random])

    def frozen_counterexample(self, samples):
        from .certify import FrozenCounterexample

        rng = np.random.default_rng(0)
        for c, cell in enumerate(self.cells):
            for p in self._samples(c, samples, rng):
                eig = np.linalg.eigvals(self.frozen_loop(p)[0])
                worst = eig[np.argmax(eig.real if self.continuous else np.abs(eig))]
                bad = worst.real >= 0 if self.continuous else abs(worst) >= 1
                if bad:
                    return FrozenCounterexample(dict(zip(self.names, p.tolist())),
                                                cell, complex(worst))  # fmt: skip
        return None

    def quadratic(self, margin):
        return quadratic_certificate(
            list(self.spanning()),
            self.plant.dt,
            margin,
            f"the loop with the dynamic controller is stable for arbitrarily fast "
            f"parameters {self.region} (one quadratic Lyapunov function of the "
            "closed-loop products spanning it)",
        )

    def bound(self, objective, margin):
        """``(bound, certificate)`` of the `Hinf` or `H2` objective, one P.

        Raises
        ------
        ValueError
            A ``w`` the controller drives.
        SynthesisError
            When the engine certifies no bound.
        """
        from .objective import certified_bound

        iw = signal_indices(objective.w, self.plant.physical_inputs, "objective.w")
        iz = signal_indices(objective.z, self.plant.output_labels, "objective.z")
        driven = [self.plant.physical_inputs[i] for i in iw if i in self.iu]
        if driven:
            raise ValueError(
                f"objective.w: {driven} are driven by the controller's outputs"
            )
        self.iw, self.iz = list(iw), list(iz)
        try:
            loops = self.terms()
        finally:
            self.iw, self.iz = [], []
        w = [self.plant.physical_inputs[i] for i in iw]
        z = [self.plant.output_labels[i] for i in iz]
        where = f"{self.region}, with the dynamic controller"
        return certified_bound(loops, objective, self.plant.dt, margin, w, z, where)

    # ------------------------------------------------------------------
    # Rates
    # ------------------------------------------------------------------
    def rate_refusal(self) -> str | None:
        """Why the rate-bounded analysis does not apply (None: it does)."""
        if not self.continuous:
            return "in discrete time"
        if not self.box:
            return "on a simplex or polytope domain (rates need a box or a grid)"
        return None

    def rate_channel(self, objective):
        """Not implemented: the loop's products are of degree three."""
        raise ValueError(
            "objective: a bound under a rate bound is not implemented with a "
            "dynamic controller; pass rate_bounds=None for the bound at arbitrary "
            "rates"
        )

    def _rate_problem(self, margin):
        from ..lmi import LMIProblem

        domain = self.plant.domain
        n = self.Acl.shape[1]
        k = len(self.names)
        bits = np.asarray(domain._bits, int)
        weights = 2 ** np.arange(k - 1, -1, -1)
        # across[a][d]: the corner position across axis d from position a.
        across = [[int((bits[a] ^ np.eye(k, dtype=int)[d]) @ weights)
                   for d in range(k)] for a in range(len(bits))]  # fmt: skip
        scale = max(1.0, max(float(np.linalg.norm(M, 2)) for M in self.Acl))
        lmi = LMIProblem(margin=margin * scale)
        used = sorted({int(i) for corners in self.corners for i in corners})
        rate_variables(lmi, used, n, k)
        for cell, corners in zip(self.cells, self.corners):
            corners = [int(i) for i in corners]
            V = self.points[corners]
            h = V.max(axis=0) - V.min(axis=0)
            slots = self._slots(corners)
            d = sum(slots)
            N = len(corners)
            T = {t: self._term(corners, slots, t)[0]
                 for t in itertools.product(range(N), repeat=d)}  # fmt: skip

            def P(v, a, corners=corners):
                return getattr(v, f"P{corners[a]}")

            def edge(v, a, e, P=P):
                """(P at the upper end - P at the lower end) of the edge."""
                b = across[a][e]
                up, down = (a, b) if bits[a][e] else (b, a)
                return P(v, up) - P(v, down)

            for signs in itertools.product((-1.0, 1.0), repeat=k):

                def D(v, a, signs=signs, h=h, edge=edge):
                    return sum(s * v.nu[e] * edge(v, a, e) / h[e]
                               for e, s in enumerate(signs))  # fmt: skip

                def term(v, order, T=T, P=P, D=D, d=d):
                    M, X = T[order[:d]], P(v, order[d])
                    return [[M.T @ X + X @ M + D(v, order[d])]]

                form_lmis(lmi, f"cell {cell} rates {signs}", corners, d + 1, term)
        return lmi

    def segments(self):
        """``(start, end, nodes, loops)``: segments of the domain, the loop
        sampled along them (evidence for `destabilising_trajectory`)."""
        if self.gridded:
            grid, out = self.plant.domain, []
            for e in range(grid.nparams):
                lines = {}
                for index in np.ndindex(*grid.shape):
                    lines.setdefault(index[:e] + index[e + 1 :], []).append(index)
                for line in lines.values():
                    ends = [grid.points[np.ravel_multi_index(q, grid.shape)]
                            for q in (line[0], line[-1])]  # fmt: skip
                    axis = grid.axes[e]
                    s = np.unique(np.concatenate([
                        np.linspace(a, b, 9) for a, b in zip(axis[:-1], axis[1:])
                    ]))  # fmt: skip
                    nodes = (s - axis[0]) / (axis[-1] - axis[0])
                    out.append(self._segment(ends[0], ends[1], nodes))
            return out
        nodes = np.linspace(0.0, 1.0, 33)
        pairs = itertools.combinations(range(len(self.points)), 2)
        return [self._segment(self.points[a], self.points[b], nodes)
                for a, b in pairs]  # fmt: skip

    def _segment(self, start, end, nodes):
        loops = [self.frozen_loop(start + s * (end - start))[0] for s in nodes]
        return start, end, nodes, loops


def _check_timebase(controller, plant):
    cdt, pdt = controller.dt, plant.dt
    if cdt is None or cdt == pdt:
        return
    discrete = bool(controller.isdtime(strict=True))
    same_kind = discrete == bool(plant.isdtime(strict=True))
    if not same_kind or (cdt is not True and pdt is not True and cdt != pdt):
        raise ValueError(
            f"controller: time base dt={cdt} differs from the plant's dt={pdt}"
        )
