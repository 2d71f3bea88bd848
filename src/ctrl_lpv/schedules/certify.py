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
   vary, of the cell's pairwise terms
   (`ctrl_lpv.schedules.polytopic.PolytopicLoops.spanning`);
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
   rates; `ctrl_lpv.schedules.objective`); with ``rate_bounds``, the L2
   gain under them too (the bounded-real form of step 3,
   `ctrl_lpv.schedules.rates.form_lmis`), the smaller of the two
   reported. Without a common Lyapunov function only the rate-bounded L2
   gain exists, so it needs ``rate_bounds``.

For a `ctrl_lpv.GriddedStateSpace` the same steps run on the pieces of
grid cells and schedule simplices, with the terms and the multilinear
``P(p)`` of `ctrl_lpv.schedules.gridded` (independent of a parameter
whose rate is not bounded). A dynamic (output-feedback)
controller is closed with the plant by signal names and analysed the same
way, with the terms of `ctrl_lpv.schedules.dynamic`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._checks import checked_rates, real_number
from ..certificate import Certificate
from ..exceptions import SynthesisError
from ..systems import GriddedStateSpace
from .dynamic import DynamicLoops, is_dynamic
from .objective import checked_objective
from .polytopic import PolytopicLoops, gridded_loops
from .schedule import GainSchedule, schedule_of

__all__ = ["certify", "ScheduleCertificate", "FrozenCounterexample"]


@dataclass(frozen=True)
class FrozenCounterexample:
    """A frozen parameter value whose closed loop is unstable.

    Attributes
    ----------
    point : dict
        The parameter value.
    cell : int or tuple
        The schedule's cell containing it (a grid cell's lower corner on a
        gridded plant; 0 for a dynamic controller on a polytopic plant).
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
        `Hinf`, H2 for `H2`) for the rates of `rate_bound` (arbitrarily fast
        parameters where they are ``inf``); None otherwise or when it is not
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
    controller : gain schedule or dynamic controller
        A scheduled state feedback ``u = -K(p) x``: a controller from
        `control.create_statefbk_iosystem` (``gain=(gains, points)``,
        ``gainsched_method="linear"``), a table ``(gains, points)``, a
        `StateFeedbackDesign` of this library (certified on another plant,
        e.g. the true one), or a `GainSchedule`. Its outputs (for a table: ``u``, the
        plant's inputs in order) are plant inputs; ``K`` acts on the plant's
        states.

        Or a dynamic (output-feedback) controller ``xk' = Ak xk + Bk y``,
        ``u = Ck xk + Dk y`` (python-control's sign: it outputs ``u``): an
        LTI `control.StateSpace`, a scheduled `PolytopicStateSpace` (as
        `OutputFeedbackDesign.controller` returns it; on the plant's domain,
        or on a box holding the plant's box or grid), an
        `OutputFeedbackDesign` or an `ObserverBasedController` (their
        ``.controller()``). The loop is closed by signal names, as
        `control.interconnect` would: its inputs are plant outputs, its
        outputs plant inputs, of the same names; the loop's state is
        ``(x, xk)``. The plant's feedthrough from ``u`` to ``y`` must be
        zero. See `ctrl_lpv.schedules.dynamic` for why the products of
        plant and controller coordinates span the loop.
    plant : `PolytopicStateSpace` or `GriddedStateSpace`
        The plant over a box of named parameters, or on a grid of them
        (e.g. linearizations at trim points, `ctrl_lpv.gss`); then every
        grid cell within the schedule's points is certified, the gain
        being affine on each simplex of the schedule, the plant
        multilinear on each cell (see `ctrl_lpv.schedules.gridded` for why
        the relaxation is sound).
    parameters : mapping of str to str, optional
        ``{scheduling variable: plant parameter}``; default: the same names,
        or else in order. For a scheduled dynamic controller ``{controller
        parameter: plant parameter}``, default the same names (required).
    rate_bounds : mapping of str to float, optional
        Rates to certify, ``{parameter: nu}``; default: find the largest
        ``nu`` for every parameter (per time unit). On a gridded plant a
        parameter not listed (or ``inf``) may vary arbitrarily fast; on a
        polytopic plant every parameter needs a finite rate.
    objective : `Hinf` or `H2`, optional
        A channel ``Hinf(w=..., z=...)`` (or `H2`) whose bound to certify
        (L2 gain, or H2): `certified` then also requires the bound,
        reported in ``.bound``. For arbitrarily fast parameters where one
        Lyapunov matrix exists; with `rate_bounds` also the L2 gain under
        them (continuous time; not with a dynamic controller), the smaller
        one reported with its rates. Its ``w`` are plant
        inputs (with a dynamic controller: not those it drives), its ``z``
        plant outputs; ``bound=`` must be None.
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
        `Hinf` or `H2` naming its channel. For a dynamic controller: an
        output that is not a plant input or an input that is not a plant
        output (named), another time base, a nonzero ``D_yu``, or a
        scheduled controller on another domain than the plant's (or a box
        holding it).

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

    A dynamic controller, closed by signal names (here LTI, ``u = -2 y``
    through a first-order filter):

    >>> K = ct.ss([[-10.0]], [[10.0]], [[-2.0]], 0, inputs="y", outputs="u")
    >>> c = lpv.certify(K, G, objective=lpv.Hinf(w="w", z="y"))
    >>> c.certified, c.rate_bound
    (True, {'a': inf})
    """
    margin = real_number(margin, "margin", positive=True, below=1.0)
    objective = checked_objective(objective)
    if is_dynamic(controller):
        loops = DynamicLoops(controller, plant, parameters)
        where = (f"the plant's {len(loops.points)} points and {samples} samples "
                 f"{'per grid cell' if loops.gridded else 'in its domain'}, with "
                 "the dynamic controller")  # fmt: skip
        return _verdict(loops, where, rate_bounds, objective, margin, samples,
                        counterexample)  # fmt: skip
    if isinstance(controller, GainSchedule):
        schedule = controller
    else:
        # A table's variables are the plant's parameters, in order.
        names = None
        if isinstance(controller, tuple) and hasattr(plant, "param_names"):
            k = np.asarray(controller[1], float).reshape(len(controller[1]), -1)
            names = plant.param_names[: k.shape[1]]
        schedule = schedule_of(controller, names=names)
    if isinstance(plant, GriddedStateSpace):
        loops = gridded_loops(schedule, plant, controller, parameters)
    else:
        loops = PolytopicLoops.of(schedule, plant, controller, parameters)
    where = f"{len(schedule.points)} points and {samples} samples per cell"
    return _verdict(loops, where, rate_bounds, objective, margin, samples,
                    counterexample)  # fmt: skip


