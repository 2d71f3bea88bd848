"""A certified estimator of the two-mass drive from its encoders.

A drive measures angles, quantized by its encoders, once per sample; the
servo needs the speeds, the shaft torque and the load torque. Raw
differencing of a 17-bit load encoder at 1 ms gives a speed quantized to
0.048 rad/s, which the servo's load-speed gain turns into tens of Nm of
torque chatter. `drive_observer` estimates them instead, with the backlash
handled as what it is: the shaft torque is a state of its own,

* in contact (the backlash angle at a flank, constant), ``dTs/dt = ks
  omega_d + cs d(omega_d)/dt`` exactly (Nordin, Galic and Gutman's model);
* in the gap ``Ts = 0``, so ``dTs/dt = 0``,

that is ``dTs/dt = c (ks omega_d + cs d(omega_d)/dt) + w_Ts`` with the
*contact* ``c`` in ``[0, 1]``: a polytopic model with two vertices (gap,
contact), plus a random-walk load torque ``Td``. Neither vertex knows the
gap width or which flank is in contact, so the estimate never depends on
the backlash estimate. The gains are an H2 (Kalman-like) observer of the
sampled polytope (`ctrl_lpv.observer`, one gain per vertex scheduled with
``c``, a common Lyapunov matrix: certified for any switching between gap
and contact), against encoder quantization and torque-rate noise.

`drive_estimator` runs it once per sample as a discrete-time python-control
system, scheduled on its own shaft-torque estimate. The certificate assumes
the contact ``c`` known; scheduling it on the estimate is not certified (a
contact made or lost between estimates is a model error for one or two
samples), which the tests check by simulation on the exact plant.

With the motor encoder alone the load is not observable in the gap (no
torque reaches it): `drive_observer` refuses ``sensors="motor"`` with the
gap vertex and its unobservable mode named.
"""

from __future__ import annotations

import math

import control as ct
import numpy as np

from .._checks import real_number
from ..estimation import ObserverDesign, observer
from ..synthesis import H2
from ..systems import PolytopicStateSpace
from .parameters import Parameters
from .sampled_tuning import sampled_tuning

__all__ = [
    "DRIVE_STATES", "drive_model", "drive_observer", "drive_estimator",
    "observer_matrices",
]  # fmt: skip

#: States of the estimation model, in order.
DRIVE_STATES = ["theta_m", "omega_m", "Ts", "theta_l", "omega_l", "Td"]
_SENSORS = {"encoders": ["theta_m", "theta_l"], "motor": ["theta_m"]}


