"""The engine's problem: an immutable description, its structure, its LMIs.

`Problem` is what a call asks (the partitioned plant, the specs, the
options). `Structure` is what fixes its compiled LMIs (sizes, the specs'
structures, the relaxation and the Lyapunov structure): the key of
`ctrl_lpv.synthesis_cache`. `build` poses the LMIs of a structure with
every number that changes between calls or rungs as a parameter (the
prescaled vertex data, the channel weights, the specs' constants, the
stage bounds), and `load` sets them for one rung, so that a compiled
problem serves every call and rung of its structure.

Variables: ``W_l`` (one per Lyapunov vertex), ``Z_k`` (one per gain),
``G`` (the slack of the extended LMIs), ``g_i`` (the squared bound of
channel ``i``), the specs' own, and the stage variables ``t``
(conditioning or decay) and ``kappa`` (gain). Every strict LMI is one
spec's block at one coefficient of the relaxation and one vertex of the
rate box (`ctrl_lpv.synthesis.parametric`). Stages: "optimal" (the
objective alone), "center" (a bound on it, the smallest eigenvalue of
``W`` maximised), "stabilize" (the decay, without an objective), "gain"
(the smallest gain under a bound on the objective) and "bounded" (the
same under a gain bound).
"""

from __future__ import annotations

import dataclasses
import weakref
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ..lmi import LMIProblem, assemble
from ..lmi.blocks import Recording, size
from .parametric import Coefficient, coefficients
from .terms import Shape, StackedTerms, Terms, names

# A given bound is posed as bound^2 (1 - BOUND_SLACK), met strictly.
BOUND_SLACK = 1e-6


@dataclass(frozen=True, eq=False)
class Problem:
    """What one call asks of the engine (immutable).

    Attributes
    ----------
    plant : `~ctrl_lpv.synthesis.channels.Partition`
        The plant, one channel per spec with a channel (in order).
    specs : tuple of `~ctrl_lpv.synthesis.spec.Spec`
        Every spec: the objective (if any) first.
    objective : `~ctrl_lpv.synthesis.spec.Spec` or None
        The channel spec minimised (``bound`` None) or met; None asks for
        stability alone.
    scheduled : bool
        One gain per vertex.
    lyap : `~ctrl_lpv.synthesis.parametric.LyapunovStructure`
    continuous : bool
    backoff, margin : float or None, float
    chain : list or None
        Solvers, ``(name, options)``; None the defaults.
    method : str
        Names the call in messages and the design.
    suspects : tuple
        Weakly controllable modes, for a refusal's hint.
    fixed : tuple of ndarray or None
        Given gains (model units, one or one per vertex): an analysis of the
        loop ``u = -K x`` with the plant's inputs kept (what a spec such as
        `Saturation` reads); ``Z_k = -K_k W`` is then a product of a
        parameter and ``W`` (a constant Lyapunov matrix), not a variable.
    """

    plant: object
    specs: tuple
    objective: object
    scheduled: bool
    lyap: object
    continuous: bool
    backoff: float | None
    margin: float
    chain: list | None
    method: str
    suspects: tuple = ()
    fixed: tuple | None = None

    @property
    def channels(self) -> tuple:
        """The channel index of each spec (None without a channel)."""
        out, i = [], 0
        for spec in self.specs:
            out.append(i if spec.channel else None)
            i += spec.channel
        return tuple(out)

    @property
    def bound_specs(self) -> tuple:
        """The specs with a channel, in channel order."""
        return tuple(s for s in self.specs if s.channel)

    @property
    def nZ(self) -> int:
        """Number of ``Z`` variables (none for an analysis)."""
        return 0 if self.fixed is not None else self.ngains

    @property
    def ngains(self) -> int:
        """Number of gains, designed or `fixed` (none without inputs)."""
        if not self.plant.m:
            return 0
        return self.plant.N if self.scheduled else 1

    @property
    def slack(self) -> bool:
        """A common gain with a parameter-dependent ``W``: the extended LMIs."""
        return not (self.lyap.constant or self.scheduled) and self.nZ > 0

    @property
    def affine(self) -> bool:
        """Whether the LMIs have no degree-two terms (see `coefficients`)."""
        return not self.scheduled and (self.lyap.constant or self.slack)

    @property
    def gain_limit(self) -> float | None:
        """The smallest gain bound of the specs (model units), if any."""
        limits = [s.gain_limit for s in self.specs if s.gain_limit is not None]
        return min(limits) if limits else None

    @property
    def decay(self):
        """``(spec position, parameter, grid)`` of a searched decay, or None."""
        for q, spec in enumerate(self.specs):
            found = spec.decays(self.continuous)
            if found is not None:
                return q, names.local(q, "lam"), found
        return None

    @property
    def fixes_scale(self) -> bool:
        return any(s.fixes_scale for s in self.specs)


