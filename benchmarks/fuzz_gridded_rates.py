"""Rate-bounded grid synthesis on random gridded plants (issue 23).

Six random plants on a 3 x 3 grid of (p, q): ``A`` nonlinear in q, ``B_u``
varying with p q and q (so the synthesis uses pairs of terms and `certify`
triples), ``z = (x0, u)``. For each: the constant-``W`` design, and the
rate-bounded ones at ``|dp/dt|, |dq/dt| <= 0.1`` and ``1``, stability and
``Hinf(w="w", z=["z0", "e"])``. Printed: the verdicts, bounds, the rates
`certify` reports, seconds. A "CertErr" whose second field is True would be
a design the LMIs produced and `certify` refused (none in the run of
``results/gridded_rate_fuzz.txt``).

Usage::

    python benchmarks/fuzz_gridded_rates.py
"""

import time

import control as ct
import numpy as np

import ctrl_lpv as lpv
from ctrl_lpv.exceptions import CertificationError, SynthesisError


def case(seed):
    rng = np.random.default_rng(seed)
    base = rng.normal(size=(2, 2)) + 0.3 * np.eye(2)
    dA, dB = rng.normal(scale=0.8, size=(2, 2, 2)), rng.normal(scale=0.5, size=2)

    def plant(p, q):
        A = base + p * dA[0] + np.sin(2 * q) * dA[1]
        B = np.array([[0.0, 1.0], [1.0 + dB[0] * p * q, 0.3 + dB[1] * q]])
        C = np.array([[1.0, 0.0], [0.0, 0.0]])
        D = np.array([[0.0, 0.0], [1.0, 0.0]])
        return ct.ss(A, B, C, D, inputs=["u", "w"], outputs=["z0", "e"])

    return lpv.gss(plant, {"p": [0.0, 0.5, 1.0], "q": [0.0, 0.5, 1.0]})


def main():
    hinf = lpv.Hinf(w="w", z=["z0", "e"])
    for seed in range(6):
        G = case(seed)
        for obj in (None, hinf):
            try:
                g0 = lpv.synthesize(G, "u", objective=obj).gamma
                c0 = "ok"
            except SynthesisError as e:
                c0 = type(e).__name__
                g0 = None
            for nu in (0.1, 1.0):
                t = time.time()
                try:
                    d = lpv.synthesize(
                        G,
                        "u",
                        objective=obj,
                        lyapunov="affine",
                        rate_bounds={"p": nu, "q": nu},
                    )
                    r = ("ok", d.gamma, d.certificate.rate_bound)
                except CertificationError as e:
                    r = (
                        "CertErr",
                        "not certified by certify" in str(e),
                        str(e).splitlines()[0][:100],
                    )
                except SynthesisError as e:
                    r = (type(e).__name__,)
                print(
                    seed,
                    "hinf" if obj else "stab",
                    "const:",
                    c0,
                    g0,
                    "nu",
                    nu,
                    r,
                    round(time.time() - t, 1),
                    flush=True,
                )


if __name__ == "__main__":
    main()
