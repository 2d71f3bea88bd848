"""Re-solves of kept problems give fresh, certified designs.

The synthesis functions keep problems in `synthesis_cache`, keyed by
structure; the data are parameters, and an inequality is read again only
when the parameters it reads change. These tests check that a reused
problem gives the design a fresh compilation gives, never the design of
other data, and that every design is still checked against its own data
(python-control's frozen H-infinity norms, closed-loop eigenvalues).
"""

import threading
import warnings

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from conftest import interior_deltas
from ctrl_lpv import SynthesisCache, synthesis_cache, twomass

HINF = {"w": "w", "u": "u", "z": ["x", "uw"]}


@pytest.fixture
def reads(monkeypatch):
    """The block functions read into affine maps, counted."""
    from ctrl_lpv.lmi import blocks

    count, real = [0], blocks.columns

    def columns(*args, **kwargs):
        count[0] += 1
        return real(*args, **kwargs)

    monkeypatch.setattr(blocks, "columns", columns)
    return count


@pytest.fixture(autouse=True)
def empty_cache():
    """Each test starts from an empty cache of the default size."""
    limits = synthesis_cache.maxsize, synthesis_cache.max_entries
    synthesis_cache.clear()
    yield
    synthesis_cache.maxsize, synthesis_cache.max_entries = limits
    synthesis_cache.clear()


def msd(stiffness=(1.0, 4.0), damping=0.5, effort_weight=0.1, x_weight=1.0):
    """Mass-spring-damper with uncertain stiffness (as the fixture)."""
    base = ct.ss(
        [[0.0, 1.0], [0.0, -damping]],
        [[0.0, 0.0], [1.0, 1.0]],
        [[x_weight, 0.0], [0.0, 0.0]],
        [[0.0, 0.0], [0.0, effort_weight]],
        inputs=["w", "u"],
        outputs=["x", "uw"],
        states=["x", "v"],
    )
    term = ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)
    return lpv.PolytopicStateSpace.from_affine(base, {"k": term}, {"k": stiffness})


def frozen_hinf_norms(sys, design, count=6):
    """python-control's H-infinity norms of frozen closed loops."""
    norms = []
    for delta in interior_deltas(sys.nvertices, count=count, seed=3):
        A = sum(d * v.A for d, v in zip(delta, sys.vertices))
        B = sum(d * v.B for d, v in zip(delta, sys.vertices))
        C = sum(d * v.C for d, v in zip(delta, sys.vertices))
        D = sum(d * v.D for d, v in zip(delta, sys.vertices))
        if design.scheduled:
            K = np.tensordot(delta, np.stack(design.gains), axes=1)
        else:
            K = design.gains[0]
        Acl = A - B[:, [1]] @ K
        Ccl = C - D[:, [1]] @ K
        norms.append(ct.linfnorm(ct.ss(Acl, B[:, [0]], Ccl, D[:, [0]]))[0])
    return np.array(norms)


def assert_same_design(a, b, rtol=1e-6):
    assert a.method == b.method
    for Ka, Kb in zip(a.gains, b.gains, strict=True):
        np.testing.assert_allclose(Ka, Kb, rtol=rtol, atol=rtol * np.abs(Kb).max())
    if b.gamma is None:
        assert a.gamma is None
    else:
        assert a.gamma == pytest.approx(b.gamma, rel=rtol)


@pytest.mark.parametrize(
    "function, kwargs",
    [
        (lpv.gain_scheduled_hinf, HINF),
        (lpv.hinf_state_feedback, dict(HINF, backoff=None)),
        (lpv.quadratic_stabilization, {"u": "u", "regions": [lpv.halfplane(0.5)]}),
        (lpv.gain_scheduled_stabilization, {"u": "u", "gain_bound": 50.0}),
    ],
)
def test_reused_problem_gives_the_fresh_design(function, kwargs, reads):
    sys = msd()
    first = function(sys, **kwargs)
    before = reads[0]
    again = function(sys, **kwargs)
    assert synthesis_cache.info()["hits"] == 1
    assert reads[0] == before > 0  # nothing read again
    synthesis_cache.maxsize = 0  # a problem of its own
    fresh = function(sys, **kwargs)
    assert reads[0] > before
    assert_same_design(again, fresh)
    assert_same_design(first, fresh)
    # The certificate is recomputed, not copied.
    assert again.certificate is not first.certificate
    assert again.certificate.verified
    if again.gamma is not None:
        assert frozen_hinf_norms(sys, again).max() <= again.gamma