# The sizes of a structure's strict LMIs (the size guard reads them), by
# structure: they depend on the shapes alone, and reading them evaluates
# every block once (measured: 8 % of a warm n = 4, N = 16 design).
_STRICT_SIZES: dict = {}
_KEPT_STRUCTURES = 64

# The inequalities `Structure.of` listed last (the problem, as a weak
# reference, the structure, the list and the scales its blocks read), for
# the `build` that follows it in a first call: listing them evaluates every
# block once, which is then not done twice.
_LISTED: list = [None, None, None, None]


@dataclass(frozen=True)
class Structure:
    """What fixes a compiled problem (the cache key; see the module doc).

    `entries` (the number of strict LMI matrix entries, ``sum size^2``)
    measures its compiled size.
    """

    n: int
    m: int
    N: int
    nZ: int
    scheduled: bool
    continuous: bool
    slack: bool
    objective: bool
    coefficients: tuple
    lyapunov: tuple
    specs: tuple
    # Gains, designed (nZ of them) or given (an analysis with inputs).
    ngains: int = 0
    entries: int = field(default=0, compare=False)
    nlmis: int = field(default=0, compare=False)
    largest: int = field(default=0, compare=False)

    @classmethod
    def of(cls, problem: Problem, a: float) -> Structure:
        """The structure of `problem` in a frame with time scaling `a`."""
        plant, lyap = problem.plant, problem.lyap
        rates = tuple(tuple((r / a).tolist()) for r in lyap.rates)
        key = cls(
            n=plant.n, m=plant.m, N=plant.N, nZ=problem.nZ, ngains=problem.ngains,
            scheduled=problem.scheduled, continuous=problem.continuous,
            slack=problem.slack, objective=problem.objective is not None,
            coefficients=coefficients(plant.system.domain, plant.N, problem.affine),
            lyapunov=(lyap.index, lyap.count, lyap.moving, rates,
                      tuple(lyap.widths.tolist()), lyap.flip.tobytes()),
            specs=tuple(
                (s.structure(), i) + (() if i is None else
                                      (plant.channels[i].nw, plant.channels[i].nz))
                for s, i in zip(problem.specs, problem.channels)
            ),
        )  # fmt: skip
        sizes = _STRICT_SIZES.pop(key, None)
        if sizes is None:
            zero = _declarations(problem, key).zeros()
            scales = {"T": np.eye(key.n), "Su": np.eye(key.m)}
            listed = list(_inequalities(problem, key, zero, scales))
            sizes = [
                assemble(blocks(zero)).shape[0] if known is None else known
                for _, blocks, is_strict, _, _, _, known, _ in listed
                if is_strict
            ]
            _LISTED[:] = [weakref.ref(problem), key, listed, scales]
        _STRICT_SIZES[key] = sizes  # the most recent last
        if len(_STRICT_SIZES) > _KEPT_STRUCTURES:
            del _STRICT_SIZES[next(iter(_STRICT_SIZES))]
        return dataclasses.replace(
            key, entries=sum(k * k for k in sizes), nlmis=len(sizes),
            largest=max(sizes, default=0),
        )  # fmt: skip

    def shape(self, problem: Problem) -> Shape:
        """What the blocks read (`~ctrl_lpv.synthesis.terms.Shape`)."""
        rates = tuple(np.array(r) for r in self.lyapunov[3])
        lyap = dataclasses.replace(problem.lyap, rates=rates)
        sizes = tuple((c.nw, c.nz) for c in problem.plant.channels)
        return Shape(self.n, self.m, lyap, self.scheduled, self.continuous,
                     self.slack, self.nZ, sizes, self.ngains)  # fmt: skip


