"""Pole regions of output-feedback designs, against independent facts.

Closed loops built by `control.interconnect` from the returned controller
system (connected by name), their eigenvalues from numpy, their norms from
`control.linfnorm`; the regions' membership tested on those eigenvalues.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv.regions import disk, halfplane, sector
from test_output_feedback import W, Z, loop_by_name, random_plant


def small_plant():
    """The docstring's plant: unstable, one measurement, two outputs."""
    return ct.ss([[0.0, 1.0], [-1.0, 0.5]], [[0.0, 0.0], [1.0, 1.0]],
                 [[1.0, 0.0], [0.0, 0.0], [1.0, 0.0]],
                 [[0.0, 0.0], [0.0, 1.0], [0.1, 0.0]],
                 inputs=["w", "u"], outputs=["z1", "z2", "y"])  # fmt: skip


@pytest.mark.parametrize("decay", [0.5, 1.0, 2.0])
def test_lti_decay_rate_holds_on_the_closed_loop(decay):
    G = small_plant()
    d = lpv.hinf_output_feedback(lpv.pss([G]), "w", "u", ["z1", "z2"], "y",
                                 constraints=[halfplane(decay)])  # fmt: skip
    assert d.certificate.verified
    cl = ct.interconnect([G, d.controller().at([1.0])], inplist=["w"],
                         outlist=["z1", "z2"])  # fmt: skip
    assert np.linalg.eigvals(cl.A).real.max() < -decay
    assert d.gamma >= float(ct.linfnorm(cl)[0])


def test_region_costs_bound_and_an_unreachable_one_is_refused():
    """Asking the closed loop to be faster cannot lower the optimum; a
    region that needs more than the plant allows is refused, not faked."""
    G = lpv.pss([small_plant()])
    free = lpv.hinf_output_feedback(G, "w", "u", ["z1", "z2"], "y", backoff=None)
    fast = lpv.hinf_output_feedback(G, "w", "u", ["z1", "z2"], "y", backoff=None,
                                    constraints=[halfplane(2.0)])  # fmt: skip
    assert fast.gamma_opt >= free.gamma_opt * (1 - 1e-6)
    empty = [halfplane(1.0), disk(0.5, -0.1)]  # Re < -1 and within [-0.6, 0.4]
    with pytest.raises((lpv.InfeasibleError, lpv.CertificationError)):
        lpv.hinf_output_feedback(G, "w", "u", ["z1", "z2"], "y", constraints=empty)


def test_polytopic_frozen_loops_stay_in_a_sector_and_halfplane():
    sys = random_plant(4, n=3, vertices=2, stable=True)
    regions = [halfplane(0.2), sector(np.pi / 3)]
    d = lpv.hinf_output_feedback(sys, W, "u", Z, "y", constraints=regions)
    assert d.certificate.verified
    controller = d.controller()
    for p in np.linspace(0.0, 1.0, 41):
        cl = loop_by_name(sys.at({"p": p}), controller.at({"p": p}))
        eig = np.linalg.eigvals(cl.A)
        for region in regions:
            assert region.contains(eig).all(), (p, region, eig)


def test_h2_design_with_a_region():
    sys = random_plant(2, n=3, vertices=2, stable=True)
    d = lpv.synthesize(sys, "u", y="y", objective=lpv.H2(W, Z),
                       constraints=[halfplane(0.3)])  # fmt: skip
    assert d.certificate.verified
    for p in np.linspace(0.0, 1.0, 21):
        cl = loop_by_name(sys.at({"p": p}), d.controller().at({"p": p}))
        assert np.linalg.eigvals(cl.A).real.max() < -0.3
        assert d.gamma >= float(ct.norm(cl, 2))


def test_discrete_time_disk():
    sys = random_plant(1, n=3, dt=0.1)
    d = lpv.hinf_output_feedback(sys, W, "u", Z, "y", constraints=[disk(0.7)])
    cl = loop_by_name(sys.vertices[0], d.controller().at([1.0]))
    assert d.certificate.verified
    assert np.abs(np.linalg.eigvals(cl.A)).max() < 0.7
    assert d.gamma >= float(ct.linfnorm(cl)[0])


def test_bad_constraints_are_named():
    G = lpv.pss([small_plant()])
    for item in (lpv.Peak("w", "z1", bound=2.0), lpv.Hinf("w", "z1")):
        with pytest.raises(ValueError, match="constraints"):
            lpv.hinf_output_feedback(G, "w", "u", ["z1", "z2"], "y", constraints=[item])
    with pytest.raises(TypeError, match="constraints"):
        lpv.hinf_output_feedback(G, "w", "u", ["z1", "z2"], "y", constraints=[1.0])
    with pytest.raises(ValueError, match="continuous-time region"):
        lpv.hinf_output_feedback(random_plant(1, n=3, dt=0.1), W, "u", Z, "y",
                                 constraints=[halfplane(0.5)])  # fmt: skip


# ------------------------------------------------------------------ mixed


def channel_norms(G, controller):
    """H2 of w -> (z1, z2) and H-infinity of w -> z1, of python-control's loop."""
    both = ct.interconnect([G, controller], inplist=["w"], outlist=["z1", "z2"])
    first = ct.interconnect([G, controller], inplist=["w"], outlist=["z1"],
                            check_unused=False)  # fmt: skip
    return float(ct.norm(both, 2)), float(ct.linfnorm(first)[0])


@pytest.mark.parametrize("fraction", [0.9, 0.5])
def test_mixed_h2_with_an_hinf_bound_on_another_channel(fraction):
    """Minimise the H2 norm subject to an L2-gain bound on a sub-channel that
    the unconstrained H2 design exceeds: the returned loop meets both, the
    H2 bound is certified above its true norm, and it costs H2."""
    G = small_plant()
    S = lpv.pss([G])
    free = lpv.h2_output_feedback(S, "w", "u", ["z1", "z2"], "y", backoff=None)
    _, free_hinf = channel_norms(G, free.controller().at([1.0]))
    limit = lpv.Hinf("w", "z1", bound=fraction * free_hinf)
    d = lpv.synthesize(S, "u", y="y", objective=lpv.H2("w", ["z1", "z2"]),
                       constraints=[limit], backoff=None)  # fmt: skip
    assert d.certificate.verified
    h2, hinf = channel_norms(G, d.controller().at([1.0]))
    assert hinf <= limit.bound
    assert h2 <= d.gamma
    assert d.gamma_opt >= free.gamma_opt * (1 - 1e-6)
    assert d.bounds[lpv.Hinf(w=("w",), z=("z1",), bound=limit.bound)] == limit.bound


def test_mixed_hinf_with_an_h2_bound_on_a_polytope():
    """The other way round on a two-vertex plant: the L2 gain minimised with
    the H2 norm of the first output within 1.5 times what an H2 design of
    that output alone certifies; frozen loops on a grid meet both bounds."""
    sys = random_plant(2, n=3, vertices=2, stable=True)
    alone = lpv.h2_output_feedback(sys, W, "u", "z0", "y")
    limit = lpv.H2(W, "z0", bound=1.5 * alone.gamma)
    d = lpv.hinf_output_feedback(sys, W, "u", Z, "y", constraints=[limit])
    assert d.certificate.verified
    for p in np.linspace(0.0, 1.0, 11):
        G, K = sys.at({"p": p}), d.controller().at({"p": p})
        first = ct.interconnect([G, K], inplist=W, outlist=["z0"], check_unused=False)
        assert float(ct.norm(first, 2)) <= limit.bound
        assert float(ct.linfnorm(loop_by_name(G, K))[0]) <= d.gamma
