"""The compiled two-mass engine against independent references.

* alpha = 0: the drive is the linear two-mass system, whose closed loop
  under a state-feedback gain is a `control.StateSpace` built here from
  the equations; `control.forced_response` (matrix exponential) is the
  reference;
* with backlash, saturation, a stepped alpha and the backstepping law: a
  tight scipy DOP853 solution (rtol 1e-10) of the python-control loop
  (`engine="fast"`), against which the compiled engine at rtol 1e-6 is
  held to the accuracy of today's LSODA path.

Few runs: the first one in a fresh checkout compiles (numba caches it).
"""

import sys

import control as ct
import numpy as np
import pytest

pytest.importorskip("numba")

from ctrl_lpv import twomass  # noqa: E402

P = twomass.Parameters()


def linear_loop(K, p=P):
    """Closed loop of the linear drive under Tm = -K [e_m, w_m, e_l, w_l].

    States theta_m, omega_m, theta_l, omega_l; inputs theta_r, Td;
    outputs theta_l, Tm.
    """
    k0, k1, k2, k3 = K
    # Ts = ks (theta_m - theta_l) + cs (omega_m - omega_l)
    ts = np.array([p.ks, p.cs, -p.ks, -p.cs])
    tm = -np.array([k0, k1, k2, k3])  # Tm = tm @ x + (k0 + k2) theta_r
    A = np.zeros((4, 4))
    A[0, 1] = A[2, 3] = 1.0
    A[1] = (tm - ts - np.array([0, p.cm, 0, 0])) / p.Jm
    A[3] = (ts - np.array([0, 0, 0, p.cl])) / p.Jl
    B = np.zeros((4, 2))
    B[1, 0] = (k0 + k2) / p.Jm
    B[3, 1] = -1.0 / p.Jl
    C = np.array([[0.0, 0.0, 1.0, 0.0], tm])
    D = np.array([[0.0, 0.0], [k0 + k2, 0.0]])
    return ct.ss(A, B, C, D)


def test_linear_drive_matches_the_matrix_exponential():
    K = twomass.paper_gain()[0]
    t = np.linspace(0.0, 2.0, 2001)
    U = np.vstack([np.full_like(t, 0.5), np.full_like(t, 8.0)])
    ref = ct.forced_response(linear_loop(K), t, U).outputs
    assert np.all(np.linalg.eigvals(linear_loop(K).A).real < 0)
    controller = twomass.lpv_controller()
    for rtol, tol in ((1e-10, 1e-9), (1e-6, 1e-6)):
        r = twomass.simulate(
            controller, alpha=0.0, T=2.0, npoints=2001, engine="compiled",
            rtol=rtol, atol=rtol * 1e-3,
        )  # fmt: skip
        labels = r.output_labels
        theta_l = r.outputs[labels.index("theta_l")]
        Tm = r.outputs[labels.index("Tm")]
        # theta_l in rad; Tm (up to 2e4 Nm) relative to its peak.
        assert np.abs(theta_l - ref[0]).max() < tol, rtol
        assert np.abs(Tm - ref[1]).max() < tol * np.abs(ref[1]).max(), rtol
        assert np.abs(r.states[4]).max() == 0.0  # theta_b stays at 0


@pytest.fixture(scope="module")
def designs():
    return twomass.comparison_designs()


def cases(designs):
    jl = P.replace(Jl=1.2 * P.Jl)
    return {
        "paper K": (twomass.lpv_controller(), dict(alpha=0.03)),
        "scheduled, integral, alpha step": (
            twomass.lpv_controller(
                designs["LPV scheduled"], alpha_estimate=0.03, torque_limit=1000.0
            ),
            dict(alpha=twomass.alpha_step(0.03, 0.045, 2.5)),
        ),  # fmt: skip
        "robust, integral, saturated": (
            twomass.lpv_controller(designs["LPV robust"], torque_limit=500.0),
            dict(alpha=0.015, params=jl),
        ),
        "backstepping": (
            twomass.backstepping_controller(Td_hat=8.0, torque_limit=2000.0),
            dict(alpha=0.045, Td=0.0),
        ),
        "dead zone": (twomass.lpv_controller(), dict(model="deadzone")),
    }


