"""The output-feedback forms as specs of the one protocol (issue 20).

The objectives and constraints of `hinf_output_feedback` and
`h2_output_feedback` are `ctrl_lpv.synthesis.spec.Spec` subclasses; their
float64 residual at a frozen closed loop (`Spec.residual`) is checked here
against independent facts: the closed loop built by python-control's
`interconnect` from the returned controller system (not the library's
closed-loop formula), the bounded-real inequality written out with numpy,
the frozen norms from `control.linfnorm` / `control.norm` (a residual below
zero proves the level above the norm, so a level below the norm must give
a positive residual), and the eigenvalues from numpy for a pole region.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv.output_feedback.mixed import output_feedback_constraints
from ctrl_lpv.output_feedback.objectives import H2Objective, HinfObjective
from ctrl_lpv.output_feedback.plant import OutputFeedbackPlant
from ctrl_lpv.output_feedback.views import FrozenLoop
from ctrl_lpv.regions import disk, halfplane
from ctrl_lpv.synthesis.spec import Spec
from test_output_feedback import W, Z, loop_by_name, random_plant


def frozen_points(sys):
    """``(delta, plant, p)``: the vertices and interior points."""
    if sys.nvertices == 1:
        return [(np.ones(1), sys.vertices[0], [1.0])]
    out = []
    for p in (0.0, 0.3, 0.5, 0.85, 1.0):
        out.append((sys.weights({"p": p}), sys.at({"p": p}), {"p": p}))
    return out


def specs_of(sys, kind, constraints):
    continuous = not sys.isdtime(strict=True)
    parts, channels = output_feedback_constraints(
        constraints, sys, "u", "y", continuous
    )
    plant = OutputFeedbackPlant.of(sys, W, "u", Z, "y")
    plant = type(plant)(**{**plant.__dict__, "channels": channels})
    return plant, kind(parts), continuous


CASES = {
    "Hinf continuous polytope": (HinfObjective, dict(seed=5, vertices=2, stable=True)),
    "Hinf discrete": (HinfObjective, dict(seed=1, dt=0.1)),
    "H2 continuous polytope": (H2Objective, dict(seed=7, vertices=2, stable=True)),
    "H2 discrete": (H2Objective, dict(seed=2, dt=0.1)),
}


def designed(kind, plant_kw, constraints=(), **kw):
    sys = random_plant(plant_kw.pop("seed"), **plant_kw)
    call = lpv.hinf_output_feedback if kind is HinfObjective else lpv.h2_output_feedback
    return sys, call(sys, W, "u", Z, "y", constraints=constraints, **kw)


def test_every_output_feedback_form_is_a_spec():
    sys = random_plant(3, vertices=2, stable=True)
    limit = lpv.H2(W, "z0", bound=10.0)
    plant, objective, _ = specs_of(sys, HinfObjective, [halfplane(0.1), limit])
    assert all(isinstance(part, Spec) for part in objective.parts())
    assert [type(p).__name__ for p in objective.parts()] == [
        "HinfObjective", "RegionConstraint", "BoundConstraint"]  # fmt: skip
    assert isinstance(H2Objective(), Spec)


@pytest.mark.parametrize("case", list(CASES))
def test_residual_against_the_python_control_loop(case):
    """At every frozen point (vertices and between them) the spec's
    residual at the design's P and level is negative, equals (H-infinity)
    the normalised eigenvalue of the bounded-real inequality of the loop
    python-control builds, and turns positive at a level below the frozen
    norm."""
    kind, plant_kw = CASES[case]
    sys, d = designed(kind, dict(plant_kw))
    plant, objective, continuous = specs_of(sys, kind, ())
    controller = d.controller()
    for delta, G, p in frozen_points(sys):
        cl = loop_by_name(G, controller.at(p))
        loop = FrozenLoop.of(plant, delta, d.controllers, d.P, d.values)
        residual = objective.residual(loop, continuous)
        assert residual < 0
        A, B, C, D = ct.ssdata(cl)  # states: plant first, then controller
        if kind is HinfObjective:
            g, P = d.values["level"], d.P
            assert g == pytest.approx(d.gamma)
            if continuous:
                F = np.block([[A.T @ P + P @ A, P @ B, C.T],
                              [B.T @ P, -g * np.eye(2), D.T],
                              [C, D, -g * np.eye(2)]])  # fmt: skip
            else:
                F = np.block([[A.T @ P @ A - P, A.T @ P @ B, C.T],
                              [B.T @ P @ A, B.T @ P @ B - g * np.eye(2), D.T],
                              [C, D, -g * np.eye(2)]])  # fmt: skip
                # A different (Schur-equivalent) form: the sign agrees.
                assert np.linalg.eigvalsh(F).max() < 0
                F = None
            if F is not None:
                s = 1.0 / np.sqrt(-np.diag(F))
                independent = np.linalg.eigvalsh(F * s[:, None] * s[None, :]).max()
                assert residual == pytest.approx(independent, rel=1e-6, abs=1e-12)
            norm = float(ct.linfnorm(cl)[0])
            assert norm < g
            below = dict(d.values, level=0.999 * norm)
        else:
            norm = float(ct.norm(cl, 2))
            assert norm**2 < d.values["level"]
            below = dict(d.values, level=0.99 * norm**2)
        low = FrozenLoop.of(plant, delta, d.controllers, d.P, below)
        assert objective.residual(low, continuous) > 0


def test_region_and_bound_residuals_against_independent_facts():
    """A pole region and a bound on another channel, posed with the
    objective: their residuals are negative on every frozen loop, the loop's
    eigenvalues (numpy) lie in the region and the channel's H2 norm
    (python-control) is below its bound; a region the loop leaves, or a
    bound below the channel's norm, gives a positive residual."""
    sys = random_plant(2, n=3, vertices=2, stable=True)
    alone = lpv.h2_output_feedback(sys, W, "u", "z0", "y")
    limit = lpv.H2(W, "z0", bound=1.5 * alone.gamma)
    region = disk(40.0)
    d = lpv.hinf_output_feedback(sys, W, "u", Z, "y", constraints=[region, limit])
    plant, objective, continuous = specs_of(sys, HinfObjective, [region, limit])
    _, in_region, bounded = objective.parts()
    controller = d.controller()
    for delta, G, p in frozen_points(sys):
        K = controller.at(p)
        loop = FrozenLoop.of(plant, delta, d.controllers, d.P, d.values)
        assert in_region.residual(loop, continuous) < 0
        assert bounded.residual(loop, continuous) < 0
        poles = np.linalg.eigvals(ct.ssdata(loop_by_name(G, K))[0])
        assert np.abs(poles).max() < 40.0
        first = ct.interconnect([G, K], inplist=W, outlist=["z0"], check_unused=False)
        h2 = float(ct.norm(first, 2))
        assert h2 <= limit.bound
        # A disk just inside the fastest pole, and the bound below the norm.
        tight = specs_of(sys, HinfObjective,
                         [disk(0.99 * np.abs(poles).max()), lpv.H2(
                             W, "z0", bound=0.99 * h2)])[1].parts()  # fmt: skip
        assert tight[1].residual(loop, continuous) > 0
        assert tight[2].residual(loop, continuous) > 0


