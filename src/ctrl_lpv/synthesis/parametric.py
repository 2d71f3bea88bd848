"""Parameter dependence of the LMIs: relaxation coefficients, Lyapunov vertices, rates.

Every LMI of `ctrl_lpv.synthesis.compose` is a matrix polynomial of degree
at most two in the convex coordinates ``delta`` of the vertices: data times
a vertex variable (``A(delta) W(delta)``, ``B(delta) Z(delta)``) is of
degree two, a variable or a datum alone (``W(delta)``, ``B_w(delta)``) of
degree one, a constant (``-I``) of degree zero. Written homogeneously, the
polynomial is negative definite on the domain if every coefficient matrix
is (a Polya relaxation of degree zero): its monomials are nonnegative and
sum to a positive number.

* On a `ctrl_lpv.ParameterBox` the coordinates are products of one
  2-simplex per parameter (a multi-simplex): the monomials are indexed by
  one of ``{lower, lower}``, ``{lower, upper}``, ``{upper, upper}`` per
  parameter, ``3**k`` coefficients for ``k`` parameters (Oliveira, Bernussou
  and Peres's multi-simplex; ROLMIP's representation). A condition that is
  multi-affine in the parameters has the vertex values among its
  coefficients and the mixed ones are sums of them: the relaxation is then
  exact.
* On any other domain the coordinates form one simplex over the ``N``
  vertices: coefficients ``delta_j delta_k``, ``j <= k`` (the vertex and
  pair LMIs of the paper's Theorem 2).

A parameter-dependent Lyapunov matrix is multi-affine on a box,
``W(p) = sum_j delta_j(p) W_j``, with ``W_j`` shared by the vertices that
differ only in parameters whose rate is unbounded (``W`` does not depend on
them). Its derivative along ``p_i`` is again linear in ``delta``:
``dW/dp_i = sum_j delta_j (W_j[i -> upper] - W_j[i -> lower]) / width_i``,
and a step ``p -> p + dp`` of a multi-affine function is exact:
``W(p + dp) = sum_S prod_{i in S} dp_i d^S W / dp_S`` over subsets ``S``
of the parameters. Both are affine (multi-affine) in the rate, so the
conditions are imposed at the vertices of the rate box ``|dp_i| <= nu_i``.

``W`` is also made independent of a parameter (as for an unbounded rate)
when depending on it could not help and would only ruin the numerics
(`lyapunov_structure`): a rate so fast that the parameter crosses its
interval more than `FAST_CROSSINGS` times per time unit of the data, and
an interval too narrow to change the data (a degenerate box: an LTI
problem in that parameter). Both are sound, since a ``W`` constant in a
parameter is one of the multi-affine ones and holds for every rate; they
give up at most what a rate of `FAST_CROSSINGS` crossings gains over an
unbounded one (measured on the mass-spring model: nothing in the seven
digits reported from 100 crossings on). In discrete time a bound above the
width is the width (``|p[k+1] - p[k]|`` cannot exceed it).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.linalg import matrix_balance

from .. import budget
from .._checks import checked_rates
from ..polytope import ParameterBox

# A rate bound above this many crossings of the parameter's interval per
# time unit of the data (the inverse of `data_rate`) counts as unbounded.
FAST_CROSSINGS = 1e3
# An interval that changes the vertex data by less than this, relative to
# their size, counts as a single value.
NEGLIGIBLE_RANGE = 1e-9


@dataclass(frozen=True)
class Coefficient:
    """One coefficient of the homogeneous polynomial of an LMI.

    Attributes
    ----------
    label : str
        Which monomial (for certificates and messages).
    const : float
        Factor of the degree-zero terms.
    linear : tuple of int
        Vertices ``j`` whose degree-one terms add up in this coefficient.
    bilinear : tuple of (int, int)
        Ordered vertex pairs ``(j, k)`` of the degree-two terms
        ``data_j variable_k``.
    """

    label: str
    const: float
    linear: tuple[int, ...]
    bilinear: tuple[tuple[int, int], ...]


def coefficients(domain, nvertices: int, affine=False) -> tuple[Coefficient, ...]:
    """The relaxation's coefficients for a domain (module docstring).

    With `affine` the LMIs have no degree-two terms (a common gain with a
    constant ``W`` or the extended LMIs' slack): their homogeneous form has
    the vertex values among its coefficients and every other coefficient
    is a sum of them, so the vertex coefficients alone are the same
    condition (the paper's Lemma 1 and Lemma 2).
    """
    if nvertices == 1:
        return (Coefficient("vertex 0", 1.0, (0,), ((0, 0),)),)
    if isinstance(domain, ParameterBox):
        out = _multi_simplex(domain)
        return tuple(c for c in out if len(c.linear) == 1) if affine else out
    if affine:
        return tuple(
            Coefficient(f"vertex {j}", 1.0, (j,), ((j, j),)) for j in range(nvertices)
        )
    out = []
    for j, k in itertools.combinations_with_replacement(range(nvertices), 2):
        if j == k:
            out.append(Coefficient(f"vertex {j}", 1.0, (j,), ((j, j),)))
        else:
            out.append(Coefficient(f"pair ({j}, {k})", 2.0, (j, k), ((j, k), (k, j))))
    return tuple(out)


def _multi_simplex(domain: ParameterBox) -> tuple[Coefficient, ...]:
    k = domain.nparams
    index = {tuple(bits): j for j, bits in enumerate(domain._bits.astype(int).tolist())}
    # Per parameter: 0 = {lower, lower}, 1 = {lower, upper}, 2 = {upper, upper}.
    single = {0: ((0,),), 1: ((0,), (1,)), 2: ((1,),)}
    double = {0: ((0, 0),), 1: ((0, 1), (1, 0)), 2: ((1, 1),)}
    names = {0: "lower", 1: "mixed", 2: "upper"}
    out = []
    for m in itertools.product((0, 1, 2), repeat=k):
        linear = tuple(
            index[tuple(b[0] for b in choice)]
            for choice in itertools.product(*(single[mi] for mi in m))
        )
        bilinear = tuple(
            (index[tuple(b[0] for b in choice)], index[tuple(b[1] for b in choice)])
            for choice in itertools.product(*(double[mi] for mi in m))
        )
        const = float(np.prod([2.0 if mi == 1 else 1.0 for mi in m]))
        if all(mi != 1 for mi in m):
            label = f"vertex {index[tuple(mi // 2 for mi in m)]}"
        else:
            label = (
                "coefficient ("
                + ", ".join(f"{n}: {names[mi]}" for n, mi in zip(domain.names, m))
                + ")"
            )
        out.append(Coefficient(label, const, linear, bilinear))
    return tuple(out)


@dataclass(frozen=True)
class LyapunovStructure:
    """Which Lyapunov matrix each vertex uses, and the rate box.

    Attributes
    ----------
    index : tuple of int
        ``W`` matrix of each vertex (all 0 for a constant Lyapunov matrix).
    count : int
        Number of distinct ``W`` matrices.
    widths : ndarray
        Parameter interval widths (empty without parameter dependence).
    rates : tuple of ndarray
        Vertices of the rate box (one zero vector when the Lyapunov matrix
        cannot move): ``dp/dt`` in continuous time, ``p[k+1] - p[k]`` in
        discrete time.
    moving : tuple of int
        Parameters along which ``W`` varies and whose rate is nonzero.
    flip : ndarray
        ``flip[j, i, b]``: the vertex equal to ``j`` with parameter ``i`` at
        its lower (``b = 0``) or upper (``b = 1``) bound.
    """

    index: tuple[int, ...]
    count: int
    widths: np.ndarray
    rates: tuple[np.ndarray, ...]
    moving: tuple[int, ...]
    flip: np.ndarray

    @property
    def constant(self) -> bool:
        """Whether there is one Lyapunov matrix."""
        return self.count == 1


def data_rate(As) -> float:
    """The fastest rate of the data: ``max_j ||A_j||`` in balanced coordinates.

    The diagonal balancing of ``sum_j |A_j|`` makes it independent of the
    units of the states; it is the time scaling of the prescaling
    (`ctrl_lpv.synthesis.scaling.Scaling`), in 1/time.
    """
    absA = sum(np.abs(A) for A in As)
    _, (t, _) = matrix_balance(absA, permute=False, separate=True)
    return max(float(np.linalg.norm(A * (t / t[:, None]), 2)) for A in As)


def _negligible(sys, flip) -> np.ndarray:
    """Whether each box parameter changes the vertex data by a negligible
    amount (`NEGLIGIBLE_RANGE`) relative to their size."""
    data = [np.block([[A, B], [C, D]]) for A, B, C, D in sys.vertex_data()]
    size = max(np.abs(M).max() for M in data)
    out = np.zeros(flip.shape[1], bool)
    for i in range(flip.shape[1]):
        change = max(np.abs(M - data[flip[j, i, 0]]).max() for j, M in enumerate(data))
        out[i] = change <= NEGLIGIBLE_RANGE * size
    return out


def lyapunov_structure(sys, lyapunov: str, rate_bounds) -> LyapunovStructure:
    """Validate `lyapunov` and `rate_bounds` and map vertices to ``W_j``.

    ``W`` does not depend on a parameter with an unbounded rate, nor on
    one whose rate bound exceeds `FAST_CROSSINGS` crossings of its interval
    per time unit of the data (continuous time; `data_rate`), nor on one
    whose interval changes the data by less than `NEGLIGIBLE_RANGE`
    (module docstring). In discrete time a rate bound above the interval's
    width is the width.
    """
    N = sys.nvertices
    if lyapunov not in ("constant", "affine"):
        raise ValueError(f"lyapunov: expected 'constant' or 'affine', got {lyapunov!r}")
    if lyapunov == "constant":
        if rate_bounds is not None:
            raise ValueError(
                "rate_bounds: only used with lyapunov='affine' (a constant "
                "Lyapunov matrix holds for any rate)"
            )
        return LyapunovStructure((0,) * N, 1, np.zeros(0), (np.zeros(0),), (),
                                 np.zeros((N, 0, 2), int))  # fmt: skip
    if rate_bounds is None:
        raise ValueError(
            "rate_bounds: lyapunov='affine' needs the rate bounds {name: nu} "
            "(nu = 0 for time-invariant parameters); an arbitrarily fast "
            "parameter needs a constant Lyapunov matrix"
        )
    domain = sys.domain
    if not isinstance(domain, ParameterBox):
        raise ValueError(
            f"lyapunov: 'affine' needs a ParameterBox domain, the system has {domain!r}"
        )
    nu = checked_rates(rate_bounds, domain.names)
    bits = domain._bits.astype(int)
    lookup = {tuple(row): j for j, row in enumerate(bits.tolist())}
    flip = np.zeros((N, domain.nparams, 2), int)
    for j, row in enumerate(bits.tolist()):
        for i in range(domain.nparams):
            for b in (0, 1):
                flipped = list(row)
                flipped[i] = b
                flip[j, i, b] = lookup[tuple(flipped)]
    nu = _effective_rates(sys, nu, flip)
    slow = [i for i in range(domain.nparams) if np.isfinite(nu[i])]
    keys = [tuple(row[slow]) for row in bits]
    distinct = sorted(set(keys))
    index = tuple(distinct.index(key) for key in keys)
    moving = tuple(i for i in slow if nu[i] > 0)
    rates = []
    for signs in itertools.product((-1.0, 1.0), repeat=len(moving)):
        r = np.zeros(domain.nparams)
        r[list(moving)] = np.array(signs) * nu[list(moving)]
        rates.append(r)
    return LyapunovStructure(index, len(distinct), domain.upper - domain.lower,
                             tuple(rates), moving, flip)  # fmt: skip


def _effective_rates(sys, nu, flip) -> np.ndarray:
    """The rate bounds `nu` with the parameters ``W`` need not depend on
    set to ``inf`` (see `lyapunov_structure`), each one logged."""
    domain = sys.domain
    widths = domain.upper - domain.lower
    nu = nu.copy()
    if sys.isdtime(strict=True):
        nu = np.minimum(nu, widths)
        fast = np.zeros(nu.shape, bool)
    else:
        rate = data_rate([A for A, _, _, _ in sys.vertex_data()])
        fast = np.isfinite(nu) & (nu > FAST_CROSSINGS * rate * widths)
    negligible = np.isfinite(nu) & _negligible(sys, flip)
    for i, name in enumerate(domain.names):
        if negligible[i]:
            why = f"its interval changes the data by less than {NEGLIGIBLE_RANGE:g}"
        elif fast[i]:
            why = (
                f"its rate bound {nu[i]:g} crosses the interval more than "
                f"{FAST_CROSSINGS:g} times per time unit of the data"
            )
        else:
            continue
        budget.progress("W does not depend on %r: %s", name, why)
        nu[i] = np.inf
    return nu


def difference_terms(structure: LyapunovStructure, j: int, subset) -> list:
    """``(W index, factor)`` pairs of ``d^S W / dp_S`` at vertex `j`.

    The finite difference of the multi-affine ``W`` over the parameters in
    `subset` (an empty subset gives ``W_j`` itself), divided by their widths.
    """
    terms = []
    for choice in itertools.product((0, 1), repeat=len(subset)):
        vertex = j
        for i, b in zip(subset, choice):
            vertex = structure.flip[vertex, i, b]
        sign = (-1.0) ** (len(subset) - sum(choice))
        scale = float(np.prod([structure.widths[i] for i in subset]))
        terms.append((structure.index[vertex], sign / scale))
    return terms


def step_terms(structure: LyapunovStructure, j: int, rate, continuous: bool):
    """``(W index, factor)`` pairs of the moved Lyapunov matrix at vertex `j`.

    Continuous time: ``dW/dt = sum_i rate_i dW/dp_i``. Discrete time:
    ``W(p + rate)``, exact for a multi-affine ``W`` (module docstring).
    Kept on the structure by ``(j, rate)``: every LMI and frozen check at
    every point asks again (measured: 60 % of the float64 checks of an
    affine H2 design with four parameters).
    """
    key = (j, np.asarray(rate, float).tobytes(), continuous)
    kept = structure.__dict__.setdefault("_steps", {})  # not a field
    if key not in kept:
        kept[key] = _step_terms(structure, j, rate, continuous)
    return kept[key]


def _step_terms(structure, j, rate, continuous):
    terms: dict[int, float] = {}
    if continuous:
        subsets = [(i,) for i in structure.moving]
    else:
        subsets = [
            s for size in range(len(structure.moving) + 1)
            for s in itertools.combinations(structure.moving, size)
        ]  # fmt: skip
    for subset in subsets:
        weight = float(np.prod([rate[i] for i in subset])) if subset else 1.0
        if weight == 0.0:
            continue
        for w_index, factor in difference_terms(structure, j, subset):
            terms[w_index] = terms.get(w_index, 0.0) + weight * factor
    return [(w, f) for w, f in terms.items() if f != 0.0]