class _Declarations:
    """Names and shapes of the variables and parameters of a structure."""

    def __init__(self):
        self.items = {}

    def variable(self, name, shape, symmetric=False):
        self.items[name] = ("variable", tuple(shape), {"symmetric": symmetric})

    def parameter(self, name, shape=(), **kwargs):
        self.items[name] = ("parameter", tuple(shape), kwargs)

    def zeros(self) -> SimpleNamespace:
        return SimpleNamespace(**{k: np.zeros(v[1]) for k, v in self.items.items()})

    def into(self, lmi: LMIProblem) -> None:
        for name, (kind, shape, kwargs) in self.items.items():
            getattr(lmi, kind)(name, shape, **kwargs)


class _Local:
    """A spec's view of the declarations: its names prefixed, its sizes."""

    def __init__(self, declarations, q, n, m, nZ, i=None, nw=0, nz=0, ngains=0):
        self._d, self._q = declarations, q
        self.n, self.m, self.nZ, self.i, self.nw, self.nz = n, m, nZ, i, nw, nz
        self.ngains = ngains

    def variable(self, name, shape, symmetric=False):
        self._d.variable(names.local(self._q, name), shape, symmetric)

    def parameter(self, name, shape=(), **kwargs):
        self._d.parameter(names.local(self._q, name), shape, **kwargs)


def spec_dims(problem, q, s: Structure) -> _Local:
    """The sizes a spec's `prescale` reads (as its `variables` declare)."""
    return _local(_Declarations(), problem, q, s)


def _local(declarations, problem, q, s):
    i = problem.channels[q]
    nw = nz = 0
    if i is not None:
        nw, nz = problem.plant.channels[i].nw, problem.plant.channels[i].nz
    return _Local(declarations, q, s.n, s.m, s.nZ, i, nw, nz, s.ngains)


def _declarations(problem: Problem, s: Structure) -> _Declarations:
    d = _Declarations()
    n, m = s.n, s.m
    for ell in range(problem.lyap.count):
        d.variable(f"W{ell}", (n, n), symmetric=True)
    for k in range(s.nZ):
        d.variable(f"Z{k}", (m, n))
    if problem.fixed is not None:
        for k in range(s.ngains):
            d.parameter(f"K{k}", (m, n))
    for i in range(len(problem.plant.channels)):
        d.variable(f"g{i}", (1, 1))
        d.parameter(f"rho{i}", (), nonneg=True)
        d.parameter(f"gfix{i}", (1, 1), nonneg=True)
    for q in range(len(problem.specs)):
        problem.specs[q].variables(_local(d, problem, q, s))
    for name in ("t", "kappa"):
        d.variable(name, (1, 1))
    if s.slack:
        d.variable("G", (n, n))
        d.parameter("eps", (), nonneg=True)
    for j in range(s.N):
        _data_parameters(d, problem, s, j)
    d.parameter("g_max", (1, 1), nonneg=True)
    d.parameter("w_max", (), nonneg=True)
    d.parameter("z_max", (), nonneg=True)
    if s.nZ:
        for name in ("gain_H", "gain_C", "gain_HK"):
            d.parameter(name, (n, n))
        d.parameter("kappa_max", (), nonneg=True)
    return d


def _data_parameters(d, problem, s, j) -> None:
    n, m = s.n, s.m
    keys = [("A", None, (n, n))] + ([("B2", None, (n, m))] if m else [])
    for i, c in enumerate(problem.plant.channels):
        keys += [("Bw", i, (n, c.nw)), ("Cz", i, (c.nz, n)), ("Dzw", i, (c.nz, c.nw))]
        keys += [("Dzu", i, (c.nz, m))] if m else []
    if s.slack:
        keys += [("e" + key, i, shape) for key, i, shape in keys
                 if key in ("A", "B2", "Cz", "Dzu")]  # fmt: skip
    for key, i, shape in keys:
        d.parameter(names.data(key, j, i), shape)


def _inequalities(problem: Problem, s: Structure, zero, scales=None):
    """``(name, blocks, strict, stages, normalization, reads, size,
    stacked)`` of a structure (`reads`, the names the blocks read, `size`,
    the matrix's, and `stacked`, its group and position, None where not
    known without an evaluation or not in a group).

    `zero` is a numeric namespace of the declared names (the specs' block
    lists are evaluated once on it, for their names); `scales` the state
    and input scalings the gain stage reads as constants.
    """
    for item in _listed(problem, s, zero, scales):
        yield item + (None,) * (8 - len(item))


