"""Refusals are true, requirements are met, bad options are named.

Independent facts: closed-loop eigenvalues, ``control.linfnorm`` of frozen
closed loops, and plants whose stabilizability is known by construction.
"""

import re

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.synthesis.options import guard_size as _guard_size
from ctrl_lpv.synthesis.problem import Structure as _Structure


def test_refusal_classes_are_distinct():
    assert not issubclass(lpv.CertificationError, lpv.InfeasibleError)
    assert not issubclass(lpv.InfeasibleError, lpv.CertificationError)
    assert issubclass(lpv.InfeasibleError, lpv.SynthesisError)
    assert issubclass(lpv.CertificationError, lpv.SynthesisError)


@pytest.mark.parametrize(
    "A, B",
    [
        # The false refusals: badly scaled, stabilizable plants.
        ([[1.0, 0.0], [1e8, -1.0]], [[1e-4], [0.0]]),
        (np.diag([1e9, -1e-9]), [[1.0], [1e-9]]),
    ],
)
def test_badly_scaled_stabilizable_plants_are_designed(A, B):
    sys = lpv.pss([(A, B, np.eye(2), 0)])
    # At most reported as weakly controllable, never refused.
    assert not any(mode.uncontrollable for mode in lpv.check_stabilizability(sys))
    design = lpv.quadratic_stabilization(sys, u=0)
    eig = np.linalg.eigvals(np.asarray(A) - np.asarray(B) @ design.gains[0])
    assert eig.real.max() < 0