def _verdict(loops, where, rate_bounds, objective, margin, samples, counterexample):
    """The steps of `certify` on closed loops of either kind."""
    nu = None if rate_bounds is None else checked_rates(rate_bounds, loops.names)
    if nu is not None and np.isinf(nu).any() and not loops.unbounded_rates:
        raise ValueError(
            f"rate_bounds: give a finite rate for every parameter {list(loops.names)} "
            "(only on a gridded plant may a parameter be left out: its P(p) then "
            "does not depend on it)"
        )
    tried = []
    frozen = loops.frozen_counterexample(samples)
    tried.append(f"frozen closed loops at {where}")
    if frozen is not None:
        return ScheduleCertificate(False, {n: 0.0 for n in loops.names}, frozen,
                                   Certificate(()), tuple(tried))  # fmt: skip
    quadratic = loops.quadratic(margin)
    tried.append("one quadratic Lyapunov function (arbitrary rates)")
    if quadratic is not None:
        rates = {n: math.inf for n in loops.names}
        if objective is None:
            return ScheduleCertificate(True, rates, None, quadratic, tuple(tried))
        found = _arbitrary_rate_bound(loops, objective, margin, tried)
        if nu is not None and not np.isinf(nu).all() and _rate_analysis(loops, tried):
            # The rates asked for may give a smaller bound than any rate.
            under = _rate_bound(loops, objective, nu, margin, tried)
            if under is not None and (found is None or under[0] < found[0]):
                rates, found = dict(zip(loops.names, nu.tolist())), under
        if found is None:
            return ScheduleCertificate(False, rates, None, quadratic, tuple(tried))
        bound, certificate = found
        return ScheduleCertificate(True, rates, None, quadratic + certificate,
                                   tuple(tried), bound)  # fmt: skip
    none = {n: 0.0 for n in loops.names}
    if not _rate_analysis(loops, tried):
        return ScheduleCertificate(False, none, None, Certificate(()), tuple(tried))
    if nu is not None:
        found = loops.rate_bounded(nu, margin)
        tried.append(f"parameter-dependent P(p), rates {nu.tolist()}")
        if found is None:
            return ScheduleCertificate(False, none, None, Certificate(()), tuple(tried))
        rates = dict(zip(loops.names, nu.tolist()))
        if objective is None:
            return ScheduleCertificate(True, rates, None, found, tuple(tried))
        under = _rate_bound(loops, objective, nu, margin, tried)
        if under is None:
            return ScheduleCertificate(False, rates, None, found, tuple(tried))
        return ScheduleCertificate(True, rates, None, found + under[1], tuple(tried),
                                   under[0])  # fmt: skip
    scale, certificate = loops.largest_rate(margin)
    tried.append("parameter-dependent P(p), bisection on the rate")
    rates = {n: float(scale) for n in loops.names}
    if objective is not None:
        tried.append(
            "the objective's bound: not computed (no Lyapunov matrix holds for "
            "arbitrary rates; pass rate_bounds= for the L2 gain under a rate bound)"
        )
    example = None
    if counterexample and scale < math.inf:
        from .counterexample import destabilising_trajectory

        example = destabilising_trajectory(loops, max(scale, 1e-6))
        tried.append("periodic parameter trajectories above the certified rate")
    certificate = certificate or Certificate(())
    return ScheduleCertificate(False, rates, example, certificate, tuple(tried))


def _rate_analysis(loops, tried) -> bool:
    """Whether the rate-bounded analysis applies (else why, in `tried`)."""
    refusal = loops.rate_refusal()
    if refusal is not None:
        tried.append(f"rate-bounded analysis: not implemented {refusal}")
    return refusal is None


def _arbitrary_rate_bound(loops, objective, margin, tried):
    """``(bound, certificate)`` of the objective for any rate, or None."""
    name = type(objective).__name__
    tried.append(f"{name} bound from {list(objective.w)} to {list(objective.z)}, "
                 "one Lyapunov matrix")  # fmt: skip
    try:
        return loops.bound(objective, margin)
    except SynthesisError as err:
        tried.append(f"{name} bound not certified: {str(err).splitlines()[0]}")
        return None


def _rate_bound(loops, objective, nu, margin, tried):
    """``(bound, certificate)`` of the L2 gain under the rates `nu`, or None."""
    what = (f"L2 gain from {list(objective.w)} to {list(objective.z)} with P(p), "
            f"rates {nu.tolist()}")  # fmt: skip
    try:
        found = loops.rate_bound(objective, nu, margin)
    except ValueError as err:
        tried.append(f"{what}: {err}")
        return None
    tried.append(what + ("" if found is not None else ": not certified"))
    return found
