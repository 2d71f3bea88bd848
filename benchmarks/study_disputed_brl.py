"""Settle a disputed bounded-real check in exact rational arithmetic.

For a fuzz case (default ``2026:14``, small) the library returns a design
that its own float64 verification accepts and that the independent checker
of ``tests/_independent.py`` refutes. Both evaluate a bounded-real
inequality in float64; this study evaluates the same matrices exactly, with
`fractions.Fraction` on the float64 numbers the design holds (every float64
is a rational), and decides their definiteness by exact symmetric Gaussian
elimination (a symmetric matrix is negative definite iff all pivots of
``-F`` are positive). The Jacobi-normalised largest eigenvalue
``lambda_max(D F D)``, ``D = diag(-F_ii)^-1/2``, is bracketed by bisection
on exact tests of ``F + t diag(-F_ii) < 0``.

Matrices examined, with the design's ``K`` (float64) and ``P`` (float64):

* the inequality the checker tests at a vertex ``(j, j)`` or a pair
  ``(j, k)`` of a scheduled design (Theorem 2's pair sum
  ``A_j - B_j K_k + A_k - B_k K_j``, ``c = 2``), with ``P`` as returned
  (``P A + A' P'``, as the library's check builds it) and with its
  symmetric part (the only part ``x' P x`` sees, as the checker uses);
* ``frozen``: the library's original-units check at the same frozen
  points it uses (vertices, pair midpoints: ``A(d) - B(d) K(d)``);
* ``scaled W``: the LMI the solver's point satisfies, in the library's
  scaled units (``W~``, ``Z~`` captured from the ladder), exactly.

Usage::

    python benchmarks/study_disputed_brl.py [--case 2026:14] [--full]
"""

from __future__ import annotations

import argparse
import os
import sys
from fractions import Fraction

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests"))

import ctrl_lpv as lpv  # noqa: E402
import ctrl_lpv.synthesis.ladder as ladder  # noqa: E402
from _independent import (  # noqa: E402
    _pair_brl,  # noqa: E402
    check_design,
    generate_case,
    negdef_margin,
)


# ----------------------------------------------------------------------
# Exact rational matrices
# ----------------------------------------------------------------------
def exact(X):
    """Object array of Fractions, equal to the float64 array `X`."""
    X = np.asarray(X, float)
    out = np.empty(X.shape, dtype=object)
    for index, value in np.ndenumerate(X):
        out[index] = Fraction(value)
    return out


def mul(A, B):
    return np.dot(A, B)  # object arrays: exact sums of exact products


def negative_definite(F) -> bool:
    """Exact: all pivots of ``-F`` positive (symmetric Gaussian elimination)."""
    M = [[-F[i, j] for j in range(F.shape[1])] for i in range(F.shape[0])]
    n = len(M)
    for p in range(n):
        pivot = M[p][p]
        if pivot <= 0:
            return False
        for i in range(p + 1, n):
            if M[i][p] == 0:
                continue
            f = M[i][p] / pivot
            row_p, row_i = M[p], M[i]
            for j in range(p + 1, n):
                row_i[j] -= f * row_p[j]
    return True


def normalized_lambda_max(F, digits=3):
    """Exact bracket of ``lambda_max(D F D)``, ``D = diag(-F_ii)^-1/2``.

    ``lambda_max(D F D) < -t`` iff ``F + t diag(-F_ii) < 0``; returns
    ``(lo, hi)`` with ``lo <= lambda_max <= hi`` (floats of exact ends), or
    None if a diagonal entry is not negative.
    """
    d = np.array([-F[i, i] for i in range(F.shape[0])], dtype=object)
    if any(x <= 0 for x in d):
        return None

    def below(t):  # lambda_max < -t ?
        G = F.copy()
        for i in range(G.shape[0]):
            G[i, i] = G[i, i] + t * d[i]
        return negative_definite(G)

    # lambda_max(D F D) lies in [-1, n - 1] (unit diagonal after scaling)
    n = F.shape[0]
    if below(Fraction(0)):
        lo_t, hi_t = Fraction(0), Fraction(1)  # answer: lambda in (-1, 0)
        # find the first power of ten: lambda_max < -t for t = 10^-k
        k = 0
        while not below(Fraction(1, 10**k)) and k < 40:
            k += 1
        lo_t, hi_t = Fraction(1, 10**k), Fraction(1, 10 ** (k - 1)) if k else 1
        for _ in range(int(digits * 3.33) + 2):
            mid = (lo_t + hi_t) / 2
            if below(mid):
                lo_t = mid
            else:
                hi_t = mid
        return float(-hi_t), float(-lo_t)
    lo_t, hi_t = Fraction(-(n - 1)), Fraction(0)  # lambda in [0, n - 1]
    k = 0
    while below(Fraction(-1, 10**k)) and k < 40:
        k += 1
    lo_t, hi_t = (
        Fraction(-1, 10 ** (k - 1)) if k else Fraction(-(n - 1)),
        Fraction(-1, 10**k),
    )
    for _ in range(int(digits * 3.33) + 2):
        mid = (lo_t + hi_t) / 2
        if below(mid):
            lo_t = mid
        else:
            hi_t = mid
    return float(-hi_t), float(-lo_t)


