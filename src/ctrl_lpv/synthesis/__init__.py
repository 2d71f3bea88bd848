"""Certified state-feedback synthesis for polytopic systems.

Four entry points, after the paper's Lemma 1, Lemma 2, Theorem 1 and
Theorem 2 (Section III):

=============================  =============  ===================
function                       gain           performance
=============================  =============  ===================
`quadratic_stabilization`      common K       quadratic stability
`hinf_state_feedback`          common K       H-infinity bound
`gain_scheduled_stabilization` vertex K_j     quadratic stability
`gain_scheduled_hinf`          vertex K_j     H-infinity bound
=============================  =============  ===================

All return a `StateFeedbackDesign` whose gains follow python-control's sign
convention ``u = -K x`` (the paper writes ``u = K x``: ``K = -Z W^-1`` here).
A design is only returned with its certificate (see `Certificate`).

Numerical policy
----------------
1. Before solving, every vertex is checked stabilizable (PBH test); a
   non-stabilizable vertex raises `InfeasibleError` naming the vertex and
   the uncontrollable mode.
2. The data are prescaled by powers of two (state balancing, input, w and z
   normalisation, and a time scaling), so that the scaled LMIs are exactly
   congruent to the original ones and a certificate of one is a certificate
   of the other.
3. Strict inequalities are posed as ``F <= -margin I`` in scaled units.
4. Back-off (default 20 %): after the minimum ``gamma*``, the problem is
   re-solved with ``gamma <= (1 + backoff) gamma*``, first maximising the
   smallest eigenvalue of ``W`` under ``W <= lambda_max(W*)`` (a
   well-conditioned Lyapunov matrix), then minimising the gain norm in the
   model's units by a convex-concave iteration: the bound
   ``||K_j||^2 <= kappa`` is linearised at the previous point (exact there,
   sufficient everywhere) and re-solved until it improves by less than 5 %.
   Each stage is one cvxpy problem built with parameters (DPP): its
   iterations and the margin retries re-solve without recompiling.
5. Every returned design is verified in float64: every LMI, the closed-loop
   Lyapunov inequality and Hurwitz stability at every vertex and at sampled
   interior points.

Re-solves
---------
The prescaled vertex data, the margin, the pole-region offsets and every
stage bound are cvxpy parameters, so a compiled problem depends only on the
structure of the call (function, dimensions, number of vertices, region
shapes, whether a gain bound is set); the power-of-two state and input
scalings, read as constants by the gain stage alone, rebuild that stage
when they change (rarely: not for new weights or gammas). `synthesis_cache`
keeps compiled problems by structure: a gamma or back-off sweep, new
performance weights (the rows of ``C`` and ``D`` of z) or another plant of
the same size reuse them, and a call then costs the solver and the
verification only (``design.timing["compile"]`` is 0). Each call sets every
parameter and verifies its own result from scratch, so a reused problem
gives the same certified design as a fresh one.

Modules
-------
Data flow one way through the package:

``channels`` (which signals are w, u, z) -> ``scaling`` (exact prescaling)
-> ``assembly`` (the LMIs as a parametrised cvxpy problem) -> ``ladder``
(solvers, prescalings, margins, stages) -> ``verification`` (float64
checks) -> ``results`` (`StateFeedbackDesign`, `Certificate`); ``paper``
holds the four public functions, thin wrappers of `synthesize`
(``compose``). It takes the performance specs of ``specs`` and the
constraint specs of ``constraints`` (and `~ctrl_lpv.regions.LMIRegion`),
and sends the paper's cases to ``ladder``, the others to ``general``, which
assembles them over the relaxation of ``parametric`` with ``terms`` (and
``problem``), searches the decay of a `Peak` spec with ``decay`` and checks
each point with ``frozen``.
"""

from .compose import h2_state_feedback, synthesize
from .constraints import GainBound, Saturation
from .paper import (
    gain_scheduled_hinf,
    gain_scheduled_stabilization,
    hinf_state_feedback,
    quadratic_stabilization,
)
from .results import Certificate, StateFeedbackDesign
from .specs import H2, Hinf, Peak

__all__ = [
    "StateFeedbackDesign",
    "Certificate",
    "quadratic_stabilization",
    "hinf_state_feedback",
    "gain_scheduled_stabilization",
    "gain_scheduled_hinf",
    "synthesize",
    "h2_state_feedback",
    "Hinf",
    "H2",
    "GainBound",
    "Saturation",
    "Peak",
]
