"""Sampled-data simulation against python-control's own discrete-time loops.

A linear plant under a zero-order hold is exactly its ZOH discretization at
the sampling instants (`control.sample_system`), so every loop here has an
independent reference: the discretized plant and the controller
interconnected in discrete time by `control.interconnect` and simulated by
`control.input_output_response`.
"""

import control as ct
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from ctrl_lpv import Encoder, Noise, Quantizer, sampled_response
from ctrl_lpv.sensors import chain

DT = 0.05


@pytest.fixture
def plant():
    return ct.ss(
        [[0.0, 1.0], [-2.0, -0.5]], [[0.0, 0.0], [1.0, 0.3]], np.eye(2),
        np.zeros((2, 2)), inputs=["u", "d"], outputs=["y", "v"], name="P",
    )  # fmt: skip


def pi_controller(dt=DT):
    """A PI position loop with speed damping: one state, a reference input."""
    return ct.ss(
        [[1.0]], [[dt, -dt, 0.0]], [[2.0]], [[4.0, -4.0, -1.5]], dt=dt,
        inputs=["r", "y", "v"], outputs=["u"], states=["xi"], name="C",
    )  # fmt: skip


def reference_loop(plant, controller, delay):
    """The same loop from python-control's discretization, delays as states."""
    dt = controller.dt
    names = ["u"] + [f"u_{i}" for i in range(delay)]  # u_{delay-1} = computed
    computed = ct.ss(*ct.ssdata(controller), dt=dt, inputs=controller.input_labels,
                     outputs=[names[-1]], name="C")  # fmt: skip
    delays = [
        ct.ss([[0.0]], [[1.0]], [[1.0]], [[0.0]], dt=dt, inputs=[names[i + 1]],
              outputs=[names[i]], name=f"z{i}")
        for i in range(delay)
    ]  # fmt: skip
    return ct.interconnect([ct.sample_system(plant, dt), computed, *delays],
                           inplist=["r", "d"], outlist=["y", "v"])  # fmt: skip


@pytest.mark.parametrize("delay", [0, 1, 2])
def test_matches_the_zoh_discretization(plant, delay):
    controller = pi_controller()
    r = sampled_response(plant, controller, 3.0, inputs={"r": 0.5, "d": -0.2},
                         X0=[0.1, 0.0], delay=delay)  # fmt: skip
    loop = reference_loop(plant, controller, delay)
    steps = r.controller.time.size
    x0 = np.zeros(loop.nstates)
    x0[:2] = [0.1, 0.0]
    ref = ct.input_output_response(
        loop, np.arange(steps) * DT, np.array([[0.5], [-0.2]]) * np.ones(steps), x0
    )
    np.testing.assert_allclose(r.plant.outputs, ref.outputs, atol=1e-7)
    # The controller read exactly the plant's outputs (no sensors given).
    np.testing.assert_array_equal(r.controller.inputs[1], r.plant.outputs[0])


def test_recording_points_follow_the_continuous_plant(plant):
    """Between samples the plant moves freely under the held command."""
    controller = pi_controller()
    r = sampled_response(plant, controller, 1.0, inputs={"r": 1.0, "d": 0.0},
                         points_per_sample=5)  # fmt: skip
    assert r.plant.time.size == 5 * 20 + 1
    held = r.plant.inputs[0]
    # The command is constant on each interval [t_k, t_k+1).
    assert np.ptp(held[:-1].reshape(20, 5), axis=1).max() == 0.0
    # From t_1 with the held command, the plant's own step response.
    k = 3
    seg = slice(5 * k, 5 * k + 6)
    t = r.plant.time[seg] - r.plant.time[5 * k]
    ref = ct.input_output_response(
        plant, t, np.vstack([np.full(t.size, held[5 * k]), np.zeros(t.size)]),
        r.plant.states[:, 5 * k],
    )  # fmt: skip
    np.testing.assert_allclose(r.plant.states[:, seg], ref.states, atol=1e-6)


