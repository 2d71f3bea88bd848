"""The sampled servo on encoders, held to independent facts.

The exact backlash plant is integrated between samples (`sampled_response`),
read through 20- and 17-bit encoders with half a count of noise, and driven
by the controller's output one sample late; the metrics are computed here
from the plant's own signals. The rest certificate's peak-to-peak gain is
checked against the worst input sequence built from the impulse response
(which attains it) and against the exact reachable set of a scalar loop.
"""

import itertools
from dataclasses import replace

import control as ct
import numpy as np
import pytest

from _issue22 import grid_mark, knife_edge
from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.rest_flank import RestFlank, flank_offset, rest_flank_step
from ctrl_lpv.twomass.sampled_tuning import sampled_tuning
from ctrl_lpv.twomass.servo_rest import _peak_to_peak, _rest_loop
from ctrl_lpv.twomass.servo_sampled import plan_snap, plan_stepper
from ctrl_lpv.twomass.trajectory import move_duration, rest_to_rest

DT = 1e-3
ENCODERS = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}


@pytest.fixture(scope="module")
def design():
    return twomass.servo_design(dt=DT, delay=1, sensors="encoders")


def _simulate(design, *, Td, theta_r=0.5, alpha=None, Jl=1.0, T=5.0, seed=1):
    params = twomass.Parameters()
    plant = twomass.plant(
        params.replace(Jl=Jl * params.Jl),
        alpha=twomass.alpha_step() if alpha is None else alpha,
    )
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": theta_r},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    return res


def _run(design, *, Td, theta_r=0.5, T=5.0, **kwargs):
    res = _simulate(design, Td=Td, theta_r=theta_r, T=T, **kwargs)
    return _metrics(res, theta_r, T)


def _metrics(res, theta_r, T):
    t, e = res.plant.time, res.plant.outputs[2] - theta_r
    torque = res.plant.inputs[0]
    outside = np.flatnonzero(np.abs(e) > 0.02 * abs(theta_r))
    settling = (
        0.0
        if not outside.size
        else (t[outside[-1] + 1] if outside[-1] + 1 < t.size else np.inf)
    )
    overshoot = max(0.0, float(np.max(np.sign(theta_r) * e))) / abs(theta_r) * 100
    last = t >= T - 1.0
    return dict(
        settling=settling,
        overshoot=overshoot,
        error=abs(e[-1]),
        rest_error=np.abs(e[last]).max(),
        ptp=np.ptp(e[last]),
        torque_std=np.std(torque[last]),
        ripple=np.abs(torque[last] - torque[last].mean()).max(),
        peak=np.abs(torque).max(),
    )


def test_controller_is_discrete_time_on_encoder_angles(design):
    servo = design.controller("drive")
    assert servo.dt == DT
    assert servo.input_labels == ["theta_m", "theta_l", "theta_r"]
    assert servo.output_labels == ["Tm"]
    assert design.certificate.verified
    # At rest at the origin the command is zero.
    x0 = np.zeros(servo.nstates)
    assert servo._out(0.0, x0, [0.0, 0.0, 0.0])[0] == 0.0


def test_paper_scenario_sampled_on_encoders(design):
    """1 ms, one sample of delay, encoders, the paper's load torque and gap
    step: the issue's targets, and the certified rest bounds hold."""
    m = _run(design, Td=8.0)
    assert m["settling"] <= 0.25
    assert m["overshoot"] <= 1.0
    assert m["error"] <= 2e-4
    assert m["torque_std"] <= 3.0
    assert m["peak"] <= design.torque_limit + 1e-9


@pytest.mark.parametrize("dt", [1e-3, 2e-3, 1.25e-4])
def test_sampled_plan_is_the_polynomial_to_its_end(design, dt):
    """The sampled planner is the minimum-snap polynomial at every sample,
    to the goal at rest with the time-to-go 0, and never reverses (the
    continuous planner's floor, a fixed filter over the last 40 ms, ran the
    reference back at the end of a move)."""
    c, distance = design.tuning, 0.5
    duration = move_duration(distance, c.accel_limit, c.min_duration)
    step = plan_stepper(c, dt)
    plan, rows = [0.0] * 6, []
    for _ in range(round(duration / dt) + 5):
        plan = step(plan, distance)
        rows.append(plan)
    rows = np.array(rows)
    t = dt * np.arange(1, len(rows) + 1)
    exact = rest_to_rest(t, distance, duration)
    np.testing.assert_allclose(rows[:, 0], exact[0], rtol=0.0, atol=1e-12)
    # The derivatives to 1e-6 of their peaks: the last samples' jerk, from
    # a state rounded on the way, scales with 1 / h^3.
    scale = np.abs(exact[1:4]).max(axis=1)
    np.testing.assert_allclose(
        rows[:, 1:4] / scale, exact[1:4].T / scale, rtol=0.0, atol=1e-6
    )
    assert np.all(rows[:, 1] >= -1e-12)
    assert rows[-1].tolist() == [distance, 0.0, 0.0, 0.0, distance, 0.0]
    # A new target mid-move re-plans from the moving state, and that move
    # too ends at rest where it is asked.
    for _ in range(round(0.1 / dt)):
        plan = step(plan, 1.0)
    assert plan[1] > 1.0
    for _ in range(round(1.0 / dt)):
        plan = step(plan, 0.2)
    assert plan == [0.2, 0.0, 0.0, 0.0, 0.2, 0.0]
    assert plan_snap(*plan) == 0.0


def test_the_load_follows_the_plan_where_the_command_acts(design):
    """Exact angles, the motor on the flank the move starts on: along a 0.5
    rad move the load follows the closed-form minimum-snap move
    (`rest_to_rest`, from the sample the target is read) within a
    sixteenth of a sample of its peak speed (0.24 mrad measured; 0.50
    without the shaft's damper and the hold in the feedforward, as without
    delay). Evaluated at the reading's instant, the plan left the load a
    sample of speed behind (4.8 mrad)."""
    d = design
    params = twomass.Parameters()
    controller = d.controller()
    x0 = np.zeros(len(controller.state_labels))
    x0[controller.state_labels.index("theta_m_hat")] = params.alpha
    exact = {name: Encoder(2**40, 0.0) for name in ("theta_m", "theta_l")}
    res = sampled_response(
        twomass.plant(params, alpha=params.alpha), controller, 0.3,
        inputs={"Td": 0.0, "theta_r": 0.5}, delay=d.delay, sensors=exact,
        X0=[params.alpha, 0.0, 0.0, 0.0, params.alpha], controller_X0=x0,
    )  # fmt: skip
    duration = move_duration(0.5, d.accel_limit, d.tuning.min_duration)
    t = res.plant.time
    # Up to the planner's floor, where the online plan is the polynomial.
    t = t[t <= duration - d.tuning.horizon_floor]
    r, v = rest_to_rest(t, 0.5, duration)[:2]
    lag = np.abs(res.plant.outputs[2][: t.size] - r)
    assert lag.max() <= v.max() * DT / 16