def test_refusal_has_the_engine_format():
    """An output-feedback refusal reads as the state-feedback engine's
    (`ctrl_lpv.synthesis.refusals`): a first line with the best point
    reached, what failed, what was tried. The best point is the optimum's
    estimate: within 1e-3 of the closed-loop norm python-control's
    `hinfsyn` (SLICOT, Riccati) reaches on the same plant."""
    from test_output_feedback_published import U as DK_U
    from test_output_feedback_published import W as DK_W
    from test_output_feedback_published import Y as DK_Y
    from test_output_feedback_published import Z as DK_Z
    from test_output_feedback_published import dk_plant

    P = dk_plant()
    with pytest.raises(lpv.CertificationError) as info:
        lpv.hinf_output_feedback(lpv.pss([P]), DK_W, DK_U, DK_Z, DK_Y, backoff=None)
    first, failed, tried = str(info.value).split("\n")
    head = "H-infinity output feedback: no certified solution found, best point "
    assert first.startswith(head + "reached: the optimum's estimate, Hinf ")
    estimate = float(first.split("Hinf ")[1].split(" ")[0])
    _, CL, _, _ = ct.hinfsyn(ct.ss(*ct.ssdata(P)), 2, 2)
    assert estimate == pytest.approx(float(ct.linfnorm(CL)[0]), rel=1e-3)
    assert failed.startswith("what failed: ") and "I - X Y" in failed
    assert "mode at -1e-06" in failed
    assert tried.startswith("tried: 2 prescalings (the Riccati-balanced")
    assert info.value.attempts


