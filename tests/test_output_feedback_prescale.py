"""The prescaling of output-feedback problems against independent facts.

The scaled plant is the plant seen through ``x = T x~``, ``u = su u~``,
``y = sy y~``: checked on frequency responses evaluated by python-control.
A controller mapped back gives exactly (powers of two) the similar closed
loop. The balancing equalises the diagonals of the Riccati estimates of
``X`` and ``Y``, recomputed here with scipy. The prescaled design against
the unscaled one on the random corpus.
"""

import control as ct
import numpy as np
import pytest
from scipy.linalg import solve_continuous_are

import ctrl_lpv as lpv
import ctrl_lpv.output_feedback.design as design_module
from _hinf_of_reference import optimal_gamma
from ctrl_lpv import CertificationError, twomass
from ctrl_lpv.output_feedback.plant import OutputFeedbackPlant
from ctrl_lpv.output_feedback.prescale import Prescaling
from ctrl_lpv.output_feedback.reconstruct import closed_loop
from test_output_feedback import W, Z, random_plant
from test_output_feedback_published import U as DK_U
from test_output_feedback_published import W as DK_W
from test_output_feedback_published import Y as DK_Y
from test_output_feedback_published import Z as DK_Z
from test_output_feedback_published import dk_plant


def plants():
    yield OutputFeedbackPlant.of(random_plant(4), W, "u", Z, "y")
    yield OutputFeedbackPlant.of(lpv.pss([dk_plant()]), DK_W, DK_U, DK_Z, DK_Y)


def as_ss(plant):
    """The generalized plant (w, u) -> (z, y) of vertex 0 as a control.StateSpace."""
    A, B1, C1, D11 = plant.A[0], plant.B1[0], plant.C1[0], plant.D11[0]
    B = np.hstack([B1, plant.B2])
    C = np.vstack([C1, plant.C2])
    D22 = np.zeros((plant.C2.shape[0], plant.B2.shape[1]))
    D = np.block([[D11, plant.D12], [plant.D21, D22]])
    return ct.ss(A, B, C, D)


