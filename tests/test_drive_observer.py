"""The drive observer against independent facts.

The gains are checked on frozen error dynamics rebuilt with python-control's
own zero-order hold (vertices and the interior of the contact range); the
estimates against the exact backlash plant (Nordin, Galic and Gutman's
model, integrated between samples) driven across the gap, read through
quantizing encoders, and compared with what raw differencing of the same
encoder readings gives.
"""

import control as ct
import numpy as np
import pytest

from ctrl_lpv import sampled_response, twomass
from ctrl_lpv.exceptions import InfeasibleError
from ctrl_lpv.sensors import Encoder
from ctrl_lpv.twomass.drive_observer import DRIVE_STATES

DT = 1e-3


@pytest.fixture(scope="module")
def design():
    return twomass.drive_observer(dt=DT)


def _continuous(contact):
    """The estimation model at a frozen contact, continuous time, by hand."""
    p = twomass.Parameters()
    Jm, Jl, cm, cl, ks, cs = p.Jm, p.Jl, p.cm, p.cl, p.ks, p.cs
    # Rows: theta_m, omega_m, Ts, theta_l, omega_l, Td.
    dwm = np.array([0, -cm / Jm, -1 / Jm, 0, 0, 0])
    dwl = np.array([0, 0, 1 / Jl, 0, -cl / Jl, -1 / Jl])
    dts = contact * (ks * np.array([0, 1, 0, 0, -1, 0]) + cs * (dwm - dwl))
    A = np.array([[0, 1, 0, 0, 0, 0], dwm, dts, [0, 0, 0, 0, 1, 0], dwl, np.zeros(6)])
    B = np.array([[0, 1 / Jm, contact * cs / Jm, 0, 0, 0]]).T
    return ct.ss(A, B, np.eye(6), 0)


def test_error_dynamics_schur_across_the_contact_range(design):
    assert design.certificate.verified
    assert design.scheduled
    C = np.zeros((2, 6))
    C[0, 0] = C[1, 3] = 1.0
    for contact in np.linspace(0.0, 1.0, 11):
        Phi = ct.c2d(_continuous(contact), DT, "zoh").A
        L = design.gain([contact])
        radius = np.abs(np.linalg.eigvals(Phi - L @ C)).max()
        assert radius < 1.0, (contact, radius)


def _run(design, torque, Td, T=2.0, seed=3):
    est = twomass.drive_estimator(design)

    def update(t, x, u, params=None):
        return est._rhs(t, x, [u[0], u[1], torque(t)])

    drive = ct.NonlinearIOSystem(
        update, lambda t, x, u, params=None: [torque(t)],
        inputs=["theta_m", "theta_l"], outputs=["Tm"], states=est.state_labels,
        dt=DT, name="drive",
    )  # fmt: skip
    sensors = {"theta_m": Encoder(2**20, 0.5), "theta_l": Encoder(2**17, 0.5)}
    return sampled_response(
        twomass.plant(alpha=0.03), drive, T, inputs={"Td": Td},
        sensors=sensors, seed=seed,
    )  # fmt: skip


def test_estimates_across_the_gap_beat_differencing(design):
    def torque(t):  # reverses four times a second: gap crossings, impacts
        return 40 * np.sin(2 * np.pi * 2 * t) + 10 * np.sin(2 * np.pi * 5.3 * t)

    res = _run(design, torque, Td=3.0)
    X, Y = res.controller.states, res.plant.outputs  # plant: omega_m 1, omega_l 3, Ts 4
    t = res.controller.time
    keep = t >= 0.1
    crossing = np.mean(Y[4][keep] == 0.0)
    assert 0.2 < crossing < 0.8  # the run spends real time in the gap

    def rms(v):
        return float(np.sqrt(np.mean(np.square(v))))

    measured = res.controller.inputs
    for state, out, angle in (("omega_m", 1, 0), ("omega_l", 3, 1)):
        i = DRIVE_STATES.index(state)
        err = rms(X[i][keep] - Y[out][keep])
        differenced = np.diff(measured[angle]) / DT
        err_diff = rms(differenced[keep[1:]] - Y[out][1:][keep[1:]])
        assert err < 0.6 * err_diff, state
        assert err < 0.03 * rms(Y[out][keep]), state
    load = DRIVE_STATES.index("omega_l")
    assert rms(X[load][keep] - Y[3][keep]) < 0.1 * err_diff
    shaft = DRIVE_STATES.index("Ts")
    assert rms(X[shaft][keep] - Y[4][keep]) < 0.15 * rms(Y[4][keep])
    # The load torque, constant, is found although it never acts alone.
    late = t >= 1.0
    assert abs(np.mean(X[DRIVE_STATES.index("Td")][late]) - 3.0) < 0.5


def test_motor_encoder_alone_is_refused_with_the_gap_named():
    with pytest.raises(InfeasibleError, match="contact.: 0.0.*theta_l"):
        twomass.drive_observer(dt=DT, sensors="motor")


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"dt": 0.0}, "dt"),
        ({"dt": DT, "sensors": "load"}, "sensors"),
        ({"dt": DT, "encoder_counts": (2**20,)}, "encoder_counts"),
        ({"dt": DT, "encoder_counts": (2**20, 1.5)}, "encoder_counts"),
        ({"dt": DT, "shaft_torque_rate": -1.0}, "shaft_torque_rate"),
    ],
)
def test_bad_arguments_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        twomass.drive_observer(**kwargs)