@pytest.mark.parametrize("alpha", [0.03, 0.06])
@pytest.mark.parametrize("theta_r", [0.5, -0.5, 1.0])
def test_feedforward_lands_the_load_at_rest(design, alpha, theta_r):
    """Exact angles, Td = 0: the feedforward with the shaft's damper and the
    torque held at a third of the sample ends the move with the load at rest
    in place (after the plan's end at most 3.1e-4 rad/s, within 5.2e-5 rad
    at 0.6 s, measured); without them the load left the braking flank at
    2.3-2.7e-3 rad/s, thrown back by the 3 Nm still on the shaft, and was
    caught 2.9e-4 rad off (`flat_feedforward`)."""
    params = twomass.Parameters()
    exact = {name: Encoder(2**40, 0.0) for name in ("theta_m", "theta_l")}
    duration = move_duration(
        abs(theta_r), design.accel_limit, design.tuning.min_duration
    )

    def landing(d):
        res = sampled_response(
            twomass.plant(params, alpha=alpha), d.controller(), 0.6,
            inputs={"Td": 0.0, "theta_r": theta_r}, delay=d.delay, sensors=exact,
        )  # fmt: skip
        t, y = res.plant.time, res.plant.outputs
        after = t >= duration
        return np.abs(y[3][after]).max(), abs(y[2][-1] - theta_r)

    speed, error = landing(design)
    assert speed <= 5e-4 and error <= 1e-4
    old = replace(design, sampling=replace(design.sampling, exact_feedforward=False))
    speed, error = landing(old)
    assert speed > 2e-3 and error > 2e-4


def test_gap_estimate_is_not_learnt_from_a_gap_crossing(design):
    """At the end of a move without load torque the motor swings across a
    wide gap; the observer reads the swing as a contact for a few samples.
    The gap estimate learns only where the move asks for torque, so it ends
    the move near the plant's half-gap (it used to halve, 0.029 rad for
    0.06, and the load hunted in a 2e-2 rad limit cycle)."""
    alpha = 0.06
    res = _simulate(design, Td=0.0, alpha=alpha, T=1.0)
    c = res.controller
    estimate = (
        design.tuning.alpha_initial + c.states[c.state_labels.index("alpha_hat_dev")]
    )
    after = c.time >= 0.3
    assert np.all(np.abs(estimate[after] - alpha) <= 0.05 * alpha)
    e = res.plant.outputs[2] - 0.5
    assert np.abs(e[after]).max() <= 2e-3


def test_a_gap_narrower_than_the_first_estimate_is_learnt_in_the_move(design):
    """A half-gap of 0.01 against the first estimate's 0.03, Td = 0: the
    move's contacts teach the estimate the narrower gap, and the rest is the
    issue's (no hunting). The readings below the estimate were trusted only
    where static: the estimate stayed at 0.028 and the rest hunted at
    137-138 Nm (seeds 1-2)."""
    alpha = 0.01
    res = _simulate(design, Td=0.0, alpha=alpha)
    c = res.controller
    estimate = (
        design.tuning.alpha_initial + c.states[c.state_labels.index("alpha_hat_dev")]
    )
    assert abs(estimate[c.time >= 0.3] - alpha).max() <= 1e-3
    m = _metrics(res, 0.5, 5.0)
    assert m["settling"] <= 0.25
    assert m["overshoot"] <= 1.0
    assert m["error"] <= 2e-4 and m["ptp"] <= 2e-4
    assert m["torque_std"] <= 3.0


@pytest.mark.parametrize("theta_r, seed", [(0.5, 1), (-0.5, 2)])
def test_gap_estimate_is_unbiased_at_the_largest_gap(design, theta_r, seed):
    """A gap of alpha_max (0.06): the readings of the half-gap scatter about
    it, and the estimate ends the move within 6e-5 rad of it. With the
    readings cut at alpha_max it was 7e-5 to 1.4e-4 rad short on every one
    of 32 runs (Td 0, +-0.5 rad, seeds 1-16), and the free rest's walls
    stood as far past the target."""
    alpha = design.tuning.alpha_max
    res = _simulate(design, Td=0.0, alpha=alpha, theta_r=theta_r, T=1.0, seed=seed)
    c = res.controller
    estimate = (
        design.tuning.alpha_initial + c.states[c.state_labels.index("alpha_hat_dev")]
    )
    assert abs(estimate[-1] - alpha) <= 6e-5


def test_certified_rest_holds_where_it_applies(design):
    """A load torque above the certificate's floor: the worst-case bounds
    of the rest hold along the simulated run (the tail of 2 s)."""
    rest = design.certificate.rest
    Td = 1.05 * rest.min_load_torque
    m = _run(design, Td=Td, alpha=0.03, T=2.0)
    assert m["rest_error"] <= rest.error_bound
    assert m["ripple"] <= rest.ripple_bound
    # Not vacuous: the floor is what the switches of the law need.
    assert rest.min_load_torque > 2 * design.tuning.contact_torque


def test_rest_gain_is_attained_by_the_worst_reading_errors(design):
    """The l1 bound is an upper bound and is attained: the reading errors
    ``n[k] = w_max sign(h[N - k])`` drive the loop to it."""
    params = twomass.Parameters()
    loop = _rest_loop(params, design.gain.ravel(), design.sampling)
    steps = 2 * np.pi / np.array([2.0**20, 2.0**17])
    w_max = 2.0 * steps
    bounds, checks = _peak_to_peak(loop, w_max)
    assert all(c.passed for c in checks)
    N = 6000
    A, B, C, D = loop.A, loop.B, loop.C, loop.D
    h = [D]
    X = B
    for _ in range(N):
        h.append(C @ X)
        X = A @ X
    for out in range(2):
        # Input sequence aligned with the impulse response of this output.
        n = np.array([w_max * np.sign(h[N - k][out]) for k in range(N + 1)])
        x = np.zeros(A.shape[0])
        for k in range(N):
            x = A @ x + B @ n[k]
        y = C[out] @ x + D[out] @ n[N]
        assert abs(y) <= bounds[out]
        assert abs(y) >= (1 - 1e-6) * bounds[out]


def test_peak_to_peak_of_a_scalar_loop_is_its_reachable_set():
    for a in (0.5, -0.9, 0.99):
        sys = ct.ss([[a]], [[1.0]], [[1.0]], [[0.0]], dt=1.0)
        bounds, _ = _peak_to_peak(sys, np.array([2.0]))
        assert bounds[0] == pytest.approx(2.0 / (1 - abs(a)), rel=1e-8)


@pytest.mark.parametrize(
    "kwargs, error, name",
    [
        ({"sensors": "encoders"}, ValueError, "sensors"),
        ({"dt": DT, "sensors": "states"}, ValueError, "sensors"),
        ({"dt": DT, "sensors": "encoders", "delay": 2}, ValueError, "delay"),
        ({"delay": 1}, ValueError, "delay"),
        ({"dt": -1.0, "sensors": "encoders"}, ValueError, "dt"),
        (
            {"dt": DT, "sensors": "motor", "reference": "stream"},
            ValueError,
            "reference",
        ),
        (
            {"dt": DT, "sensors": "encoders", "reference": "sine"},
            ValueError,
            "reference",
        ),
        ({"reference": "stream"}, ValueError, "reference"),
        (
            {"dt": DT, "sensors": "encoders", "reference": "stream", "stream": 100.0},
            TypeError,
            "stream",
        ),
    ],
)
def test_sampling_arguments_are_checked(kwargs, error, name):
    with pytest.raises(error, match=name):
        twomass.servo_design(certify=False, **kwargs)


