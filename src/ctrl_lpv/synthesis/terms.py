"""The parameter-dependent products of the LMIs at one relaxation coefficient.

A `Terms` object evaluates, for one `~ctrl_lpv.synthesis.parametric.Coefficient`
and one vertex of the rate box, the homogenised sums the specs write their
blocks with: ``A(delta) W(delta) + B2(delta) Z(delta)`` (degree two),
``W(delta)`` and the data of a channel (degree one), constants (degree
zero). It reads everything from a namespace ``v`` of named variables and
parameters (the prescaled vertex data are parameters, see `names`), so the
same code is read into the problem's affine maps and checks a point
(float64 arrays, `ctrl_lpv.lmi.LMIProblem.check`). A spec sees a view bound to
itself (`Terms.bind`): its channel's data, its own variables.
"""

from __future__ import annotations

import numpy as np

from ..lmi.blocks import Batch
from .parametric import Coefficient, step_terms


class names:
    """Names of the engine's variables and parameters in the namespace.

    Vertex data ``A_j``, ``B2_j``; channel ``i``: ``Bw{i}_j``, ``Cz{i}_j``,
    ``Dzw{i}_j``, ``Dzu{i}_j`` and the weight ``rho{i}``; for the extended
    LMIs the products with their scalar, ``eA_j``, ``eB2_j``, ``eCz{i}_j``
    and ``eDzu{i}_j``; a spec's own names are prefixed by its position.
    """

    @staticmethod
    def data(key, j, i=None) -> str:
        return f"{key}_{j}" if i is None else f"{key}{i}_{j}"

    @staticmethod
    def local(q, name) -> str:
        return f"s{q}_{name}"


class Shape:
    """What the blocks need to know of the problem's structure.

    Attributes: ``n``, ``m``, ``lyap`` (the
    `~ctrl_lpv.synthesis.parametric.LyapunovStructure`, rates prescaled),
    ``scheduled``, ``continuous``, ``slack`` (the extended LMIs), ``nZ``
    (number of gain variables), ``channel_sizes`` (``(nw, nz)`` per
    channel) and ``ngains`` (number of gains; given ones, parameters
    ``K_k``, where there are no gain variables).
    """

    def __init__(self, n, m, lyap, scheduled, continuous, slack, nZ, channel_sizes,
                 ngains=0):  # fmt: skip
        self.n = n
        self.m = m
        self.lyap = lyap
        self.scheduled = scheduled
        self.continuous = continuous
        self.slack = slack
        self.nZ = nZ
        self.channel_sizes = channel_sizes
        self.ngains = ngains


