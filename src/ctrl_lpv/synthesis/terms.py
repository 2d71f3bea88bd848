"""The parameter-dependent products of the LMIs at one relaxation coefficient.

A `Terms` object evaluates, for one `~ctrl_lpv.synthesis.parametric.Coefficient`
and one vertex of the rate box, the homogenised sums the spec classes write
their blocks with: ``A(delta) W(delta) + B2(delta) Z(delta)`` (degree two),
``W(delta)`` and the data of a channel (degree one), constants (degree zero).
It works on cvxpy variables when the problem is built and on float arrays
when `ctrl_lpv.lmi.LMIProblem` checks a point, from the same code.
"""

from __future__ import annotations

import numpy as np

from .parametric import Coefficient, LyapunovStructure, step_terms


class Terms:
    """Sums of one coefficient (see the module docstring).

    Parameters
    ----------
    v : namespace
        Variables and parameters (``W0``, ``W1``, ..., ``Z0``, ..., and the
        spec variables ``g<i>``, ``Y<i>``).
    coefficient : `Coefficient`
    rate : ndarray
        Vertex of the rate box.
    lyapunov : `LyapunovStructure`
    data : list of dict
        Prescaled vertex data: ``"A"``, ``"B2"`` and, per spec index,
        ``(i, key)`` for ``"Bw"``, ``"Cz"``, ``"Dzw"``, ``"Dzu"``.
    specs : dict
        Spec -> index.
    rho : dict
        Spec index -> weight of the identity block of the spec's ``w`` in
        the prescaled LMIs (a power of two; see `ctrl_lpv.synthesis.general`).
    scheduled : bool
        One ``Z`` per vertex.
    continuous : bool
    prescaled : dict, optional
        ``id(spec)`` -> a constraint's constants in prescaled units (its
        ``prescale``).
    """

    def __init__(self, v, coefficient: Coefficient, rate, lyapunov: LyapunovStructure,
                 data, specs, rho, scheduled: bool, continuous: bool,
                 prescaled=None):  # fmt: skip
        self.v = v
        self.c = coefficient
        self.rate = rate
        self.lyap = lyapunov
        self.d = data
        self.specs = specs
        self.weights = rho
        self.scheduled = scheduled
        self.continuous = continuous
        self.scaled = prescaled or {}
        self.n = data[0]["A"].shape[0]
        self.m = data[0]["B2"].shape[1]

    def _W(self, index):
        return getattr(self.v, f"W{index}")

    def _Z(self, k):
        return getattr(self.v, f"Z{k if self.scheduled else 0}")

    def identity(self, size):
        """``I`` (degree zero)."""
        return self.c.const * np.eye(size)

    def const(self, expression):
        """A parameter-independent variable such as ``g I`` or ``Y``."""
        return self.c.const * expression

    def W(self):
        """``W(delta)``."""
        return sum(self._W(self.lyap.index[j]) for j in self.c.linear)

    def W_moved(self):
        """``dW/dt`` (continuous) or ``W(p + dp)`` (discrete) at the rate."""
        out = 0
        for j in self.c.linear:
            for index, factor in step_terms(self.lyap, j, self.rate, self.continuous):
                out = out + factor * self._W(index)
        if isinstance(out, int):
            return np.zeros((self.n, self.n))
        return out

    def _product(self, left, right):
        out = 0
        for j, k in self.c.bilinear:
            term = self.d[j][left] @ self._W(self.lyap.index[k])
            if self.m:
                term = term + self.d[j][right] @ self._Z(k)
            out = out + term
        return out

    def AW(self):
        """``A(delta) W(delta) + B2(delta) Z(delta)``, i.e. ``A_cl W``."""
        return self._product("A", "B2")

    @property
    def slack(self) -> bool:
        """Whether the LMIs are the extended ones, with the slack ``G``."""
        return hasattr(self.v, "G")

    def G(self):
        """The slack matrix (parameter-independent)."""
        return self.c.const * self.v.G

    def eps(self):
        """The scalar of the continuous-time extended LMIs."""
        return self.v.eps

    def _slack_product(self, left, right):
        out = 0
        for j, k in self.c.bilinear:
            out = out + self.d[j][left] @ self.v.G + self.d[j][right] @ self._Z(k)
        return out

    def AG(self):
        """``A(delta) G + B2(delta) Z``, i.e. ``A_cl G`` (common gain)."""
        return self._slack_product("A", "B2")

    def CG(self, spec):
        """``Cz(delta) G + Dzu(delta) Z``, i.e. ``C_cl G``."""
        i = self.specs[spec]
        return self._slack_product((i, "Cz"), (i, "Dzu"))

    def CW(self, spec):
        """``Cz(delta) W(delta) + Dzu(delta) Z(delta)``, i.e. ``C_cl W``."""
        i = self.specs[spec]
        return self._product((i, "Cz"), (i, "Dzu"))

    def B2(self):
        """``B2(delta)`` (degree one)."""
        return sum(self.d[j]["B2"] for j in self.c.linear)

    def linear(self, name):
        """A gain-like variable (``Z``, ``Zg``): one per vertex when scheduled
        (degree one), else constant (degree zero)."""
        if self.scheduled:
            return sum(getattr(self.v, f"{name}{j}") for j in self.c.linear)
        return self.c.const * getattr(self.v, f"{name}0")

    def prescaled(self, spec):
        """A spec's constants in prescaled units."""
        return self.scaled[id(spec)]

    def data(self, spec, key):
        """A channel's datum (``"Bw"``, ``"Dzw"``) as a degree-one sum."""
        i = self.specs[spec]
        return sum(self.d[j][(i, key)] for j in self.c.linear)

    def nw(self, spec):
        """Number of exogenous inputs of a spec."""
        return self.d[0][(self.specs[spec], "Bw")].shape[1]

    def nz(self, spec):
        """Number of performance outputs of a spec."""
        return self.d[0][(self.specs[spec], "Cz")].shape[0]

    def rho(self, spec):
        """Weight of the identity block of a spec's exogenous input."""
        return self.weights[self.specs[spec]]

    def g(self, spec):
        """The spec's squared bound variable."""
        return getattr(self.v, f"g{self.specs[spec]}")

    def Y(self, spec):
        """The H2 spec's trace variable."""
        return getattr(self.v, f"Y{self.specs[spec]}")
