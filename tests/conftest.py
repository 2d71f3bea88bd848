"""Shared fixtures: small polytopic plants with known properties."""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv


@pytest.fixture
def mass_spring():
    """Mass-spring-damper with an uncertain stiffness k in [1, 4].

    States [x, v], inputs [w (force disturbance), u (force)],
    outputs [x, u_weighted].
    """
    base = ct.ss(
        [[0.0, 1.0], [0.0, -0.5]],
        [[0.0, 0.0], [1.0, 1.0]],
        [[1.0, 0.0], [0.0, 0.0]],
        [[0.0, 0.0], [0.0, 0.1]],
        inputs=["w", "u"],
        outputs=["x", "uw"],
        states=["x", "v"],
        name="msd",
    )
    term = ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)
    return lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": (1.0, 4.0)})


@pytest.fixture
def unstable_pair():
    """Two open-loop unstable vertices, varying input gain."""
    v1 = ct.ss([[0.0, 1.0], [1.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0]], 0)
    v2 = ct.ss([[0.0, 1.0], [3.0, -1.0]], [[0.0], [2.0]], [[1.0, 0.0]], 0)
    return lpv.pss([v1, v2], {"p": (0.0, 1.0)}, inputs="u", outputs="y")


def interior_deltas(nvertices, count=20, seed=0):
    rng = np.random.default_rng(seed)
    return [np.eye(nvertices)[j] for j in range(nvertices)] + list(
        rng.dirichlet(np.ones(nvertices), size=count)
    )
