"""The README's example, run as written, closes a loop that stabilizes."""

import contextlib
import io
import pathlib
import re
import warnings

import control as ct
import numpy as np
import pytest
import scipy.linalg

import ctrl_lpv as lpv

README = pathlib.Path(__file__).resolve().parents[1] / "README.md"


def example_code() -> str:
    """The first ```python block of the README's "Example" section."""
    text = README.read_text()
    section = text.split("\n## Example\n", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    assert blocks, "no python code block in the README's Example section"
    return blocks[0]


@pytest.fixture(scope="module")
def example():
    namespace = {"__name__": "readme_example"}
    out = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stdout(out):
        # An unconnected signal is only a warning in python-control.
        warnings.simplefilter("error")
        exec(compile(example_code(), str(README), "exec"), namespace)
    namespace["stdout"] = out.getvalue()
    return namespace


def frozen_gain(design, k):
    """K(k): the vertex gains combined with the convex coordinate of k."""
    lam = (k - 1.0) / 3.0  # k in [1, 4]
    return (1 - lam) * design.gains[0] + lam * design.gains[1]


def frozen_closed_loop(design, k):
    """A(k) - B_u K(k), from the README's numbers, written here."""
    A = np.array([[0.0, 1.0], [-k, -0.5]])
    Bu = np.array([[0.0], [1.0]])
    return A - Bu @ frozen_gain(design, k)


def test_example_runs_and_its_own_loop_settles(example):
    assert "StateFeedbackDesign" in example["stdout"]
    resp = example["resp"]
    # From q = 1, the closed loop the README simulates is back at rest.
    assert np.all(np.abs(resp.outputs[:2, -1]) < 1e-4)
    assert abs(resp.outputs[0, 0] - 1.0) < 1e-12


@pytest.mark.parametrize("k", [1.0, 1.7, 4.0])
def test_connected_by_name_matches_the_frozen_closed_loop(example, k):
    plant, ctrl, design = example["plant"], example["ctrl"], example["design"]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # every input of both blocks connected
        loop = ct.interconnect(
            [plant, ctrl], inputs=["w", "k"], outputs=["q", "v", "u", "uw"]
        )
    Acl = frozen_closed_loop(design, k)
    eig = np.linalg.eigvals(Acl)
    assert eig.real.max() < 0  # stabilizing at this frozen k
    T = np.linspace(0.0, 8.0, 81)
    x0 = np.array([1.0, -0.5])
    # ctrl_lpv's simulation of the python-control loop (python-control's
    # own input_output_response runs in the README itself).
    resp = lpv.simulate(loop, T, [0 * T, k + 0 * T], x0, rtol=1e-10, atol=1e-12)
    expected = np.column_stack([scipy.linalg.expm(Acl * t) @ x0 for t in T])
    np.testing.assert_allclose(resp.outputs[:2], expected, atol=1e-7)
    # u = -K(k) x is what reached the plant (the loop is closed).
    u = -(frozen_gain(design, k) @ expected)[0]
    np.testing.assert_allclose(resp.outputs[2], u, atol=1e-6)
    np.testing.assert_allclose(resp.outputs[3], 0.1 * u, atol=1e-7)
    # Convergence at the rate of the slowest closed-loop eigenvalue.
    norms = np.linalg.norm(resp.outputs[:2], axis=0)
    assert norms[-1] < 1e-3 * norms[0]
    assert norms[-1] <= 10 * norms[0] * np.exp(0.9 * eig.real.max() * T[-1])


@pytest.fixture(scope="module")
def composable():
    text = README.read_text()
    section = text.split("\n## Objectives, Lyapunov functions and discrete time\n", 1)[
        1
    ]
    code = re.findall(r"```python\n(.*?)```", section.split("\n## ", 1)[0], flags=re.S)[
        0
    ]
    namespace = {"__name__": "readme_composable"}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(compile(code, str(README), "exec"), namespace)
    return namespace


def test_composable_example_bounds_its_frozen_loops(composable):
    design, dt_design = composable["design"], composable["dt_design"]
    h2, hinf = sorted(design.bounds.values())
    assert hinf < 1.0
    for k in np.linspace(1.0, 4.0, 13):
        A, B, C, D = ct.ssdata(design.closed_loop({"k": k}))
        loop = ct.ss(A, B, C, D)
        assert ct.norm(loop, 2) <= h2
        assert ct.linfnorm(loop)[0] < 1.0
        A, B, C, D = ct.ssdata(dt_design.closed_loop({"k": k}))
        assert np.abs(np.linalg.eigvals(A)).max() < 1
        assert ct.linfnorm(ct.ss(A, B, C, D, dt=0.05))[0] <= dt_design.gamma
