"""Constraint specs of `synthesize` beyond performance bounds.

`GainBound` bounds the gains; `Saturation` certifies a region of attraction
under input saturation; `PoleRegion` is the spec of a pole region (an
`ctrl_lpv.regions.LMIRegion`, which `as_spec` wraps). Each implements the
protocol of `~ctrl_lpv.synthesis.spec.Spec`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import per_input, positive_levels, real_number
from ..lmi import normalized_max_eig
from ..regions import LMIRegion, region_blocks
from .spec import Spec, unit


@dataclass(frozen=True)
class GainBound(Spec):
    """Bound on the spectral norm of every gain, in the model's units.

    Parameters
    ----------
    bound : float
        Upper bound on ``||K||_2`` (every vertex gain when scheduled).

    Notes
    -----
    Imposed by convex-concave iterations from the first certified point (a
    sufficient condition); a design whose gain stays above the bound is
    not returned. With an objective to minimise the bound is the user's
    limit and the back-off a default: where the iterations end above the
    bound on every rung, the ladder runs again with ``1 + backoff``
    squared (up to 4 times the optimum), and the design's ``backoff`` and
    ``ladder`` say so.
    """

    unique = True
    paper_case = True

    bound: float

    def __post_init__(self):
        object.__setattr__(
            self, "bound", real_number(self.bound, "bound", positive=True)
        )

    def __str__(self) -> str:
        return f"GainBound({self.bound:g})"

    def validate(self, context) -> None:
        if not context.constant:
            raise ValueError(
                "constraints: GainBound is implemented for a constant Lyapunov "
                "matrix only"
            )

    @property
    def gain_limit(self) -> float:
        """The bound: the engine's gain stage imposes it."""
        return self.bound

    def variables(self, declare) -> None:
        """None: the gain stage's tangent bound is the engine's."""

    def prescale(self, frame, dims) -> dict:
        """No constants."""
        return {}

    def lmis(self, t, continuous):
        """None: see `gain_limit`."""
        return []

    def coefficient_lmis(self, t, continuous):
        """None: see `gain_limit`."""
        return []

    def residual(self, loop, continuous) -> float:
        """Relative excess ``||K||_2 / bound - 1`` of the frozen gain."""
        return float(np.linalg.norm(loop.K, 2)) / self.bound - 1