@pytest.mark.slow
@pytest.mark.parametrize(
    "case",
    [
        dict(Td=5.0, alpha=0.06, Jl=0.8),
        dict(Td=5.0, alpha=0.03, Jl=1.2, theta_r=-1.0),
        dict(Td=8.0, alpha=0.045, Jl=1.0, theta_r=0.2),
        dict(Td=2.0, alpha=0.06, Jl=1.0),
        dict(Td=3.0, alpha=0.06, Jl=1.0, theta_r=0.05),
        dict(Td=3.0, alpha=0.06, Jl=1.0, theta_r=-0.05),
    ],
)
def test_grid_with_a_load_torque(design, case):
    m = _run(design, **case)
    assert m["settling"] <= 0.3
    assert m["overshoot"] <= 1.5
    assert m["torque_std"] <= 3.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "Td, alpha, theta_r",
    [
        (8.0, 0.03, -0.05),
        (-8.0, 0.03, 0.05),
        (8.0, 0.06, -0.05),
        (30.0, 0.03, -0.1),
        pytest.param(
            30.0,
            0.06,
            -0.05,
            marks=knife_edge(
                "2 of seeds 1-6 miss at stop 63 (4 and 5) and since stop 64 (1: "
                "2.62 %, and 4): the gap's take-up stops 10 ms apart on a 0.04 Nm "
                "difference in the joined load torque"
            ),
        ),
    ],
)
def test_first_small_move_from_mid_gap_with_the_load_torque_along(
    design, Td, alpha, theta_r
):
    """The run starts with the load mid-gap and a small step in the direction
    the load torque pushes: 2.2-4.4 % over before the load torque
    was measured by the load's fall and held by the integral in the first
    move, 5.9 % at Td 30 and alpha 0.06 before the move restarted from the
    fallen load and the gap was taken up (`ctrl_lpv.twomass.cold_start`;
    docs/servo.rst, "The first move from mid-gap")."""
    m = _run(design, Td=Td, alpha=alpha, theta_r=theta_r)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


#: First moves from the origin (the load mid-gap, the load torque unknown)
#: that miss (measured, seed 1; docs/servo.rst, "The first move from
#: mid-gap"): none since stop 64. Jl x1.2 at alpha 0.06 under Td 3 and 8
#: Nm missed (1.75-2.37 %) while the observer's model ran on the old
#: inertia as the inertia estimate learnt the new one: its load ran ahead
#: of the load, and the crossing in the middle of the move read that as
#: load torque. Now its state follows the learnt inertia.
_FIRST_MOVE_MISSES: set = set()
#: On the knife edge (`_issue22.grid_mark`): the 0.05 rad move under Td 3
#: both ways (the planned crossing into the hold releases the braking with
#: the load 20 % heavier than the plan's, its load-torque estimate at 6-7
#: Nm for 3; both within 1.5 % since stop 63 on the machine of stop 62).
_FIRST_MOVE_EDGE = {
    (3.0, 0.06, 1.2, -0.05): "1.75 % on the machine of stop 61, within 1.5 % on that "
    "of stop 62",
    (3.0, 0.06, 1.2, 0.05): "within 1.5 % on the machine of stop 61, 4.59 % on "
    "that of stop 62",
}


def _first_moves():
    runs = []
    for Td, alpha, Jl, step in itertools.product(
        (8.0, 3.0), (0.03, 0.06), (0.8, 1.0, 1.2),
        (0.05, -0.05, 0.1, -0.1, 0.2, -0.2, 1.0, -1.0),
    ):  # fmt: skip
        marks = grid_mark((Td, alpha, Jl, step), _FIRST_MOVE_MISSES, _FIRST_MOVE_EDGE)
        runs.append(pytest.param(Td, alpha, Jl, step, marks=marks))
    return runs


@pytest.mark.slow
@pytest.mark.parametrize("Td, alpha, Jl, theta_r", _first_moves())
def test_grid_of_first_moves_from_mid_gap(design, Td, alpha, Jl, theta_r):
    """Issue 22's steps of 0.05 to 1 rad both ways, Jl x0.8 to x1.2, as the
    first move from the origin under a load torque (seed 1)."""
    m = _run(design, Td=Td, alpha=alpha, Jl=Jl, theta_r=theta_r, T=1.5)
    assert m["overshoot"] <= 1.5
    assert m["settling"] <= 0.3


def _estimate_noise(Phi, M, steps):
    """Standard deviation of the filtered estimate's error, per state, under
    the encoders' reading noise alone (quantization and half a count, white),
    from the error dynamics' discrete Lyapunov equation (summed by doubling:
    the states' scales, 1e-6 rad to 1 Nm, defeat a direct solve)."""
    C = np.zeros((2, 6))
    C[0, 0] = C[1, 3] = 1.0
    R = np.diag((steps * steps) * (1.0 / 12.0 + 0.25))
    A = Phi @ (np.eye(6) - M @ C)
    assert np.abs(np.linalg.eigvals(A)).max() < 1.0
    X, Ak = (Phi @ M) @ R @ (Phi @ M).T, A
    for _ in range(64):  # X = sum_k A^k Q A^k', 2^64 terms
        X, Ak = X + Ak @ X @ Ak.T, Ak @ Ak
    F = (np.eye(6) - M @ C) @ X @ (np.eye(6) - M @ C).T + M @ R @ M.T
    return np.sqrt(np.diag(F))


def _load_torque_time(Phi, M):
    """Samples the filtered load-torque estimate takes to learn 63 % of a
    load-torque step (its error's free response from 1 Nm)."""
    C = np.zeros((2, 6))
    C[0, 0] = C[1, 3] = 1.0
    A = (np.eye(6) - M @ C) @ Phi
    error, samples = np.eye(6)[5], 0
    while abs(error[5]) > np.exp(-1.0):
        error, samples = A @ error, samples + 1
        assert samples < 10_000
    return samples


