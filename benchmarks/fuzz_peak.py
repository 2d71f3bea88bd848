"""Random `Peak` designs checked against independent facts (issue 13).

Random plants with one or two vertices, one to three states, badly scaled
states, continuous or discrete time (ZOH, 0.05 s), common or scheduled
gains, ``z = [c x; 0.3 u]``. Each design is checked on five frozen points
of the polytope, without ``ctrl_lpv``: the closed loop is Hurwitz (Schur),
the steady state under a constant unit input is below the certified bound,
and in discrete time so is ``|z[k]|`` along 300 samples of random signs.

A refusal is reported with whether the paper's Theorem 1 (vertex gains) or
Lemma 1 (common) refuses the plain stabilization too; when it does, no
quadratic design exists that the search found, so the refusal says nothing
new about `Peak`.

Usage::

    python benchmarks/fuzz_peak.py [--seed 1] [--n 60]
"""

from __future__ import annotations

import argparse
import time
import warnings

import control as ct
import numpy as np

import ctrl_lpv as lpv

D = np.array([[0.0, 0.0], [0.0, 0.3]])


def random_plant(rng):
    n, nv = int(rng.integers(1, 4)), int(rng.integers(1, 3))
    scale = 10.0 ** rng.uniform(-2, 2, size=n)
    base = rng.normal(size=(n, n))
    B = rng.normal(size=(n, 2)) * scale[:, None]
    C = np.vstack([rng.normal(size=(1, n)), np.zeros((1, n))]) / scale
    vertices = [
        ct.ss(
            (base + 0.5 * rng.normal(size=(n, n))) * scale[:, None] / scale,
            B,
            C,
            D,
            inputs=["w", "u"],
        )  # fmt: skip
        for _ in range(nv)
    ]
    if rng.random() < 0.3:
        vertices = [ct.c2d(v, 0.05) for v in vertices]
    gains = "scheduled" if nv > 1 and rng.random() < 0.5 else "common"
    return lpv.PolytopicStateSpace(vertices), gains


def violations(sys, design, rng) -> list[str]:
    """Independent checks on frozen loops; the failures, named."""
    discrete = sys.isdtime(strict=True)
    n, N = sys.nstates, sys.nvertices
    out = []
    for lam in np.linspace(0.0, 1.0, 5 if N > 1 else 1):
        delta = np.array([1 - lam, lam]) if N > 1 else np.ones(1)
        A = sum(d * v.A for d, v in zip(delta, sys.vertices))
        B = sum(d * v.B for d, v in zip(delta, sys.vertices))
        gains = design.gains
        K = sum(d * k for d, k in zip(delta, gains)) if len(gains) > 1 else gains[0]
        Acl, Ccl = A - B[:, [1]] @ K, sys.vertices[0].C - D[:, [1]] @ K
        eig = np.linalg.eigvals(Acl)
        if (np.abs(eig).max() >= 1) if discrete else (eig.real.max() >= 0):
            out.append(f"unstable at {lam:g}")
        shift = np.eye(n) if discrete else np.zeros((n, n))
        steady = Ccl @ np.linalg.solve(shift - Acl, B[:, 0])
        if np.linalg.norm(steady) >= design.gamma:
            out.append(f"steady state {np.linalg.norm(steady):.4g} at {lam:g}")
        if discrete:
            x = np.zeros(n)
            for w in rng.choice([-1.0, 1.0], size=300):
                if np.linalg.norm(Ccl @ x) >= design.gamma:
                    out.append(f"peak exceeded at {lam:g}")
                    break
                x = Acl @ x + B[:, 0] * w
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=60)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(args.seed)
    designs = failing = refused = plain_refused = 0
    start = time.perf_counter()
    for i in range(args.n):
        sys, gains = random_plant(rng)
        try:
            design = lpv.synthesize(sys, "u", objective=lpv.Peak("w"), gains=gains)
        except lpv.SynthesisError as exc:
            refused += 1
            try:
                lpv.synthesize(sys, "u", gains=gains)
                plain = "plain stabilization found"
            except lpv.SynthesisError:
                plain_refused += 1
                plain = "plain stabilization refused too"
            print(f"{i}: refused ({type(exc).__name__}); {plain}")
            continue
        designs += 1
        bad = violations(sys, design, rng)
        failing += bool(bad)
        print(f"{i}: gamma {design.gamma:.4g} {'; '.join(bad) or 'checks pass'}")
    print(
        f"seed {args.seed}: {args.n} problems, {designs} designs, {failing} failing "
        f"the independent checks, {refused} refused ({plain_refused} where the "
        f"plain stabilization is refused too); {time.perf_counter() - start:.0f} s"
    )


if __name__ == "__main__":
    main()