@dataclass(frozen=True)
class Saturation(Spec):
    """Certified region of attraction under actuator saturation.

    The plant sees ``sat(u)``, each input clipped at ``|u_i| <= u_max_i``,
    with ``u = -K x``. The spec certifies that the ellipsoid
    ``E = {x : x' P x <= 1}`` of the design's Lyapunov matrix ``P`` lies in
    the region of attraction of the saturated closed loop (``w = 0``, every
    admissible parameter trajectory), and contains the given `points`.

    Parameters
    ----------
    u_max : float or sequence of float
        Saturation level of each control input (one value for all).
    points : sequence of array_like, optional
        States (model units) that must lie in ``E``: initial conditions
        from which convergence is certified despite saturation.
    decay : float, optional
        Rate ``sigma >= 0`` of ``V = x' P x`` inside ``E`` (``w = 0``):
        ``dV/dt <= -2 sigma V`` (1/s, continuous time) or ``V(k+1) <=
        exp(-2 sigma) V(k)`` (per sample, discrete time). Default 0.

    Notes
    -----
    The generalized sector condition (Gomes da Silva and Tarbouriech, IEEE
    TAC 50(1), 2005; Tarbouriech, Garcia, Gomes da Silva and Queinnec,
    *Stability and Stabilization of Linear Systems with Saturating
    Actuators*, 2011, chapter 3): with the dead zone ``psi = u - sat(u)``
    and an auxiliary gain ``G``, ``psi' T (psi + G x) <= 0`` for every
    diagonal ``T > 0`` wherever ``|((K - G) x)_i| <= u_max_i``. With
    ``W = P^-1``, ``Z = -K W``, ``Zg = G W`` and ``S = T^-1`` the LMIs are

    ``[[sym(A W + B2 Z) - dW/dt + 2 sigma W, *], [-S B2' - Zg, -2 S]] < 0``
    (continuous time), ``[[-r W, *, *], [-Zg, -2 S, *], [A W + B2 Z, -B2 S,
    -W+]] < 0`` with ``r = exp(-2 sigma)`` (discrete time: ``x+ = A_cl x -
    B2 psi``, a Schur complement of ``V(x+) - r V(x) - 2 psi' T (psi + G
    x) < 0``), ``[[u_max_i^2, *], [-(Z + Zg)_i', W]] > 0`` (``E`` inside
    the sector's region) and ``[[1, *], [x0, W]] > 0`` for each point.
    With a spec that carries a peak-bounded disturbance (`Peak`,
    `~ctrl_lpv.synthesis.region.RegionSize`; `Spec.disturbance`) the sector
    inequality also carries its decay ``lambda W`` and disturbance column,
    so that ``E`` is invariant for the saturated loop under every
    disturbance of peak ``w_max``: the ultimate-bound certificate of the
    servo. ``E`` shares ``P`` with the performance specs: with an `Hinf`
    objective ``E`` is also the set that the linear loop's states reach
    with unit disturbance energy, so a larger region costs gamma. With a
    constant or a scheduled ``W``; with given gains (an analysis) too.
    """

    unique = True

    u_max: tuple
    points: tuple = ()
    decay: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "u_max", positive_levels(self.u_max, "u_max"))
        try:
            points = tuple(
                tuple(real_number(x, "points", below=1e150) for x in np.ravel(p))
                for p in self.points
            )
        except TypeError:
            raise TypeError(
                f"points: expected a sequence of state vectors, got {self.points!r}"
            ) from None
        object.__setattr__(self, "points", points)
        object.__setattr__(
            self, "decay", real_number(self.decay, "decay", minimum=0.0, below=1e150)
        )

    def __str__(self) -> str:
        rate = f", decay={self.decay:g}" if self.decay else ""
        return f"Saturation(u_max={list(self.u_max)}, {len(self.points)} points{rate})"

    def structure(self) -> tuple:
        return (*super().structure(), len(self.points))

    def validate(self, context) -> None:
        if not (context.constant or context.scheduled):
            raise ValueError(
                "constraints: Saturation with a common gain and lyapunov='affine' is "
                "not implemented (the extended LMIs have no sector form here); use "
                "gains='scheduled' or a constant Lyapunov matrix"
            )
        if not context.m:
            raise ValueError("constraints: Saturation needs control inputs u")
        self.check_sizes(context.n, context.m)

    @property
    def fixes_scale(self) -> bool:
        """Its points fix the scale of ``W``."""
        return True

    def check_sizes(self, n: int, m: int) -> np.ndarray:
        """The levels, one per input; refuse sizes that do not fit."""
        out = per_input(self.u_max, m, "u_max", "control inputs")
        for point in self.points:
            if len(point) != n:
                raise ValueError(f"points: a point has {len(point)} entries, not {n}")
        return out

    def variables(self, declare) -> None:
        """``Zg`` (one per gain, the auxiliary gain times ``W``), the diagonal
        of ``S``, and the parameters ``levels``, ``rate`` and
        ``contraction`` (the decay in continuous and discrete time) and
        ``point{q}``."""
        n, m = declare.n, declare.m
        for k in range(declare.ngains):
            declare.variable(f"Zg{k}", (m, n))
        declare.variable("S", (m, 1))
        declare.parameter("levels", (m,), nonneg=True)
        declare.parameter("rate", (), nonneg=True)
        declare.parameter("contraction", (), nonneg=True)
        for q in range(len(self.points)):
            declare.parameter(f"point{q}", (n, 1))

    def prescale(self, frame, dims) -> dict:
        """Levels, the decay and points in the prescaled units of a rung.

        With ``W = k T W~ T'`` and ``K = Su K~ T^-1`` (``k`` the scaling's
        `w_factor`), ``(K - G) W (K - G)' = k Su (Z~ + Zg~) W~^-1 (.)' Su``
        and ``x0' W^-1 x0 = x~0' W~^-1 x~0 / k`` with ``x~0 = T^-1 x0``;
        the decay ``2 sigma / a`` (continuous) or ``exp(-2 sigma)``
        (discrete, where ``a = 1``).
        """
        sc = frame.scaling
        k = sc.w_factor
        out = {"levels": self.check_sizes(dims.n, dims.m) ** 2 / (k * sc.Su**2)}
        out["rate"] = 2.0 * self.decay / frame.a
        out["contraction"] = float(np.exp(-2.0 * self.decay))
        Ti = np.linalg.inv(sc.matrix)
        for q, p in enumerate(self.points):
            out[f"point{q}"] = (Ti @ np.array(p) / np.sqrt(k))[:, None]
        return out

    def lmis(self, t, continuous):
        """The sector inequality at one coefficient and rate."""
        m, S = t.m, t.var("S")
        # S (degree zero) alone carries the coefficient's constant; times
        # B2 (degree one) it does not: B2(delta) S has B2_j S + B2_k S at a
        # pair, as Zg(delta) has Zg_j + Zg_k.
        S_data = sum(S[i, 0] * unit(m, i) for i in range(m))
        S = t.const(S_data)
        W, AW, Zg = t.W(), t.AW(), t.local_linear("Zg")
        disturbances = t.disturbances()
        if continuous:
            sector = [
                [2 * AW - t.W_moved() + t.var("rate") * W],
                [-S_data @ t.B2().T - Zg, -2 * S],
            ]
            for lam, Bw, D in disturbances:
                # E must be invariant for the saturated loop under the disturbance.
                sector[0][0] = sector[0][0] + lam * W
                sector.append([Bw.T, 0] + [0] * (len(sector) - 2) + [D])
            return [("saturation sector", sector)]
        # Discrete time: rows x, psi, the disturbances, then x+.
        first = -t.var("contraction") * W
        for lam, _, _ in disturbances:
            first = first + lam * W
        sector = [[first], [-Zg, -2 * S]]
        for _, _, D in disturbances:
            sector.append([0, 0] + [0] * (len(sector) - 2) + [D])
        sector.append(
            [AW, -t.B2() @ S_data] + [Bw for _, Bw, _ in disturbances] + [-t.W_moved()]
        )
        return [("saturation sector", sector)]

    def coefficient_lmis(self, t, continuous):
        """``E`` inside the sector's region, and the points inside ``E``."""
        Zsum = t.Z() + t.local_linear("Zg")
        levels = t.var("levels")
        out = []
        for i in range(t.m):
            out.append((
                f"saturation level {i}",
                [[-t.const(levels[i] * np.eye(1))], [Zsum[i : i + 1, :].T, -t.W()]],
            ))  # fmt: skip
        for q in range(len(self.points)):
            out.append((
                f"saturation point {q}",
                [[-t.identity(1)], [t.const(t.var(f"point{q}")), -t.W()]],
            ))  # fmt: skip
        return out

    def loop_fields(self, here) -> dict:
        """The auxiliary gain ``G`` and the multiplier ``T`` in model units.

        ``G = Zg W^-1`` (unscaled as a gain), ``T = (a / w_factor) Su^-1
        S~^-1 Su^-1`` (``S~`` the solution's diagonal), so that the sector
        inequality in the model's units is congruent to the prescaled one.
        """
        sc = here.frame.scaling
        Zg = here.gain_like("Zg")
        S = np.ravel(here.var("S"))
        return {
            "G": sc.unscale_K(Zg @ np.linalg.inv(here.W_scaled)),
            "T": np.diag(sc.a / sc.w_factor / (sc.Su**2 * S)),
        }

    def model_values(self, frame, read) -> dict:
        """``Zg`` (each gain's ``G W``, model units: ``k Su Zg~ T'``) and the
        multiplier ``T`` (as `loop_fields`); ``G = Zg P``."""
        sc = frame.scaling
        Zg, k = [], 0
        while True:
            try:
                Zt = np.asarray(read(f"Zg{k}"), float)
            except KeyError:
                break
            Zg.append(sc.w_factor * (sc.Su[:, None] * (Zt @ sc.matrix.T)))
            k += 1
        S = np.ravel(np.asarray(read("S"), float))
        return {"Zg": tuple(Zg), "T": np.diag(sc.a / sc.w_factor / (sc.Su**2 * S))}

    def reported(self, P):
        """The largest ``x0' P x0`` over the points (below 1), or None."""
        return self.level(P)

    def level(self, P) -> float | None:
        """The largest ``x0' P x0`` over the points (None without points)."""
        if not self.points:
            return None
        return max(float(np.array(x) @ P @ np.array(x)) for x in self.points)

    def residual(self, loop, continuous) -> float:
        """Largest excess, in the model's units, of the certified statements.

        The sector inequality (Jacobi-normalised eigenvalue) with the loop's
        auxiliary gain ``G`` and multiplier ``T``, continuous time ``[[sym(P
        Acl) + dP/dt + 2 sigma P, -(P B2 + G' T)], [*, -2 T]] < 0``, discrete
        time ``[Acl, -B2]' P+ [Acl, -B2] + [[-r P, -G' T], [*, -2 T]] < 0``
        (with a disturbance: its decay, column and multipliers), and the
        relative excesses of ``(K - G)_i W (K - G)_i' <= u_max_i^2`` and
        ``x0' P x0 <= 1``.
        """
        M = sector_matrix(loop, continuous, self.decay)
        worst = normalized_max_eig(M[None])
        m = loop.B2.shape[1]
        levels = self.check_sizes(loop.Acl.shape[0], m)
        F = loop.K - loop.G
        for i in range(m):
            worst = max(worst, float(F[i] @ loop.W @ F[i]) / levels[i] ** 2 - 1)
        level = self.level(loop.P)
        return worst if level is None else max(worst, level - 1)