def test_latched_rest_runs_on_quieter_observer_gains(design):
    """While the flank is latched the observer runs on gains of a lower
    shaft-torque intensity (`SampledTuning.rest_rates`): each gain set is a
    stable filter at the gap and in contact; under the encoders' reading
    noise the rest gains' motor-speed and shaft-torque estimates are
    several times quieter (what moved the parked motor: Td = 0 chattered at
    3.4-7.2 Nm over the last second with the moving gains on 12 of 30 runs,
    docs/servo.rst), and they learn a load torque within 50 ms, as the
    moving gains do: the latch's flank is the one the load torque presses
    the load onto, and a load falling under 0.5 Nm has fallen 1.1e-4 rad by
    then, within the latch's 3e-4 rad (with a load-torque intensity of 2
    Nm/s they took 170 ms, and 0.5-1 Nm relayed on 12 of 64 runs)."""
    s = design.sampling
    assert s.M_rest is not None
    steps = 2.0 * np.pi / np.array([2.0**20, 2.0**17])
    dt = design.dt
    for Phi, M, M_rest in zip(s.Phi, s.M, s.M_rest):
        moving, rest = (
            _estimate_noise(Phi, M, steps),
            _estimate_noise(Phi, M_rest, steps),
        )
        # omega_m, Ts
        assert np.all(rest[[1, 2]] < 0.5 * moving[[1, 2]])
        assert _load_torque_time(Phi, M_rest) * dt <= 0.05
        assert _load_torque_time(Phi, M) * dt <= 0.05
    # Above the fast sampling the observer is slow already: one gain set.
    assert sampled_tuning(2e-3).rest_rates is None


#: The quiet-rest runs that miss (measured; docs/servo.rst, "The move's
#: end", "A lighter load at Td = 0", "The learnt inertia at rest", "The
#: flank a load torque presses" and "The gap read at its largest"): the
#: lighter load's 0.05 rad move at alpha 0.06 (its first move's contact
#: with the unknown gap; a ping-pong across the flanks at rest, which seeds
#: miss changes with any change of the move's end: 2 now passes, 3 misses
#: at 1.77 %). Its 0.2 rad move at alpha 0.03 on seed 2 (3.6 Nm) passes
#: since a held contact teaches a narrower gap. With the latch's flank
#: from the asked shaft torque alone and a slow load-torque estimate at
#: rest, the 0.2 rad move relayed on seeds 5 and 6 (53-99 Nm) and the 1 rad
#: move on seeds 2 and 4 (44 and 22 Nm). Seeds 3-5 of the lighter load's
#: 0.05 rad move pass since a flip towards a coming load is timed to it
#: (`rest_flank.flip_duration`), not a step.
_REST_MISSES = {(0.06, 0.05, 0.8, 1)}
_REST_EDGE = {
    (0.06, 0.05, 0.8, 5): "within 3 Nm on the machine of stop 61, 3.01 Nm on that "
    "of stop 62",
    (0.06, 0.05, 0.8, 3): "the row misses on 9 of seeds 1-24 before stop 63, 10 "
    "at stop 63 (20.7 Nm on seed 3 here) and 3 since stop 64",
    (0.06, 0.05, 0.8, 6): "the row misses on 9 of seeds 1-24 before stop 63, 10 "
    "at stop 63 (11.7 Nm on seed 6 here) and 3 since stop 64 (seed 6: 13 % "
    "over, the load kicked off the flank at the end of the move)",
    (0.06, 0.05, 0.8, 2): "the row misses on 3 of seeds 1-24 since stop 64 (9.17 "
    "Nm on seed 2 here), 10 at stop 63",
}


def _rest_runs():
    rows = [(0.03, 0.5, 1.0), (0.06, 0.5, 1.0), (0.06, -0.5, 1.0),
            (0.03, 0.05, 1.0), (0.03, 1.0, 1.2),
            (0.03, 0.05, 0.8), (0.06, 0.05, 0.8), (0.03, 0.2, 0.8)]  # fmt: skip
    runs = []
    for row in rows:
        for seed in range(1, 7):
            marks = grid_mark((*row, seed), _REST_MISSES, _REST_EDGE)
            runs.append(pytest.param(*row, seed, marks=marks))
    return runs


@pytest.mark.slow
@pytest.mark.parametrize("alpha, theta_r, Jl, seed", _rest_runs())
def test_no_load_torque_rest_is_quiet_on_every_seed(design, alpha, theta_r, Jl, seed):
    """Issue 22, no hunting sampled, Td = 0: torque standard deviation over
    the last second <= 3 Nm on every noise seed but `_REST_MISSES`; at the
    nominal inertia the issue's rest too, end error and last-second
    peak-to-peak <= 2e-4 rad (the free rest, `twomass.free_rest`; the
    latched law alone missed 41 of 96 runs of the four nominal rows on
    seeds 1-24, docs/servo.rst), off it a peak-to-peak <= 5e-4 rad."""
    m = _run(design, Td=0.0, alpha=alpha, theta_r=theta_r, Jl=Jl, seed=seed)
    assert m["settling"] <= 0.3
    assert m["overshoot"] <= 1.5
    assert m["torque_std"] <= 3.0
    if Jl == 1.0:
        assert m["error"] <= 2e-4
        assert m["ptp"] <= 2e-4
    else:
        assert m["ptp"] <= 5e-4


@pytest.mark.slow
@pytest.mark.parametrize(
    "Td, theta_r, Jl, seed",
    [(0.5, 0.5, 1.0, 7), (0.5, 0.5, 1.0, 13), (0.5, -0.5, 1.0, 3),
     (0.5, -0.5, 1.0, 9), (0.5, -0.5, 1.0, 18), (1.0, 0.5, 0.8, 6),
     (1.0, 0.5, 0.8, 14)],
)  # fmt: skip
def test_light_load_torque_rests_on_its_flank(design, Td, theta_r, Jl, seed):
    """Issue 22, no hunting sampled under a small load torque (alpha 0.03):
    the issue's rest (end error and last-second peak-to-peak <= 2e-4 rad,
    torque standard deviation <= 3 Nm). The latched flank is the one the
    load torque presses the load onto (`rest_flank`): with the asked shaft
    torque alone these runs relayed (torque standard deviation up to 156
    Nm; traced on seed 7: the latch took the flank the load bounced off at
    the move's end, and the load fell across the gap onto the motor's
    flip). Seeds 9 and 18 of -0.5 rad were a ping-pong across the flanks
    (31-37 Nm), each flip timed to the load's speed alone: the load torque
    sped the load up, and it met the motor still crossing
    (`rest_flank.flip_duration`)."""
    m = _run(design, Td=Td, alpha=0.03, theta_r=theta_r, Jl=Jl, seed=seed)
    assert m["error"] <= 2e-4 and m["ptp"] <= 2e-4
    assert m["torque_std"] <= 3.0


@pytest.mark.slow
@pytest.mark.parametrize(
    "Td, seed",
    [(3.0, 2), (3.0, 7), (3.0, 22), (3.0, 30), (5.0, 17), (5.0, 22), (5.0, 26)],
)
def test_a_load_torque_that_brings_the_load_keeps_its_flank(design, Td, seed):
    """Issue 22, no hunting sampled under a load torque beyond the latch's
    (alpha 0.03, Jl x0.8, -0.2 rad: the move ends about 1.4 mrad short with
    the load torque pushing the load towards the target): the issue's rest.
    The flank stays the one holding the load torque; with the flank of the
    asked shaft torque (the load-position term's push) these runs relayed
    at 120-150 Nm of torque standard deviation. And no probing of the gap
    there: on seed 30 the probe held the gap estimate 3 mrad wide, and the
    load rested 4.5e-4 rad short."""
    m = _run(design, Td=Td, alpha=0.03, theta_r=-0.2, Jl=0.8, seed=seed)
    assert m["error"] <= 2e-4 and m["ptp"] <= 2e-4
    assert m["torque_std"] <= 3.0


