"""A torque-limited position servo for the two-mass drive with backlash.

`servo_design` builds what a drive engineer would deploy on the exact
backlash plant, in four parts (details in ``docs/servo.rst``):

1. an online rest-to-rest planner (`ctrl_lpv.twomass.trajectory`): a
   minimum-snap move of the load whose duration keeps the feedforward torque
   within a share of the limit for the heaviest load, re-planned from the
   present state whenever the target ``theta_r`` changes;
2. the flat feedforward of the contact model along that move, with the
   backlash offset ``alpha_hat psi(T*/T_eps)`` in the motor reference: the
   motor leads (or trails) the load by the estimated half-gap on the flank
   that transmits the shaft torque ``T*`` asked for;
3. certified state feedback on the tracking error (`ctrl_lpv.
   hinf_state_feedback` on `lpv_model` with ``p`` and the load inertia as
   polytope parameters), clipped at the torque limit, with conditional
   integration (anti-windup);
4. against hunting: the flank is chosen by the whole shaft torque asked for
   (feedforward plus load feedback), so that a residual load error makes the
   motor cross the gap and push (and a moving load is braked on the other
   flank); the gap is estimated online from ``theta_m - theta_l`` at
   contacts (shaft-torque observer on the motor side) and widened when a
   contact asked for is not made; the integral of the load error runs only
   in contact and fades out of it (at rest in the gap no torque reaches the
   load, so there is no load torque to integrate).

The settings of each part are one object of `ctrl_lpv.twomass.servo_config`
(`ServoPlanner`, `ServoSynthesis`, `ServoAntiHunting`, `ServoEstimator`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import control as ct
import numpy as np

from .._checks import as_matrix, flag, real_number
from ..estimation import ObserverDesign
from ..exceptions import CertificationError
from ..interconnection import kernel_nlsys
from ..synthesis import StateFeedbackDesign, hinf_state_feedback
from ..systems import PolytopicStateSpace
from .cold_start import cold_start
from .drive_observer import _encoder_steps, drive_observer, observer_matrices
from .inertia import ServoInertia, inertia_adaptation
from .model import lpv_model
from .motor_estimator import MotorEstimator, MotorObserver, motor_observer
from .parameters import Parameters
from .sampled_tuning import ALTERNATING_LIMIT, FAST_TORQUE_WEIGHT, sampled_tuning
from .servo_certificate import ServoCertificate, servo_certificate
from .servo_config import (
    ServoAntiHunting,
    ServoEstimator,
    ServoPlanner,
    ServoStream,
    ServoSynthesis,
    interval,
    positive_range,
)
from .servo_kernel import INPUTS, STATES, ServoTuning, servo_kernel
from .servo_rest import alternating_mode, rest_bound
from .servo_sampled import SampledServo, sampled_servo
from .stream import stream_gain
from .trajectory import PEAK_ACCEL, move_duration

__all__ = ["ServoDesign", "servo_design", "servo_polytope"]

_READ = {"encoders": ("theta_m", "theta_l"), "motor": ("theta_m",)}
#: Asked shaft torque, Nm, below which the motor-encoder design asks for no
#: flank: at rest with a small load torque the motor waits mid-gap instead of
#: crossing it on a load error it cannot see (the load is not observable in
#: the gap).
MOTOR_FLANK_DEADBAND = 1.0


def servo_polytope(
    params: Parameters | None = None,
    *,
    p_bounds: tuple[float, float] = ServoSynthesis.p_bounds,
    Jl_range: tuple[float, float] = (0.8, 1.2),
    torque_weight: float = FAST_TORQUE_WEIGHT,
    integral_weight: float = ServoSynthesis.integral_weight,
) -> PolytopicStateSpace:
    """The tracking-error model with the load inertia as a second parameter.

    The vertices of `lpv_model` (tracking formulation, integral of the
    load-angle error) at ``Jl * Jl_range[0]`` and ``Jl * Jl_range[1]``.
    ``A`` is affine in ``p`` and in ``1/Jl`` and bilinear in the pair, so
    on the box ``p_bounds x [1/Jl_max, 1/Jl_min]`` it stays in the convex
    hull of these four vertices: a common certificate covers every
    ``(p, Jl)`` of the box, also time-varying.

    Parameters
    ----------
    params : `Parameters`, optional
        Nominal drive data.
    p_bounds : (float, float), optional
        Interval of the backlash parameter (see `lpv_model`).
    Jl_range : (float, float), optional
        Load inertia as multiples of ``params.Jl``.
    torque_weight, integral_weight : float, optional
        Weights of the performance outputs (see `lpv_model`).

    Returns
    -------
    `ctrl_lpv.PolytopicStateSpace`
        Four vertices, inputs ``["Td", "Tm"]``, outputs ``["e_l", "Tm_w",
        "int_e_l_w"]``.
    """
    params = Parameters() if params is None else params
    lo, hi = positive_range(Jl_range, "Jl_range")
    p_bounds = interval(p_bounds, "p_bounds")
    torque_weight = real_number(torque_weight, "torque_weight", positive=True)
    integral_weight = real_number(integral_weight, "integral_weight", positive=True)
    vertices = []
    for f in (lo, hi):
        m = lpv_model(
            params.replace(Jl=f * params.Jl), p_bounds=p_bounds,
            formulation="tracking", integral=True,
            torque_weight=torque_weight, integral_weight=integral_weight,
        )  # fmt: skip
        vertices += list(m.vertices)
    return PolytopicStateSpace(
        vertices, inputs=m.input_labels, outputs=m.output_labels,
        states=m.state_labels, name="twomass_servo_error",
    )  # fmt: skip


@dataclass(frozen=True)
class ServoDesign:
    """A servo design: its tuning, feedback design and certificate.

    Attributes
    ----------
    params : `Parameters`
        Nominal drive data of the design (feedforward and models).
    torque_limit : float
        The motor torque limit, Nm; the controller never asks for more.
    alpha_max : float
        Largest half-gap the design allows for, rad.
    Jl_range : (float, float)
        Load inertias covered, as multiples of ``params.Jl``.
    Td_max : float
        Largest load torque allowed for in the torque budget, Nm.
    gain : ndarray
        ``1 x 5`` feedback gain on ``[e_m, omega_m err, e_l, omega_l err,
        int e_l]`` (``u = -K x``).
    feedback : `ctrl_lpv.StateFeedbackDesign` or None
        The certified synthesis that gave `gain` (None for a given gain).
    tuning : `ServoTuning`
        Every number of the control law.
    certificate : `ServoCertificate`
        What is certified, with its float64 checks.
    dt : float or None
        Sample time of the controller, s (None: continuous time).
    delay : int
        Samples between reading the sensors and the command acting.
    sensors : {"states", "encoders", "motor"}
        What the controller reads.
    reference : {"plan", "stream"}
        What ``theta_r`` is: a target reached by a planned move, or a
        set-point streamed every sample (sampled designs).
    encoder_counts : (int, int) or None
        Counts per revolution of the motor and load encoders (sampled).
    sampling : `ctrl_lpv.twomass.servo_sampled.SampledServo` or None
        The sampled law's numbers (None in continuous time).
    observer : `ctrl_lpv.ObserverDesign`, `MotorObserver` or None
        The drive observer of an encoder design (the two mode observers of
        a motor-encoder design, `ctrl_lpv.twomass.motor_estimator`).
    """

    params: Parameters
    torque_limit: float
    alpha_max: float
    Jl_range: tuple[float, float]
    Td_max: float
    gain: np.ndarray
    feedback: StateFeedbackDesign | None
    tuning: ServoTuning
    certificate: ServoCertificate = field(repr=False)
    dt: float | None = None
    delay: int = 0
    sensors: str = "states"
    reference: str = "plan"
    encoder_counts: tuple | None = None
    sampling: SampledServo | None = field(default=None, repr=False)
    observer: ObserverDesign | MotorObserver | None = field(default=None, repr=False)

    @property
    def accel_limit(self) -> float:
        """Peak load acceleration of planned moves, rad/s^2."""
        return self.tuning.accel_limit

    def move_duration(self, distance) -> float:
        """Duration of a planned rest-to-rest move of `distance` rad, s."""
        return move_duration(distance, self.accel_limit, self.tuning.min_duration)

    def controller(self, name: str = "servo") -> ct.NonlinearIOSystem:
        """The servo as a python-control I/O system.

        Parameters
        ----------
        name : str, optional
            System name (default ``"servo"``).

        Returns
        -------
        `control.NonlinearIOSystem`
            Continuous time: inputs ``["theta_m", "omega_m", "theta_l",
            "omega_l", "theta_r"]`` (``theta_r`` the commanded target; it
            may step at any time), output ``["Tm"]`` within
            ``+-torque_limit``; states as in
            `ctrl_lpv.twomass.servo_kernel.STATES`, all zero at rest at the
            origin. The output does not feed through from ``theta_r``.
            Sampled (`dt` set): a discrete-time system with inputs
            ``["theta_m", "theta_l", "theta_r"]`` (the encoder angles),
            whose output computed at ``t_k`` acts from ``t_{k + delay}``
            (`ctrl_lpv.twomass.servo_sampled`); simulate it on the plant
            with `ctrl_lpv.sampled_response` and the same ``delay``.
        """
        if not isinstance(name, str):
            raise TypeError(f"name: expected a string, got {type(name).__name__}")
        if self.sampling is not None:
            return sampled_servo(self.tuning, self.sampling, name)
        return kernel_nlsys(
            servo_kernel(self.tuning),
            inputs=INPUTS,
            outputs=["Tm"],
            states=STATES,
            feedthrough=[[True, True, True, True, False]],
            name=name,
        )

    def __str__(self) -> str:
        t = self.tuning
        lines = [
            f"ServoDesign: |Tm| <= {self.torque_limit:g} Nm, alpha <= "
            f"{self.alpha_max:g} rad, Jl in [{self.Jl_range[0]:g}, "
            f"{self.Jl_range[1]:g}] x {self.params.Jl:g} kg m^2, "
            f"Td <= {self.Td_max:g} Nm",
            f"  moves: minimum-snap, peak acceleration {t.accel_limit:.3g} rad/s^2 "
            f"(0.5 rad in {self.move_duration(0.5):.3f} s, 1 rad in "
            f"{self.move_duration(1.0):.3f} s)"
            if self.reference == "plan" else
            "  reference: a set-point streamed every sample (tracker of its "
            "speed, acceleration and jerk, no planning)",
            "  feedback K = " + np.array2string(self.gain, precision=4, separator=", "),
            "  runs: continuous time, every state measured" if self.dt is None else
            f"  runs: every {self.dt * 1e3:g} ms, {self.delay} sample(s) of delay, "
            + ("on the motor and load encoders (drive observer)"
               if self.sensors == "encoders" else
               "on the motor encoder alone (dead-zone estimator, half-gap "
               "learnt at contacts)"),
            "  anti-hunting: "
            + ("flank chosen by the asked shaft torque, gap estimate, contact-aware "
               "integral" if t.anti_hunting else "off"),
            str(self.certificate),
        ]  # fmt: skip
        return "\n".join(lines)


def servo_design(
    params: Parameters | None = None,
    *,
    torque_limit: float = 500.0,
    alpha_max: float = 0.06,
    Jl_range: tuple[float, float] = (0.8, 1.2),
    Td_max: float = 10.0,
    gain=None,
    planner: ServoPlanner | None = None,
    synthesis: ServoSynthesis | None = None,
    anti_hunting: ServoAntiHunting | None = None,
    estimator: ServoEstimator | None = None,
    certify: bool = True,
    dt: float | None = None,
    delay: int = 0,
    sensors: str = "states",
    encoder_counts=(2**20, 2**17),
    reference: str = "plan",
    stream: ServoStream | None = None,
    inertia: ServoInertia | None = None,
) -> ServoDesign:
    """Design the torque-limited position servo of the two-mass drive.

    The limits and ranges say what the design knows of the drive; the
    settings of each part of the servo are one object each
    (`ctrl_lpv.twomass.servo_config`), default the tuning of
    ``docs/servo.rst``: ``servo_design(anti_hunting=ServoAntiHunting(
    enabled=False))`` switches the anti-hunting law off.

    Parameters
    ----------
    params : `Parameters`, optional
        Nominal drive data (default the paper's).  ``params.alpha`` is not
        used: the gap is unknown in ``[0, alpha_max]``.
    torque_limit : float, optional
        Motor torque limit, Nm (default 500).
    alpha_max : float, optional
        Largest half-gap, rad (default 0.06).
    Jl_range : (float, float), optional
        Load inertia range as multiples of ``params.Jl`` (default 0.8-1.2).
    Td_max : float, optional
        Largest load torque, Nm, for the torque budget (default 10).
    gain : array_like, optional
        Use this ``1 x 4`` or ``1 x 5`` gain instead of the synthesis (for
        comparisons, e.g. `paper_gain`); a 4-column gain gets no integral.
    planner : `ServoPlanner`, optional
        The move planner: torque reserve, shortest move, horizon floor.
    synthesis : `ServoSynthesis`, optional
        The feedback synthesis: backlash parameter interval and weights
        (unused with `gain`).
    anti_hunting : `ServoAntiHunting`, optional
        The flank choice and the integral action: on or off, flank width,
        integral leak and hold, the latch at rest (default with `dt`: the
        latch of `ctrl_lpv.twomass.sampled_tuning.sampled_tuning` for it).
    estimator : `ServoEstimator`, optional
        The shaft-torque observer and the gap estimate: on or off, contact
        torque, rates, observer bandwidth.
    certify : bool, optional
        Compute the ultimate bound of the certificate (default True). With
        `dt` on encoders the rest certificate is computed either way where
        it chooses the drive observer's intensities (`sampled_tuning`): the
        controller does not depend on `certify`.
    dt : float, optional
        Sample time, s: a discrete-time controller whose update and output
        run once per sample (default None: continuous time). The feedback
        gain is then designed on the zero-order-hold model.
    delay : {0, 1}, optional
        Samples of computation delay (with `dt`): ``1`` means the command
        computed from the samples at ``t_k`` acts on ``[t_{k+1},
        t_{k+2})``; the controller predicts the state at ``t_{k+1}`` from
        the command already on its way.
    sensors : {"states", "encoders", "motor"}, optional
        ``"states"`` (continuous time: every state measured exactly);
        ``"encoders"`` (needs `dt`): the motor and load angles only, the
        speeds and torques estimated by `ctrl_lpv.twomass.drive_observer`;
        ``"motor"`` (needs `dt`): the motor encoder alone, read by
        `ctrl_lpv.twomass.motor_estimator` (the backlash's dead zone in
        the prediction, one Kalman gain per mode with a certified H2
        bound, the half-gap learnt from contacts made earlier or later
        than predicted). The
        load is not observable in the gap: at rest with a load torque
        below about twice `MOTOR_FLANK_DEADBAND` the motor waits mid-gap
        and the load error is bounded by the gap, not corrected; no rest
        certificate (``certificate.rest`` is None).
    encoder_counts : (int, int), optional
        Counts per revolution of the motor and load encoders (the
        observer's measurement noise and the rest certificate's reading
        error).
    reference : {"plan", "stream"}, optional
        What ``theta_r`` is. ``"plan"`` (default): a target; each change
        starts an online rest-to-rest move (at least ``min_duration``
        long). ``"stream"`` (needs `dt`): a position set-point updated every
        sample by a motion controller, followed without re-planning: the
        tracker of `ctrl_lpv.twomass.stream` (`stream` settings) gives its
        speed, acceleration and jerk; the feedforward of the contact model
        is evaluated on them one sample ahead (``delay=1``) and the torque
        half a sample more (the hold), with the drive observer's load
        torque added (the integral is held while the set-point moves);
        the feedback, the flank offset and
        the drive observer are those of ``"plan"``. The set-point should be
        smooth: the tracker follows cubics without lag and so overshoots a
        step by 20 % (targets that jump are for ``"plan"``).
    stream : `ServoStream`, optional
        The tracker's bandwidth (``reference="stream"``).
    inertia : `ServoInertia`, optional
        The load-inertia estimate learnt along moves
        (`ctrl_lpv.twomass.inertia`; ``sensors="encoders"``): by default
        on up to 1.5 ms of sample time (`sampled_tuning`),
        ``ServoInertia(enabled=False)`` keeps the nominal inertia.

    Returns
    -------
    `ServoDesign`

    Raises
    ------
    TypeError
        For settings that are not of their class (``anti_hunting=False``:
        use ``ServoAntiHunting(enabled=False)``), and values that are not
        real numbers or bools.
    ValueError
        For non-positive limits, reversed ranges, a torque budget that
        leaves no acceleration, or `sensors`, `dt` and `delay` that do not
        go together.
    CertificationError
        With `dt` on encoders, when none of the drive observer's
        intensities gives a certified rest loop (without `certify` too,
        where the rule has several to choose from).
    """
    arguments = dict(locals())
    checked_dt, _ = _sampling(dt, delay, sensors)
    # The sample time's tuning rule (`sampled_tuning`); on encoders the fast
    # one only where its rest loop does not alternate (`ALTERNATING_LIMIT`).
    rule = None if checked_dt is None else sampled_tuning(checked_dt)
    design = _servo_design(rule, **arguments)
    if rule is None or sensors != "encoders":
        return design
    slow = sampled_tuning(checked_dt, fast=False)
    mode = alternating_mode(design.params, design.gain, design.sampling)
    if rule == slow or mode <= ALTERNATING_LIMIT:
        return design
    return _servo_design(slow, **arguments)


def _servo_design(
    rule, *, params, torque_limit, alpha_max, Jl_range, Td_max, gain, planner,
    synthesis, anti_hunting, estimator, certify, dt, delay, sensors,
    encoder_counts, reference, stream, inertia,
):  # fmt: skip
    """`servo_design` under the sample time's tuning `rule` (None: continuous
    time)."""
    params = Parameters() if params is None else params
    if not isinstance(params, Parameters):
        raise TypeError(f"params: expected twomass.Parameters, got {type(params)!r}")
    torque_limit = real_number(torque_limit, "torque_limit", positive=True)
    alpha_max = real_number(alpha_max, "alpha_max", positive=True)
    Td_max = real_number(Td_max, "Td_max", minimum=0.0)
    lo, hi = positive_range(Jl_range, "Jl_range")
    planner = _settings(planner, ServoPlanner, "planner")
    synthesis = _settings(synthesis, ServoSynthesis, "synthesis")
    estimator = _settings(estimator, ServoEstimator, "estimator")
    certify = flag(certify, "certify")
    dt, delay = _sampling(dt, delay, sensors)
    if anti_hunting is None and rule is not None:
        anti_hunting = ServoAntiHunting(
            rest_flank=rule.rest_flank, free_rest=rule.free_rest
        )
    anti_hunting = _settings(anti_hunting, ServoAntiHunting, "anti_hunting")
    stream = _settings(stream, ServoStream, "stream")
    if inertia is None and rule is not None:
        inertia = ServoInertia(
            enabled=rule.learn_inertia, cold_start=rule.fit_cold_start
        )
    inertia = _settings(inertia, ServoInertia, "inertia")
    if reference not in ("plan", "stream"):
        raise ValueError(f"reference: expected 'plan' or 'stream', got {reference!r}")
    if reference == "stream" and dt is None:
        raise ValueError(
            "reference: 'stream' needs a sample time dt (a set-point streamed "
            "once per sample)"
        )
    if reference == "stream" and sensors == "motor":
        raise ValueError(
            "reference: 'stream' is not supported with sensors='motor' (the "
            "motor-encoder estimator is designed and tested for planned moves)"
        )
    budget = (1.0 - planner.torque_reserve) * torque_limit - Td_max
    if budget <= 0:
        raise ValueError(
            f"torque_limit: {torque_limit:g} Nm leaves no torque for motion after "
            f"the reserve and Td_max = {Td_max:g} Nm"
        )
    accel_limit = budget / (params.Jm + hi * params.Jl)
    alpha_initial = estimator.initial_half_gap
    if alpha_initial is None:
        alpha_initial = 0.5 * alpha_max
    elif alpha_initial > alpha_max:
        raise ValueError(
            f"estimator.initial_half_gap: {alpha_initial:g} rad is beyond "
            f"alpha_max = {alpha_max:g} rad"
        )

    feedback = None
    if gain is None:
        weight = synthesis.torque_weight
        if weight is None:
            weight = FAST_TORQUE_WEIGHT if rule is None else rule.torque_weight
        model = servo_polytope(
            params, p_bounds=synthesis.p_bounds, Jl_range=(lo, hi),
            torque_weight=weight,
            integral_weight=synthesis.integral_weight,
        )  # fmt: skip
        if dt is not None:
            model = model.sample(dt)
        feedback = hinf_state_feedback(model, w=["Td"], u=["Tm"])
        K = np.asarray(feedback.gains[0], float).reshape(1, -1)
    else:
        K = as_matrix(gain, "gain")
        if K.shape not in ((1, 4), (1, 5)):
            raise ValueError(f"gain: expected a 1 x 4 or 1 x 5 gain, got {K.shape}")
        if K.shape[1] == 4:
            K = np.hstack([K, [[0.0]]])
    tuning = ServoTuning(
        Jm=params.Jm, Jl=params.Jl, cm=params.cm, cl=params.cl, ks=params.ks,
        cs=params.cs, gain=tuple(float(k) for k in K[0]),
        torque_limit=torque_limit, accel_limit=float(accel_limit),
        min_duration=planner.min_duration, horizon_floor=planner.horizon_floor,
        alpha_max=alpha_max, alpha_initial=alpha_initial,
        flank_width=anti_hunting.flank_width,
        contact_torque=estimator.contact_torque,
        estimate_rate=estimator.estimate_rate, probe_rate=estimator.probe_rate,
        integral_leak=anti_hunting.integral_leak,
        observer_bandwidth=estimator.observer_bandwidth,
        integral_hold=anti_hunting.integral_hold,
        flank_deadband=MOTOR_FLANK_DEADBAND if sensors == "motor" else 0.0,
        anti_hunting=anti_hunting.enabled,
        gap_estimate=estimator.gap_estimate and sensors != "motor",
        learn_torque=estimator.learn_torque, probe_error=estimator.probe_error,
        static_speed=estimator.static_speed,
        narrowing_band=estimator.narrowing_band,
        rest_estimate_rate=estimator.rest_estimate_rate,
        # On the motor encoder alone the motor waits mid-gap at rest (the
        # flank dead band): no flank to latch.
        rest_flank=None if sensors == "motor" else anti_hunting.rest_flank,
    )  # fmt: skip
    observer = sampling = rest = None
    if dt is not None:
        tracker = None
        if reference == "stream":
            tracker = tuple(float(v) for v in stream_gain(dt, stream.bandwidth))

        def sampled(Phi=None, Gamma=None, M=None, motor=None, M_rest=None):
            return SampledServo(
                dt=dt, delay=delay, Phi=Phi, Gamma=Gamma, M=M, M_rest=M_rest,
                reference=reference,
                stream_gain=tracker, measured=tuple(_READ[sensors]), estimator=motor,
                inertia=(
                    inertia_adaptation(inertia, params.Jl, (lo, hi), dt, params.cl)
                    if sensors == "encoders" else None
                ),
                # Not on the motor encoder alone: its estimator's fall and
                # landing logic were measured on the feedforward without (with
                # it 6 of its 180 grid and scenario tests missed targets).
                exact_feedforward=rule.exact_feedforward and sensors != "motor",
                cold_start=(
                    cold_start(encoder_counts, _READ[sensors])
                    if sensors == "encoders" else None
                ),
                free_rest=(
                    _free_rest(anti_hunting.free_rest, encoder_counts)
                    if sensors == "encoders" else None
                ),
            )  # fmt: skip

        if sensors == "motor":
            observer = motor_observer(params, dt=dt, motor_counts=encoder_counts[0])
            motor = MotorEstimator(
                observer, alpha_max=alpha_max, alpha_spread=alpha_max / math.sqrt(12.0)
            )
            sampling = sampled(motor=motor)
        else:
            # The observer intensities of the rule (`sampled_tuning`), in
            # order, until the certified rest covers its target load torque.
            # On the motor encoder alone the load angle at rest is not
            # observable (the motor sees theta_l + alpha): no rest certificate.
            observer, sampling, rest = _encoder_observer(
                params, K, tuning, sampled, rule, dt=dt, sensors=sensors,
                encoder_counts=encoder_counts, Jl_range=(lo, hi), certify=certify,
                rates=(estimator.shaft_torque_rate, estimator.load_torque_rate),
            )  # fmt: skip
    certificate = servo_certificate(
        params, K, feedback, alpha_max=alpha_max, Jl_range=(lo, hi),
        Td_max=Td_max, torque_limit=torque_limit, bound=certify and dt is None,
        dt=dt, rest=rest,
    )  # fmt: skip
    return ServoDesign(
        params=params, torque_limit=torque_limit, alpha_max=alpha_max,
        Jl_range=(lo, hi), Td_max=Td_max, gain=K, feedback=feedback,
        tuning=tuning, certificate=certificate, dt=dt, delay=delay,
        sensors=sensors, reference=reference, sampling=sampling, observer=observer,
        encoder_counts=None if dt is None else tuple(encoder_counts),
    )  # fmt: skip


def _free_rest(free, encoder_counts):
    """`free` with the load encoder's reading variance (a third of a count
    squared: its quantization, a twelfth, and half a count of noise), or
    None."""
    if free is None or free.reading_variance is not None:
        return free
    return replace(free, reading_variance=_encoder_steps(encoder_counts)[1] ** 2 / 3.0)


def _sampling(dt, delay, sensors):
    """Check that `dt`, `delay` and `sensors` go together."""
    if sensors not in ("states", "encoders", "motor"):
        raise ValueError(
            f"sensors: expected 'states', 'encoders' or 'motor', got {sensors!r}"
        )
    if isinstance(delay, bool) or delay not in (0, 1):
        raise ValueError(f"delay: expected 0 or 1 samples, got {delay!r}")
    if dt is None:
        if sensors != "states":
            raise ValueError(
                f"sensors: {sensors!r} needs a sample time dt (a drive reads its "
                "encoders once per sample)"
            )
        if delay:
            raise ValueError("delay: needs a sample time dt")
        return None, 0
    dt = real_number(dt, "dt", positive=True)
    if sensors == "states":
        raise ValueError(
            "sensors: a sampled servo reads encoder angles; use "
            "sensors='encoders' with dt (sensors='states' is the continuous, "
            "full-state design, dt=None)"
        )
    return dt, int(delay)


def _settings(value, cls, label: str):
    """The settings object of one part: `value`, or the defaults for None."""
    if value is None:
        return cls()
    if not isinstance(value, cls):
        raise TypeError(
            f"{label}: expected a {cls.__name__} (e.g. {cls.__name__}(...) with the "
            f"fields to change), got {value!r}"
        )
    return value


# Keep the planner's constant visible for the docs and tests.
PEAK_ACCEL = PEAK_ACCEL


def _encoder_observer(
    params, K, tuning, sampled, rule, *, dt, sensors, encoder_counts, Jl_range,
    certify, rates,
):  # fmt: skip
    """The drive observer, the sampled law's numbers and the certified rest.

    Given intensities (`rates`, None: the `rule`'s) are used as they are;
    otherwise those of the `rule` (`sampled_tuning`) are tried in order and the first
    whose certified load-torque floor is at most the rule's target, with a
    certified time constant at most the rule's, is kept, else the lowest
    floor (among the fast enough, if any). A loop that does not certify is
    skipped; if none does, the last refusal is raised. Without `certify`
    the rest certificate is still computed where it chooses between
    intensities, so that the controller is the same either way, and is not
    returned.
    """
    if rates == (None, None):
        candidates = rule.rates
    else:
        default = rule.rates[0]
        candidates = [tuple(d if r is None else r for r, d in zip(rates, default))]
    latch = (
        0.0 if tuning.rest_flank is None or not tuning.anti_hunting
        else tuning.rest_flank.latch_torque
    )  # fmt: skip
    M_rest = None
    if rule.rest_rates is not None:
        # The latched rest's quieter gains (`SampledTuning.rest_rates`).
        M_rest = observer_matrices(
            drive_observer(
                params, dt=dt, sensors=sensors, encoder_counts=encoder_counts,
                shaft_torque_rate=rule.rest_rates[0],
                load_torque_rate=rule.rest_rates[1],
            )
        )[2]  # fmt: skip
    best, refusal = None, None
    for shaft, load in candidates:
        observer = drive_observer(
            params, dt=dt, sensors=sensors, encoder_counts=encoder_counts,
            shaft_torque_rate=shaft, load_torque_rate=load,
        )  # fmt: skip
        Phi, Gamma, M = observer_matrices(observer)
        sampling = sampled(Phi, Gamma, M, M_rest=M_rest)
        if not certify and len(candidates) == 1:
            return observer, sampling, None
        try:
            rest = rest_bound(
                params, K, sampling, Jl_range=Jl_range, encoder_counts=encoder_counts,
                flank_width=tuning.flank_width, contact_torque=tuning.contact_torque,
                latch_torque=latch,
            )  # fmt: skip
        except CertificationError as exc:
            refusal = exc
            continue
        slow = rest.time_constant > rule.max_time_constant
        rank = (slow, rest.min_load_torque)
        if best is None or rank < best[0]:
            best = (rank, observer, sampling, rest)
        if not slow and rest.min_load_torque <= rule.floor_target:
            break
    if best is None:
        raise refusal
    return (*best[1:3], best[3] if certify else None)
