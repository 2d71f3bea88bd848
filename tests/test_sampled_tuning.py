"""The sampled servo's tuning per sample time (issue 22).

The rule of `ctrl_lpv.twomass.sampled_tuning` against the loop that runs:
at 2 ms the certified rest covers the paper's load torque of 8 Nm, and the
certified bounds hold along simulated runs on the exact plant with the
encoders; the fast tuning of 1 ms used at 2 ms rings (its certified floor
and the simulated torque at rest say so).
"""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from _issue22 import grid_mark, knife_edge
from ctrl_lpv import twomass
from ctrl_lpv.twomass.sampled_tuning import (
    ALTERNATING_LIMIT,
    FAST_SAMPLING,
    FLOOR_TARGET,
    QUIET_REST_SAMPLING,
    SampledTuning,
    sampled_tuning,
)
from ctrl_lpv.twomass.servo_compare import run_sampled_servo_scenario
from ctrl_lpv.twomass.servo_rest import _rest_loop


def _run(design, *, Td, alpha, theta_r=0.5, Jl=1.0, T=3.0, seed=1):
    """Settling (2 %), and over the last second: the largest load error, the
    torque's largest deviation from its mean and its standard deviation."""
    res = run_sampled_servo_scenario(
        design, alpha=twomass.alpha_step() if alpha is None else alpha, Jl=Jl,
        Td=Td, theta_r=theta_r, T=T, seed=seed,
    )  # fmt: skip
    t = res.time
    e = res.outputs[res.output_labels.index("theta_l")] - theta_r
    torque = res.outputs[res.output_labels.index("Tm")]
    outside = np.flatnonzero(np.abs(e) > 0.02 * abs(theta_r))
    settling = t[outside[-1] + 1] if outside.size else 0.0
    last = t >= T - 1.0
    return dict(
        settling=settling,
        rest_error=np.abs(e[last]).max(),
        ripple=np.abs(torque[last] - torque[last].mean()).max(),
        torque_std=np.std(torque[last]),
    )


@pytest.fixture(scope="module")
def design_2ms():
    return twomass.servo_design(dt=2e-3, delay=1, sensors="encoders")


def test_rule_by_sample_time():
    fast, slow = sampled_tuning(1e-3), sampled_tuning(2e-3)
    assert isinstance(fast, SampledTuning)
    assert sampled_tuning(FAST_SAMPLING) == fast
    assert sampled_tuning(QUIET_REST_SAMPLING) == fast
    # Faster, the moving observer's gains at rest too (quiet enough there).
    assert sampled_tuning(1.25e-4) == replace(fast, rest_rates=None)
    # The continuous servo's weight and the 3000 / 20 Nm/s observer at 1 ms.
    assert fast.torque_weight == 5e-4
    assert fast.rates == ((3000.0, 20.0),)
    assert slow.torque_weight > fast.torque_weight
    assert len(slow.rates) > 1
    assert all(shaft < 3000.0 for shaft, _ in slow.rates)


@pytest.mark.parametrize("dt", [0.0, -1e-3, "1e-3", None])
def test_rule_refuses_a_bad_sample_time(dt):
    with pytest.raises((TypeError, ValueError), match="dt"):
        sampled_tuning(dt)


def test_rule_can_be_asked_for_either_tuning():
    assert sampled_tuning(1e-3, fast=False) == sampled_tuning(2e-3, fast=False)
    assert sampled_tuning(1e-3, fast=False).rates == sampled_tuning(2e-3).rates
    assert sampled_tuning(2e-3, fast=True).rates == sampled_tuning(1e-3).rates
    with pytest.raises(TypeError, match="fast"):
        sampled_tuning(1e-3, fast="yes")


def _flipping(design):
    """The largest modulus of the rest loop's eigenvalues with a negative
    real part (numpy on the loop's matrix)."""
    loop = _rest_loop(design.params, design.gain[0], design.sampling)
    poles = np.linalg.eigvals(loop.A)
    poles = poles[poles.real < 0.0]
    return np.abs(poles).max() if poles.size else 0.0