def _listed(problem: Problem, s: Structure, zero, scales=None):
    """`_inequalities`, the spec's with their reads and sizes, the engine's
    own (few and small) without."""
    n, m = s.n, s.m
    shape = s.shape(problem)
    channels = problem.channels
    specs = tuple(zip(problem.specs, channels))
    rates = shape.lyap.rates
    labels = [str(spec) for spec in problem.specs]
    several = sum(c is not None for c in channels) > 1
    # Specs of one kind (two Hinf channels) are told apart by name, equal
    # constraints (a region given twice) by position.
    tags = [f" #{q}" if labels.count(x) > 1 else
            (f" [{x}]" if several and channels[q] is not None else "")
            for q, x in enumerate(labels)]  # fmt: skip
    cont = s.continuous

    def view(c, r, q):
        return lambda v: Terms(v, c, r, shape, specs).bind(q)

    # The one evaluation on `zero` of a spec's method gives its LMIs'
    # names, sizes and the names they read (`ctrl_lpv.lmi.LMIProblem.add`,
    # ``reads``): none of them is evaluated again to learn these.
    read: set = set()
    recording = Recording(vars(zero), read)

    def at_zero(method, terms_of):
        read.clear()
        found = method(terms_of(recording), cont)
        return found, None if "__dict__" in read else frozenset(read)

    # A spec's LMIs of one kind, rate and position in its list, at every
    # coefficient: one group, evaluated stacked at a point (`StackedTerms`;
    # `ctrl_lpv.lmi.LMIProblem.add`, ``stacked``).
    groups: dict = {}

    def group(method, r, q, k):
        key = (method, r.tobytes(), q, k)
        if key not in groups:

            def blocks(v, positions=None, repeats=None):
                cs = s.coefficients
                if positions is not None:
                    cs = [cs[p] for p in positions]
                t = StackedTerms(v, cs, r, shape, specs, repeats)
                return method(t.bind(q), cont)[k][1]

            groups[key] = blocks
        return groups[key]

    def named(method, terms_of, at, strict=True, stages=None, norm=False,
              stacked=None):  # fmt: skip
        found, reads = at_zero(method, terms_of)
        for k, (name, blocks) in enumerate(found):
            yield (f"{name}{at}",
                   lambda v, k=k: method(terms_of(v), cont)[k][1],
                   strict, stages, norm, reads, size(blocks),
                   None if stacked is None else (group(method, *stacked[:2], k),
                                                 stacked[2]))  # fmt: skip

    for ell in range(problem.lyap.count):
        yield (
            f"W{ell} > 0",
            lambda v, e=ell: [[-getattr(v, f"W{e}")]],
            True,
            None,
            False,
        )
    for ci, c in enumerate(s.coefficients):
        for r in rates:
            r = np.asarray(r, float)
            at = c.label + (f", rate {np.round(r, 12).tolist()}"
                            if len(rates) > 1 else "")  # fmt: skip
            for q, spec in enumerate(problem.specs):
                yield from named(spec.lmis, view(c, r, q), f"{tags[q]} {at}",
                                 stacked=(r, q, ci))  # fmt: skip
                if not s.objective:
                    yield from named(spec.decay_lmis, view(c, r, q),
                                     f"{tags[q]} {at}", False, ("stabilize",),
                                     True, (r, q, ci))  # fmt: skip
        for q, spec in enumerate(problem.specs):
            r = np.asarray(rates[0], float)
            yield from named(spec.coefficient_lmis, view(c, r, q),
                             f"{tags[q]} {c.label}", stacked=(r, q, ci))  # fmt: skip
    once = Coefficient("problem", 1.0, (), ())
    for q, spec in enumerate(problem.specs):
        terms_of = view(once, rates[0], q)
        found, reads = at_zero(lambda t, _, spec=spec: spec.problem_lmis(t), terms_of)
        for k, (name, blocks, strict) in enumerate(found):
            yield (f"{name}{tags[q]}",
                   lambda v, k=k, spec=spec, terms_of=terms_of:
                   spec.problem_lmis(terms_of(v))[k][1],
                   strict, None, False, reads, size(blocks))  # fmt: skip
    for i in range(len(problem.plant.channels)):
        if s.objective and i == 0:
            yield ("g <= g_max", lambda v: [[v.g0 - v.g_max]], False,
                   ("center", "gain", "bounded"), False)  # fmt: skip
        else:
            yield (f"bound {i}",
                   lambda v, i=i: [[getattr(v, f"g{i}") - getattr(v, f"gfix{i}")]],
                   False, None, False)  # fmt: skip
    for ell in range(problem.lyap.count):
        yield (f"W{ell} <= w_max I",
               lambda v, e=ell: [[getattr(v, f"W{e}") - v.w_max * np.eye(n)]],
               False, ("center", "stabilize", "gain", "bounded"), True)  # fmt: skip
        yield (f"W{ell} >= t I",
               lambda v, e=ell: [[v.t[0, 0] * np.eye(n) - getattr(v, f"W{e}")]],
               False, ("center", "stabilize"), True)  # fmt: skip
    for k in range(s.nZ):
        # The stabilization LMIs are homogeneous in (W, Z): W <= I together
        # with ||Z|| <= 1 fixes the scale and balances decay against gain;
        # larger z_max admit the smaller decays of badly scaled problems.
        yield (f"||Z{k}||^2 <= z_max",
               lambda v, k=k: [[-v.z_max * np.eye(n)],
                               [getattr(v, f"Z{k}"), -np.eye(m)]],
               False, ("stabilize",), True)  # fmt: skip
    if s.nZ:
        # The gain of Z_k is K_k = -Z_k X_k^-1: X_k its vertex's W, or the
        # slack G of the extended LMIs.
        # The back-off ("gain") bounds the prescaled gain, a gain bound
        # ("bounded") the model's.
        lyap = problem.lyap
        scales = scales or {"T": np.eye(n), "Su": np.eye(m)}
        unit = {"T": np.eye(n), "Su": np.eye(m)}
        for k in range(s.nZ):
            X = "G" if s.slack else f"W{lyap.index[k if s.scheduled else 0]}"
            for stage, units, label in (("gain", unit, " (prescaled)"),
                                        ("bounded", scales, "")):  # fmt: skip
                yield (f"||K{k}||^2 <= kappa{label}",
                       lambda v, k=k, X=X, units=units: gain_tangent_blocks(
                           getattr(v, X), getattr(v, f"Z{k}"), v.gain_H, v.gain_C,
                           v.gain_HK, v.kappa[0, 0], units["T"], units["Su"]),
                       False, (stage,), True)  # fmt: skip
        # Only with a gain bound (another stage): a cap far above every
        # gain would cost the solvers digits.
        yield ("kappa <= kappa_max",
               lambda v: [[v.kappa - v.kappa_max * np.eye(1)]],
               False, ("bounded",), True)  # fmt: skip