def test_changed_vertex_entry_changes_the_design():
    sys = msd()
    before = lpv.gain_scheduled_hinf(sys, **HINF)
    # One entry of one vertex: how w enters at k = 4 only.
    A, B, C, D = sys.vertex_data()[1]
    B = B.copy()
    B[1, 0] = 2.0
    vertices = [sys.vertex_data()[0], (A, B, C, D)]
    other = lpv.pss(vertices, {"k": (1.0, 4.0)}, inputs=["w", "u"],
                    outputs=["x", "uw"], states=["x", "v"])  # fmt: skip
    after = lpv.gain_scheduled_hinf(other, **HINF)
    assert synthesis_cache.info()["hits"] == 1
    assert not np.allclose(after.gains[1], before.gains[1], rtol=1e-3)
    assert after.gamma != pytest.approx(before.gamma, rel=1e-4)
    # Verified against the new data, independently of the library.
    assert after.certificate.verified
    assert frozen_hinf_norms(other, after).max() <= after.gamma
    for delta in interior_deltas(2, count=20):
        Acl = sum(d * v[0] for d, v in zip(delta, vertices)) - sum(
            d * v[1] for d, v in zip(delta, vertices)
        )[:, [1]] @ np.tensordot(delta, np.stack(after.gains), axes=1)
        assert np.linalg.eigvals(Acl).real.max() < 0
    # And it is the design a fresh compilation gives for the new data.
    synthesis_cache.clear()
    assert_same_design(after, lpv.gain_scheduled_hinf(other, **HINF))