@pytest.mark.parametrize("dt", [0.75e-3, 1.25e-3])
def test_fast_tuning_whose_rest_loop_alternates_gives_way_to_the_slow_one(dt):
    """Within the fast tuning's range of sample times, its drive observer
    puts a rest-loop eigenvalue near -1 at some of them (a command that
    flips sign every sample: 0.75, 1.25 and 1.5 ms, where the paper
    scenario chattered at 6-16 Nm at rest): there the design runs the slow
    tuning, whose rest loop has no such mode, and the paper scenario rests
    within the issue's 5 Nm."""
    fast = sampled_tuning(dt)
    forced = twomass.servo_design(
        dt=dt, delay=1, sensors="encoders", certify=False,
        synthesis=twomass.ServoSynthesis(torque_weight=fast.torque_weight),
        estimator=twomass.ServoEstimator(
            shaft_torque_rate=fast.rates[0][0], load_torque_rate=fast.rates[0][1]
        ),
    )  # fmt: skip
    assert _flipping(forced) > ALTERNATING_LIMIT
    design = twomass.servo_design(dt=dt, delay=1, sensors="encoders", certify=False)
    assert _flipping(design) < 0.5
    assert design.sampling.M_rest is None  # the slow tuning's
    m = _run(design, Td=8.0, alpha=0.03, T=3.0)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0
    # Where the fast tuning's rest does not alternate it is kept.
    kept = twomass.servo_design(dt=1e-3, delay=1, sensors="encoders", certify=False)
    assert _flipping(kept) < 0.5 and kept.sampling.M_rest is not None


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda: twomass.ServoEstimator(shaft_torque_rate=-1.0), "shaft_torque_rate"),
        (lambda: twomass.ServoEstimator(load_torque_rate=0.0), "load_torque_rate"),
        (lambda: twomass.ServoEstimator(load_torque_rate="5"), "load_torque_rate"),
        (lambda: twomass.ServoSynthesis(torque_weight=0.0), "torque_weight"),
    ],
)
def test_settings_are_checked(make, name):
    with pytest.raises((TypeError, ValueError), match=name):
        make()


def test_2ms_rest_certificate_covers_the_paper_load_torque(design_2ms):
    """2 ms, one sample of delay: certified, and the rest certificate
    covers |Td| >= 8 Nm (it needed 297 Nm with the 1 ms tuning)."""
    cert = design_2ms.certificate
    assert cert.verified
    assert cert.rest.min_load_torque <= FLOOR_TARGET
    # The floor is what the law's switches need: above twice the contact
    # torque (the contact schedule) whatever the loop.
    assert cert.rest.min_load_torque > 2 * design_2ms.tuning.contact_torque
    assert cert.rest_ripple_bound <= 10.0


def test_the_controller_does_not_depend_on_certify():
    """At 4 ms the rest certificate chooses the drive observer's
    intensities among the rule's (100/5 Nm/s, not the first): the design
    without `certify` runs the same observer (it ran the rule's first) and
    returns no rest bound."""
    designs = [
        twomass.servo_design(dt=4e-3, delay=1, sensors="encoders", certify=certify)
        for certify in (False, True)
    ]
    slow = sampled_tuning(4e-3)
    first = twomass.servo_design(
        dt=4e-3, delay=1, sensors="encoders", certify=False,
        estimator=twomass.ServoEstimator(
            shaft_torque_rate=slow.rates[0][0], load_torque_rate=slow.rates[0][1]
        ),
    )  # fmt: skip
    uncertified, certified = (d.sampling.M for d in designs)
    for mine, theirs, rules_first in zip(uncertified, certified, first.sampling.M):
        np.testing.assert_array_equal(mine, theirs)
        assert not np.allclose(mine, rules_first)
    assert designs[0].certificate.rest_error_bound is None
    assert designs[1].certificate.rest_error_bound > 0.0


def test_certified_time_constant_is_no_faster_than_the_loop(design_2ms):
    """The rest's certified time constant is within the rule's limit and
    not faster than the slowest eigenvalue of the loop that runs, rebuilt
    at each certified inertia with the observer's model on the nominal
    inertia and on the load's."""
    rest = design_2ms.certificate.rest
    assert 0.0 < rest.time_constant <= sampled_tuning(2e-3).max_time_constant
    params = twomass.Parameters()
    for scale, learnt in ((j, d) for j in rest.inertias for d in (0.0, j - 1.0)):
        loop = _rest_loop(
            params.replace(Jl=scale * params.Jl), design_2ms.gain.ravel(),
            design_2ms.sampling, learnt=learnt,
        )  # fmt: skip
        radius = np.abs(np.linalg.eigvals(loop.A)).max()
        assert radius <= np.exp(-2e-3 / rest.time_constant) < 1.0


def test_2ms_paper_scenario_within_the_certified_rest(design_2ms):
    """The paper scenario (Td = 8 Nm, the gap step) at 2 ms on encoders:
    issue 22's targets at 2 ms (settling <= 0.3 s, torque std <= 5 Nm), and
    the certified rest bounds hold over the last second of the run."""
    cert = design_2ms.certificate
    assert 8.0 >= cert.rest.min_load_torque
    # The gap steps at 2.5 s: the last second of 5 s is at rest again.
    m = _run(design_2ms, Td=8.0, alpha=None, T=5.0)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0
    assert m["rest_error"] <= cert.rest_error_bound
    assert m["ripple"] <= cert.rest_ripple_bound


