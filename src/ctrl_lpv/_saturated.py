"""The calls of `ctrl_lpv.saturation` on the one engine.

`prepare` checks the arguments of `saturated_state_feedback` and
`saturation_region` at the boundary; `design` and `analysis` pose them to
the engine (`ctrl_lpv.synthesis.general.run_general`) as a `RegionSize`
objective (the ellipsoid's size; its channel is the peak-bounded
disturbance) with a `Saturation` constraint (the generalized sector
condition, continuous or discrete time), and read the engine's design back
as a `SaturatedDesign`. Prescaling, margins, solvers, the float64
certificate and the refusals are the engine's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import eigh

from . import budget
from ._checks import as_matrix, per_input, positive_levels, real_number, signal_indices
from ._sector_checks import sector_statement
from .exceptions import InfeasibleError, SynthesisError
from .lmi import default_solvers
from .reachability import Ellipsoid
from .synthesis.constraints import Saturation
from .synthesis.region import RegionSize, region_size
from .systems import PolytopicStateSpace

# The back-off's search of the largest decay (as a fraction of the data's
# rate scale): first trial, limit, bisections.
_DECAY_START = 1e-3
_DECAY_MAX = 4.0
_DECAY_BISECTIONS = 6


@dataclass(frozen=True)
class Call:
    """A checked call: the plant's data and what is asked."""

    sys: PolytopicStateSpace
    iu: list
    iw: list
    u_max: np.ndarray
    w_max: np.ndarray
    decay: float
    shape: np.ndarray | None
    points: np.ndarray | None
    rows: np.ndarray | None
    beta_min: float | None
    margin: float

    @property
    def continuous(self) -> bool:
        return not self.sys.isdtime(strict=True)

    @property
    def dt(self) -> float:
        """The sampling period (1 for ``dt=True``; 0 in continuous time)."""
        if self.continuous:
            return 0.0
        return 1.0 if self.sys.dt is True else float(self.sys.dt)

    def vertex(self, j):
        """``(A_j, B_u,j)``."""
        A, B, _, _ = self.sys.vertex_data()[j]
        return A, B[:, self.iu]


def _levels(value, size, name):
    """Positive levels, one per input (a single level for all)."""
    levels = positive_levels(np.ravel(np.asarray(value, dtype=object)), name)
    return per_input(levels, size, name, "inputs")


def _reference(shape, points, n):
    if shape is not None and points is not None:
        raise ValueError("shape, points: give one of them, not both")
    if points is not None:
        V = as_matrix(points, "points")
        if V.shape[1] != n:
            if V.shape[0] != n:
                raise ValueError(f"points: expected rows of {n} entries, got {V.shape}")
            V = V.T
        if np.any(np.all(V == 0, axis=1)):
            raise ValueError("points: a point is zero")
        return None, V
    R = np.eye(n) if shape is None else as_matrix(shape, "shape", (n, n))
    R = 0.5 * (R + R.T)
    if np.linalg.eigvalsh(R)[0] <= 0:
        raise ValueError("shape: must be a symmetric positive definite matrix")
    return R, None


def _output_rows(sys, output):
    """Rows ``C`` of the outputs to keep small: names/indices or a matrix."""
    names = isinstance(output, (str, int, np.integer)) or (
        isinstance(output, (list, tuple))
        and all(isinstance(o, (str, int, np.integer)) for o in output)
    )
    if names:
        iy = signal_indices(output, tuple(sys.output_labels), "output")
        Cs = [d[2][iy] for d in sys.vertex_data()]
        if any(not np.allclose(C, Cs[0]) for C in Cs[1:]):
            raise ValueError("output: the rows differ between vertices; pass a matrix")
        return Cs[0]
    return as_matrix(output, "output")