def sector_matrix(loop, continuous, decay) -> np.ndarray:
    """The primal sector inequality of `Saturation` at a frozen loop.

    In ``(x, psi[, w])`` (model units): ``V' + 2 sigma V - 2 psi' T (psi +
    G x)`` (continuous time) or ``V(x+) - exp(-2 sigma) V(x) - 2 psi' T
    (psi + G x)`` (discrete time), with the disturbance of a `Peak` or
    region spec (``loop.lam``, ``loop.Bd``, ``loop.mu_w``) where present:
    negative definite on a certified loop.
    """
    Acl, B2, G, T, P = loop.Acl, loop.B2, loop.G, loop.T, loop.P
    n, m = B2.shape
    disturbed = loop.lam is not None
    nw = loop.Bd.shape[1] if disturbed else 0
    lam = loop.lam if disturbed else 0.0
    Bd = loop.Bd if disturbed else np.zeros((n, 0))
    Mw = np.diag(loop.mu_w) if disturbed else np.zeros((0, 0))
    off = -(G.T @ T)
    if continuous:
        top = Acl.T @ P + P @ Acl + loop.P_moved + (2 * decay + lam) * P
        return np.block([
            [top, off - P @ B2, P @ Bd],
            [off.T - B2.T @ P, -2 * T, np.zeros((m, nw))],
            [Bd.T @ P, np.zeros((nw, m)), -Mw],
        ])  # fmt: skip
    F = np.hstack([Acl, -B2, Bd])
    base = np.block([
        [-(np.exp(-2 * decay) - lam) * P, off, np.zeros((n, nw))],
        [off.T, -2 * T, np.zeros((m, nw))],
        [np.zeros((nw, n)), np.zeros((nw, m)), -Mw],
    ])  # fmt: skip
    return F.T @ loop.P_moved @ F + base


