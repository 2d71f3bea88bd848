"""Gate of issue 20: the hand-built saturation pipeline against the one engine.

`saturated_state_feedback` and `saturation_region` now run on the engine
(`RegionSize` objective, `Saturation` constraint, `run_general`); the old
pipeline (its own prescaling, line search, back-off and verifier) is kept
as ``_old_saturated_state_feedback`` / ``_old_saturation_region`` for this
comparison only. On a seeded corpus (random open-loop unstable polytopes
n = 1..3, N = 1..4, one or two saturated inputs, points or a shape, common
or vertex gains; the plants of tests/test_saturation.py, with and without a
peak-bounded disturbance and the output objective) both must give the same
verdict, and the engine's region may not be smaller than the old one beyond
``TOL`` (the strict LMIs' margin, 1e-6 in each path's own prescaled units,
costs a region near the edge of feasibility a few 1e-3; at margin 1e-8 the
engine matches the old optimum there). Each engine result is re-checked
here with numpy: the reference set inside the ellipsoid, the sector and
inclusion inequalities in the model's units.

Measured when the gate was written (old code present): see the commit.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv._saturation_lmi import (
    _old_saturated_state_feedback,
    _old_saturation_region,
)
from ctrl_lpv.exceptions import SynthesisError
from ctrl_lpv.saturation import saturated_state_feedback, saturation_region

TOL = 5e-3


def _random_case(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 4))
    N = int(rng.integers(1, 5))
    m = 1 if n == 1 else int(rng.integers(1, 3))
    A0 = rng.standard_normal((n, n))
    # Shift so that A0 has an eigenvalue with real part in (0, 1): open-loop
    # unstable, yet with a bounded region under saturation.
    A0 += (rng.uniform(0.05, 1.0) - max(np.linalg.eigvals(A0).real)) * np.eye(n)
    B0 = rng.standard_normal((n, m))
    verts = [
        ct.ss(
            A0 + 0.3 * rng.standard_normal((n, n)),
            B0 + 0.2 * rng.standard_normal((n, m)),
            np.eye(n),
            0,
        )
        for _ in range(N)
    ]
    u = [f"u{i}" for i in range(m)]
    sys = lpv.PolytopicStateSpace(verts, inputs=u)
    kwargs = {}
    if rng.uniform() < 0.5:
        kwargs["points"] = rng.standard_normal((int(rng.integers(1, n + 1)), n))
    else:
        L = rng.standard_normal((n, n))
        kwargs["shape"] = L @ L.T + 0.5 * np.eye(n)
    if N > 1 and rng.uniform() < 0.3:
        kwargs["gains"] = "scheduled"
    return sys, u, rng.uniform(0.5, 2.0, m), kwargs


def _test_plant():
    verts = [
        ct.ss([[0.0, 1.0], [a, 0.0]], [[0.0, 0.0], [b, 1.0]], np.eye(2), 0,
              inputs=["u", "w"])
        for b in (0.5, 1.5)
        for a in (-0.1, 0.3)
    ]  # fmt: skip
    return lpv.PolytopicStateSpace(verts, domain=lpv.box(b=(0.5, 1.5), a=(-0.1, 0.3)))


def _cases():
    scalar = lpv.PolytopicStateSpace([ct.ss([[1.0]], [[2.0]], [[1.0]], 0)], inputs="u")
    yield "scalar a=1 b=2", scalar, "u", np.array([0.5]), {}
    plant = _test_plant()
    pts = np.array([[1.0, 0.0], [0.0, 1.0], [-0.5, 0.5]])
    yield "plant points", plant, "u", np.array([1.0]), {"points": pts}
    yield "plant decay", plant, "u", np.array([1.0]), {"decay": 0.3}
    yield "plant scheduled", plant, "u", np.array([1.0]), {"gains": "scheduled"}
    yield "plant w", plant, "u", np.array([1.0]), {"w": "w", "w_max": 0.05}
    yield "plant output", plant, "u", np.array([1.0]), {
        "w": "w", "w_max": 0.05, "output": np.array([[1.0, 0.0]]), "beta_min": 0.4,
    }  # fmt: skip
    A1 = np.array([[0.5, 1.0, 0.0], [0.0, 0.2, 1.0], [0.0, 0.0, -1.0]])
    A2 = A1 + np.diag([0.3, 0.0, 0.0])
    B = np.array([[1.0, 0.0], [0.0, 0.5], [0.3, 1.0]])
    two = lpv.pss([ct.ss(A, B, np.eye(3), 0) for A in (A1, A2)], {"p": (0, 1)},
                  inputs=["u1", "u2"])  # fmt: skip
    yield "two inputs", two, ["u1", "u2"], np.array([1.0, 2.0]), {}
    # An unstable mode that u does not reach: no region, both refuse.
    stuck = lpv.PolytopicStateSpace(
        [ct.ss(np.diag([1.0, -1.0]), [[0.0], [1.0]], np.eye(2), 0)], inputs="u"
    )
    yield "not stabilizable", stuck, "u", np.array([1.0]), {}
    for seed in range(24):
        yield (f"seed {seed}", *_random_case(seed))


CASES = list(_cases())


def _run(function, *args, **kwargs):
    try:
        return function(*args, **kwargs)
    except SynthesisError:
        return None


def _size(d, kwargs):
    """What the call optimises: beta, or minus the size along the output."""
    if "output" in kwargs:
        return -float(d.support(kwargs["output"]).max())
    return d.beta


def _numpy_checks(d, sys, kwargs):
    """The certificate's statements recomputed in the model's units."""
    P, W = d.P, np.linalg.inv(d.P)
    assert d.certificate.verified
    assert np.linalg.eigvalsh(P).min() > 0
    if "points" in kwargs:
        V = kwargs["points"] * d.beta
        assert np.einsum("ij,jk,ik->i", V, P, V).max() <= 1 + 1e-9
    iu = [sys.physical_inputs.index(name) for name in d.u]
    iw = [sys.physical_inputs.index(name) for name in d.w]
    for k, (K, G) in enumerate(zip(d.gains, d.G)):
        F = K - G
        ratio = np.einsum("ij,jk,ik->i", F, W, F) / d.u_max**2
        assert ratio.max() <= 1 + 1e-7, (k, ratio)
    c = 2 * d.decay + d.lam
    for j, (A, B, _, _) in enumerate(sys.vertex_data()):
        if d.scheduled:
            continue  # the vertex pairs are the engine's own rows
        K, G, Bu = d.gains[0], d.G[0], B[:, iu]
        Acl = A - Bu @ K
        top = Acl.T @ P + P @ Acl + c * P
        off = -(P @ Bu + G.T @ d.T)
        M = np.block([[top, off], [off.T, -2 * d.T]])
        if iw:
            E = B[:, iw] * d.w_max
            m, nw = len(iu), len(iw)
            M = np.block([[M, np.vstack([P @ E, np.zeros((m, nw))])],
                          [E.T @ P, np.zeros((nw, m)), -np.diag(d.mu)]])  # fmt: skip
        scale = np.sqrt(np.abs(np.diag(M)))
        assert np.linalg.eigvalsh(M / np.outer(scale, scale)).max() < 1e-9, j


@pytest.mark.parametrize(
    "name, sys, u, u_max, kwargs", CASES, ids=[c[0] for c in CASES]
)
def test_design_same_verdict_and_no_smaller_region(name, sys, u, u_max, kwargs):
    old = _run(_old_saturated_state_feedback, sys, u, u_max, backoff=None, **kwargs)
    new = _run(saturated_state_feedback, sys, u, u_max, backoff=None, **kwargs)
    assert (old is None) == (new is None), name
    if new is None:
        return
    _numpy_checks(new, sys, kwargs)
    a, b = _size(new, kwargs), _size(old, kwargs)
    assert a >= b - TOL * abs(b), (name, a, b)


@pytest.mark.parametrize(
    "name, sys, u, u_max, kwargs", CASES, ids=[c[0] for c in CASES]
)
def test_analysis_same_verdict_and_no_smaller_region(name, sys, u, u_max, kwargs):
    # The gain of a backed-off design, analysed by both paths.
    design = _run(_old_saturated_state_feedback, sys, u, u_max, **kwargs)
    if design is None:
        pytest.skip("no design to analyse")
    gain = list(design.gains) if design.scheduled else design.gains[0]
    options = {k: v for k, v in kwargs.items() if k != "gains"}
    old = _run(_old_saturation_region, sys, gain, u, u_max, **options)
    new = _run(saturation_region, sys, gain, u, u_max, **options)
    assert (old is None) == (new is None), name
    if new is None:
        return
    assert not new.designed
    for K, K0 in zip(new.gains, design.gains):
        np.testing.assert_array_equal(K, K0)  # the given gain, unchanged
    _numpy_checks(new, sys, options)
    a, b = _size(new, options), _size(old, options)
    assert a >= b - TOL * abs(b), (name, a, b)