def test_gamma_sweep_reuses_and_stays_certified(reads):
    sys = msd()
    best = lpv.hinf_state_feedback(sys, **HINF)
    fresh_reads = reads[0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for factor in (1.05, 1.5, 3.0):
            bound = factor * best.gamma_opt
            before = reads[0]
            design = lpv.hinf_state_feedback(sys, gamma=bound, **HINF)
            # the bounds and the gain stage's linearisation, not the vertices
            assert reads[0] - before < fresh_reads / 2
            # g <= g_max is a side constraint, met to the solver's accuracy.
            assert design.gamma <= bound * (1 + 1e-5)
            assert design.certificate.verified
            assert frozen_hinf_norms(sys, design).max() <= design.gamma
        with pytest.raises(lpv.InfeasibleError):
            lpv.hinf_state_feedback(sys, gamma=0.5 * best.gamma_opt, **HINF)
    # An infeasible solve leaves nothing behind for the next one.
    again = lpv.hinf_state_feedback(sys, **HINF)
    assert_same_design(again, best)


def test_backoff_sweep_bounds_gamma():
    sys = msd()
    designs = [lpv.gain_scheduled_hinf(sys, backoff=b, **HINF) for b in (0.0, 0.1, 0.5)]
    info = synthesis_cache.info()
    assert (info["hits"], info["misses"], info["size"]) == (2, 1, 1)
    for backoff, design in zip((0.0, 0.1, 0.5), designs):
        assert design.gamma_opt == pytest.approx(designs[0].gamma_opt, rel=1e-6)
        # g <= g_max is a side constraint, met to the solver's accuracy.
        assert design.gamma <= (1 + backoff) * design.gamma_opt * (1 + 1e-5)
        assert frozen_hinf_norms(sys, design).max() <= design.gamma


def test_weight_sweep_gamma_grows_with_the_weight():
    # Scaling a performance output up cannot lower the optimal gamma, and
    # it does not change the structure: one compilation for the sweep. (Here
    # w and u share a channel, so the infimum is the effort weight 0.1 for
    # every x weight: high gain makes u cancel w. The estimates agree to
    # 1e-6, not strictly increase.)
    gammas = []
    for weight in (1.0, 2.0, 4.0):
        sys = msd(x_weight=weight)
        design = lpv.gain_scheduled_hinf(sys, backoff=None, **HINF)
        assert frozen_hinf_norms(sys, design).max() <= design.gamma
        gammas.append(design.gamma_opt)
    assert synthesis_cache.info()["misses"] == 1
    assert gammas[0] <= gammas[1] * (1 + 1e-6)
    assert gammas[1] <= gammas[2] * (1 + 1e-6)
    assert gammas[0] == pytest.approx(0.1, rel=1e-4)


def test_rescaled_states_rebuild_only_what_they_must():
    # A change of units of one state changes the power-of-two prescaling,
    # which the gain stage reads as a constant: still the fresh design.
    sys = msd()
    lpv.hinf_state_feedback(sys, **HINF)
    S = np.diag([1.0, 64.0])  # v in other units
    other = lpv.pss(
        [(S @ A @ np.linalg.inv(S), S @ B, C @ np.linalg.inv(S), D)
         for A, B, C, D in sys.vertex_data()],
        {"k": (1.0, 4.0)}, inputs=["w", "u"], outputs=["x", "uw"],
    )  # fmt: skip
    reused = lpv.hinf_state_feedback(other, **HINF)
    assert synthesis_cache.info()["hits"] == 1
    synthesis_cache.clear()
    fresh = lpv.hinf_state_feedback(other, **HINF)
    assert_same_design(reused, fresh)
    assert frozen_hinf_norms(other, reused).max() <= reused.gamma


def test_concurrent_calls_get_their_own_problem():
    results = {}

    def design(key, sys):
        results[key] = lpv.gain_scheduled_hinf(sys, backoff=None, **HINF)

    systems = {"a": msd(), "b": msd(damping=1.5)}
    threads = [threading.Thread(target=design, args=item) for item in systems.items()]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    synthesis_cache.clear()
    for key, sys in systems.items():
        assert_same_design(
            results[key], lpv.gain_scheduled_hinf(sys, backoff=None, **HINF)
        )


def test_cache_size_and_eviction():
    cache = SynthesisCache(maxsize=1)
    assert cache.info() == {"hits": 0, "misses": 0, "size": 0, "maxsize": 1,
                            "entries": 0, "max_entries": 250_000}  # fmt: skip
    synthesis_cache.maxsize = 1
    lpv.quadratic_stabilization(msd(), u="u")
    lpv.hinf_state_feedback(msd(), **HINF)  # evicts the first structure
    lpv.quadratic_stabilization(msd(), u="u")
    info = synthesis_cache.info()
    # Lemma 1 on n = 2, N = 2: two 2 x 2 Lyapunov LMIs and W > 0.
    assert (info["hits"], info["misses"], info["size"], info["entries"]) == (
        0, 3, 1, 3 * 4
    )  # fmt: skip
    synthesis_cache.maxsize = 0
    assert synthesis_cache.info()["size"] == 0
    with pytest.raises(ValueError, match="maxsize"):
        synthesis_cache.maxsize = -1
    with pytest.raises(TypeError, match="maxsize"):
        synthesis_cache.maxsize = 1.5


def test_a_structure_over_the_budget_is_not_kept():
    synthesis_cache.max_entries = 20  # Lemma 1 here has 12 entries, Lemma 2 54
    lpv.quadratic_stabilization(msd(), u="u")
    assert synthesis_cache.info()["size"] == 1
    design = lpv.hinf_state_feedback(msd(), **HINF)
    assert design.certificate.verified
    # Not kept, and it did not flush the structure that fits.
    assert synthesis_cache.info()["size"] == 1
    again = lpv.hinf_state_feedback(msd(), **HINF)
    assert again.timing["compile"] > 0
    assert_same_design(again, design)
    with pytest.raises(ValueError, match="max_entries"):
        synthesis_cache.max_entries = -5


def test_two_mass_gamma_sweep_close_to_the_optimum():
    # A gamma 2 % above gamma* needs a Lyapunov matrix larger than the
    # first bound W <= 1e3 I (scaled units) allows; the design must still
    # come out certified, and python-control must agree with its bound.
    model = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    kw = {"w": "Td", "u": "Tm", "z": list(model.output_labels), "backoff": None}
    best = lpv.gain_scheduled_hinf(model, **kw)
    for factor in (1.02, 1.5):
        bound = factor * best.gamma_opt
        design = lpv.gain_scheduled_hinf(model, gamma=bound, **kw)
        assert design.certificate.verified
        assert design.gamma <= bound * (1 + 1e-5)
        for p in (-0.95, -0.4, 0.0):
            A, Bw, C, D = ct.ssdata(design.closed_loop(p))
            assert ct.linfnorm(ct.ss(A, Bw, C, D))[0] <= design.gamma
