"""`synthesize` on a `GriddedStateSpace`: gains at the grid points, one P.

(Rate-bounded synthesis: tests/test_gridded_rate_synthesis.py.)

Checked against independent facts: the frozen closed loops (``G.at(p)``
under the gains interpolated by scipy, as python-control interpolates them)
are stable and their `control.linfnorm` stays below the certified bound on
a grid ten times denser; the synthesis, optimal over the relaxation that
`certify` analyses, does at least as well as an LQR schedule certified on
the same plant; the design's table drives `control.create_statefbk_iosystem`.
"""

import control as ct
import numpy as np
import pytest
from scipy.interpolate import LinearNDInterpolator

import ctrl_lpv as lpv

GRAVITY, DAMPING = 9.81, 0.5


def pendulum_dynamics(t, x, u, params):
    m = params.get("m", 1.0)
    # w disturbs the angle's rate; the control acts through the torque.
    torque = -m * GRAVITY * np.sin(x[0]) - DAMPING * x[1] + u[0]
    return [x[1] + u[1], torque / m]


PENDULUM = ct.nlsys(pendulum_dynamics, None, inputs=["u", "w"],
                    states=["theta", "omega"], outputs=["theta", "omega"],
                    params={"m": 1.0})  # fmt: skip


def with_effort(theta0, m):
    """The pendulum linearized at the trim angle theta0, with the control
    effort as a third output."""
    lin = ct.linearize(PENDULUM, [theta0, 0.0], [m * GRAVITY * np.sin(theta0), 0.0],
                       params={"m": m}, copy_names=True)  # fmt: skip
    C = np.vstack([lin.C, [0.0, 0.0]])
    D = np.vstack([lin.D, [1.0, 0.0]])
    outputs = ["theta", "omega", "effort"]
    return ct.ss(lin.A, lin.B, C, D, inputs=lin.input_labels,
                 states=lin.state_labels, outputs=outputs)  # fmt: skip


AXES = {"theta0": np.linspace(0.0, 1.2, 3), "m": np.linspace(0.8, 1.25, 3)}
DENSE = [np.linspace(0.0, 1.2, 21), np.linspace(0.8, 1.25, 21)]
HINF = lpv.Hinf(w="w", z=["theta", "effort"])


@pytest.fixture(scope="module")
def G():
    return lpv.gss(with_effort, AXES)


def frozen_loops(G, gains):
    points = G.grid.points
    interp = LinearNDInterpolator(points, np.array(gains).reshape(len(points), -1))
    for a in DENSE[0]:
        for m in DENSE[1]:
            S = G.at([a, m])
            K = interp([a, m]).reshape(1, 2)
            yield ct.ss(S.A - S.B[:, [0]] @ K, S.B[:, [1]],
                        S.C[[0, 2]] - S.D[[0, 2]][:, [0]] @ K, 0)  # fmt: skip


def test_hinf_design_bounds_the_frozen_norms_and_beats_an_lqr_schedule(G):
    design = lpv.synthesize(G, "u", objective=HINF)
    assert design.certificate.certified and design.certificate.certificate.verified
    worst = max(float(ct.linfnorm(loop)[0]) for loop in frozen_loops(G, design.gains))
    assert design.gamma >= worst
    points = G.grid.points
    lqr = [ct.lqr(G.at(p)[:, "u"], np.diag([10.0, 1.0]), 1.0)[0] for p in points]
    analysed = lpv.certify((lqr, points), G, objective=HINF)
    assert analysed.certified
    # The LQR gains with the analysis's P are a point of the synthesis's
    # relaxation: the optimum is no worse.
    assert design.gamma <= analysed.bound * (1 + 1e-3)


def test_stabilizing_design_stabilizes_every_frozen_loop(G):
    design = lpv.synthesize(G, "u")
    assert design.certificate.certified and design.gamma is None
    assert design.certificate.rate_bound == {"theta0": np.inf, "m": np.inf}
    for loop in frozen_loops(G, design.gains):
        assert np.linalg.eigvals(loop.A).real.max() < 0


@pytest.mark.filterwarnings("ignore:cannot verify system output:UserWarning")
def test_design_table_drives_a_python_control_controller():
    def upright(theta0):
        return with_effort(theta0, 1.0)

    G = lpv.gss(upright, {"theta0": np.linspace(0.0, 1.2, 4)})
    design = lpv.synthesize(G, "u", objective=HINF)
    sys = upright(0.6)[["theta", "omega"], "u"]
    ctrl, _ = ct.create_statefbk_iosystem(sys, design.table,
                                          gainsched_indices=["xd[0]"])  # fmt: skip
    verdict = lpv.certify(ctrl, G, objective=HINF)
    assert verdict.certified
    assert verdict.bound == pytest.approx(design.gamma, rel=1e-3)
    midpoint = 0.5 * (design.gains[0] + design.gains[1])  # 0.2: between 0, 0.4
    np.testing.assert_allclose(design.gain(0.2), midpoint, rtol=1e-12)


def test_options_not_implemented_on_grids_are_refused(G):
    with pytest.raises(ValueError, match="lyapunov"):
        lpv.synthesize(G, "u", lyapunov="quadratic")
    with pytest.raises(ValueError, match="rate_bounds: lyapunov='affine' needs"):
        lpv.synthesize(G, "u", lyapunov="affine")
    with pytest.raises(ValueError, match="rate_bounds: only used"):
        lpv.synthesize(G, "u", rate_bounds={"m": 1.0})
    with pytest.raises(ValueError, match="y: output feedback"):
        lpv.synthesize(G, "u", y="theta", objective=HINF)
    with pytest.raises(TypeError, match="objective"):
        lpv.synthesize(G, "u", objective=lpv.H2(w="w", z="theta"))
    with pytest.raises(ValueError, match="constraints"):
        lpv.synthesize(G, "u", constraints=[lpv.Hinf(w="w", z="theta", bound=2.0)])