@pytest.mark.slow
@pytest.mark.parametrize("alpha", [0.03, 0.06])
def test_no_load_torque_the_load_settles_without_a_limit_cycle(design, alpha):
    """Td = 0: the load settles and stays within the issue's 2e-4 rad (error
    peak-to-peak over the last second). Before the gap estimate learned only
    where the move asks for torque on the flank it is on, alpha = 0.06 took
    4.9 s with a 2e-2 rad limit cycle. (The torque and other seeds:
    `test_no_load_torque_rest_is_quiet_...`.)"""
    m = _run(design, Td=0.0, alpha=alpha)
    assert m["settling"] <= 0.3
    assert m["overshoot"] <= 1.5
    assert m["ptp"] <= 2e-4


#: Gaps narrower than the first estimate (half of alpha_max) on the knife
#: edge (measured on the machine of stop 61): the first move from mid-gap
#: at alpha 0.01 under Td 3 over -0.05 rad, the load torque along the
#: step, overshoots 1.6-1.7 % on seeds 1-4: the fall before the contact
#: is too short for the cold start's fit of the load torque to join (4.0
#: Nm, not significant), and when the braking starts the observer has 1 Nm
#: of 3 and the inertia estimate reads the rest as a load 8 % lighter.
_NARROW_EDGE = {
    (0.01, 3.0, -0.05): "1.6-1.7 % on the machine of stop 61, within 1.5 % on "
    "that of stop 62",
    (0.0, 0.0, -0.05): "no gap, Td 0, +-0.05 rad, seeds 1-6, 5 s: the rest's error "
    "peak-to-peak 4.5-5.5e-4 rad on 3 of 12 runs (seed 4 here among them; 1 of 12 "
    "before stop 63, the first move as before to 1e-5 rad), on 3-5 of 12 over 3 s",
}


def _narrow_gap_runs():
    runs = []
    rows = itertools.product(
        (0.0, 0.005, 0.01, 0.02, 0.025), (0.0, 1.0, 3.0), (0.5, -0.5, 0.05, -0.05)
    )
    for k, row in enumerate(rows):
        marks = grid_mark(row, edge=_NARROW_EDGE)
        runs.append(pytest.param(*row, 1 + k % 6, marks=marks))
    return runs


@pytest.mark.slow
@pytest.mark.parametrize("alpha, Td, theta_r, seed", _narrow_gap_runs())
def test_gaps_narrower_than_the_first_estimate(design, alpha, Td, theta_r, seed):
    """Issue 22, no hunting sampled, alpha up to alpha_max: from no gap to
    just below the first estimate, Td 0 to 3 Nm, the first move from the
    origin. The issue's rest (torque standard deviation <= 3 Nm, error
    peak-to-peak <= 2e-4 rad), and the targets of the move's size: 0.5 rad
    as the paper scenario, 0.05 rad as the steps. Before a held contact
    taught a narrower gap, 49 of these 60 runs missed and 40 hunted (up to
    163 Nm)."""
    m = _run(design, Td=Td, alpha=alpha, theta_r=theta_r, seed=seed)
    assert m["torque_std"] <= 3.0
    assert m["ptp"] <= 2e-4
    if abs(theta_r) >= 0.5:
        assert m["settling"] <= 0.25
        assert m["overshoot"] <= 1.0
        assert m["error"] <= 2e-4
    else:
        assert m["settling"] <= 0.3
        assert m["overshoot"] <= 1.5


# A streamed set-point: a 0.2 rad, 1 Hz sine sent every sample.
SINE_AMPLITUDE, SINE_HZ = 0.2, 1.0


def _sine(t):
    return SINE_AMPLITUDE * np.sin(2.0 * np.pi * SINE_HZ * t)


@pytest.fixture(scope="module")
def stream_design():
    return twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", reference="stream", certify=False
    )


def _stream_error(design, *, Td, alpha, T, Jl=1.0, seed=1):
    """Load error to the sine fed in, from the plant's own load angle."""
    params = twomass.Parameters()
    plant = twomass.plant(
        params.replace(Jl=Jl * params.Jl),
        alpha=twomass.alpha_step() if alpha is None else alpha,
    )
    res = sampled_response(
        plant, design.controller(), T, inputs={"Td": Td, "theta_r": _sine},
        delay=design.delay, sensors=ENCODERS, seed=seed,
    )  # fmt: skip
    p = res.plant
    t = p.time
    theta_l = p.outputs[p.output_labels.index("theta_l")]
    after = t >= 1.0
    torque = p.inputs[p.input_labels.index("Tm")]
    return np.abs(theta_l - _sine(t))[after].max(), np.abs(torque[after]).max()


def _sine_torque(Td, Jl=1.0):
    """The largest torque the sine asks of the rigid drive, ``(Jm + Jl)
    A w^2 + (cm + cl) A w + |Td|`` (a bound: the terms peak at different
    times)."""
    p = twomass.Parameters()
    w = 2.0 * np.pi * SINE_HZ
    inertia = p.Jm + Jl * p.Jl
    friction = (p.cm + p.cl) * SINE_AMPLITUDE * w
    return inertia * SINE_AMPLITUDE * w**2 + friction + abs(Td)


def test_stream_tracker_poles_and_polynomials():
    """The tracker's error dynamics has the four poles asked for, and a
    cubic set-point is followed without lag: its derivatives, computed by
    hand, are the tracker's state once the transient has died."""
    from ctrl_lpv.twomass.stream import jerk_model, stream_gain

    bandwidth = 100.0
    L = stream_gain(DT, bandwidth)
    Phi = jerk_model(DT)
    E = (np.eye(4) - np.outer(L, [1.0, 0.0, 0.0, 0.0])) @ Phi
    # A quadruple eigenvalue: the computed ones spread as the 4th root of
    # the rounding, so compare the characteristic polynomial instead.
    expected = np.poly([np.exp(-bandwidth * DT)] * 4)
    np.testing.assert_allclose(np.poly(E), expected, atol=1e-12)

    def cubic(t):
        return np.array([0.3 + 2 * t - t**2 + 0.5 * t**3, 2 - 2 * t + 1.5 * t**2,
                         -2 + 3 * t, 3.0])  # fmt: skip

    z = np.zeros(4)
    for k in range(400):
        z = z if k == 0 else Phi @ z
        z = z + L * (cubic(k * DT)[0] - z[0])
    np.testing.assert_allclose(z, cubic(399 * DT), rtol=1e-6, atol=1e-6)


def test_streamed_sine_is_tracked_without_replanning(stream_design, design):
    """1 ms, one sample of delay, encoders, Td = 8 Nm: the sine streamed to
    the controller is followed within 5 mrad after the first second (the
    error computed here from the plant's load angle and the sine fed in),
    where the planner, re-planning a move at every new sample, is more than
    ten times further off."""
    assert stream_design.reference == "stream"
    err, _ = _stream_error(stream_design, Td=8.0, alpha=0.03, T=1.6)
    assert err <= 5e-3
    planned, _ = _stream_error(design, Td=8.0, alpha=0.03, T=1.6)
    assert planned > 10 * err