def brl_exact(P, Acl, B1, Ccl, D1, g, c):
    """``[[A'P + PA, PB, C'], [B'P, -c I, D'], [C, D, -c g I]]`` exactly."""
    nw, nz = B1.shape[1], Ccl.shape[0]
    PA = mul(P, Acl)
    PB = mul(P, B1)
    top = np.hstack([PA + PA.T, PB, Ccl.T])
    mid = np.hstack([PB.T, -c * np.eye(nw, dtype=int).astype(object), D1.T])
    low = np.hstack([Ccl, D1, -c * g * np.eye(nz, dtype=int).astype(object)])
    F = np.vstack([top, mid, low])
    for i in range(F.shape[0]):  # ints from eye -> Fractions
        for j in range(F.shape[1]):
            F[i, j] = Fraction(F[i, j])
    return F


# ----------------------------------------------------------------------
def capture_design(case):
    """Run the library; keep the ladder's last verified point (scaled)."""
    seen = {}
    original = ladder.verify

    def spy(original_data, data, sol, gains, margin, scheduled, P, gamma):
        out = original(original_data, data, sol, gains, margin, scheduled, P, gamma)
        seen.update(data=data, sol=sol, gains=gains, P=P, gamma=gamma, cert=out)
        return out

    ladder.verify = spy
    try:
        design = case.call(lpv)
    finally:
        ladder.verify = original
    return design, seen


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="2026:14")
    parser.add_argument("--full", action="store_true", help="not the small variant")
    args = parser.parse_args(argv)
    seed, index = map(int, args.case.split(":"))
    case = generate_case(seed, index, small=not args.full)
    print(case.describe())
    design, seen = capture_design(case)
    K = [np.asarray(k, float) for k in design.gains]
    P = np.asarray(design.P, float)
    gamma = float(design.gamma)
    print(
        f"design: {design.method}, gamma {gamma:.6g} (gamma_opt "
        f"{design.gamma_opt}), max ||K|| {max(np.linalg.norm(k, 2) for k in K):.3g}, "
        f"cond(P) {np.linalg.cond(P):.3g}, ladder {list(design.ladder)}"
    )
    print(f"library certificate: {design.certificate}")
    result = check_design(case, K, P, gamma)
    print(f"checker: {result}")

    V = case.vertices
    N = case.N
    sched = len(K) > 1
    pairs = [(j, j) for j in range(N)]
    if sched:
        pairs += [(j, k) for j in range(N) for k in range(j + 1, N)]
    Pe = exact(P)
    g = Fraction(gamma) ** 2
    Ke = [exact(k) for k in K]
    Ve = [tuple(exact(x) for x in v) for v in V]

    def closed(j, k):
        A, B1, B2, C, D1, D2 = Ve[j]
        Kk = Ke[k] if sched else Ke[0]
        return A - mul(B2, Kk), B1, C - mul(D2, Kk), D1

    print(
        "\nthe checker's vertex/pair inequality with P as returned (not "
        "symmetrised, as the library's check), exact; and the checker's float64 "
        "enclosure (it uses sym(P)):"
    )
    for j, k in pairs:
        Acl, B1, Ccl, D1 = closed(j, k)
        c = 1
        if j != k:
            Acl2, B12, Ccl2, D12 = closed(k, j)
            Acl, B1, Ccl, D1, c = Acl + Acl2, B1 + B12, Ccl + Ccl2, D1 + D12, 2
        F = brl_exact(Pe, Acl, B1, Ccl, D1, g, c)
        nd = negative_definite(F)
        bracket = normalized_lambda_max(F)
        # and what the checker's float64 enclosure says at this (j, k)
        dP = np.diag(P)
        dd = 2.0 ** np.round(-0.5 * np.log2(dP))
        Vd = [
            (A * dd[None, :] / dd[:, None], B1_ / dd[:, None], B2 / dd[:, None],
             C * dd[None, :], D1_, D2)
            for A, B1_, B2, C, D1_, D2 in V
        ]  # fmt: skip
        Kd = [k_ * dd[None, :] for k_ in K]
        Pd = P * dd[:, None] * dd[None, :]

        def closed_f(a, b, Vd=Vd, Kd=Kd):
            A, B1_, B2, C, D1_, D2 = Vd[a]
            Kk = Kd[b] if sched else Kd[0]
            return (A - B2 @ Kk, np.abs(A) + np.abs(B2) @ np.abs(Kk), B1_,
                    C - D2 @ Kk, np.abs(C) + np.abs(D2) @ np.abs(Kk), D1_)  # fmt: skip

        Ff, Gf = _pair_brl(closed_f, j, k, 0.5 * (Pd + Pd.T), gamma**2)
        inner = 2 * case.n + case.m + case.nw + case.nz
        enclosure = negdef_margin(Ff, Gf, inner)
        print(
            f"  {(j, k)}: negative definite {nd}; lambda_max(DFD) in "
            f"{bracket}; checker's float64 enclosure "
            f"[{enclosure[0]:.3g}, {enclosure[1]:.3g}]"
        )

    print("\nlibrary's frozen-point inequality, exact (vertices, midpoints):")
    deltas = [np.eye(N)[j] for j in range(N)]
    if N > 1:
        deltas += [0.5 * (np.eye(N)[j] + np.eye(N)[k])
                   for j in range(N) for k in range(j + 1, N)]  # fmt: skip
    for delta in deltas:
        de = [Fraction(x) for x in delta]
        A, B1, B2, C, D1, D2 = (sum(d * v[i] for d, v in zip(de, Ve)) for i in range(6))
        Kd = sum(d * k for d, k in zip(de, Ke)) if sched else Ke[0]
        F = brl_exact(Pe, A - mul(B2, Kd), B1, C - mul(D2, Kd), D1, g, 1)
        print(
            f"  delta {np.round(delta, 2).tolist()}: negative definite "
            f"{negative_definite(F)}; lambda_max(DFD) in {normalized_lambda_max(F)}"
        )

    print("\nthe same with the symmetric part of P (x'Px only sees it), exact:")
    Ps = (Pe + Pe.T) / 2
    asym = np.abs(P - P.T).max() / np.abs(P).max()
    print(f"  ||P - P'||_max / ||P||_max = {asym:.3g}")
    for j, k in pairs:
        Acl, B1, Ccl, D1 = closed(j, k)
        c = 1
        if j != k:
            Acl2, B12, Ccl2, D12 = closed(k, j)
            Acl, B1, Ccl, D1, c = Acl + Acl2, B1 + B12, Ccl + Ccl2, D1 + D12, 2
        F = brl_exact(Ps, Acl, B1, Ccl, D1, g, c)
        print(
            f"  {(j, k)}: negative definite {negative_definite(F)}; "
            f"lambda_max(DFD) in {normalized_lambda_max(F)}"
        )

    sol, data = seen["sol"], seen["data"]
    print("\nthe solver's point (W~, Z~, g~) in the scaled units of the LMIs, exact:")
    W = exact(sol.W)
    gt = exact(sol.g)[0, 0]
    for j in range(len(data)):
        A, B1, B2, C, D1, D2 = (exact(x) for x in data[j])
        Z = exact(getattr(sol, f"Z{j if sched else 0}"))
        q = mul(A, W) + mul(B2, Z)
        R = mul(C, W) + mul(D2, Z)
        nw, nz = B1.shape[1], C.shape[0]
        F = np.vstack([
            np.hstack([q + q.T, R.T, B1]),
            np.hstack([R, -gt * np.eye(nz, dtype=int).astype(object), D1]),
            np.hstack([B1.T, D1.T, -np.eye(nw, dtype=int).astype(object)]),
        ])  # fmt: skip
        for a in range(F.shape[0]):
            for b in range(F.shape[1]):
                F[a, b] = Fraction(F[a, b])
        print(
            f"  vertex {j}: negative definite {negative_definite(F)}; "
            f"lambda_max(DFD) in {normalized_lambda_max(F)}"
        )
        if not sched:
            break


if __name__ == "__main__":
    main()