def gain_tangent_blocks(X, Z, H, C, HK, kappa, T, Su):
    """``||K||^2 <= kappa kappa0`` for ``K = -Z X^-1``, linearised at ``X0``.

    With ``K = Su Z X^-1 T^-1`` in prescaled units, the bound is
    ``(Su Z)'(Su Z) <= kappa kappa0 (T X)'(T X)``, whose right side is
    bounded below by its tangent at ``G0 = T X0``, ``G0' T X + (T X)' G0 -
    G0' G0`` (as ``(T X - G0)'(T X - G0) >= 0``): sufficient everywhere
    and exact at ``X0``. By a Schur complement and a congruence the block
    returned, ``[[-(T X H + (T X H)' - C), *], [Su Z HK, -kappa I]] <= 0``,
    is that bound for ``H = G0^-1``, ``C = I`` and ``HK = G0^-1 /
    sqrt(kappa0)`` (well scaled where ``X0`` is the point's own ``X``),
    or, at ``X0 = w0 I`` with ``T = I``, for ``H = I``, ``C = w0 I``, ``HK
    = I`` and ``kappa0 = 1 / w0`` (well scaled where ``w0`` is far below
    ``X``). ``H``, ``C``, ``HK`` are parameters, `T` and `Su` the state and
    input scalings as matrices (constants of the structure).
    """
    m = Z.shape[0]
    M = T @ X @ H
    return [[-(M + M.T - C)], [Su @ Z @ HK, -kappa * np.eye(m)]]