@pytest.mark.parametrize("seed", [1, 2])
def test_streamed_reversals_cross_the_gap_without_a_slam(stream_design, seed):
    """alpha 0.06, Td = 0: the shaft torque of the sine changes sign twice a
    period and the motor crosses the 0.12 rad gap each time. Planned from
    the tracker's extrapolation (`gap_crossing.streamed_sign_changes`), the
    crossing asks for less than twice the torque the sine needs on a rigid
    drive (48.8 Nm); taken by the flank choice alone it slammed at the
    500 Nm limit at every reversal."""
    err, peak = _stream_error(stream_design, Td=0.0, alpha=0.06, T=2.1, seed=seed)
    assert err <= 5e-3
    assert peak <= 2.0 * _sine_torque(0.0)


# --- The flank latch at rest (`rest_flank`) ------------------------------


def test_rest_flank_holds_against_noise_and_flips_on_evidence():
    """The CUSUM test on the asked shaft torque: zero-mean noise of the size
    the encoders give (0.3 Nm) never flips the latched flank in 10 s; a
    sustained torque of the other sign (1 Nm) flips it after about
    ``flip_evidence / (1 - flip_torque)`` seconds."""
    f = RestFlank()
    dt = 1e-3
    rng = np.random.default_rng(0)
    side, evidence = rest_flank_step(
        f, dt, 0.0, 0.0, resting=True, error=0.0, speed=0.0, load_torque=0.0,
        tstar=0.5, psi=1.0,
    )  # fmt: skip
    assert side == 1.0
    for tstar in 0.3 * rng.standard_normal(10_000):
        side, evidence = rest_flank_step(
            f, dt, side, evidence, resting=True, error=0.0, speed=0.0,
            load_torque=0.0, tstar=tstar, psi=0.0,
        )  # fmt: skip
        assert side == 1.0
    steps = 0
    while side == 1.0:
        side, evidence = rest_flank_step(
            f, dt, side, evidence, resting=True, error=0.0, speed=0.0,
            load_torque=0.0, tstar=-1.0, psi=-1.0,
        )  # fmt: skip
        steps += 1
    expected = f.flip_evidence / (1.0 - f.flip_torque) / dt
    assert side == -1.0 and abs(steps - expected) <= 2


def test_rest_flank_holds_while_its_shaft_is_loaded():
    """While the shaft carries torque on the latched flank (a load bouncing
    off it) neither the evidence of the other flank nor a load error beyond
    the release flips or releases it; once the shaft lets go, both act."""
    f = RestFlank()
    dt, steps = 1e-3, 1000
    common = dict(resting=True, speed=0.0, load_torque=0.0, psi=0.0)
    side, evidence = 1.0, 0.0
    for _ in range(steps):  # 1 s of 5 Nm asked on the other flank
        side, evidence = rest_flank_step(
            f, dt, side, evidence, error=0.0, tstar=-5.0, pressed=True, **common
        )
    assert (side, evidence) == (1.0, 0.0)
    far = 2.0 * f.release_error
    assert rest_flank_step(
        f, dt, 1.0, 0.0, error=far, tstar=0.0, pressed=True, **common
    ) == (1.0, 0.0)
    assert rest_flank_step(
        f, dt, 1.0, 0.0, error=far, tstar=0.0, pressed=False, **common
    ) == (0.0, 0.0)
    flipped = rest_flank_step(
        f, dt, 1.0, f.flip_evidence, error=0.0, tstar=-5.0, pressed=False, **common
    )
    assert flipped == (-1.0, 0.0)


def test_rest_flank_latches_only_near_the_target_with_a_small_load_torque():
    """And only on the flank the motor already turns to (no jump of the
    motor reference)."""
    f = RestFlank()
    near = dict(
        error=0.5 * f.latch_error, speed=0.0, load_torque=0.0, tstar=-0.4, psi=-0.95
    )
    assert rest_flank_step(f, 1e-3, 0.0, 0.0, resting=True, **near)[0] == -1.0
    assert rest_flank_step(f, 1e-3, 0.0, 0.0, resting=False, **near)[0] == 0.0
    for change in (
        dict(error=2 * f.latch_error), dict(speed=2 * f.latch_speed),
        dict(load_torque=-2 * f.latch_torque), dict(psi=-0.5 * f.latch_flank),
    ):  # fmt: skip
        assert rest_flank_step(
            f, 1e-3, 0.0, 0.0, resting=True, **{**near, **change}
        ) == (0.0, 0.0)
    # Released by a load error beyond release_error, or a new move.
    far = dict(near, error=2 * f.release_error)
    assert rest_flank_step(f, 1e-3, 1.0, 0.01, resting=True, **far) == (0.0, 0.0)
    assert rest_flank_step(f, 1e-3, 1.0, 0.01, resting=False, **near) == (0.0, 0.0)


def test_latch_is_outside_the_certified_rest(design):
    """The latch reads the load-torque estimate; the certificate's floor
    keeps that estimate above the latch's threshold along every admissible
    run, so the certified loop never latches."""
    rest = design.certificate.rest
    params = twomass.Parameters()
    loop = _rest_loop(params, design.gain.ravel(), design.sampling)
    steps = 2 * np.pi / np.array([2.0**20, 2.0**17])
    bounds, _ = _peak_to_peak(loop, rest.counts_error * steps)
    assert loop.output_labels[5] == "Td_hat"
    assert rest.min_load_torque - bounds[5] >= RestFlank().latch_torque


def _flip(f, dt, ah, *, error=0.0, speed=0.0, accel=0.0):
    """A flip from -1 to +1 sampled at `dt` until parked: the motor's
    offset, rate and acceleration (rad, rad/s, rad/s^2) per sample."""
    psi, dpsi, ddpsi = [], [], []
    previous, crossing, parked = -1.0, (0.0, 0.0), 0
    while parked < 2:  # the crossing, then parked on the new flank
        p, dp, ddp, crossing = flank_offset(
            f, dt, 1.0, previous, crossing, alpha_hat=ah, error=error,
            speed=speed, accel=accel,
        )  # fmt: skip
        psi.append(p), dpsi.append(dp), ddpsi.append(ddp)
        previous, parked = 1.0, parked + (crossing[0] == 0.0)
    return tuple(ah * np.array(q) for q in (psi, dpsi, ddpsi))


def test_flank_offset_crosses_the_gap_along_a_quintic():
    """A flip of the latched flank moves the parking point from one flank to
    the other at the peak acceleration asked for, with its rates; no
    crossing acceleration gets a step."""
    f, dt, ah = RestFlank(), 1e-4, 0.03
    park = 1.0 - f.clearance / ah
    psi, dpsi, ddpsi = _flip(f, dt, ah)
    assert psi[0] == pytest.approx(-ah * park) and psi[-1] == ah * park
    assert np.all(np.diff(psi) >= 0.0)
    # The rates are those of the path (finite differences), and the peak
    # acceleration is the one asked for.
    assert np.allclose(np.gradient(psi, dt)[1:-1], dpsi[1:-1], atol=2e-3)
    accel = np.gradient(np.gradient(psi, dt), dt)[2:-2]
    assert np.abs(accel).max() == pytest.approx(f.crossing_accel, rel=0.01)
    assert np.abs(ddpsi).max() == pytest.approx(f.crossing_accel, rel=0.01)
    off = RestFlank(crossing_accel=0.0)
    still = flank_offset(
        off, dt, 1.0, -1.0, (0.0, 0.0), alpha_hat=ah, error=0.0, speed=0.0
    )
    assert [ah * q for q in still[:3]] == pytest.approx([ah * park, 0.0, 0.0])
    assert still[3] == (0.0, 0.0)