def test_stiff_two_mass_drive_is_designed():
    params = twomass.Parameters(ks=3.3e9)
    model = twomass.lpv_model(
        params, p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    design = lpv.hinf_state_feedback(model, w=["Td"], u=["Tm"])
    iu = model.input_labels.index("Tm")
    for v in model.vertices:
        assert np.linalg.eigvals(v.A - v.B[:, [iu]] @ design.gains[0]).real.max() < 0


@pytest.mark.parametrize("state_scale", [1e-4, 1.0, 1e4])
@pytest.mark.parametrize("input_scale", [1e-3, 1e3])
def test_pbh_refusal_is_scale_invariant(state_scale, input_scale):
    # x1' = x1 (unstable, no input), x2' = -x2 + u: not stabilizable in any
    # units; with a coupling from x1 to u-driven x2 it still is not.
    A = np.array([[1.0, 0.0], [2.0, -1.0]])
    B = np.array([[0.0], [1.0]])
    T = np.diag([1.0, state_scale])
    At = np.linalg.solve(T, A @ T)
    Bt = np.linalg.solve(T, B) * input_scale
    sys = lpv.pss([(At, Bt, np.eye(2), 0)])
    with pytest.raises(lpv.InfeasibleError, match=r"eigenvalue 1 .*PBH residual"):
        lpv.check_stabilizability(sys)
    # The same plant with the input on x1 as well is stabilizable.
    Bc = np.linalg.solve(T, np.array([[1e-6], [1.0]])) * input_scale
    assert lpv.check_stabilizability(lpv.pss([(At, Bc, np.eye(2), 0)])) == ()


def test_open_gap_is_refused_with_the_residual():
    model = twomass.lpv_model(p_bounds=(-1.0, 0.0), formulation="tracking")
    with pytest.raises(lpv.InfeasibleError, match="PBH residual") as info:
        lpv.hinf_state_feedback(model, w=["Td"], u=["Tm"])
    assert "p = {'p': -1.0}" in str(info.value)


@pytest.fixture(scope="module")
def plant():
    base = ct.ss(
        [[0, 1], [0, -0.5]], [[0, 0], [1, 1]], [[1, 0], [0, 0]],
        [[0, 0], [0, 0.1]], inputs=["w", "u"], outputs=["x", "uw"],
    )  # fmt: skip
    stiffness = ([[0, 0], [-1, 0]], 0, 0, 0)
    return lpv.PolytopicStateSpace.from_affine(base, {"k": stiffness}, {"k": (1, 4)})


CHANNELS = dict(w="w", u="u", z=["x", "uw"])


def frozen_norms(sys, design):
    norms = []
    for k in np.linspace(1, 4, 7):
        A, B, C, D = ct.ssdata(design.closed_loop({"k": k}))
        norms.append(ct.linfnorm(ct.ss(A, B, C, D))[0])
    return np.array(norms)


def test_required_gamma_is_met_strictly(plant):
    best = lpv.hinf_state_feedback(plant, **CHANNELS)
    required = best.gamma_opt * 1.001
    design = lpv.hinf_state_feedback(plant, gamma=required, **CHANNELS)
    assert design.gamma < required
    assert frozen_norms(plant, design).max() <= design.gamma


def test_impossible_gamma_is_proven_infeasible(plant):
    with pytest.raises(lpv.InfeasibleError) as info:
        lpv.hinf_state_feedback(plant, gamma=1e-12, **CHANNELS)
    assert info.value.farkas is not None and info.value.farkas.proves_infeasible


def test_gain_bound_miss_is_not_called_infeasible(plant):
    with pytest.raises(lpv.CertificationError, match="gain_bound") as info:
        lpv.hinf_state_feedback(plant, gain_bound=1e-3, **CHANNELS)
    # The back-off was widened before the refusal, and the refusal says so
    # after the detail of the back-off asked for.
    message = str(info.value)
    assert "no certified solution found" in message.splitlines()[0]
    assert message.splitlines()[-1].startswith("widened: with the back-off up to 1.07")
    # Where the ladder's time went: each solver of its attempts, by name.
    tried = next(line for line in message.splitlines() if line.startswith("tried:"))
    spent = tried.split("; time ", 1)[1]
    assert re.match(r"[0-9.e+-]+ s: ", spent), spent
    for solver in {a.solver for a in info.value.attempts}:
        assert re.search(rf"{re.escape(solver)} [0-9.e+-]+ s", spent), (solver, spent)


def test_huge_bounds_are_accepted(plant):
    design = lpv.hinf_state_feedback(plant, gain_bound=1e300, **CHANNELS)
    assert frozen_norms(plant, design).max() <= design.gamma


def test_zero_backoff_is_the_raw_optimum(plant):
    raw = lpv.hinf_state_feedback(plant, backoff=0, **CHANNELS)
    backed_off = lpv.hinf_state_feedback(plant, **CHANNELS)
    # The raw point is certified with the margin, gamma* estimated without:
    # they differ by the margin's effect only, far less than the back-off.
    assert raw.gamma_opt <= raw.gamma <= raw.gamma_opt * (1 + 1e-4)
    assert raw.gamma < backed_off.gamma


def test_time_limit_is_honoured(plant):
    with pytest.raises(lpv.CertificationError, match="time_limit"):
        lpv.hinf_state_feedback(plant, time_limit=1e-9, **CHANNELS)


@pytest.mark.parametrize(
    "options, error, name",
    [
        (dict(gamma="1"), TypeError, "gamma"),
        (dict(gamma=1e200), ValueError, "gamma"),
        (dict(gamma=-1.0), ValueError, "gamma"),
        (dict(backoff="0.2"), TypeError, "backoff"),
        (dict(backoff=-0.1), ValueError, "backoff"),
        (dict(margin=None), TypeError, "margin"),
        (dict(margin=2.0), ValueError, "margin"),
        (dict(gain_bound=np.inf), ValueError, "gain_bound"),
        (dict(time_limit=0), ValueError, "time_limit"),
        (dict(u=1.5), TypeError, "u"),
        (dict(solvers=[("NOPE", {})]), ValueError, "solvers"),
        (dict(solvers=[]), ValueError, "solvers"),
        (dict(solvers=42), TypeError, "solvers"),
        (dict(regions=[1.0]), TypeError, "regions"),
    ],
)
def test_bad_options_name_the_argument(plant, options, error, name):
    with pytest.raises(error, match=f"^{name}:"):
        lpv.hinf_state_feedback(plant, **{**CHANNELS, **options})


def test_single_region_and_solver_name_are_accepted(plant):
    design = lpv.hinf_state_feedback(
        plant, regions=lpv.halfplane(1.0), solvers="CLARABEL", **CHANNELS
    )
    for k in (1.0, 4.0):
        A = design.closed_loop({"k": k}).A
        assert np.linalg.eigvals(A).real.max() < -1.0


@pytest.mark.parametrize(
    "vertex, match",
    [
        (([[1j, 0], [0, 1]], [[1], [1]], np.eye(2), 0), "complex"),
        ((np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[0]]), "no states"),
    ],
)
def test_bad_matrices_are_refused(vertex, match):
    with pytest.raises((TypeError, ValueError), match=match):
        lpv.pss([vertex])


def test_large_problems_warn_with_an_estimate():
    # Theorem 1 on 200 vertices: 200 * 201 / 2 Lyapunov LMIs of size 2.
    structure = _Structure(
        n=2, m=1, N=200, nZ=200, scheduled=True, continuous=True, slack=False,
        objective=False, coefficients=(), lyapunov=(), specs=(),
        entries=20100 * 4 + 4, nlmis=20100, largest=2,
    )  # fmt: skip
    with pytest.warns(lpv.ProblemSizeWarning, match="20100 LMIs"):
        _guard_size(structure)
    with pytest.raises(lpv.CertificationError, match="^time_limit:.*20100 LMIs"):
        _guard_size(structure, time_limit=60.0)


def test_gain_bound_holds_for_the_raw_optimum(plant):
    raw = lpv.hinf_state_feedback(plant, backoff=None, **CHANNELS)
    bound = 0.5 * np.linalg.norm(raw.gains[0], 2)
    design = lpv.hinf_state_feedback(plant, backoff=None, gain_bound=bound, **CHANNELS)
    assert np.linalg.norm(design.gains[0], 2) <= bound
    assert frozen_norms(plant, design).max() <= design.gamma


def test_saturation_accepts_a_solver_name():
    sys = lpv.pss([([[1.0]], [[1.0]], [[1.0]], 0)], inputs=["u"])
    design = lpv.saturated_state_feedback(sys, "u", 1.0, solvers="CLARABEL")
    assert design.certificate.verified
