"""Gate of issue 20: `ultimate_bound` on the one engine against its old path.

The old path is the hand-built LMI problem of `ctrl_lpv.reachability`
(its own prescaling, decay line search and checks); the new one the
engine's `OutputPeaks` analysis. Both run on a seeded corpus of random
stable polytopes (n = 1..5, N = 1..4, one or two disturbances and
outputs) and the servo's contact loop, and must give the same verdicts,
the new bound at most the old one (up to the solvers' accuracy). The
whole corpus runs with ``-m slow`` (``python tests/test_analysis_engine.py``
prints the comparison).
"""

import time

import numpy as np
import pytest

from ctrl_lpv import reachability
from ctrl_lpv.exceptions import CertificationError

# New bound <= old bound * (1 + RTOL): both optimise the same objective,
# over decays found by different searches.
RTOL = 1e-3


def stable_polytope(seed, n, N, nw, ny):
    """Vertices ``(A_j, E_j)``, output rows ``C`` and peaks ``w_max``.

    Seeds 1, 4, ... quadratically stable by construction (``T (S - S' - c
    I) T^-1``, a common ``P``), the others random Hurwitz matrices around
    one centre, close (seeds 0, 3, ...) or far apart (2, 5, ...: some of
    them without a common ``P``, which both paths must refuse).
    """
    rng = np.random.default_rng([seed, n, N, nw, ny])
    T = (
        np.diag(2.0 ** rng.integers(-3, 4, size=n))
        @ np.linalg.qr(rng.normal(size=(n, n)))[0]
    )
    Ti = np.linalg.inv(T)
    A0 = rng.normal(size=(n, n))
    As = []
    for _ in range(N):
        if seed % 3 == 1:
            S = rng.normal(size=(n, n))
            A = T @ (S - S.T - rng.uniform(0.2, 2.0) * np.eye(n)) @ Ti
        else:
            A = A0 + (0.3 if seed % 3 == 0 else 1.5) * rng.normal(size=(n, n))
            shift = np.linalg.eigvals(A).real.max() + rng.uniform(0.1, 1.0)
            A = A - shift * np.eye(n)
        As.append(A)
    Es = [rng.normal(size=(n, nw)) for _ in range(N)]
    C = rng.normal(size=(ny, n))
    w_max = rng.uniform(0.2, 3.0, size=nw)
    return As, Es, C, w_max


def servo_loop():
    """The servo's contact loop and its two bounded outputs (the servo
    certificate's ultimate bound)."""
    from ctrl_lpv import twomass
    from ctrl_lpv.twomass.servo import servo_design
    from ctrl_lpv.twomass.servo_certificate import contact_loop

    gain = servo_design(certify=False).gain
    As, Es = contact_loop(twomass.Parameters(), gain, (0.8, 1.2))
    return As, Es, np.vstack([np.eye(5)[2], gain]), np.ones(1)


def corpus():
    sizes = [(1, 1, 1, 1), (2, 1, 1, 1), (2, 2, 1, 2), (3, 2, 2, 1), (3, 3, 1, 2),
             (4, 2, 1, 1), (4, 4, 2, 2), (5, 3, 1, 1)]  # fmt: skip
    return [(seed, *size) for seed in range(6) for size in sizes] + ["servo"]


FAST = [(0, 2, 2, 1, 2), (1, 3, 2, 2, 1), (2, 4, 4, 2, 2), "servo"]


def run(path, data):
    start = time.process_time()
    try:
        result = path(*data, None)
    except CertificationError as exc:
        result = exc
    return result, time.process_time() - start


def compare(case):
    """``(verdicts, ratio, old seconds, new seconds)`` of one case."""
    As, Es, C, w_max = servo_loop() if case == "servo" else stable_polytope(*case)
    data = reachability._prepare((As, Es), None, w_max, C, None, None, 1e-6)
    old, t_old = run(reachability._ultimate_bound_lmi, data)
    new, t_new = run(reachability._ultimate_bound_engine, data)
    verdicts = tuple(not isinstance(r, Exception) for r in (old, new))
    ratio = None
    if all(verdicts):
        assert new.certificate.verified and old.certificate.verified
        # The objective both minimise: the largest output bound relative to
        # its row's norm in the states' natural units (both read the same
        # rows: the bounds' ratio per output, at the worst output).
        T = reachability._gramian_scaling(As, [E * w_max for E in Es])
        scale = np.linalg.norm(C * T, axis=1)
        ratio = float(np.max(new.bounds / scale) / np.max(old.bounds / scale))
    return verdicts, ratio, t_old, t_new


def check(case):
    verdicts, ratio, _, _ = compare(case)
    assert verdicts[0] == verdicts[1], f"{case}: old {verdicts[0]}, new {verdicts[1]}"
    if ratio is not None:
        assert ratio <= 1 + RTOL, f"{case}: new / old = {ratio:.6g}"


@pytest.mark.parametrize("case", FAST)
def test_engine_bound_is_the_old_one_or_better(case):
    check(case)


@pytest.mark.slow
@pytest.mark.parametrize("case", corpus())
def test_whole_corpus_engine_against_the_old_path(case):
    check(case)


if __name__ == "__main__":
    rows = [(case, *compare(case)) for case in corpus()]
    ratios = [r for _, _, r, _, _ in rows if r is not None]
    same = sum(v[0] == v[1] for _, v, _, _, _ in rows)
    both = sum(all(v) for _, v, _, _, _ in rows)
    for case, v, r, a, b in rows:
        print(case, v, None if r is None else f"{r:.6f}", f"{a:.2f} {b:.2f}")
    print(
        f"{len(rows)} cases, {same} same verdicts, {both} both certified; new/old "
        f"in [{min(ratios):.6f}, {max(ratios):.6f}]; CPU old "
        f"{sum(a for *_, a, _ in rows):.1f} s, new {sum(b for *_, b in rows):.1f} s"
    )