@pytest.mark.parametrize("ah", [0.03, 0.06])
@pytest.mark.parametrize("error", [-5e-4, 0.0, 3e-4])
@pytest.mark.parametrize("speed", [-2e-2, -9e-3, -3e-3, 0.0, 3e-3])
@pytest.mark.parametrize("accel", [-0.2, 0.0, 0.05])
def test_a_flip_parks_the_motor_before_the_load_meets_it(ah, error, speed, accel):
    """A flip to the flank +1 (it brakes a load moving the negative way):
    a load coming at it, at its speed and under the acceleration of its
    load torque where that pulls it towards the flank (an estimate that it
    slows down is not trusted), meets the parked motor `clearance` short
    of the target, and the crossing is parked in half its time to there,
    never faster than `RestFlank.catch_accel`, never slower than the slow
    crossing; a load that does not come gets the slow crossing."""
    f, dt = RestFlank(), 1e-4
    psi, _, ddpsi = _flip(f, dt, ah, error=error, speed=speed, accel=accel)
    duration = (psi.size - 2) * dt
    gap = 2.0 * (ah - f.clearance)
    slow = np.sqrt(10.0 / np.sqrt(3.0) * gap / f.crossing_accel)  # the quintic's
    fastest = slow * np.sqrt(f.crossing_accel / f.catch_accel)
    assert fastest - 2 * dt <= duration <= slow + 2 * dt
    assert np.abs(ddpsi).max() <= f.catch_accel * 1.01
    # The load's path over the next two slow crossings, stepped: where it
    # first reaches -clearance.
    t = np.arange(0.0, 2.0 * slow, 1e-5)
    pull = min(accel, 0.0)
    reached = np.flatnonzero(error + speed * t + 0.5 * pull * t * t <= -f.clearance)
    if reached.size:
        meets = t[reached[0]]
        assert duration <= max(f.arrival_share * meets, fastest) + 2 * dt
        assert duration >= min(f.arrival_share * meets, slow) - 2 * dt
    else:
        assert duration == pytest.approx(slow, abs=2 * dt)


@pytest.mark.parametrize("seed", [10, 15])
def test_a_flip_towards_a_coming_load_does_not_slam(design, seed):
    """Td = 0, alpha 0.06, 0.5 rad: after the move the load coasts through
    the target at 9e-3 rad/s, and the latch flips to the flank that brakes
    it. That crossing is timed to park the motor before the load arrives
    (`rest_flank.flip_duration`); it was a step of the motor reference
    across the gap, at the 500 Nm limit, for loads faster than 5e-3 rad/s
    (these two seeds of 15). The rest still meets the issue's targets."""
    res = _simulate(design, Td=0.0, alpha=0.06, T=4.0, seed=seed)
    t, torque = res.plant.time, res.plant.inputs[0]
    side = res.controller.states[res.controller.state_labels.index("flank_side")]
    after = res.controller.time >= 0.3
    assert np.count_nonzero(np.diff(side[after])) >= 1  # a flip at rest
    assert np.abs(torque[t >= 0.3]).max() <= 100.0
    m = _metrics(res, 0.5, 4.0)
    assert m["settling"] <= 0.25 and m["overshoot"] <= 1.0
    assert m["error"] <= 2e-4 and m["ptp"] <= 2e-4 and m["torque_std"] <= 3.0


def test_a_light_load_falling_onto_a_flip_is_not_thrown_back(design):
    """A random move of the fuzz (Td 0.38 Nm, alpha 0.0462, Jl x0.819,
    -0.072 rad, seed 3069): the load, caught on the flank that braked it,
    falls back under its load torque and the latch flips to the flank that
    holds it. Timed to the load's speed alone (4 mrad/s when the flip
    began), the crossing was met by the load 0.2 s later at 17 mrad/s and
    threw it back at 37: a ping-pong to the end of the run (63.6 Nm of torque
    standard deviation over the last second, 264 Nm peaks). Timed to where
    the load torque brings it (`rest_flank.flip_duration`), the rest is
    quiet."""
    res = _simulate(
        design, Td=0.38, theta_r=-0.072, alpha=0.0462, Jl=0.819, T=2.5, seed=3069
    )  # fmt: skip
    m = _metrics(res, -0.072, 2.5)
    assert m["settling"] <= 0.3 and m["overshoot"] <= 1.5
    assert m["torque_std"] <= 3.0 and m["ptp"] <= 2e-4
    side = res.controller.states[res.controller.state_labels.index("flank_side")]
    assert np.count_nonzero(np.diff(side[res.controller.time >= 1.0])) == 0


@pytest.mark.parametrize("Td", [0.0, 5.0])
def test_a_target_moved_back_mid_move_is_not_passed(design, Td):
    """A move to 0.1 rad re-targeted to 0.06 rad 56 ms in (the load at
    1e-2 rad, 0.65 rad/s): the re-plan reaches the new target without
    passing it (`gap_crossing.no_reversal_duration`); the re-plan of the
    usual duration ran 11-12 mrad past it (23-24 %) and came back."""
    params = twomass.Parameters()
    res = sampled_response(
        twomass.plant(params, alpha=0.03), design.controller(), 1.5,
        inputs={"Td": Td, "theta_r": lambda t: 0.1 if t < 0.056 else 0.06},
        delay=design.delay, sensors=ENCODERS, seed=1,
    )  # fmt: skip
    t, theta_l = res.plant.time, res.plant.outputs[2]
    after = t >= 0.056
    start = theta_l[after][0]
    step = 0.06 - start
    e = theta_l[after] - 0.06
    assert np.max(np.sign(step) * e) <= 0.015 * abs(step)
    outside = np.flatnonzero(np.abs(e) > 0.02 * abs(step))
    assert t[after][outside[-1] + 1] - 0.056 <= 0.15
    assert abs(e[-1]) <= 2e-4


@pytest.fixture(scope="module")
def latched_design():
    """The latched law at every rest (no free rest, `twomass.free_rest`)."""
    return twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", certify=False,
        anti_hunting=twomass.ServoAntiHunting(free_rest=None),
    )  # fmt: skip


