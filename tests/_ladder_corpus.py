"""A corpus of designs and refusals for the engine's ladder (issue 20).

``outcomes()`` runs every case and returns what the ladder decided, in
plain data: the verdict (a design, or the exception's type and message),
the certified bound and its estimate, the gains (state feedback) or the
controller matrices (output feedback) as exact float lists, the design's
``ladder`` notes and the solver attempts. ``tests/data/ladder_corpus.json``
holds these outcomes as the state-feedback and output-feedback loops gave
them before they became one loop (``tests/test_hooked_ladder.py`` compares).

Run ``python tests/_ladder_corpus.py OUT.json`` to write them.
"""

from __future__ import annotations

import json
import sys

import numpy as np

import ctrl_lpv as lpv
from _independent import generate_case
from test_output_feedback import W, Z, random_plant

# The fast cases of tests/test_trust_fuzz.py (designs and refusals of every
# state-feedback function).
FUZZ_SEED = 2026
FUZZ = [i for i in range(20) if i not in {0, 13, 18, 19}]


def _hinf_of(seed, **kw):
    return lambda: lpv.hinf_output_feedback(random_plant(seed), W, "u", Z, "y", **kw)


def cases():
    """``(name, call)`` pairs: 16 state-feedback and 8 output-feedback."""
    out = []
    for i in FUZZ:
        case = generate_case(FUZZ_SEED, i, small=True)
        out.append((f"fuzz {case.label()} {case.function}", lambda c=case: c.call(lpv)))
    for seed in (0, 1, 3, 9):
        out.append((f"hinf_of {seed} raw", _hinf_of(seed, backoff=None)))
    out.append(("hinf_of 5 backoff", _hinf_of(5)))
    out.append(("hinf_of 2-vertex", lambda: lpv.hinf_output_feedback(
        random_plant(4, vertices=2), W, "u", Z, "y")))  # fmt: skip
    out.append(("h2_of 2 raw", lambda: lpv.h2_output_feedback(
        random_plant(2), W, "u", Z, "y", backoff=None)))  # fmt: skip
    out.append(("hinf_of dt 6", lambda: lpv.hinf_output_feedback(
        random_plant(6, dt=0.1), W, "u", Z, "y", backoff=None)))  # fmt: skip
    return out


def _exact(values):
    """Floats as their hex strings (an exact comparison, JSON-safe)."""
    return [float(v).hex() for v in np.ravel(values)]


def _attempts(attempts):
    return [[a.solver, a.status, a.certified, a.message, a.converged] for a in attempts]


def outcome(call) -> dict:
    """What the ladder decided for `call` (module docstring)."""
    try:
        d = call()
    except Exception as exc:  # noqa: BLE001 - the verdict is compared
        return {
            "verdict": type(exc).__name__,
            "message": str(exc),
            "attempts": _attempts(getattr(exc, "attempts", ())),
        }
    gains = getattr(d, "gains", None)
    if gains is None:
        gains = [M for controller in d.controllers for M in controller]
    return {
        "verdict": "design",
        "gamma": None if d.gamma is None else float(d.gamma).hex(),
        "gamma_opt": None if d.gamma_opt is None else float(d.gamma_opt).hex(),
        "gains": [_exact(K) for K in gains],
        "ladder": list(d.ladder),
        "attempts": _attempts(getattr(d, "attempts", ())),
        "timing": sorted(d.timing),
    }


def outcomes() -> dict:
    return {name: outcome(call) for name, call in cases()}


if __name__ == "__main__":
    with open(sys.argv[1], "w") as f:
        json.dump(outcomes(), f, indent=1, sort_keys=True)