@dataclass(frozen=True, eq=False)
class PoleRegion(Spec):
    """The spec of a pole region: every frozen closed loop in `region`.

    Parameters
    ----------
    lmi_region : `ctrl_lpv.regions.LMIRegion`
        ``{s : L + M s + M' conj(s) < 0}``: ``kron(L, W) + sym(kron(M,
        A_cl W)) < 0`` at each coefficient (in discrete time a disk of the
        z-plane).
    """

    paper_case = True

    lmi_region: LMIRegion

    @property
    def region(self) -> LMIRegion:
        """The region imposed."""
        return self.lmi_region

    def __str__(self) -> str:
        return str(self.region)

    def structure(self) -> tuple:
        """``M`` (it multiplies the data); ``L`` is a parameter."""
        M = self.region.M
        return (*super().structure(), M.shape, tuple(M.ravel().tolist()))

    def validate(self, context) -> None:
        if not (context.constant or context.scheduled):
            raise ValueError(
                "constraints: pole regions with a common gain and lyapunov='affine' "
                "are not implemented (the extended LMIs have no region form here); "
                "use gains='scheduled' or a constant Lyapunov matrix"
            )
        if not context.continuous:
            _require_unit_disk(self.region)

    def variables(self, declare) -> None:
        """The parameter ``L`` (time-scaled)."""
        declare.parameter("L", self.region.L.shape)

    def prescale(self, frame, dims) -> dict:
        """``L`` for the prescaled time ``t~ = a t`` (``M`` is unchanged)."""
        return {"L": self.region.L / frame.a}

    def lmis(self, t, continuous):
        """None that depend on the rate."""
        return []

    def coefficient_lmis(self, t, continuous):
        """The region LMI at one coefficient."""
        blocks = region_blocks(t.var("L"), self.region.M, t.W(), t.AW())
        return [(f"region {self.region}", blocks)]

    def residual(self, loop, continuous) -> float:
        """The region's own residual (`ctrl_lpv.regions.LMIRegion.residual`)."""
        return self.region.residual(loop, continuous)