def drive_model(
    params: Parameters | None = None,
    *,
    dt: float,
    encoder_counts=(2**20, 2**17),
    shaft_torque_rate: float = 3000.0,
    load_torque_rate: float = 20.0,
) -> PolytopicStateSpace:
    """The drive as its encoders see it, sampled: the observer's model.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data (``alpha`` is not used).
    dt : float
        Sample time, s (zero-order hold of the torque).
    encoder_counts : (int, int), optional
        Counts per revolution of the motor and load encoders; their
        quantization noise (standard deviation ``step / sqrt(12)``) is the
        unit of the measurement-noise inputs.
    shaft_torque_rate, load_torque_rate : float, optional
        Intensities of the random walks of ``Ts`` (what the contact model
        misses: impacts, transitions) and ``Td``, Nm/s per unit input.

    Returns
    -------
    `ctrl_lpv.PolytopicStateSpace`
        Discrete time (``dt``), parameter ``contact`` in ``[0, 1]`` (0: the
        gap, 1: contact), states `DRIVE_STATES`, inputs ``["Tm", "w_Ts",
        "w_Td", "n_m", "n_l"]``, outputs ``["theta_m", "theta_l",
        "omega_m_err", "omega_l_err", "Ts_err"]`` (the measured angles,
        then the weighted states whose estimation error the H2 observer
        minimises: speeds in rad/s, the shaft torque in kNm).
    """
    params = Parameters() if params is None else params
    if not isinstance(params, Parameters):
        raise TypeError(f"params: expected twomass.Parameters, got {type(params)!r}")
    dt = real_number(dt, "dt", positive=True)
    steps = _encoder_steps(encoder_counts)
    rates = [
        real_number(shaft_torque_rate, "shaft_torque_rate", positive=True),
        real_number(load_torque_rate, "load_torque_rate", positive=True),
    ]
    Jm, Jl, cm, cl, ks, cs = (
        params.Jm, params.Jl, params.cm, params.cl, params.ks, params.cs
    )  # fmt: skip
    vertices = []
    for c in (0.0, 1.0):
        A = np.zeros((6, 6))
        B = np.zeros((6, 5))
        A[0, 1] = 1.0
        A[1, [1, 2]] = [-cm / Jm, -1.0 / Jm]
        B[1, 0] = 1.0 / Jm
        A[3, 4] = 1.0
        A[4, [2, 4, 5]] = [1.0 / Jl, -cl / Jl, -1.0 / Jl]
        # Contact: dTs/dt = ks omega_d + cs d(omega_d)/dt.
        A[2] = c * cs * (A[1] - A[4])
        A[2, [1, 4]] += c * ks * np.array([1.0, -1.0])
        B[2, 0] = c * cs / Jm
        B[2, 1], B[5, 2] = rates
        C = np.zeros((5, 6))
        C[0, 0] = C[1, 3] = 1.0
        C[2, 1] = C[3, 4] = 1.0
        C[4, 2] = 1e-3
        D = np.zeros((5, 5))
        D[0, 3], D[1, 4] = steps / math.sqrt(12.0)
        vertices.append(ct.ss(A, B, C, D))
    model = PolytopicStateSpace(
        vertices, {"contact": (0.0, 1.0)},
        inputs=["Tm", "w_Ts", "w_Td", "n_m", "n_l"],
        outputs=["theta_m", "theta_l", "omega_m_err", "omega_l_err", "Ts_err"],
        states=DRIVE_STATES, name="twomass_encoders",
    )  # fmt: skip
    return model.sample(dt)


def drive_observer(
    params: Parameters | None = None,
    *,
    dt: float,
    sensors: str = "encoders",
    encoder_counts=(2**20, 2**17),
    shaft_torque_rate: float | None = None,
    load_torque_rate: float | None = None,
    backoff: float | None = 0.2,
) -> ObserverDesign:
    """Certified H2 observer of the drive's speeds and torques from encoders.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data.
    dt : float
        Sample time, s.
    sensors : {"encoders", "motor"}, optional
        Motor and load encoders (default), or the motor encoder alone
        (refused: the load is not observable in the gap).
    encoder_counts : (int, int), optional
        Counts per revolution of the motor and load encoders (their
        quantization is the measurement noise the gains weigh).
    shaft_torque_rate, load_torque_rate : float or None, optional
        Intensities of the random walks of ``Ts`` and ``Td``, Nm/s: larger
        values give faster, noisier estimates of the torques. None (the
        default): the first intensities of
        `ctrl_lpv.twomass.sampled_tuning.sampled_tuning` for `dt`.
    backoff : float or None, optional
        Relax the minimal H2 bound by this fraction for a well-conditioned
        Lyapunov matrix (default 0.2; None: the raw optimum).

    Returns
    -------
    `ctrl_lpv.ObserverDesign`
        Gains scheduled with ``contact`` (predictor form ``x_hat[k+1] = Phi
        x_hat[k] + Gamma Tm[k] + L (y[k] - C x_hat[k])``), the certified H2
        bound and the certificate of the error dynamics.

    Raises
    ------
    InfeasibleError
        For ``sensors="motor"``: the gap vertex is not detectable from the
        motor angle (the load's angle and speed, and ``Td``, do not reach
        it).
    ValueError
        For an unknown `sensors`.
    """
    if sensors not in _SENSORS:
        raise ValueError(f"sensors: expected 'encoders' or 'motor', got {sensors!r}")
    rule = sampled_tuning(dt).rates[0]
    shaft_torque_rate = rule[0] if shaft_torque_rate is None else shaft_torque_rate
    load_torque_rate = rule[1] if load_torque_rate is None else load_torque_rate
    model = drive_model(
        params, dt=dt, encoder_counts=encoder_counts,
        shaft_torque_rate=shaft_torque_rate, load_torque_rate=load_torque_rate,
    )  # fmt: skip
    return observer(
        model, _SENSORS[sensors], u="Tm", w=["w_Ts", "w_Td", "n_m", "n_l"],
        z=["omega_m_err", "omega_l_err", "Ts_err"], objective=H2(), backoff=backoff,
    )  # fmt: skip