class Terms:
    """Sums of one coefficient (see the module docstring).

    Parameters
    ----------
    v : namespace
        Variables and parameters by name (`names`).
    coefficient : `Coefficient`
    rate : ndarray
        Vertex of the rate box (prescaled units).
    shape : `Shape`
    specs : sequence of (spec, channel index or None)
        Every spec of the problem with its channel (views of the others
        are what `disturbances` reads).
    """

    def __init__(self, v, coefficient: Coefficient, rate, shape: Shape, specs=()):
        self.v = v
        self.c = coefficient
        self.rate = rate
        self.shape = shape
        self.specs = tuple(specs)
        self.n, self.m = shape.n, shape.m
        self.q = self.i = None

    def bind(self, q: int) -> Terms:
        """The view of spec number `q` (its channel, its own names)."""
        view = Terms(self.v, self.c, self.rate, self.shape, self.specs)
        view.q, view.i = q, self.specs[q][1]
        return view

    # -- degree zero -------------------------------------------------------
    def identity(self, size):
        """``I`` (degree zero)."""
        return self.c.const * np.eye(size)

    def const(self, expression):
        """A parameter-independent variable such as ``g I`` or ``Y``."""
        return self.c.const * expression

    def decay(self):
        """The stage variable ``t`` (the decay the stabilization stage
        maximises)."""
        return self._get("t")[0, 0]

    # -- the Lyapunov matrix and the gains ---------------------------------
    def _get(self, name):
        return getattr(self.v, name)

    def _W(self, index):
        return self._get(f"W{index}")

    def _Z(self, k):
        k = k if self.shape.scheduled else 0
        if not self.shape.nZ and self.shape.ngains:
            # A given gain (an analysis): Z_k = -K_k W, W constant.
            return -self._get(f"K{k}") @ self._W(0)
        return self._get(f"Z{k}")

    def W(self):
        """``W(delta)``."""
        return sum(self._W(self.shape.lyap.index[j]) for j in self.c.linear)

    def W_moved(self):
        """``dW/dt`` (continuous) or ``W(p + dp)`` (discrete) at the rate."""
        out = 0
        for j in self.c.linear:
            for index, factor in step_terms(
                self.shape.lyap, j, self.rate, self.shape.continuous
            ):
                out = out + factor * self._W(index)
        if isinstance(out, int):
            return np.zeros((self.n, self.n))
        return out

    def _vertex(self, key, j):
        if key in ("B2", "Dzu", "eB2", "eDzu") and not self.m:
            return None  # no control input (an analysis)
        i = self.i if key in ("Cz", "Dzu", "Bw", "Dzw", "eCz", "eDzu") else None
        return self._get(names.data(key, j, i))

    def _product(self, left, right, slack=False):
        out = 0
        for j, k in self.c.bilinear:
            X = self._get("G") if slack else self._W(self.shape.lyap.index[k])
            term = self._vertex(left, j) @ X
            B = self._vertex(right, j)
            if B is not None:
                term = term + B @ self._Z(k)
            out = out + term
        return out

    def AW(self):
        """``A(delta) W(delta) + B2(delta) Z(delta)``, i.e. ``A_cl W``."""
        return self._product("A", "B2")

    def CW(self):
        """``Cz(delta) W(delta) + Dzu(delta) Z(delta)``, i.e. ``C_cl W``."""
        return self._product("Cz", "Dzu")

    def Z(self):
        """The gain variable ``Z(delta)``: one per vertex when scheduled
        (degree one), else constant (degree zero)."""
        if self.shape.scheduled:
            return sum(self._Z(j) for j in self.c.linear)
        return self.c.const * self._Z(0)

    def B2(self):
        """``B2(delta)`` (degree one)."""
        return sum(self._vertex("B2", j) for j in self.c.linear)

    # -- the extended LMIs -------------------------------------------------
    @property
    def slack(self) -> bool:
        """Whether the LMIs are the extended ones, with the slack ``G``."""
        return self.shape.slack

    def G(self):
        """The slack matrix (parameter-independent)."""
        return self.c.const * self._get("G")

    def eps(self):
        """The scalar of the continuous-time extended LMIs."""
        return self._get("eps")

    def AG(self):
        """``A(delta) G + B2(delta) Z``, i.e. ``A_cl G`` (common gain)."""
        return self._product("A", "B2", slack=True)

    def eps_AG(self):
        """``eps A_cl G`` (the products with ``eps`` are parameters)."""
        return self._product("eA", "eB2", slack=True)

    def CG(self):
        """``Cz(delta) G + Dzu(delta) Z``, i.e. ``C_cl G``."""
        return self._product("Cz", "Dzu", slack=True)

    def eps_CG(self):
        """``eps C_cl G``."""
        return self._product("eCz", "eDzu", slack=True)

    # -- the bound spec's channel and its own names -------------------------
    def data(self, key):
        """The channel's datum (``"Bw"``, ``"Dzw"``) as a degree-one sum."""
        return sum(self._vertex(key, j) for j in self.c.linear)

    def nw(self) -> int:
        """Number of exogenous inputs of the channel."""
        return self.shape.channel_sizes[self.i][0]

    def nz(self) -> int:
        """Number of performance outputs of the channel."""
        return self.shape.channel_sizes[self.i][1]

    def rho(self):
        """Weight of the identity block of the channel's ``w``."""
        return self._get(f"rho{self.i}")

    def g(self):
        """The channel's squared-bound variable."""
        return self._get(f"g{self.i}")

    def var(self, name):
        """The spec's own variable or parameter `name`."""
        return self._get(names.local(self.q, name))

    def local_linear(self, name):
        """A spec's gain-like variable ``name{k}`` (as `Z`)."""
        if self.shape.scheduled:
            return sum(self.var(f"{name}{j}") for j in self.c.linear)
        return self.c.const * self.var(f"{name}0")

    def disturbances(self) -> list:
        """The peak-bounded disturbances of the other specs (see
        `~ctrl_lpv.synthesis.spec.Spec.disturbance`)."""
        out = []
        for q, (spec, _) in enumerate(self.specs):
            if q != self.q:
                found = spec.disturbance(self.bind(q))
                if found is not None:
                    out.append(found)
        return out