@dataclass
class Compiled:
    """A cached problem: the LMIs and the constants its gain stage reads."""

    lmi: LMIProblem
    scales: dict


def build(problem: Problem, s: Structure) -> Compiled:
    """The LMI problem of a structure, every number a parameter.

    Parameters get their values from `load`, before every use.
    """
    declarations = _declarations(problem, s)
    lmi = LMIProblem(margin=problem.margin)
    declarations.into(lmi)
    ref, listed_for, listed, scales = _LISTED
    _LISTED[:] = [None, None, None, None]
    if ref is None or ref() is not problem or listed_for != s:
        scales = {"T": np.eye(s.n), "Su": np.eye(s.m)}
        listed = _inequalities(problem, s, declarations.zeros(), scales)
    for name, blocks, strict, stages, norm, reads, _, stacked in listed:
        lmi.add(name, blocks, strict=strict, stages=stages, normalization=norm,
                reads=reads, stacked=stacked)  # fmt: skip
    return Compiled(lmi, scales)


def load(compiled: Compiled, problem: Problem, s: Structure, frame, margin) -> dict:
    """Set every parameter of a (possibly reused) problem for one rung.

    All of them, stage bounds included, so that nothing of a previous call
    can leak into this one. Returns the prescaled vertex data (the
    extended LMIs' products are set again for each of their scalars,
    `set_eps`).
    """
    lmi = compiled.lmi
    scales = {"T": frame.scaling.matrix, "Su": np.diag(frame.scaling.Su)}
    if any(not np.array_equal(compiled.scales[k], v) for k, v in scales.items()):
        compiled.scales.update(scales)
        # The scalings enter `gain_tangent_blocks` as matrix factors only.
        lmi.invalidate("bounded", same_code=True)
    data = frame.scaled(problem.plant)
    if problem.fixed is not None:
        # u = -K x with u = Su u~, x = T x~: K~ = Su^-1 K T.
        sc = frame.scaling
        for k, K in enumerate(problem.fixed):
            lmi.set_parameter(f"K{k}", (K / sc.Su[:, None]) @ sc.matrix)
    for j in range(s.N):
        lmi.set_parameter(names.data("A", j), data["A"][j])
        if s.m:
            lmi.set_parameter(names.data("B2", j), data["B2"][j])
        for i in range(len(problem.plant.channels)):
            for key in ("Bw", "Cz", "Dzw") + (("Dzu",) if s.m else ()):
                lmi.set_parameter(names.data(key, j, i), data[key, i][j])
    for q, (spec, i) in enumerate(zip(problem.specs, problem.channels)):
        dims = spec_dims(problem, q, s)
        for name, value in spec.prescale(frame, dims).items():
            lmi.set_parameter(names.local(q, name), value)
        if i is None:
            continue
        lmi.set_parameter(f"rho{i}", frame.rho(i))
        fixed = 0.0
        if spec.bound is not None and not (s.objective and i == 0):
            fixed = spec.to_scaled(spec.bound, frame, i) * (1 - BOUND_SLACK)
        lmi.set_parameter(f"gfix{i}", fixed)
    lmi.margin = margin
    lmi.set_parameter("g_max", 1.0)
    lmi.set_parameter("w_max", 1.0)
    lmi.set_parameter("z_max", 1.0)
    if s.nZ:
        for name in ("gain_H", "gain_C", "gain_HK"):
            lmi.set_parameter(name, np.eye(s.n))
        lmi.set_parameter("kappa_max", 1.0)
    return data


def set_eps(lmi: LMIProblem, problem: Problem, s: Structure, data, eps) -> None:
    """The scalar of the extended LMIs and its products with the data."""
    lmi.set_parameter("eps", eps)
    for j in range(s.N):
        lmi.set_parameter(names.data("eA", j), eps * data["A"][j])
        lmi.set_parameter(names.data("eB2", j), eps * data["B2"][j])
        for i in range(len(problem.plant.channels)):
            lmi.set_parameter(names.data("eCz", j, i), eps * data["Cz", i][j])
            lmi.set_parameter(names.data("eDzu", j, i), eps * data["Dzu", i][j])