@pytest.mark.parametrize("index", [0, 1])
def test_scaled_plant_is_the_plant_in_new_signals(index):
    plant = list(plants())[index]
    pre = Prescaling.riccati(plant)
    assert pre is not None
    for factor in (*pre.t, *pre.su, *pre.sy):
        assert factor == 2.0 ** np.round(np.log2(factor))
    G, Gs = as_ss(plant), as_ss(pre.apply(plant))
    nw, nz = plant.B1.shape[2], plant.C1.shape[1]
    left = np.diag(np.concatenate([np.ones(nz), 1.0 / pre.sy]))
    right = np.diag(np.concatenate([np.ones(nw), pre.su]))
    for s in (0.01j, 0.3 + 1j, 20j):
        np.testing.assert_allclose(Gs(s), left @ G(s) @ right, rtol=1e-10,
                                   atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("index", [0, 1])
def test_controller_maps_back_to_the_similar_closed_loop(index):
    """Any controller of the scaled plant, mapped back: the closed loop is
    the scaled one under ``diag(t, I)``, entry by entry exactly, and ``P``
    maps with it (``xi' P xi`` unchanged)."""
    plant = list(plants())[index]
    pre = Prescaling.riccati(plant)
    scaled = pre.apply(plant)
    rng = np.random.default_rng(index)
    n, m, p = plant.n, plant.B2.shape[1], plant.C2.shape[0]
    Ks = (rng.standard_normal((n, n)), rng.standard_normal((n, p)),
          rng.standard_normal((m, n)), rng.standard_normal((m, p)))  # fmt: skip
    e = np.ones(1)
    Acl, Bcl, Ccl, Dcl = closed_loop(plant, plant.data(e), pre.controller(Ks))
    As, Bs, Cs, Ds = closed_loop(scaled, scaled.data(e), Ks)
    S = np.concatenate([pre.t, np.ones(n)])
    np.testing.assert_allclose(Acl, S[:, None] * As / S[None, :], rtol=1e-13,
                               atol=1e-13 * np.abs(Acl).max())  # fmt: skip
    np.testing.assert_allclose(Bcl, S[:, None] * Bs, rtol=1e-13,
                               atol=1e-13 * np.abs(Bcl).max())  # fmt: skip
    np.testing.assert_allclose(Ccl, Cs / S[None, :], rtol=1e-13,
                               atol=1e-13 * np.abs(Ccl).max())  # fmt: skip
    np.testing.assert_allclose(Dcl, Ds, rtol=1e-13, atol=1e-13)
    M = rng.standard_normal((2 * n, 2 * n))
    Ps = M @ M.T
    xi_s = rng.standard_normal(2 * n)
    xi = S * xi_s
    assert np.isclose(xi @ pre.lyapunov(Ps) @ xi, xi_s @ Ps @ xi_s, rtol=1e-12)


def test_balancing_is_the_fourth_root_of_the_riccati_estimates():
    """``t_i`` is ``(X_ii / Y_ii)^(1/4)`` within the powers-of-two rounding
    (a factor sqrt(2)), ``X = Xc^-1`` and ``Y = Yf^-1`` from the H2 control
    and filter Riccati equations recomputed with scipy (weights regularised
    by 1e-6 of their norms); on the published plant these estimates differ
    by over 1e4 between states (the weight's slow pole)."""
    plant = OutputFeedbackPlant.of(lpv.pss([dk_plant()]), DK_W, DK_U, DK_Z, DK_Y)
    A, B1, C1 = plant.A[0], plant.B1[0], plant.C1[0]

    def care(A, B, C, D):
        Q, R = C.T @ C, D.T @ D
        Q = Q + 1e-6 * max(1.0, np.linalg.norm(Q, 2)) * np.eye(Q.shape[0])
        R = R + 1e-6 * max(1.0, np.linalg.norm(R, 2)) * np.eye(R.shape[0])
        return solve_continuous_are(A, B, Q, R, s=C.T @ D)

    x = np.diag(np.linalg.inv(care(A, plant.B2, C1, plant.D12)))
    y = np.diag(np.linalg.inv(care(A.T, plant.C2.T, B1.T, plant.D21.T)))
    assert (x / y).max() / (x / y).min() > 1e4
    ratio = Prescaling.riccati(plant).t / (x / y) ** 0.25
    assert np.all(ratio <= np.sqrt(2) * (1 + 1e-9))
    assert np.all(ratio >= 1 / np.sqrt(2) * (1 - 1e-9))


@pytest.mark.parametrize(
    "seeds", [range(0, 12, 3), pytest.param(range(20), marks=pytest.mark.slow)]
)
def test_prescaled_against_unscaled_on_the_random_corpus(seeds, monkeypatch):
    """Each prescaling alone against the DGKF optimum: what either certifies
    is within 1e-3 of the optimum, and the design (both in turn) certifies
    every plant that one of them does (measured on 20 plants before the
    performance blocks' margin was made relative to gamma: the same 17
    certify, worst gaps 6.8e-4 and 6.5e-4, docs/output_feedback.rst; since,
    the unscaled solve also certifies seed 3, optimum 59.07, within 4.7e-4,
    which the prescaled one alone refuses)."""
    results = {}
    for kind in ("Riccati", "none"):
        monkeypatch.setattr(design_module, "prescalings", lambda plant, k=kind: [k])
        for seed in seeds:
            G = random_plant(seed).vertices[0]
            A, B, C, _ = ct.ssdata(G)
            gamma_ref = optimal_gamma(A, B[:, :2], B[:, 2:], C[:2], C[2:])
            try:
                d = lpv.hinf_output_feedback(random_plant(seed), W, "u", Z, "y",
                                             backoff=None)  # fmt: skip
            except CertificationError:
                continue
            assert gamma_ref * (1 - 1e-6) <= d.gamma <= gamma_ref * (1 + 1e-3)
            results[kind, seed] = d.gamma
    monkeypatch.undo()
    for seed in seeds:
        if ("none", seed) in results and ("Riccati", seed) not in results:
            d = lpv.hinf_output_feedback(random_plant(seed), W, "u", Z, "y",
                                         backoff=None)  # fmt: skip
            assert d.gamma <= results["none", seed] * (1 + 1e-9), seed


def test_prescaled_twomass_design_is_no_worse_than_unscaled(monkeypatch):
    """The two-mass drive on both encoders, each prescaling alone: the
    prescaled design's certified bound is at most the unscaled one's
    (measured: 0.0365 against 0.923), and its frozen closed loops, built by
    name by python-control, are stable with norms below it."""
    gammas = {}
    for kind in ("Riccati", "none"):
        monkeypatch.setattr(design_module, "prescalings", lambda plant, k=kind: [k])
        gammas[kind] = d = twomass.output_feedback_design(sensors="both")
        assert d.certificate.verified
    d = gammas["Riccati"]
    assert d.gamma <= gammas["none"].gamma
    plant = d.plant
    for p in np.linspace(-0.95, 0.0, 5):
        loop = ct.interconnect(
            [plant.system.at({"p": p}), d.controller().at({"p": p})],
            inplist=plant.names("w"), outlist=plant.names("z"),
        )  # fmt: skip
        assert np.linalg.eigvals(loop.A).real.max() < 0
        assert float(ct.linfnorm(loop)[0]) <= d.gamma
