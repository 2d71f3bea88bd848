"""Certified state-feedback synthesis for polytopic systems.

One engine: `synthesize` poses every design from composable specs
(`Hinf`, `H2`, `Peak`, `GainBound`, `Saturation`, pole regions). The
paper's Lemma 1, Lemma 2, Theorem 1 and Theorem 2 (Section III) are thin
calls of it with their specs, as is `h2_state_feedback`:

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
   of the other; a Riccati prescaling and the model's own units follow in
   the fallback ladder.
3. Strict inequalities are posed as ``F <= -margin I`` in scaled units.
4. One solve where one solve suffices: the minimum ``gamma*`` is posed
   again (its bound rescaled to order one) only when its point does not
   certify or the margin is not negligible against it. Back-off (default
   20 %): one solve of the smallest gain norm under ``gamma <= (1 +
   backoff) gamma*`` (the gain bound linearised at a ``W`` of the margin's
   order, so that the minimisation prefers a large, well-conditioned ``W``),
   then one convex-concave step of the gain norm in the model's units
   (exact at that point); the centering stage (the smallest eigenvalue of
   ``W`` maximised) only where these do not certify.
5. Every returned design is verified in float64: every LMI, the closed-loop
   Lyapunov inequality and every spec's statement and Hurwitz (Schur)
   stability at every vertex and at sampled interior points.

Re-solves
---------
The prescaled vertex data, the channel weights, the specs' constants
(pole-region offsets, saturation levels), the margin and every stage bound
are parameters, so a compiled problem depends only on the structure of the
call (dimensions, number of vertices, the relaxation, the specs'
structures, the Lyapunov structure); the state and input scalings, read as
constants by a gain bound's stage alone, rebuild that stage when they
change. `synthesis_cache` keeps compiled problems by structure: a gamma or
back-off sweep, new performance weights or another plant of the same size
reuse them and read again only the LMIs whose data changed (an identical
second call reads none: ``design.timing["compile"]`` is then about 0).
Each call sets every parameter and verifies its own result from scratch.

Modules
-------
Data flow one way through the package:

``spec`` (the protocol every spec implements), ``specs`` (`Hinf`, `H2`,
`Peak`) and ``constraints`` (`GainBound`, `Saturation`, pole regions) ->
``compose`` (`synthesize`: checks, the plant partitioned once by
``channels``, an immutable ``problem.Problem``) -> ``general`` (the
fallback ladder; prescalings of ``scaling``, the cached LMIs of
``problem`` over the relaxation of ``parametric`` with ``terms``) ->
``stages`` and ``gains`` (one rung; the decay search of ``decay``,
refutations of ``refutation``) -> ``points`` and ``frozen`` (float64 checks
in the model's units) -> ``results`` (`StateFeedbackDesign`,
`Certificate`); ``paper`` holds the public wrappers (the paper's four
functions and `h2_state_feedback`), ``recheck`` re-checks a design read
back from a file.
"""

from .compose import synthesize
from .constraints import GainBound, Saturation
from .gridded import GriddedDesign
from .paper import (
    gain_scheduled_hinf,
    gain_scheduled_stabilization,
    h2_state_feedback,
    hinf_state_feedback,
    quadratic_stabilization,
)
from .results import Certificate, StateFeedbackDesign
from .specs import H2, Hinf, Peak

__all__ = [
    "StateFeedbackDesign",
    "GriddedDesign",
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