def test_certificate_carries_each_specs_frozen_residual():
    """The certificate has one frozen-residual row per spec (as the
    state-feedback engine's frozen checks), negative on a design; with the
    level below the largest frozen norm (python-control, on a grid that
    holds the verification points' range) the objective's row fails."""
    from ctrl_lpv.output_feedback.checks import closed_loop_certificate

    sys = random_plant(5, vertices=2, stable=True)
    d = lpv.hinf_output_feedback(sys, W, "u", Z, "y", constraints=[halfplane(0.05)])
    plant, objective, _ = specs_of(sys, HinfObjective, [halfplane(0.05)])
    rows = {c.what: c for c in d.certificate.checks if "frozen closed loop" in c.what}
    assert set(rows) == {f"{part} (frozen closed loop)" for part in objective.parts()}
    assert all(c.passed and c.value < 0 for c in rows.values())
    controller = d.controller()
    worst = max(
        float(ct.linfnorm(loop_by_name(sys.at({"p": p}), controller.at({"p": p})))[0])
        for p in np.linspace(0.0, 1.0, 41)
    )
    low = closed_loop_certificate(plant, objective, d.controllers, d.P,
                                  dict(d.values, level=0.999 * worst))  # fmt: skip
    assert not low.verified
    failed = [c.what for c in low.checks if not c.passed]
    assert f"{objective} (frozen closed loop)" in failed


def test_progress_is_logged_per_rung_as_the_engine_does(caplog):
    """INFO lines per rung (prescaling), stage and certified point, in the
    state-feedback engine's words; the certified point's bound is the
    design's."""
    import logging

    sys = random_plant(5, vertices=2, stable=True)
    with caplog.at_level(logging.INFO, logger="ctrl_lpv"):
        d = lpv.hinf_output_feedback(sys, W, "u", Z, "y")
    lines = [r.getMessage() for r in caplog.records]
    assert any("rung CLARABEL, the Riccati-balanced prescaling" in m for m in lines)
    assert any("stage 'optimal': certified" in m for m in lines)
    reached = [m for m in lines if "reached a certified point" in m]
    assert len(reached) == 1
    assert float(reached[0].rsplit(" ", 1)[1]) == pytest.approx(d.gamma, rel=1e-5)


def test_renormalised_rung_certifies_on_the_plant(monkeypatch, caplog):
    """Renormalisation on failure only, as the engine's: with z scaled by
    1e-3 (the optimum scales by 1e-3 exactly) and the plant's own rung made
    to fail, the design comes from the rung with z renormalised by a power
    of two, certified on the plant itself: its optimum is 1e-3 that of the
    unscaled plant, its bound within the back-off and above the frozen
    norms python-control computes."""
    import logging

    import ctrl_lpv.output_feedback.design as design_module

    base = random_plant(5, vertices=2, stable=True)
    s = np.diag([1e-3, 1e-3, 1.0])
    sys = lpv.PolytopicStateSpace(
        [ct.ss(G.A, G.B, s @ G.C, s @ G.D, inputs=G.input_labels,
               outputs=G.output_labels) for G in base.vertices],
        domain=base.domain,
    )  # fmt: skip
    reference = lpv.hinf_output_feedback(base, W, "u", Z, "y")
    C1 = OutputFeedbackPlant.of(sys, W, "u", Z, "y").C1
    rebuild = design_module.rebuild

    def failing(plant, *args, **kw):
        if np.array_equal(plant.C1, C1):  # the plant's own units: refused
            raise lpv.CertificationError("forced", ())
        return rebuild(plant, *args, **kw)

    monkeypatch.setattr(design_module, "rebuild", failing)
    with caplog.at_level(logging.INFO, logger="ctrl_lpv"):
        d = lpv.hinf_output_feedback(sys, W, "u", Z, "y")
    (line,) = [
        m.getMessage() for m in caplog.records if "renormalised" in m.getMessage()
    ]
    scale = float(line.rsplit(" ", 1)[1])
    assert np.log2(scale) == np.round(np.log2(scale))  # exact: a power of two
    assert 0.7 < scale * d.gamma_opt < 1.42
    assert d.certificate.verified
    assert d.gamma_opt == pytest.approx(1e-3 * reference.gamma_opt, rel=1e-3)
    assert d.gamma <= 1.2 * d.gamma_opt * (1 + 1e-3)
    controller = d.controller()
    for p in np.linspace(0.0, 1.0, 5):
        cl = loop_by_name(sys.at({"p": p}), controller.at({"p": p}))
        assert float(ct.linfnorm(cl)[0]) <= d.gamma