def test_metrics_as_accurate_as_the_lsoda_path(designs):
    """Against DOP853 at rtol 1e-10, the compiled engine at rtol 1e-6 errs
    no more than 3 times scipy's LSODA at rtol 1e-6 (up to 1e-7 rad of
    noise).

    The metrics follow theta_l and Tm: each metric's error is held to 3
    times LSODA's plus what a 1e-6 rad error of theta_l (the accuracy
    target of the simulations) moves it: 1e-7 s of rise time at 10 rad/s,
    2e-4 % of overshoot on the 0.5 rad step, 5e-6 rad s of IAE over 5 s,
    0.02 Nm of peak torque through gains of 2e4 Nm/rad, 2e-6 of the energy
    (relative), and a settling time where the error crosses the band at
    0.1 rad/s or faster.
    """
    floors = dict(rise_time=1e-6, settling_time=1e-5, overshoot=2e-4,
                  steady_state_error=1e-6, iae=5e-6, ise=1e-6, peak_input=0.02,
                  energy=2e-6)  # fmt: skip  # energy: relative
    for name, (controller, kw) in cases(designs).items():
        ref = twomass.simulate(controller, engine="fast", method="DOP853",
                               rtol=1e-10, atol=1e-12, **kw)  # fmt: skip
        lsoda = twomass.simulate(controller, engine="fast", **kw)
        ours = twomass.simulate(controller, engine="compiled", **kw)
        assert ours.output_labels == ref.output_labels
        assert ours.state_labels == ref.state_labels
        e_ours = float(np.abs(ours.outputs[0] - ref.outputs[0]).max())
        e_lsoda = float(np.abs(lsoda.outputs[0] - ref.outputs[0]).max())
        if name == "dead zone":
            # The damping torque jumps at each contact: an explicit RK step
            # across the jump errs to first order in the tolerance (LSODA's
            # error is 3 times smaller); still well under 1e-6 rad.
            assert e_ours <= 1e-6, (name, e_ours, e_lsoda)
        else:
            # Within 3 times LSODA's, as the metrics: which of the two errs
            # less at a saturation's corner follows the machine's rounding
            # (1.3e-7 against 2.4e-7 on an AVX2 machine, the other way on
            # AVX-512).
            assert e_ours <= max(3.0 * e_lsoda, 1e-7), (name, e_ours, e_lsoda)
        m_ref, m_lsoda, m_ours = (twomass.metrics(r).as_dict()
                                  for r in (ref, lsoda, ours))  # fmt: skip
        for key, floor in floors.items():
            if np.isinf(m_ref[key]):
                assert np.isinf(m_ours[key]), (name, key)
                continue
            scale = abs(m_ref[key]) if key == "energy" else 1.0
            err = abs(m_ours[key] - m_ref[key])
            assert err <= 3 * abs(m_lsoda[key] - m_ref[key]) + floor * scale, (
                name, key, err, m_lsoda[key] - m_ref[key],
            )  # fmt: skip


def test_engine_choice_and_refusals(monkeypatch):
    scheduled = twomass.lpv_controller(
        np.vstack([twomass.paper_gain()] * 2), p_bounds=(-1.0, 0.0),
        alpha_estimate=lambda t: 0.03,
    )  # fmt: skip
    short = dict(T=0.05, npoints=51)
    # No compiled form (a callable estimate, a general alpha(t)): "auto" is
    # the fast path, "compiled" says why not.
    for controller, kw, what in (
        (scheduled, {}, "controller"),
        (twomass.lpv_controller(), dict(alpha=lambda t: 0.03), "alpha"),
    ):
        auto = twomass.simulate(controller, engine="auto", **kw, **short)
        fast = twomass.simulate(controller, engine="fast", **kw, **short)
        np.testing.assert_array_equal(auto.outputs, fast.outputs)
        with pytest.raises(ValueError, match=what):
            twomass.simulate(controller, engine="compiled", **kw, **short)
    paper = twomass.lpv_controller()
    with pytest.raises(ValueError, match="method"):
        twomass.simulate(paper, engine="compiled", method="LSODA", **short)
    # Without numba: a clear ImportError for "compiled", the fast path for
    # "auto".
    monkeypatch.setitem(sys.modules, "numba", None)
    with pytest.raises(ImportError, match=r"ctrl_lpv\[fast\]"):
        twomass.simulate(paper, engine="compiled", **short)
    auto = twomass.simulate(paper, engine="auto", **short)
    fast = twomass.simulate(paper, engine="fast", **short)
    np.testing.assert_array_equal(auto.outputs, fast.outputs)


def test_divergence_is_reported_like_the_fast_engine():
    from ctrl_lpv import DivergenceError

    unstable = twomass.lpv_controller(-twomass.paper_gain())  # positive feedback
    for engine in ("fast", "compiled"):
        with pytest.raises(DivergenceError, match="plant_") as info:
            twomass.simulate(unstable, engine=engine, T=2.0, npoints=201)
        assert 0.0 < info.value.time < 2.0, engine