def as_spec(item):
    """`item` as a `Spec`: a pole region is wrapped in a `PoleRegion`.

    Raises
    ------
    TypeError
        If `item` is not a spec or a pole region.
    """
    if isinstance(item, LMIRegion):
        return PoleRegion(item)
    if isinstance(item, Spec):
        return item
    raise TypeError(
        f"constraints: expected Hinf, H2, Peak, GainBound, Saturation or pole "
        f"regions, got {item!r}"
    )


def pole_regions(constraints, who: str) -> tuple[LMIRegion, ...]:
    """The pole regions of `constraints`, for `who`, which takes no other.

    Raises
    ------
    ValueError
        For another spec (a bound, a gain bound: not implemented for `who`).
    TypeError
        For anything else than `LMIRegion` (``halfplane``, ``disk``,
        ``sector``) or `PoleRegion` items.
    """
    if constraints is None:
        return ()
    if isinstance(constraints, (LMIRegion, PoleRegion)):
        constraints = (constraints,)
    if isinstance(constraints, (str, bytes)) or not hasattr(constraints, "__iter__"):
        raise TypeError(
            f"constraints: expected pole regions (halfplane, disk, sector), got "
            f"{constraints!r}"
        )
    out = []
    for item in constraints:
        if isinstance(item, PoleRegion):
            item = item.region
        elif isinstance(item, Spec):
            raise ValueError(
                f"constraints: {item} is not implemented for {who}, which takes "
                "pole regions (halfplane, disk, sector)"
            )
        if not isinstance(item, LMIRegion):
            raise TypeError(
                f"constraints: {who} takes pole regions (halfplane, disk, sector) "
                f"only, got {item!r}"
            )
        out.append(item)
    return tuple(out)


def _require_unit_disk(region: LMIRegion) -> None:
    """A discrete-time region must be a disk inside the unit circle."""
    L, M = region.L, region.M
    is_disk = (
        L.shape == (2, 2)
        and np.array_equal(M, [[0.0, 1.0], [0.0, 0.0]])
        and L[0, 0] == L[1, 1]
        and L[0, 1] == L[1, 0]
    )
    if not is_disk:
        raise ValueError(
            f"constraints: {region} is a continuous-time region; a discrete-time "
            "system takes disk(radius, center) regions of the z-plane"
        )
    radius, center = -L[0, 0], -L[0, 1]
    if abs(center) + radius > 1:
        raise ValueError(
            f"constraints: {region} is not inside the unit circle, so it does not "
            "imply stability"
        )
