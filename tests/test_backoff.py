"""The default back-off: one convex-concave step from the certified optimum.

Checked against facts outside the back-off: the frozen loops' H-infinity
norms (``control.linfnorm``), the raw optimum's design (``backoff=None``)
and the solver calls each design made.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from _direct_reference import channels, frozen_loop, random_vertices

W, U, Z = [0], [1, 2], [0, 1, 2]


def _largest_gain(design):
    return max(np.linalg.norm(K, 2) for K in design.gains)


@pytest.mark.parametrize("seed, scheduled", [(1, True), (2, False), (3, True)])
def test_default_backoff_is_one_solve_beyond_the_optimum(seed, scheduled):
    vertices = random_vertices(4, 4, seed=seed)
    sys = lpv.pss(vertices)
    function = lpv.gain_scheduled_hinf if scheduled else lpv.hinf_state_feedback
    raw = function(sys, w=W, u=U, z=Z, backoff=None)
    design = function(sys, w=W, u=U, z=Z)
    assert design.certificate.verified
    # Issue 20: the back-off in one extra solve.
    assert len(design.attempts) == len(raw.attempts) + 1
    assert design.gamma_opt == pytest.approx(raw.gamma_opt, rel=1e-9)
    assert raw.gamma <= design.gamma <= 1.2 * design.gamma_opt * (1 + 1e-9)
    # The certified bound holds on the frozen loops (vertices, random points).
    data = channels(vertices, W, U, Z)
    rng = np.random.default_rng(seed)
    points = [*np.eye(len(vertices)), *rng.dirichlet(np.ones(len(vertices)), 8)]
    worst = max(
        ct.linfnorm(ct.ss(*frozen_loop(data, design.gains, d)))[0] for d in points
    )
    assert worst <= design.gamma
    # The step's tangent is exact at the optimum, which it may keep: the
    # gain never grows, and the slack in the bound buys a smaller one.
    assert _largest_gain(design) < _largest_gain(raw)


def test_the_one_steps_loose_gap_tolerance_keeps_its_point(monkeypatch):
    """The one step solved to Clarabel's default gap tolerance and to
    `STEP_GAP_TOL`: the same gain to 1e-4, both certified, fewer iterations.

    The step's point is verified in float64 like any other; the digits of
    its objective the default tolerance buys cost iterations only.
    """
    import clarabel

    from ctrl_lpv.synthesis import stages

    iterations = []
    original = clarabel.DefaultSolver

    class Counted:
        def __init__(self, *args, **kwargs):
            self._solver = original(*args, **kwargs)

        def solve(self):
            solution = self._solver.solve()
            iterations.append(int(solution.iterations))
            return solution

        def __getattr__(self, name):
            return getattr(self._solver, name)

    monkeypatch.setattr(clarabel, "DefaultSolver", Counted)
    sys = lpv.pss(random_vertices(8, 16, seed=1))
    designs, steps = {}, {}
    for tol in (None, stages.STEP_GAP_TOL):
        monkeypatch.setattr(stages, "STEP_GAP_TOL", tol)
        del iterations[:]
        designs[tol] = lpv.gain_scheduled_hinf(sys, w=W, u=U, z=Z)
        assert designs[tol].certificate.verified
        assert len(iterations) == 2  # the optimum, the one step
        steps[tol] = iterations[-1]
    tight, loose = designs[None], designs[stages.STEP_GAP_TOL]
    assert _largest_gain(loose) == pytest.approx(_largest_gain(tight), rel=1e-4)
    assert loose.gamma == pytest.approx(tight.gamma, rel=1e-4)
    assert steps[stages.STEP_GAP_TOL] < steps[None]