class StackedTerms(Terms):
    """`Terms` of several coefficients at once, stacked along a leading axis.

    For the float64 check of a point (`ctrl_lpv.lmi.LMIProblem.check`): the
    namespace holds plain values; each sum over a coefficient's vertices is
    taken slot by slot (its first vertex, its second, ...), every slot's
    values gathered into one stack (`~ctrl_lpv.lmi.blocks.Batch`) and a
    coefficient with fewer vertices given zeros there. The sums are those
    of `Terms`, term for term in the same order (a zero added last changes
    no bit), so a spec's block function evaluates every coefficient in one
    pass. A value that is not a plain array (a stack already) raises
    ``TypeError``, as a block function that does not broadcast may.

    Parameters
    ----------
    v, rate, shape, specs
        As `Terms`.
    coefficients : sequence of `Coefficient`
    repeats : sequence of int, optional
        Rows per coefficient (default one): reading the maps, each
        coefficient's rows hold the unit points of the variables it reads,
        and the namespace's variables are stacks of one value per row.
    """

    def __init__(self, v, coefficients, rate, shape: Shape, specs=(), repeats=None):
        super().__init__(v, coefficients[0], rate, shape, specs)
        self.coefficients = tuple(coefficients)
        self.repeats = repeats
        const = np.array([c.const for c in self.coefficients], float)
        if repeats is not None:
            const = np.repeat(const, repeats)
        self._const = const[:, None, None].view(Batch)

    def bind(self, q: int) -> StackedTerms:
        view = StackedTerms(self.v, self.coefficients, self.rate, self.shape,
                            self.specs, self.repeats)  # fmt: skip
        view.q, view.i = q, self.specs[q][1]
        return view

    def _slots(self, lists):
        """Per slot, the item of each coefficient's list (None past its end)."""
        width = max((len(x) for x in lists), default=0)
        return [[x[s] if s < len(x) else None for x in lists] for s in range(width)]

    def _gather(self, value_of, items):
        """The stack of ``value_of(item)`` (zeros where the item is None),
        one per coefficient, or per row (`repeats`): a variable given as a
        stack of rows is taken row by row."""
        found = {}
        for item in items:
            if item is not None and item not in found:
                value = value_of(item)
                if value is None:
                    return None
                if type(value) is not np.ndarray and not (
                    self.repeats is not None and isinstance(value, Batch)
                ):
                    raise TypeError("a stacked coefficient reads plain values only")
                found[item] = np.asarray(value)
        if not found:
            raise TypeError("no value in a slot")
        # The distinct values (a few vertices) and a zero, then one take.
        position = {item: k for k, item in enumerate(found)}
        position[None] = len(found)
        values = list(found.values())
        if self.repeats is None:
            table = np.stack(values + [np.zeros_like(values[0])])
            return table[[position[item] for item in items]].view(Batch)
        rows = np.repeat([position[item] for item in items], self.repeats)
        shapes = {value.shape for value in values}
        if shapes == {values[0].shape} and values[0].ndim == 2:
            table = np.stack(values + [np.zeros_like(values[0])])
            return table[rows].view(Batch)
        # Row-stacked values (variables): row r of the value of its item,
        # written item by item (each a few rows of the stack).
        out = np.zeros((len(rows),) + values[0].shape[-2:])
        for k, value in enumerate(values):
            where = np.flatnonzero(rows == k)
            out[where] = value[where] if value.ndim == 3 else value
        return out.view(Batch)

    def _linear_sum(self, value_of):
        lists = [c.linear for c in self.coefficients]
        return sum(self._gather(value_of, slot) for slot in self._slots(lists))

    def identity(self, size):
        return self._const * np.eye(size)

    def const(self, expression):
        return self._const * expression

    def W(self):
        index = self.shape.lyap.index
        return self._linear_sum(lambda j: self._W(index[j]))

    def W_moved(self):
        lyap, continuous = self.shape.lyap, self.shape.continuous
        lists = [
            [term for j in c.linear
             for term in step_terms(lyap, j, self.rate, continuous)]
            for c in self.coefficients
        ]  # fmt: skip
        slots = self._slots(lists)
        if not slots:
            return np.zeros((self.n, self.n))
        out = 0
        for slot in slots:
            factors = np.array([0.0 if t is None else t[1] for t in slot])
            if self.repeats is not None:
                factors = np.repeat(factors, self.repeats)
            W = self._gather(self._W, [None if t is None else t[0] for t in slot])
            out = out + factors[:, None, None] * W
        return out

    def _product(self, left, right, slack=False):
        index = self.shape.lyap.index
        out = 0
        for slot in self._slots([c.bilinear for c in self.coefficients]):
            js = [None if p is None else p[0] for p in slot]
            ks = [None if p is None else p[1] for p in slot]
            if slack:
                X = self._get("G")
            else:
                X = self._gather(lambda k: self._W(index[k]), ks)
            term = self._gather(lambda j: self._vertex(left, j), js) @ X
            B = self._gather(lambda j: self._vertex(right, j), js)
            if B is not None:
                term = term + B @ self._gather(self._Z, ks)
            out = out + term
        return out

    def Z(self):
        if self.shape.scheduled:
            return self._linear_sum(self._Z)
        return self._const * self._Z(0)

    def B2(self):
        return self._linear_sum(lambda j: self._vertex("B2", j))

    def G(self):
        return self._const * self._get("G")

    def data(self, key):
        return self._linear_sum(lambda j: self._vertex(key, j))

    def local_linear(self, name):
        if self.shape.scheduled:
            return self._linear_sum(lambda j: self.var(f"{name}{j}"))
        return self._const * self.var(f"{name}0")