def prepare(sys, u, u_max, shape, points, output, beta_min, decay, w, w_max,
            margin) -> Call:  # fmt: skip
    """The arguments checked (a `ValueError` or `TypeError` naming one)."""
    if not isinstance(sys, PolytopicStateSpace):
        raise TypeError(
            f"sys: expected a PolytopicStateSpace, got {type(sys).__name__}; wrap an "
            "LTI system as PolytopicStateSpace([sys])"
        )
    inputs = sys.physical_inputs
    if u is None:
        raise ValueError("u: name the saturated control input(s)")
    iu = signal_indices(u, inputs, "u")
    if not iu:
        raise ValueError("u: at least one control input is required")
    iw = signal_indices(w, inputs, "w") if w is not None else []
    if set(iw) & set(iu):
        raise ValueError("w, u: an input cannot be both a disturbance and a control")
    umax = _levels(u_max, len(iu), "u_max")
    if iw and w_max is None:
        raise ValueError("w_max: required with w")
    if not iw and w_max is not None:
        raise ValueError("w_max: given without w")
    wmax = _levels(w_max, len(iw), "w_max") if iw else np.zeros(0)
    decay = real_number(decay, "decay", minimum=0.0, below=1e150)
    margin = real_number(margin, "margin", positive=True, below=1.0)
    beta_min = real_number(beta_min, "beta_min", allow_none=True, positive=True)
    n = sys.nstates
    R, V = _reference(shape, points, n)
    if beta_min is not None and output is None:
        raise ValueError("beta_min: only with output (the region is maximised)")
    rows = None
    if output is not None:
        if not iw:
            raise ValueError(
                "output: minimising the size needs a disturbance w (without one the "
                "invariant ellipsoid shrinks to the origin)"
            )
        C = _output_rows(sys, output)
        if C.shape[1] != n or not np.any(C != 0):
            raise ValueError(f"output: expected nonzero rows of {n} entries")
        rows = C[np.einsum("ij,ij->i", C, C) > 0]
    return Call(sys, iu, iw, umax, wmax, decay, R, V, rows, beta_min, margin)


def given_gains(call: Call, gain):
    """The gain of ``u = -K x`` (or one per vertex), checked: ``m x n``
    matrices whose linear loops are asymptotically stable at the vertices
    (else no region of attraction exists: `InfeasibleError`)."""
    sys, m = call.sys, len(call.iu)
    Ks = [gain] if np.ndim(gain) <= 2 else list(gain)
    Ks = [as_matrix(K, f"gain[{k}]", (m, sys.nstates)) for k, K in enumerate(Ks)]
    if len(Ks) not in (1, sys.nvertices):
        raise ValueError(
            f"gain: expected one gain or {sys.nvertices} vertex gains, got {len(Ks)}"
        )
    for j in range(sys.nvertices):
        A, B = call.vertex(j)
        eig = np.linalg.eigvals(A - B @ Ks[j if len(Ks) > 1 else 0])
        worst = float(eig.real.max() if call.continuous else np.abs(eig).max() - 1)
        if worst >= 0:
            raise InfeasibleError(
                f"gain: the linear closed loop at vertex {j} is not asymptotically "
                f"stable ({'real part' if call.continuous else 'modulus - 1'} "
                f"{worst:.6g}), so the saturated loop has no region of attraction"
            )
    return tuple(Ks)


def _engine(call: Call, scheduled, fixed, sigma, bound, backoff, chain, method,
            lambdas=None):  # fmt: skip
    """One engine call at the decay `sigma` (1/s); the objective minimised
    (`bound` None) or met, the disturbance's decay searched on `lambdas`
    (model units; None: the grid). Returns the engine's design and the two
    specs."""
    from .stabilizability import check_stabilizability
    from .synthesis.general import run_general
    from .synthesis.parametric import lyapunov_structure

    sys = call.sys
    sat = Saturation(
        tuple(call.u_max), decay=sigma if call.continuous else sigma * call.dt
    )
    region = RegionSize(
        shape=call.shape, points=call.points, rows=call.rows,
        beta_min=call.beta_min, w_max=tuple(call.w_max), bound=bound,
        lambdas=lambdas,
    )  # fmt: skip
    suspects = ()
    if fixed is None and call.continuous:
        suspects = check_stabilizability(sys, call.iu)
    design = run_general(
        sys, call.iu, [region], [(call.iw, [], [])], region, (sat,), scheduled,
        lyapunov_structure(sys, "constant", None), call.continuous, backoff,
        call.margin, chain, None, method, suspects, fixed=fixed,
    )  # fmt: skip
    return design, region, sat


def analysis(call: Call, fixed, chain):
    """`saturation_region`: the largest certified region of given gains."""
    found = _engine(call, len(fixed) > 1, fixed, call.decay, None, None, chain,
                    "saturation_region")  # fmt: skip
    return _result(call, *found, call.decay, None, designed=False)