def test_continuous_external_input_acts_between_samples(plant):
    """A callable input is evaluated inside the integration, not held."""
    controller = ct.ss([], [], [], [[0.0]], dt=DT, inputs=["y"], outputs=["u"])
    r = sampled_response(plant, controller, 2.0,
                         inputs={"d": lambda t: np.sin(3.0 * t)})  # fmt: skip
    A, B = plant.A, plant.B

    def rhs(t, x):
        return A @ x + B[:, 1] * np.sin(3.0 * t)

    ref = solve_ivp(rhs, (0.0, 2.0), [0.0, 0.0], t_eval=r.plant.time,
                    rtol=1e-10, atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(r.plant.states, ref.y, atol=1e-7)


def test_encoder_readings_are_on_its_grid_and_seeded(plant):
    controller = pi_controller()
    counts = 2**12
    step = 2 * np.pi / counts
    kw = dict(inputs={"r": 0.5, "d": 0.0}, sensors={"y": Encoder(counts, noise=0.5)})
    a = sampled_response(plant, controller, 2.0, seed=3, **kw)
    b = sampled_response(plant, controller, 2.0, seed=3, **kw)
    c = sampled_response(plant, controller, 2.0, seed=4, **kw)
    read = a.controller.inputs[1]
    np.testing.assert_allclose(read / step, np.round(read / step), atol=1e-9)
    true = a.plant.outputs[0]
    # Half a count of noise: a reading is rarely more than 3 counts off.
    assert np.abs(read - true).max() < 3.5 * step
    np.testing.assert_array_equal(read, b.controller.inputs[1])
    assert not np.array_equal(read, c.controller.inputs[1])


def test_noiseless_quantizer_rounds():
    rng = np.random.default_rng(0)
    q = Quantizer(0.25)
    assert q(0.3, rng) == 0.25 and q(-0.4, rng) == -0.5
    sensor = chain(Noise(0.0), Quantizer(0.5))
    assert sensor(0.74, rng) == 0.5


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (dict(controller=ct.ss([], [], [], [[1.0]], inputs=["y"], outputs=["u"])),
         "controller"),
        (dict(plant=ct.ss([[0.9]], [[1.0, 0.0]], [[1.0], [0.0]], np.zeros((2, 2)),
                          dt=DT, inputs=["u", "d"], outputs=["y", "v"])), "plant"),
        (dict(inputs={"r": 1.0}), "'d'"),
        (dict(inputs={"d": 0.0}), "'r'"),
        (dict(inputs={"r": 1.0, "d": 0.0, "typo": 1.0}), "typo"),
        (dict(sensors={"v_typo": Quantizer(0.1)}), "sensors"),
        (dict(delay=-1), "delay"),
        (dict(T=-1.0), "T"),
        (dict(points_per_sample=0), "points_per_sample"),
        (dict(initial_command={"d": 1.0}), "initial_command"),
        (dict(X0=[1.0, 2.0, 3.0]), "X0"),
    ],
)  # fmt: skip
def test_bad_arguments_are_named(plant, change, match):
    args = dict(plant=plant, controller=pi_controller(), T=1.0,
                inputs={"r": 1.0, "d": 0.0})  # fmt: skip
    args.update(change)
    with pytest.raises((ValueError, TypeError), match=match):
        sampled_response(args.pop("plant"), args.pop("controller"), args.pop("T"),
                         **args)  # fmt: skip


def _two_mass_pd(dt=1e-3):
    """A saturated PD position loop on the two-mass drive, sampled."""
    from ctrl_lpv import twomass

    K = twomass.paper_gain()[0]

    def out(t, x, u, params=None):
        tm, wm, tl, wl, tr = u
        v = -(K[0] * (tm - tr) + K[1] * wm + K[2] * (tl - tr) + K[3] * wl)
        return [min(max(v, -500.0), 500.0)]

    return ct.nlsys(
        None, out, inputs=["theta_m", "omega_m", "theta_l", "omega_l", "theta_r"],
        outputs=["Tm"], dt=dt, name="pd",
    )  # fmt: skip


def test_two_mass_plant_steps_compiled_as_with_scipy():
    """The exact backlash plant offers a compiled `advance`: the run agrees
    with the LSODA path (the plant without it) and with a tight LSODA."""
    pytest.importorskip("numba")
    import dataclasses

    from ctrl_lpv import twomass

    def without_advance(plant):
        plant._kernel = dataclasses.replace(plant._kernel, advance=None)
        return plant

    controller = _two_mass_pd()
    fast = twomass.plant(alpha=0.03)
    assert fast._kernel.advance is not None
    args = (controller, 0.3)
    kw = dict(inputs={"theta_r": 0.5, "Td": 8.0}, points_per_sample=2)
    ours = sampled_response(fast, *args, **kw)
    lsoda = sampled_response(without_advance(twomass.plant(alpha=0.03)), *args, **kw)
    tight = sampled_response(without_advance(twomass.plant(alpha=0.03)), *args,
                             rtol=1e-12, atol=1e-14, **kw)  # fmt: skip
    # The load moved, and the shaft crossed the gap both ways: a real test.
    theta_b = ours.plant.states[4]
    assert ours.plant.states[2, -1] > 0.1
    assert theta_b.max() > 0.029 and theta_b.min() < -0.029
    for r in (ours, lsoda):
        np.testing.assert_array_equal(r.plant.time, tight.plant.time)
        np.testing.assert_array_equal(r.controller.time, tight.controller.time)
    # Angles (rad) and speeds (rad/s) at the default rtol 1e-8: LSODA is
    # within 1e-7 of the tight run here, the compiled steps no further.
    for r in (ours, lsoda):
        err = np.abs(r.plant.states - tight.plant.states).max(axis=1)
        assert np.all(err[[0, 2, 4]] < 1e-7) and np.all(err[[1, 3]] < 1e-5), err
        np.testing.assert_allclose(r.controller.outputs, tight.controller.outputs,
                                   atol=1e-3)  # fmt: skip
    # A load torque that varies within the samples is integrated by LSODA.
    vary = dict(inputs={"theta_r": 0.5, "Td": lambda t: 8.0 * t})
    a = sampled_response(twomass.plant(alpha=0.03), controller, 0.05, **vary)
    b = sampled_response(
        without_advance(twomass.plant(alpha=0.03)), controller, 0.05, **vary
    )
    np.testing.assert_array_equal(a.plant.states, b.plant.states)
