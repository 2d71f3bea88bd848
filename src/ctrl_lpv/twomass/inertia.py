"""The load inertia, learnt by the sampled servo along its moves.

The servo's feedforward and its drive observer (`drive_observer`) use the
nominal load inertia ``Jl``. On a load heavier or lighter than that both
are wrong in proportion to the load's acceleration: the feedforward asks
for ``Jl a`` where ``(1 + delta) Jl a`` is needed, and the observer's load
torque soaks up the missing ``delta Jl a`` through its slow random walk,
so that its load-speed estimate lags during the move and the move ends
with a load torque that is not there (34 Nm after a 0.1 rad reversal at
``Jl x 1.2``). On the 1 ms servo on encoders at ``Jl x 1.2`` each mistake
alone overshoots reversals by 1.2-3.4 %, both together by 2.6-6.3 %, and
with both on the true inertia by 0.1-0.8 % (``docs/servo.rst``).

`InertiaAdaptation` learns ``delta`` within a move, as a drive's inertia
identification does, from what the observer already sees: the observer's
model is on the learnt inertia (`InertiaAdaptation.learnt_model`: the
nominal model's load torque ``Td + delta_hat / (1 + delta_hat) (Ts - Td -
cl omega_l)``, which along the plan is ``Td + delta_hat Jl a_r``, ``a_r``
the planned load acceleration), and ``(Td, delta)`` are fitted together to
the encoder readings' innovation by recursive least squares, whose
regressors are the sensitivities of the observer's predicted readings to
a load-torque offset and to ``delta``, passed through the observer's
model and its own correction (its load torque absorbs a share of either,
at its own pace). While the plan accelerates the two look
alike and the prior shares them (load torque 10 Nm at a cold start,
``delta`` 0.1 standard deviation); over a rest-to-rest move the planned
acceleration integrates to zero, so a load torque keeps asking the same
way while the plan brakes, and the fit tells it from an inertia error.
The fit's load-torque step is added to the observer's load torque.

A share of each sample's correction by the acceleration alone was the
first version: with the slow observer of `sampled_tuning` above 1.5 ms it
read a load torque not yet estimated when a move starts as inertia
(measured at 2 ms, Td = 30 Nm from a cold start: the load torque estimate
stayed at 2-4 Nm through the move, ``delta_hat`` ended at -0.10, settling
in 0.40 s; 0.22 s with the fit). A fit on the correction itself, without
the observer's sensitivities, still settled in 0.36 s: the observer's
correction lags the torque it corrects, so the regressor must lag alike.

The fit runs in contact and while the shaft pushes the way the plan
accelerates (a gap crossing's impact is not inertia), each sample weighted
by ``a_r^2 / (a_r^2 + accel_floor^2)``; at rest (``a_r = 0``; the
planner's ``a_r`` is 1e-26 rad/s^2 there), in the gap or pushed back,
``delta_hat`` is held. ``delta_hat`` is projected on the design's inertia
range and kept between moves. The feedforward uses ``(1 + delta_hat) Jl``
(`flat_feedforward`'s ``scale``).

The model is on the learnt inertia at rest and at impacts too: on the
nominal one a lighter load's bounces on a flank at rest read as a load
torque of 1-2 Nm, and its rest after a move without load torque hunted
(Jl x0.8, 0.5 rad, seeds 1-16: all 16, now 1; ``docs/servo.rst``, "The
learnt inertia at rest"). The rest certificate (`servo_rest`) takes the
model on the nominal inertia or on one within 0.1 of the load's.

What the fit knows of the load torque when a move starts is what the
observer learnt before it. At a cold start (a move from the first sample,
the load torque unknown: the 2 ms rows above) the fit starts from the
wide prior and the observer keeps its own load-torque correction. After a
rest the observer has learnt the load torque: over ``memory`` seconds at
rest the fit's load-torque prior shrinks to `TORQUE_SETTLED` and the
load torque counts as known, and while the plan accelerates the
observer's own load-torque correction is handed to the fit in proportion
(the observer's load torque is held, the fit's regressors follow the
observer so corrected). Without this gate a 0.05 rad move at 1 ms, whose
braking half is a gap crossing the fit does not read, learnt from its
accelerating half only, where the two look alike: the observer's load
torque soaked up the inertia error (Td 3 Nm read as -5.7 Nm while
accelerating at Jl x0.8, +10 Nm at the end of the move), ``delta_hat``
reached half the true error and the small-move grid of
``tests/test_servo_inertia.py`` passed 42 runs of 108 (61 with the
per-sample share the fit replaced).

A certified polytopic observer with ``delta`` as a state, scheduled on the
contact and ``a_r`` (`ctrl_lpv.observer`, one Lyapunov matrix), was tried
first: with the regressor changing sign across the polytope the common
Lyapunov matrix left ``Td`` and ``delta`` unestimated (error modes at
0.99998-1.0). So the learning is not certified; neither were the moves
(the planner, the gap crossings). It is checked by the simulation grid of
issue 22 (``tests/test_servo_inertia.py``, ``docs/servo.rst``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import flag, real_number

__all__ = ["ServoInertia", "InertiaAdaptation", "inertia_adaptation", "INERTIA_STATES"]

#: Indices of the shaft torque, the load speed and the load torque in
#: `DRIVE_STATES`.
_TS, _WL, _TD = 2, 4, 5
#: The estimate's states in the sampled controller: ``delta_hat``, the
#: fit's covariance of (load torque, delta) less its prior, the
#: sensitivities of the observer's predicted state to both, and how far the
#: observer has learnt the load torque at rest (0 at a cold start, 1 after
#: a rest of a few ``memory``), less its value at the start.
_NAMES = ("theta_m", "omega_m", "Ts", "theta_l", "omega_l", "Td")
INERTIA_STATES = (
    ["delta_Jl_hat", "P_Td_dev", "P_cross_dev", "P_delta_dev"]
    + [f"S_Td_{name}" for name in _NAMES]
    + [f"S_delta_{name}" for name in _NAMES]
    + ["Td_known_dev"]
)
#: Variance, rad^2, of an encoder angle's reading error against the model.
READING_VARIANCE = (2.0 * np.pi / 2**17) ** 2 * 1e2
#: Prior standard deviation, Nm, of the load torque not yet learnt by the
#: observer when a move starts.
TORQUE_PRIOR = 10.0
#: Prior standard deviation, Nm, of the load torque after a rest: what the
#: fast observer's estimate still misses of it (1 ms, encoders: 0.1-0.2 Nm
#: of noise per sample; 1 Nm leaves the fit a share of a load torque that
#: changed at rest).
TORQUE_SETTLED = 1.0
#: A fit weight below this is the rest's (a planned acceleration below 3
#: mrad/s^2).
REST_WEIGHT = 1e-6


@dataclass(frozen=True)
class ServoInertia:
    """Settings of the sampled servo's online load-inertia estimate.

    Parameters
    ----------
    enabled : bool, optional
        Learn the load inertia along moves (default True; used with
        ``sensors="encoders"``). False: the nominal inertia throughout.
    gain : float, optional
        Prior standard deviation of ``delta_hat`` in the fit (default
        0.1): how far a move from a cold start may move it per its
        evidence.
    accel_floor : float, optional
        Planned load acceleration, rad/s^2, below which the move says
        little of the inertia (default 3): the fit's weight of a sample is
        ``a^2 / (a^2 + accel_floor^2)``.
    memory : float, optional
        Seconds at rest over which the observer learns the load torque
        (default 0.1): the fit's covariance returns to its prior with the
        load torque known (`TORQUE_SETTLED`) and the load torque counts
        as known.
    cold_start : bool, optional
        Whether the load torque is unknown when the controller starts
        (default True): the first moves are fitted. False trusts the
        observer's load torque from the start, the inertia learnt from the
        observer's load-torque correction alone; `servo_design` sets it by
        `sampled_tuning` when ``inertia`` is not given (False up to 1.5 ms,
        whose fast observer learns the load torque within the first move).
    """

    enabled: bool = True
    gain: float = 0.1
    accel_floor: float = 3.0
    memory: float = 0.1
    cold_start: bool = True

    def __post_init__(self):
        object.__setattr__(self, "enabled", flag(self.enabled, "ServoInertia.enabled"))
        cold = flag(self.cold_start, "ServoInertia.cold_start")
        object.__setattr__(self, "cold_start", cold)
        for name in ("gain", "accel_floor", "memory"):
            label = f"ServoInertia.{name}"
            value = real_number(getattr(self, name), label, positive=True)
            object.__setattr__(self, name, value)


@dataclass(frozen=True)
class InertiaAdaptation:
    """The inertia estimate as the sampled servo runs it.

    Attributes
    ----------
    Jl : float
        Nominal load inertia, kg m^2.
    gain, accel_floor, memory : float
        As in `ServoInertia`.
    bounds : (float, float)
        Range of ``delta_hat`` (the design's ``Jl_range`` less one).
    dt : float
        Sample time, s.
    known_at_start : float, optional
        How far the load torque counts as known when the controller starts
        (0: a cold start, the default; 1: `ServoInertia.cold_start` False).
    cl : float, optional
        Nominal load friction, Nm s/rad (the load's acceleration in
        `learnt_model`; default 0).
    """

    Jl: float
    gain: float
    accel_floor: float
    memory: float
    bounds: tuple[float, float]
    dt: float
    known_at_start: float = 0.0
    cl: float = 0.0

    def initial(self):
        """The estimate's states (`INERTIA_STATES`) before any move."""
        return np.zeros(len(INERTIA_STATES))

    def correct(self, xhat, learnt, innovation, M, rows, Phi, accel, contact=1.0):
        """Filtered estimate, and the estimate's states for the next sample.

        Parameters
        ----------
        xhat : ndarray
            The predicted drive-observer state (`DRIVE_STATES`).
        learnt : array_like
            The estimate's states (`INERTIA_STATES`).
        innovation : ndarray
            The encoder angles less their prediction ``y - C x_hat``.
        M : ndarray
            The observer's filter gain (``correction = M innovation``).
        rows : list of int
            The states the encoders read (`DRIVE_STATES` indices).
        Phi : ndarray
            The observer's sampled model over the sample.
        accel : float
            The planned load acceleration, rad/s^2.
        contact : float, optional
            The observer's contact weight in ``[0, 1]``: in the gap no
            torque reaches the load, and its motion says nothing of the
            inertia.

        Returns
        -------
        filtered : ndarray
            The observer's corrected state (while the plan accelerates,
            the share of its load-torque correction that the load torque
            known at rest gives to delta taken off; the fit's load-torque
            step added).
        learnt : ndarray
            The estimate's states for the next sample (``delta_hat``
            first).
        """
        learnt = np.asarray(learnt, float)
        delta, known = learnt[0], learnt[-1] + self.known_at_start
        cold = np.diag([TORQUE_PRIOR**2, self.gain**2])
        P = cold + np.array([[learnt[1], learnt[2]], [learnt[2], learnt[3]]])
        sens = learnt[4:-1].reshape(2, -1).T  # columns: load torque, delta
        innovation = np.asarray(innovation, float)
        # Only while the shaft pushes the way the plan accelerates: just
        # after a gap crossing the estimate reads the impact as contact.
        torque, floor = self.Jl * accel, self.Jl * self.accel_floor
        weight = contact * torque * torque / (torque * torque + floor * floor)
        weight *= xhat[_TS] * accel > 0.0
        # A load torque learnt at rest (``known`` near 1): what the
        # observer's load torque would absorb while the plan accelerates is
        # the inertia error, so that share of its correction goes to delta
        # directly; from a cold start the fit tells the two apart over the
        # move (the braking half), on the rest of the weight.
        share = weight * known
        correction = M @ innovation
        filtered = xhat + correction
        if share > 0.0:
            filtered[_TD] -= share * correction[_TD]
            moved = share * correction[_TD] / torque
            delta = delta + moved
            # The state moves to where the learnt inertia would have led
            # it, along the prediction's sensitivity to delta: left where
            # the old inertia led it, the observer's load ran up to 0.045
            # rad/s ahead of a load 20 % heavier, and in the gap crossing
            # in the middle of the move that error went to the load torque
            # (2-6 Nm; docs/servo.rst, "The observer's state follows the
            # learnt inertia").
            shift = sens[:, 1] * moved
            shift[_TD] = 0.0
            filtered = filtered + shift
        M = np.array(M, float)
        M[_TD] *= 1.0 - share
        # How the predicted readings move with a load-torque offset and with
        # delta: through the model and the observer's own correction of it,
        # so that a load torque, which asks the same way while the plan
        # brakes, is told from an inertia error.
        psi = sens[rows]
        # At rest the planner's a_r is 1e-26 rad/s^2, not 0: a weight below
        # REST_WEIGHT is the rest's.
        fit = weight * (1.0 - known)
        if weight > REST_WEIGHT and fit > 0.0:
            # The fit's gain of readings weighted by `fit` (1/fit times as
            # noisy), written without dividing by a vanishing weight.
            spread = READING_VARIANCE * np.eye(len(rows)) + fit * psi @ P @ psi.T
            K = fit * np.linalg.solve(spread, psi @ P).T
            step = K @ innovation
            filtered[_TD] += step[0]
            delta = delta + step[1]
            P = P - K @ psi @ P
        delta = min(max(delta, self.bounds[0]), self.bounds[1])
        if weight <= REST_WEIGHT:
            relax = min(1.0, self.dt / self.memory)
            settled = np.diag([TORQUE_SETTLED**2, self.gain**2])
            P = P + (settled - P) * relax
            known = known + (1.0 - known) * relax
        # The prediction (`learnt_model`) moves with a load-torque offset
        # as with ``1 / (1 + delta)`` of it, and with delta as with the load
        # torque ``net / (1 + delta)^2``.
        net = filtered[_TS] - filtered[_TD] - self.cl * filtered[_WL]
        drive = np.zeros((len(xhat), 2))
        drive[_TD] = 1.0 / (1.0 + delta), net / (1.0 + delta) ** 2
        model = self.learnt_model(Phi, delta)
        sens = model @ (sens - M @ psi) + (np.asarray(Phi) - np.eye(len(xhat))) @ drive
        dev = P - cold
        return filtered, np.array(
            [
                delta,
                dev[0, 0],
                dev[0, 1],
                dev[1, 1],
                *sens[:, 0],
                *sens[:, 1],
                known - self.known_at_start,
            ]
        )

    def learnt_model(self, Phi, delta):
        """The observer's sampled model `Phi` on the load inertia ``(1 +
        delta) Jl``: the load's acceleration ``(Ts - Td - cl omega_l) / ((1
        + delta) Jl)`` is the nominal model's with the load torque ``Td +
        delta / (1 + delta) (Ts - Td - cl omega_l)``, that share held over
        the sample."""
        Phi = np.asarray(Phi, float)
        share = np.zeros(Phi.shape[0])
        share[[_TS, _TD, _WL]] = 1.0, -1.0, -self.cl
        column = Phi[:, _TD].copy()
        column[_TD] -= 1.0
        return Phi + delta / (1.0 + delta) * np.outer(column, share)

    def predict(self, Phi, Gamma, filtered, u, delta):
        """``x_hat[k+1|k]`` on the learnt inertia (`learnt_model`)."""
        return self.learnt_model(Phi, delta) @ filtered + Gamma * u


def inertia_adaptation(
    settings: ServoInertia,
    Jl: float,
    Jl_range: tuple[float, float],
    dt: float,
    cl: float = 0.0,
) -> InertiaAdaptation | None:
    """The `InertiaAdaptation` of `settings` at sample time `dt` for the
    nominal load inertia `Jl` and friction `cl` (None when disabled)."""
    if not isinstance(settings, ServoInertia):
        raise TypeError(f"inertia: expected a ServoInertia, got {settings!r}")
    if not settings.enabled:
        return None
    lo, hi = (float(f) - 1.0 for f in Jl_range)
    return InertiaAdaptation(
        Jl=float(Jl), gain=settings.gain, accel_floor=settings.accel_floor,
        memory=settings.memory, bounds=(lo, hi),
        dt=real_number(dt, "dt", positive=True),
        known_at_start=0.0 if settings.cold_start else 1.0, cl=float(cl),
    )  # fmt: skip