def design(call: Call, scheduled, backoff, chain):
    """`saturated_state_feedback`: the raw optimum, or the back-off.

    The back-off keeps the objective within ``1 + backoff`` of the raw
    optimum and spends the slack as the old pipeline did: first on decay
    (the largest rate ``sigma_max`` whose raw optimum stays within it,
    doubling then bisection, each a raw engine call), then on the gain (the
    engine's back-off under that bound, at the rate halfway between the
    requested one and ``sigma_max``): a gain minimised at the requested
    rate alone drifts to the edge of linear stability when that rate is 0.
    Once the call's time budget has run out the certified raw optimum is
    returned.
    """
    method = "saturated_state_feedback"
    sigma0 = call.decay
    raw = _engine(call, scheduled, None, sigma0, None, None, chain, method)
    optimum = raw[0].gamma_opt or raw[0].gamma
    if not backoff:
        return _result(call, *raw, sigma0, optimum)
    target = raw[0].gamma * (1 + backoff)
    # The disturbance's decay stays the optimum's (one solve per trial).
    lambdas = (raw[0].values[raw[1]]["decay"],) if call.iw else None

    # The search asks the first solver only (a fallback such as SCS takes
    # tens of seconds to refuse a decay that is out of reach).
    first = (chain or default_solvers())[:1]

    def within(sigma):
        if budget.remaining() <= 0:
            return False  # out of time: the certified optimum stands
        try:
            found = _engine(
                call, scheduled, None, sigma, None, None, first, method, lambdas
            )
        except SynthesisError:
            return False
        return found[0].gamma <= target

    scale = 1.0 / call.dt if call.dt else _rate_scale(call)
    lo, hi = sigma0, max(2 * sigma0, _DECAY_START * scale)
    while hi < _DECAY_MAX * scale and within(hi):
        lo, hi = hi, 2 * hi
    for _ in range(_DECAY_BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if within(mid) else (lo, mid)
    for sigma in dict.fromkeys((sigma0 + 0.5 * (lo - sigma0), sigma0)):
        if budget.remaining() <= 0:
            break
        try:
            found = _engine(
                call, scheduled, None, sigma, target, backoff, chain, method, lambdas
            )
        except SynthesisError:
            continue
        return _result(call, *found, sigma, optimum)
    return _result(call, *raw, sigma0, optimum)  # the certified optimum stands


def _rate_scale(call: Call) -> float:
    """The data's rate scale (1/s): the largest ``||A_j||``."""
    out = max(float(np.linalg.norm(call.vertex(j)[0], 2))
              for j in range(call.sys.nvertices))  # fmt: skip
    return out or 1.0


def _result(call: Call, design, region, sat, sigma, optimum, designed=True):
    """The engine's design as a `SaturatedDesign` (model units)."""
    from .saturation import SaturatedDesign

    sys, P = call.sys, design.P
    own = design.values[sat]
    has_w = bool(call.iw)
    lam, mu, rho = 0.0, np.zeros(0), 0.0
    if has_w:
        values = design.values[region]
        lam, mu = values["decay"], values["mu"]
        rate = 2 * sigma if call.continuous else 1 - np.exp(-2 * sigma * call.dt)
        rho = float(mu.sum() / (rate + lam))
    certificate = replace(
        design.certificate,
        statement=sector_statement(has_w, call.continuous)
        + "; " + design.certificate.statement,
    )  # fmt: skip
    labels = sys.physical_inputs
    reach = eigh(np.linalg.inv(P), region.reference(), eigvals_only=True)[-1]
    return SaturatedDesign(
        system=sys,
        u=tuple(labels[i] for i in call.iu),
        u_max=call.u_max.copy(),
        gains=tuple(design.gains),
        G=tuple(Zg @ P for Zg in own["Zg"]),
        P=P,
        ellipsoid=Ellipsoid(P, 1.0),
        ultimate=Ellipsoid(P, rho) if has_w else None,
        rho=rho,
        beta=region_size(P, call.shape, call.points),
        beta_opt=None if call.rows is not None or not optimum else 1.0 / optimum,
        decay=sigma,
        lam=lam,
        w=tuple(labels[i] for i in call.iw),
        w_max=call.w_max.copy(),
        certificate=certificate,
        capped=bool(reach >= 0.99 * region.cap),
        designed=designed,
        attempts=tuple(design.attempts),
        T=own["T"],
        mu=mu,
        shape=call.shape,
        points=call.points,
        ladder=tuple(design.ladder),
    )
