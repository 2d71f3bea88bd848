"""Analysis with vertex gains and an input matrix that depends on the
parameter: ``B_u(p) K(p)`` is quadratic in the convex coordinates, so the
vertex closed loops alone do not span the closed loop. The certified bounds
must still hold at every frozen point (norms from python-control, with the
gain interpolated as the design schedules it)."""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv


def plant():
    def vertex(b):
        return ct.ss([[0.0, 1.0], [-1.0, -0.3]], [[0.0, 0.0], [1.0, b]],
                     [[1.0, 0.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 1.0]],
                     inputs=["w", "u"], outputs=["z", "zu"])  # fmt: skip

    return lpv.PolytopicStateSpace([vertex(0.3), vertex(3.0)], domain={"b": (0.3, 3.0)})


# Vertex gains chosen so that the cross terms matter: each tuned to its own
# vertex's input gain b, so that b K adds -0.2 of damping at both vertices,
# while in between (b0 + b1)(K0 + K1) / 4 adds -0.6: the plant's 0.3 of
# damping goes negative, a frozen closed loop that the vertices' loops do
# not span.
GAINS = [np.array([[0.0, -0.2 / 0.3]]), np.array([[0.0, -0.2 / 3.0]])]
GOOD = [np.array([[6.0, 8.0]]), np.array([[0.1, 0.3]])]


def frozen(p, gains):
    sys = plant()
    K = np.tensordot(sys.weights({"b": p}), np.array(gains), axes=1)
    G = sys.at({"b": p})
    A, B, C, D = ct.ssdata(G)
    return ct.ss(A - B[:, [1]] @ K, B[:, [0]], C - D[:, [1]] @ K, D[:, [0]])


@pytest.mark.parametrize(
    ("analysis", "norm"),
    [(lpv.l2_gain_bound, lambda s: float(ct.linfnorm(s)[0])),
     (lpv.h2_bound, lambda s: float(ct.norm(s, 2)))],
)  # fmt: skip
def test_bound_holds_between_the_vertices(analysis, norm):
    bound = analysis(plant(), GOOD, "w", "u", ["z", "zu"]).gamma
    worst = max(norm(frozen(p, GOOD)) for p in np.linspace(0.3, 3.0, 55))
    assert worst <= bound


@pytest.mark.parametrize("analysis", [lpv.l2_gain_bound, lpv.h2_bound])
def test_unstable_between_stable_vertices_is_refused(analysis):
    for j in (0, 1):  # stable at the vertices ...
        assert np.linalg.eigvals(frozen((0.3, 3.0)[j], GAINS).A).real.max() < 0
    # ... unstable in between
    assert np.linalg.eigvals(frozen(1.65, GAINS).A).real.max() > 0
    with pytest.raises((lpv.InfeasibleError, lpv.CertificationError)):
        analysis(plant(), GAINS, "w", "u", ["z", "zu"])