def test_2ms_small_load_torque_rests_latched(design_2ms):
    """2 ms, Td = 1 Nm, alpha 0.06: the rest is quiet (the issue's 5 Nm at
    2 ms). The latch of 3e-4 rad left a relay cycle 4-6e-4 rad short of the
    target at 92 Nm of torque standard deviation (seed 1)."""
    assert (
        sampled_tuning(2e-3).rest_flank.latch_error
        > sampled_tuning(1e-3).rest_flank.latch_error
    )
    m = _run(design_2ms, Td=1.0, alpha=0.06, seed=1)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0
    assert m["rest_error"] <= 2e-4


def test_2ms_small_step_against_a_load_torque(design_2ms):
    """2 ms, Td 3, alpha 0.06, a 0.05 rad step (a row of the bench): within
    issue 22's 2 ms targets. With the torque weight 2e-3 and no crossing
    planned above 1.5 ms it settled in 0.418 s: the load stopped 1.4 mrad
    short on the braking flank, fell back while the flank choice crossed
    the gap after the move, and the soft rest loop took it up slowly."""
    m = _run(design_2ms, Td=3.0, alpha=0.06, theta_r=0.05, seed=1)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0


#: The runs of `test_2ms_grid` that miss (measured; docs/servo.rst, "The
#: slow tuning's moves"): without load torque at alpha 0.06 the rest after
#: a 0.05 rad step is a ping-pong between the flanks (9.2 and 5.7 Nm of
#: torque std; 0.82 and 1.13 s of settling with the torque weight 2e-3), and
#: the 0.05 rad step against Td 8 settles in 0.35-0.37 s. Strict: a run that
#: starts meeting the targets fails here, so that the list is kept true.
_2MS_MISSES = {
    (0.0, 0.06, -0.05),
    (8.0, 0.03, 0.05),
    (8.0, 0.06, 0.05),
}
#: On the knife edge (`_issue22.grid_mark`).
_2MS_EDGE = {
    (0.0, 0.06, 0.05): "a ping-pong at rest on the machine of stop 61, met on that "
    "of stop 62",
}


@pytest.mark.slow
@pytest.mark.parametrize(
    "Td, alpha, theta_r",
    [
        pytest.param(*case, marks=grid_mark(case, _2MS_MISSES, _2MS_EDGE))
        for case in itertools.product(
            (0.0, 3.0, -3.0, 8.0), (0.03, 0.06), (0.05, -0.05, 0.2, -1.0)
        )
    ],
)  # fmt: skip
def test_2ms_grid(design_2ms, Td, alpha, theta_r):
    """Issue 22's 2 ms targets (settling within 0.3 s, torque standard
    deviation at rest within 5 Nm) on first moves of 0.05 to 1 rad both
    ways at the nominal inertia (28 of 32; 21 with the torque weight 2e-3
    and the move's logic off above 1.5 ms)."""
    m = _run(design_2ms, Td=Td, alpha=alpha, theta_r=theta_r, seed=1)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0


@pytest.mark.slow
def test_1ms_tuning_at_2ms_rings(design_2ms):
    """The 1 ms tuning used at 2 ms: its certified floor and ripple are an
    order of magnitude above the rule's, and the simulated torque at rest
    with the paper's load torque chatters more than the issue allows."""
    fast = sampled_tuning(1e-3)
    old = twomass.servo_design(
        dt=2e-3, delay=1, sensors="encoders",
        synthesis=twomass.ServoSynthesis(torque_weight=fast.torque_weight),
        estimator=twomass.ServoEstimator(
            shaft_torque_rate=fast.rates[0][0], load_torque_rate=fast.rates[0][1]
        ),
    )  # fmt: skip
    new = design_2ms.certificate.rest
    assert old.certificate.rest.min_load_torque >= 10 * new.min_load_torque
    assert old.certificate.rest_ripple_bound >= 10 * new.ripple_bound
    m_old = _run(old, Td=8.0, alpha=None, T=5.0)
    m_new = _run(design_2ms, Td=8.0, alpha=None, T=5.0)
    assert m_old["torque_std"] >= 5.0
    assert m_new["torque_std"] <= 0.2 * m_old["torque_std"]


