"""The prescalings' channel and time scales (stacked over the vertices)
against the norms of each vertex computed one by one."""

import numpy as np
import pytest

from ctrl_lpv.synthesis.scaling import Scaling, channel_scales, pow2


def _vertices(rng, N, n, nw, nz, m):
    out = []
    for _ in range(N):
        scale = 10.0 ** rng.uniform(-3, 3, size=n)
        A = rng.standard_normal((n, n)) * scale[:, None] / scale
        B1 = rng.standard_normal((n, nw)) * scale[:, None]
        C = rng.standard_normal((nz, n)) / scale
        B2, D1 = rng.standard_normal((n, m)), rng.standard_normal((nz, nw))
        out.append((A, B1, B2, C, D1, rng.standard_normal((nz, m))))
    return out


def _one_by_one(vertices, T, Su, a):
    Tm = np.diag(T) if T.ndim == 1 else T
    nb1 = max((np.linalg.norm(np.linalg.solve(Tm, v[1]), 2) if v[1].size else 0.0)
              for v in vertices)  # fmt: skip
    sw = pow2(a / nb1) if nb1 > 0 else 1.0
    stacked = [np.hstack([v[3] @ Tm, v[4] * sw, v[5] * Su]) for v in vertices]
    nz = max((np.linalg.norm(M, 2) if M.size else 0.0) for M in stacked)
    return sw, (pow2(nz) if nz > 0 else 1.0)


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("sizes", [(4, 1, 3, 2), (3, 0, 0, 1), (5, 2, 4, 0)])
def test_channel_scales_are_the_largest_vertex_norms(seed, sizes):
    rng = np.random.default_rng(seed)
    n, nw, nz, m = sizes
    vertices = _vertices(rng, 5, n, nw, nz, m)
    for T in (
        2.0 ** rng.integers(-4, 5, size=n),
        rng.standard_normal((n, n)) + 3 * np.eye(n),
    ):
        Su, a = 2.0 ** rng.integers(-3, 4, size=m).astype(float), 4.0
        assert channel_scales(vertices, T, Su, a) == _one_by_one(vertices, T, Su, a)


@pytest.mark.parametrize("seed", range(4))
def test_time_scale_is_the_largest_balanced_vertex_norm(seed):
    vertices = _vertices(np.random.default_rng(seed), 4, 4, 1, 2, 2)
    sc = Scaling.of(vertices)
    largest = max(np.linalg.norm(v[0] * (sc.T / sc.T[:, None]), 2) for v in vertices)
    assert sc.a == pow2(largest)
    assert Scaling.of(vertices, time_scaling=False).a == 1.0
