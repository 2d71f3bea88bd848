"""The LMI problem of the general engine: specs over the relaxation, with stages.

Variables: ``W_l`` (one per Lyapunov vertex), ``Z_k`` (one per gain),
``G`` (the slack of the extended LMIs), ``g_i`` and ``Y_i`` of the specs,
and the stage variables ``t`` (conditioning or decay) and ``kappa`` (gain).
Every strict LMI is one spec's block at one coefficient of the relaxation
and one vertex of the rate box (`ctrl_lpv.synthesis.parametric`). Stages:
"optimal" (the objective alone), "center" (a bound on it, the smallest
eigenvalue of ``W`` maximised), "stabilize" (the decay, without an
objective) and "gain" (the gain iterations).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..lmi import LMIProblem
from .specs import H2, Peak, Stability
from .terms import Terms

# A given bound is posed as bound^2 (1 - BOUND_SLACK), met strictly.
BOUND_SLACK = 1e-6
# The scalar of the continuous-time extended LMIs (prescaled time units,
# where the data are of order one), tried in turn.
EPSILONS = (100.0, 30.0, 10.0, 3.0, 1.0, 0.1, 0.01)


def _rho(job):
    a, kappa = job.scaling.a, job.scaling.w_factor
    return {i: sw**2 * kappa / a for i, (sw, _) in enumerate(job.channel)}


def _scaled_data(job):
    sc = job.scaling
    T, Ti = sc.matrix, np.linalg.inv(sc.matrix)
    if sc.T.ndim == 1:
        Ti = np.diag(1.0 / sc.T)  # exact: powers of two
    Su, a = sc.Su, sc.a
    out = []
    for v in job.original:
        d = {"A": Ti @ v["A"] @ T / a, "B2": Ti @ v["B2"] * Su / a}
        for i, (sw, sz) in enumerate(job.channel):
            d[(i, "Bw")] = Ti @ v[(i, "Bw")] * sw / a
            d[(i, "Cz")] = v[(i, "Cz")] @ T / sz
            d[(i, "Dzw")] = v[(i, "Dzw")] * sw / sz
            d[(i, "Dzu")] = v[(i, "Dzu")] * Su / sz
        out.append(d)
    return out


# -- the problem -----------------------------------------------------
def build_problem(job) -> LMIProblem:
    """The LMIs of a job's specs over the relaxation, with its stages."""
    data = _scaled_data(job)
    rho = _rho(job)
    n, m = data[0]["A"].shape[0], data[0]["B2"].shape[1]
    nZ = job._nZ()
    lmi = LMIProblem(margin=job.margin)
    for ell in range(job.lyap.count):
        lmi.variable(f"W{ell}", (n, n), symmetric=True)
        lmi.add(f"W{ell} > 0", lambda v, e=ell: [[-getattr(v, f"W{e}")]])
    for k in range(nZ):
        lmi.variable(f"Z{k}", (m, n))
    for i, spec in enumerate(job.specs):
        lmi.variable(f"g{i}", (1, 1))
        if isinstance(spec, H2):
            nz = data[0][(i, "Cz")].shape[0]
            lmi.variable(f"Y{i}", (nz, nz), symmetric=True)
        if isinstance(spec, Peak):
            ones = np.ones((1, data[0][(i, "Bw")].shape[1]))
            lmi.variable("mu", (ones.size, 1))
            # The decay of the invariance inequality, searched by the job.
            lmi.parameter("lam", nonneg=True, value=job.lam)
            lmi.add("sum(mu) <= lambda",
                    lambda v, ones=ones: [[ones @ v.mu - v.lam * np.eye(1)]],
                    strict=False)  # fmt: skip
    for spec in job.constraints:
        if hasattr(spec, "variables"):
            spec.variables(lmi, n, m, nZ)
    for name in ("t", "kappa"):
        lmi.variable(name, (1, 1))
    if job.slack:
        lmi.variable("G", (n, n))
        lmi.parameter("eps", nonneg=True, value=job.eps)
    lmi.parameter("g_max", (1, 1), nonneg=True, value=np.ones((1, 1)))
    lmi.parameter("w_max", nonneg=True, value=1.0)
    lmi.parameter("z_max", nonneg=True, value=1.0)

    # Keyed by identity: a region holds arrays and is not hashable.
    prescaled = {
        id(spec): spec.prescale(job.scaling, n, m)
        for spec in (*job.specs, *job.constraints)
        if hasattr(spec, "prescale")
    }
    performance = job.specs or [Stability()]
    # Specs of one kind (two Hinf channels) are told apart by name, equal
    # constraints (a region given twice) by position.
    names = [str(spec) for spec in job.constraints]
    tagged = [(spec, f" [{spec}]" if len(performance) > 1 else "")
              for spec in performance]  # fmt: skip
    tagged += [(spec, f" #{q}" if names.count(x) > 1 else "")
               for q, (spec, x) in enumerate(zip(job.constraints, names))]  # fmt: skip

    def terms(v, c, r):
        return Terms(v, c, r, job.lyap, data, job.index, rho, job.scheduled,
                     job.continuous, prescaled)  # fmt: skip

    zero = SimpleNamespace(**{
        name: np.zeros(item.shape)
        for name, item in (*lmi._vars.items(), *lmi._params.items())
    })  # fmt: skip
    for c in job.coefficients:
        for r in job.rates:
            at = c.label + (f", rate {np.round(r * job.scaling.a, 12).tolist()}"
                            if len(job.rates) > 1 else "")  # fmt: skip
            for spec, tag in tagged:
                if hasattr(spec, "lmis"):
                    _add(lmi, spec.lmis, lambda v, c=c, r=r: terms(v, c, r),
                         job.continuous, zero, f"{tag} {at}")  # fmt: skip
            if not job.specs:
                # The decay of the stabilization stage, as in Lemma 1.
                def decay(v, c=c, r=r):
                    blocks = Stability().lmis(terms(v, c, r), job.continuous)[0][1]
                    return _shifted(blocks, v.t[0, 0] * c.const)

                lmi.add(f"decay {at}", decay, strict=False,
                        stages=("stabilize",), normalization=True)  # fmt: skip
        for spec, tag in tagged:
            if hasattr(spec, "coefficient_lmis"):
                _add(lmi, spec.coefficient_lmis,
                     lambda v, c=c: terms(v, c, job.rates[0]), job.continuous,
                     zero, f"{tag} {c.label}")  # fmt: skip
    for i, spec in enumerate(job.specs):
        g = f"g{i}"
        if isinstance(spec, H2):
            nw = data[0][(i, "Cz")].shape[0]
            lmi.add(f"trace Y{i} < h{i}", lambda v, i=i, nw=nw, g=g: [[
                sum(getattr(v, f"Y{i}")[k : k + 1, k : k + 1] for k in range(nw))
                - getattr(v, g)
            ]])  # fmt: skip
        if spec.bound is not None:
            fixed = spec.bound**2 / job._to_model(i) * (1 - BOUND_SLACK)
            lmi.add(f"{spec} bound", lambda v, g=g, fixed=fixed: [
                [getattr(v, g) - fixed]], strict=False)  # fmt: skip
        elif i == 0:
            lmi.add("g <= g_max", lambda v: [[v.g0 - v.g_max]], strict=False,
                    stages=("center", "gain"))  # fmt: skip
    for ell in range(job.lyap.count):
        lmi.add(f"W{ell} <= w_max I",
                lambda v, e=ell: [[getattr(v, f"W{e}") - v.w_max * np.eye(n)]],
                strict=False, stages=("center", "stabilize"),
                normalization=True)  # fmt: skip
        lmi.add(f"W{ell} >= t I",
                lambda v, e=ell: [[v.t[0, 0] * np.eye(n) - getattr(v, f"W{e}")]],
                strict=False, stages=("center", "stabilize"),
                normalization=True)  # fmt: skip
    for k in range(nZ):
        lmi.add(f"||Z{k}||^2 <= z_max", lambda v, k=k: [
            [-v.z_max * np.eye(n)], [getattr(v, f"Z{k}"), -np.eye(m)]],
            strict=False, stages=("stabilize",), normalization=True)  # fmt: skip
    if job.gain_bound is not None:
        T, Su = job.scaling.matrix, np.diag(job.scaling.Su)
        lmi.parameter("gain_Ginv", (n, n), value=np.eye(n))
        lmi.parameter("gain_Ginv_K", (n, n), value=np.eye(n))
        lmi.parameter("kappa_max", nonneg=True, value=1.0)
        for k in range(nZ):

            def gain_lmi(v, k=k):
                return job.gain_bound.tangent(
                    v.W0, getattr(v, f"Z{k}"), v.gain_Ginv, v.gain_Ginv_K,
                    v.kappa[0, 0], T, Su,
                )  # fmt: skip

            lmi.add(f"||K{k}||^2 <= kappa", gain_lmi, strict=False,
                    stages=("gain",))  # fmt: skip
        lmi.add("kappa <= kappa_max",
                lambda v: [[v.kappa - v.kappa_max * np.eye(1)]],
                strict=False, stages=("gain",))  # fmt: skip
    return lmi


def _add(lmi, method, terms_of, continuous, zero, at) -> None:
    """Add the named blocks of a spec method (``lmis`` or
    ``coefficient_lmis``), built once per name from fresh terms."""
    for q, (name, _) in enumerate(method(terms_of(zero), continuous)):

        def blocks(v, q=q):
            return method(terms_of(v), continuous)[q][1]

        lmi.add(f"{name}{at}", blocks)


# -- stages ----------------------------------------------------------


def _shifted(blocks, shift):
    """`blocks` plus ``shift I`` on the diagonal (``2 X`` stands for ``X + X'``)."""
    out = [list(row) for row in blocks]
    for i, row in enumerate(out):
        size = row[i].shape[0]
        row[i] = row[i] + shift * np.eye(size)
    return out