@pytest.mark.slow
@pytest.mark.parametrize(
    "dt, case, settling",
    [
        # Issue 22's 0.3 s with a load inertia off nominal at 2 ms: the
        # inertia estimate learnt at every sample time (0.302 s at Jl x0.8
        # and 0.55 s at Jl x1.2 without it; 0.21 s with it).
        (2e-3, dict(Td=8.0, alpha=0.03, Jl=0.8), 0.3),
        (2e-3, dict(Td=30.0, alpha=0.03), 0.3),
        (2e-3, dict(Td=-10.0, alpha=0.045, Jl=1.2, theta_r=-0.5), 0.3),
        # 125 us keeps the 1 ms tuning: its floor is 28-32 Nm (28.2 on one
        # machine, 31.9 on another: the back-off H2 observer's gains are
        # where the solver stops), so 40 Nm.
        (1.25e-4, dict(Td=40.0, alpha=0.03), 0.3),
    ],
)
def test_certified_rest_holds_along_runs(dt, case, settling):
    """Where the certified rest applies (|Td| at least its floor) its bounds
    hold over the last second, and the torque at rest is within issue 22's
    5 Nm at 125 us and 2 ms."""
    design = twomass.servo_design(dt=dt, delay=1, sensors="encoders")
    cert = design.certificate
    if abs(case["Td"]) < cert.rest.min_load_torque:
        pytest.fail(f"floor {cert.rest.min_load_torque:.3g} Nm above |Td|")
    m = _run(design, T=5.0, **case)
    assert m["rest_error"] <= cert.rest_error_bound
    assert m["ripple"] <= cert.rest_ripple_bound
    assert m["torque_std"] <= 5.0
    assert m["settling"] <= settling


#: The rows of ``benchmarks/bench_sampled_servo.py`` at 2 ms (name, Td,
#: alpha (None: the paper's gap step), Jl, theta_r); the 0.05 rad step at
#: Td 3 is `test_2ms_small_step_against_a_load_torque`. The 0.05 rad step
#: at Jl x0.8 was a strict xfail until the slow tuning's moves (0.53 s on
#: seed 1, 54-56 Nm on other seeds).
_ROWS_2MS = [
    ("paper", 8.0, None, 1.0, 0.5),
    ("Td 5, alpha 0.06, Jl x0.8", 5.0, 0.06, 0.8, 0.5),
    ("Td 5, alpha 0.03, Jl x1.2, -1 rad", 5.0, 0.03, 1.2, -1.0),
    ("Td 2, alpha 0.06", 2.0, 0.06, 1.0, 0.5),
    ("Td 0, alpha 0.03", 0.0, 0.03, 1.0, 0.5),
    ("Td 0, alpha 0.06", 0.0, 0.06, 1.0, 0.5),
    ("Td 1, alpha 0.03", 1.0, 0.03, 1.0, 0.5),
    pytest.param(
        "Td 0, alpha 0.03, Jl x0.8, 0.05 rad",
        0.0,
        0.03,
        0.8,
        0.05,
        marks=knife_edge(
            "0.25-0.26 s on the machine of stop 61, 0.334 s on that of stop 62"
        ),
    ),
    ("Td 0, alpha 0.03, Jl x1.2, 1 rad", 0.0, 0.03, 1.2, 1.0),
    ("Td 30, alpha 0.03", 30.0, 0.03, 1.0, 0.5),
]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5, 6])
def test_2ms_rest_under_a_small_load_torque_is_latched(design_2ms, seed):
    """Issue 22 at 2 ms, Td 5 at Jl x1.2 after a -1 rad move (the load
    overshoots 5 mrad): torque standard deviation at rest within 5 Nm on
    every seed (63-83 Nm on four of six with the latch within 8e-4 rad and
    up to 2 Nm: a relay of the unlatched flank choice), and the latch up
    to 6 Nm stays below the certified floor, so the certified rest never
    latches."""
    latch = design_2ms.tuning.rest_flank.latch_torque
    assert latch < design_2ms.certificate.rest.min_load_torque
    m = _run(design_2ms, Td=5.0, alpha=0.03, Jl=1.2, theta_r=-1.0, seed=seed)
    assert m["settling"] <= 0.3
    assert m["torque_std"] <= 5.0


@pytest.mark.slow
@pytest.mark.parametrize("name, Td, alpha, Jl, theta_r", _ROWS_2MS)
def test_2ms_rows_settle(design_2ms, name, Td, alpha, Jl, theta_r):
    """Issue 22 at 2 ms: settling (2 %) within 0.3 s on the benchmark's
    rows, the load inertia off nominal included (without the inertia
    estimate at 2 ms, main 9ded357, seed 1: Jl x0.8 0.300 s, Jl x1.2 -1 rad
    0.386 s, Jl x0.8 0.05 rad 1.12 s, Jl x1.2 1 rad 0.382 s)."""
    m = _run(design_2ms, Td=Td, alpha=alpha, Jl=Jl, theta_r=theta_r, T=1.5)
    assert m["settling"] <= 0.3