def drive_estimator(
    design: ObserverDesign,
    *,
    contact_torque: float = 1.5,
    name: str = "drive_estimator",
) -> ct.NonlinearIOSystem:
    """The drive observer as a discrete-time I/O system, scheduled on itself.

    At each sample ``t_k`` it reads the encoder angles and the torque
    ``Tm`` applied over ``[t_k, t_{k+1})``, outputs the filtered estimate
    ``x_hat[k|k] = x_hat[k|k-1] + Phi^-1 L (y[k] - C x_hat[k|k-1])`` and
    updates its state to ``x_hat[k+1|k]``. The contact is scheduled on the
    predicted shaft torque: 0 below `contact_torque`, 1 above twice it,
    smooth between.

    Parameters
    ----------
    design : `ctrl_lpv.ObserverDesign`
        From `drive_observer`.
    contact_torque : float, optional
        Shaft torque, Nm, below which the estimate counts as the gap.
    name : str, optional
        System name.

    Returns
    -------
    `control.NonlinearIOSystem`
        ``dt`` of the design; inputs ``["theta_m", "theta_l", "Tm"]`` (the
        plant's names), outputs and states ``<state>_hat`` for
        `DRIVE_STATES`.
    """
    if not isinstance(design, ObserverDesign):
        raise TypeError(f"design: expected an ObserverDesign, got {type(design)!r}")
    tc = real_number(contact_torque, "contact_torque", positive=True)
    Phi, Gam, M = observer_matrices(design)
    rows = [DRIVE_STATES.index(s) for s in design.y]

    def blend(pair, c):
        return pair[0] + c * (pair[1] - pair[0])

    def correct(x, u):
        c = _smoothstep(abs(x[2]) / tc - 1.0)
        innovation = np.asarray(u[: len(rows)], float) - x[rows]
        return c, x + blend(M, c) @ innovation

    def output(t, x, u, params=None):
        return correct(x, u)[1]

    def update(t, x, u, params=None):
        c, filtered = correct(x, u)
        return blend(Phi, c) @ filtered + blend(Gam, c) * u[-1]

    hats = [f"{s}_hat" for s in DRIVE_STATES]
    inputs = [s for s in ("theta_m", "theta_l") if s in design.y] + ["Tm"]
    return ct.NonlinearIOSystem(
        update, output, inputs=inputs, outputs=hats, states=hats,
        dt=design.system.dt, name=name,
    )  # fmt: skip


def observer_matrices(design: ObserverDesign):
    """``(Phi, Gamma, M)`` at the gap and in contact: the sampled model, its
    torque column and the filter gain ``M = Phi^-1 L`` of the current
    estimate ``x_hat[k|k] = x_hat[k|k-1] + M (y[k] - C x_hat[k|k-1])``."""
    frozen = [design.system.at([c]) for c in (0.0, 1.0)]
    Phi = tuple(f.A for f in frozen)
    Gamma = tuple(f.B[:, 0] for f in frozen)
    M = tuple(np.linalg.solve(P, design.gain([c])) for P, c in zip(Phi, (0.0, 1.0)))
    return Phi, Gamma, M


def _encoder_steps(counts) -> np.ndarray:
    """Quantization steps, rad, of ``(motor, load)`` encoder counts."""
    try:
        values = [int(c) for c in counts]
    except (TypeError, ValueError):
        raise ValueError(
            f"encoder_counts: expected (motor, load) counts per revolution, got "
            f"{counts!r}"
        ) from None
    if len(values) != 2 or min(values) < 2 or values != list(counts):
        raise ValueError(
            "encoder_counts: expected two integer counts per revolution >= 2, got "
            f"{counts!r}"
        )
    return 2.0 * math.pi / np.asarray(values, float)


def _smoothstep(s: float) -> float:
    """0 below 0, 1 above 1, ``s^2 (3 - 2 s)`` between."""
    s = min(max(s, 0.0), 1.0)
    return s * s * (3.0 - 2.0 * s)