def test_rest_without_load_torque_crosses_the_gap_without_a_slam(latched_design):
    """Td = 0 on encoders, the latched law without the free rest (alpha
    0.03, seed 2; 2 flank changes after the first second on this run): once
    latched the motor stays below 30 Nm, every change of flank a crossing of
    the gap at `RestFlank.crossing_accel` (``Jm`` x 12 rad/s^2 = 4.8 Nm)
    where a step of the motor reference slams at the torque limit; the gap
    estimate stays within the parking clearance of the gap (no probing while
    latched, the contact not made there is the clearance), and the
    continuous flank choice chatters several times more."""
    design = latched_design
    res = _simulate(design, Td=0.0, alpha=0.03, seed=2)
    c, t = res.controller, res.plant.time
    side = c.states[c.state_labels.index("flank_side")]
    dev = c.states[c.state_labels.index("alpha_hat_dev")]
    alpha_hat = design.tuning.alpha_initial + dev
    torque = res.plant.inputs[0]
    rest = t >= 1.0
    assert np.all(side[rest] != 0.0) and np.count_nonzero(np.diff(side[rest])) >= 1
    assert np.abs(torque[rest]).max() <= 30.0
    assert abs(alpha_hat[-1] - 0.03) < RestFlank().clearance
    # The same run with the flips as steps, and with no latch at all.
    for rest_flank, peak, spread in (
        (RestFlank(crossing_accel=0.0), 400.0, 0.0),
        (None, 0.0, 5.0 * np.std(torque[rest])),
    ):
        other = twomass.servo_design(
            dt=DT, delay=1, sensors="encoders", certify=False,
            anti_hunting=twomass.ServoAntiHunting(
                rest_flank=rest_flank, free_rest=None
            ),
        )  # fmt: skip
        old = _simulate(other, Td=0.0, alpha=0.03, seed=2).plant.inputs[0]
        assert np.abs(old[rest]).max() >= peak
        assert np.std(old[rest]) >= spread


@pytest.mark.parametrize("seed", [2, 5])
def test_small_load_torque_leans_on_the_latched_flank_held_by_the_integral(
    design, seed
):
    """Td = 1 Nm, below the observer's contact torque (1.5 Nm), alpha 0.06:
    the load leans on the latched flank and the integral holds the load
    torque, so the load rests at the target (1-3e-5 rad on these seeds;
    it sat 2.2-2.6e-4 rad off while the integral leaked and the faded
    proportional term held the torque). Facts from the plant: the shaft
    stays in contact all along the last second (shaft torque > 0) and
    carries the load torque on average."""
    res = _simulate(design, Td=1.0, alpha=0.06, T=2.5, seed=seed)
    t, e = res.plant.time, res.plant.outputs[2] - 0.5
    last = t >= 1.5
    shaft = res.plant.outputs[4][last]
    assert np.abs(e[last]).max() <= 5e-5
    assert np.std(res.plant.inputs[0][last]) <= 3.0
    assert shaft.min() > 0.0
    assert abs(shaft.mean() - 1.0) <= 0.05


@pytest.mark.slow
@pytest.mark.parametrize(
    "Td, alpha, Jl",
    [(8.0, None, 1.0), (8.0, 0.03, 1.0), (0.0, 0.03, 1.0), (0.0, 0.06, 1.0),
     (0.0, 0.0, 1.0), (8.0, 0.06, 1.0), (8.0, None, 1.2), (-8.0, 0.045, 0.8)],
)  # fmt: skip
def test_streamed_sine_grid(stream_design, Td, alpha, Jl):
    """Issue 22's streamed sine (alpha None: the paper's gap step at 2.5 s);
    after the first second no gap crossing asks for more than twice the
    sine's rigid-body torque."""
    err, peak = _stream_error(stream_design, Td=Td, alpha=alpha, T=5.0, Jl=Jl)
    assert err <= 5e-3
    assert peak <= 2.0 * _sine_torque(Td, Jl)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
@pytest.mark.parametrize(
    "Td, alpha", [(0.5, 0.03), (0.5, 0.06), (1.0, 0.03), (1.0, 0.06), (2.0, 0.06)]
)
def test_quiet_rest_with_small_load_torques(design, Td, alpha, seed):
    """Issue 22, no hunting sampled: 0.5 rad with small load torques on every
    noise seed (alpha 0.06 at 0.5-1 Nm sat 2.2-2.9e-4 rad off on all six
    before the leaning load's integral). Td = 0 meets the torque target
    (`test_no_load_torque_rest_is_quiet_on_every_seed`), not yet these
    error targets on every seed (docs/servo.rst)."""
    m = _run(design, Td=Td, alpha=alpha, seed=seed)
    assert m["settling"] <= 0.25
    assert m["overshoot"] <= 1.0
    assert m["error"] <= 2e-4
    assert m["ptp"] <= 2e-4
    assert m["torque_std"] <= 3.0


def test_streamed_sine_never_latches_a_flank(stream_design):
    """A streamed sine's turning points (the speed crosses zero for a
    sample) are not a rest: the flank latch stays off all along."""
    res = sampled_response(
        twomass.plant(alpha=0.03), stream_design.controller(), 1.2,
        inputs={"Td": 0.0, "theta_r": _sine}, delay=stream_design.delay,
        sensors=ENCODERS, seed=1,
    )  # fmt: skip
    c = res.controller
    assert np.all(c.states[c.state_labels.index("flank_side")] == 0.0)


def _streamed_stop(t):
    """0.2 rad streamed as a quintic over 0.6 s, then held."""
    s = np.clip(np.asarray(t) / 0.6, 0.0, 1.0)
    return 0.2 * s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


@pytest.mark.slow
def test_streamed_set_point_that_stops_rests_latched(stream_design):
    """Td = 0, alpha 0.03: once the streamed set-point holds, the flank
    latches and the torque chatter at rest is a fraction of the continuous
    flank choice's on the same runs. The Td = 0 rest is chaotic (one seed
    is quiet where the next flips the flank a dozen times), so the medians
    over six noise seeds are compared (50 against 128 Nm measured; not yet
    the planned move's 0.4 Nm)."""

    def rest(design, seed):
        res = sampled_response(
            twomass.plant(alpha=0.03), design.controller(), 4.0,
            inputs={"Td": 0.0, "theta_r": _streamed_stop}, delay=design.delay,
            sensors=ENCODERS, seed=seed,
        )  # fmt: skip
        t, c = res.plant.time, res.controller
        last = t >= 3.0
        side = c.states[c.state_labels.index("flank_side")]
        e = res.plant.outputs[2] - _streamed_stop(t)
        return np.std(res.plant.inputs[0][last]), side[last], np.abs(e[last]).max()

    unlatched = twomass.servo_design(
        dt=DT, delay=1, sensors="encoders", reference="stream", certify=False,
        anti_hunting=twomass.ServoAntiHunting(rest_flank=None),
    )  # fmt: skip
    latched_runs = [rest(stream_design, seed) for seed in range(1, 7)]
    unlatched_runs = [rest(unlatched, seed) for seed in range(1, 7)]
    for (_, side, error), (_, old_side, _) in zip(latched_runs, unlatched_runs):
        assert np.all(side != 0.0) and np.all(old_side == 0.0)
        assert error <= 1e-3
    torque = np.median([run[0] for run in latched_runs])
    old_torque = np.median([run[0] for run in unlatched_runs])
    assert torque <= 0.6 * old_torque
