"""Settings of `servo_design`, one small frozen dataclass per part.

The servo's four parts (see `ctrl_lpv.twomass.servo`) each take their
settings as one object: the move planner (`ServoPlanner`), the certified
feedback synthesis (`ServoSynthesis`), the anti-hunting law
(`ServoAntiHunting`) and the shaft-torque observer with its gap estimate
(`ServoEstimator`). Every field is checked when the object is made, and
the error names the class and the field. The defaults are the tuning of
``docs/servo.rst``.
"""

from __future__ import annotations

from dataclasses import dataclass

from .._checks import flag, real_number
from .free_rest import FreeRest
from .rest_flank import RestFlank

__all__ = [
    "ServoPlanner",
    "ServoSynthesis",
    "ServoAntiHunting",
    "ServoEstimator",
    "ServoStream",
]


def interval(value, label: str) -> tuple[float, float]:
    """A pair ``(low, high)`` of real numbers with ``low <= high``."""
    try:
        items = list(value)
    except TypeError:
        items = None
    if isinstance(value, (str, bytes)) or items is None or len(items) != 2:
        raise TypeError(f"{label}: expected (low, high), got {value!r}")
    lo, hi = (real_number(v, label) for v in items)
    if lo > hi:
        raise ValueError(f"{label}: need low <= high, got {value!r}")
    return lo, hi


def positive_range(value, label: str) -> tuple[float, float]:
    """A pair ``(low, high)`` with ``0 < low <= high``."""
    lo, hi = interval(value, label)
    if not lo > 0:
        raise ValueError(f"{label}: need 0 < low <= high, got {value!r}")
    return lo, hi


def _check(obj, positive=(), nonnegative=(), flags=()) -> None:
    """Check the named fields of a frozen dataclass and store them normalised.

    Positive and nonnegative fields become floats, flags bools; an error
    names ``Class.field``.
    """
    cls = type(obj).__name__
    for kind, names in (("positive", positive), ("nonneg", nonnegative),
                        ("flag", flags)):  # fmt: skip
        for name in names:
            value, label = getattr(obj, name), f"{cls}.{name}"
            if kind == "flag":
                value = flag(value, label)
            elif kind == "positive":
                value = real_number(value, label, positive=True)
            else:
                value = real_number(value, label, minimum=0.0)
            # Frozen: the checked value replaces the given one, once, here.
            object.__setattr__(obj, name, value)


@dataclass(frozen=True)
class ServoPlanner:
    """Settings of the servo's online rest-to-rest planner.

    Parameters
    ----------
    torque_reserve : float, optional
        Share of the torque limit kept for the feedback, in ``[0, 1)``:
        moves are planned so that the rigid-body torque of the heaviest
        load plus ``Td_max`` stays below ``(1 - torque_reserve) *
        torque_limit`` (default 0.12).
    min_duration : float, optional
        Shortest move, s (default 0.2: short moves excite the shaft mode
        through the feedforward's inertia error).
    horizon_floor : float, optional
        Floor of the continuous planner's time-to-go, s (default 0.04);
        sampled, the planner runs the move to its end
        (`ctrl_lpv.twomass.servo_sampled.plan_stepper`).

    Raises
    ------
    TypeError, ValueError
        For a value that is not a real number in its range, naming the
        field.
    """

    torque_reserve: float = 0.12
    min_duration: float = 0.2
    horizon_floor: float = 0.04

    def __post_init__(self):
        _check(self, positive=("min_duration", "horizon_floor"))
        reserve = real_number(
            self.torque_reserve, "ServoPlanner.torque_reserve", minimum=0.0, below=1.0
        )
        object.__setattr__(self, "torque_reserve", reserve)


@dataclass(frozen=True)
class ServoSynthesis:
    """Settings of the certified feedback synthesis of the servo.

    The gain comes from `ctrl_lpv.hinf_state_feedback` on
    `servo_polytope` with these settings (see `lpv_model` for the
    weights).

    Parameters
    ----------
    p_bounds : (float, float), optional
        Interval of the backlash parameter (default ``(-0.5, 0)``).
    torque_weight : float or None, optional
        Weight of ``Tm`` in the performance output; None (the default):
        5e-4 in continuous time, and per sample time the rule of
        `ctrl_lpv.twomass.sampled_tuning.sampled_tuning`.
    integral_weight : float, optional
        Weight of the integral of the load-angle error (default 30).

    Raises
    ------
    TypeError, ValueError
        For a value that is not a real number in its range, or reversed
        `p_bounds`, naming the field.
    """

    p_bounds: tuple[float, float] = (-0.5, 0.0)
    torque_weight: float | None = None
    integral_weight: float = 30.0

    def __post_init__(self):
        _check(self, positive=("integral_weight",))
        if self.torque_weight is not None:
            _check(self, positive=("torque_weight",))
        bounds = interval(self.p_bounds, "ServoSynthesis.p_bounds")
        object.__setattr__(self, "p_bounds", bounds)


@dataclass(frozen=True)
class ServoAntiHunting:
    """Settings of the servo's flank choice and integral action.

    Against hunting (``docs/servo.rst``) the flank of the backlash offset
    is chosen by the whole shaft torque asked for (feedforward plus load
    feedback), and the integral of the load error runs only in contact,
    fading out of it.

    Parameters
    ----------
    enabled : bool, optional
        Flank choice by the feedback, probing for a wider gap and the
        contact-aware integral (default True). False: the backlash offset
        follows the feedforward torque only and the integral always runs.
    flank_width : float, optional
        Shaft torque, Nm, over which the backlash offset turns from one
        flank to the other (default 0.5; a steady asked torque inside this
        band makes a steep flank choice, so it is kept small). Used with
        `enabled` False too.
    integral_leak : float, optional
        Decay rate (1/s) of the integral out of contact (default 2).
    integral_hold : float, optional
        Planned speed, rad/s, above which the integral is held (default
        0.05): it integrates at rest, for the load torque, not the tracking
        error of a move (which would wind it up); 0 disables the hold.
        Used with `enabled` False too.
    rest_flank : `ctrl_lpv.twomass.rest_flank.RestFlank` or None, optional
        Sampled servo (``dt`` set), with `enabled`: at rest with a small
        load torque the flank is latched and changed on evidence only
        (default ``RestFlank()``); None keeps the continuous flank choice
        at rest (which chatters on encoders: 111-223 Nm at Td = 0). With
        ``reference="stream"`` the servo rests only once the streamed
        set-point has stopped (tracker speed and acceleration near zero);
        with ``sensors="motor"`` the latch is off (the motor waits mid-gap).
    free_rest : `ctrl_lpv.twomass.free_rest.FreeRest` or None, optional
        Sampled servo on both encoders, within the latch (`rest_flank`): a
        free load (no load torque) is caught and rests on the motor held
        alone as a soft wall (default ``FreeRest()``; `servo_design`'s default up to
        1.5 ms of sample time only, `ctrl_lpv.twomass.sampled_tuning`);
        None keeps the latched law at every rest.

    Raises
    ------
    TypeError, ValueError
        For a value that is not a real number in its range, an `enabled`
        that is not a bool, or a `rest_flank` that is not a `RestFlank` (a
        `free_rest` that is not a `FreeRest`), naming the field.
    """

    enabled: bool = True
    flank_width: float = 0.5
    integral_leak: float = 2.0
    integral_hold: float = 0.05
    rest_flank: RestFlank | None = RestFlank()
    free_rest: FreeRest | None = FreeRest()

    def __post_init__(self):
        _check(
            self,
            positive=("flank_width",),
            nonnegative=("integral_leak", "integral_hold"),
            flags=("enabled",),
        )
        if self.rest_flank is not None and not isinstance(self.rest_flank, RestFlank):
            raise TypeError(
                "ServoAntiHunting.rest_flank: expected a RestFlank or None, got "
                f"{self.rest_flank!r}"
            )
        if self.free_rest is not None and not isinstance(self.free_rest, FreeRest):
            raise TypeError(
                "ServoAntiHunting.free_rest: expected a FreeRest or None, got "
                f"{self.free_rest!r}"
            )


@dataclass(frozen=True)
class ServoEstimator:
    """Settings of the shaft-torque observer and the online gap estimate.

    The observer on the motor side gives the shaft torque, which tells
    contact from the gap; in contact the gap estimate moves towards the
    flank seen in ``theta_m - theta_l``.

    Parameters
    ----------
    gap_estimate : bool, optional
        Estimate the gap online (default True); otherwise the backlash
        offset uses ``alpha_max / 2``.
    contact_torque : float, optional
        Observed shaft torque, Nm, above which the drive counts as in
        contact (weight 1 from twice this value; default 1.5). The gap
        estimate widens when twice this torque is asked for and not seen.
    estimate_rate : float, optional
        Rate of the gap estimate in contact, 1/s (default 50).
    probe_rate : float, optional
        Rate at which the estimate widens when a contact asked for is not
        made, rad/s (default 0.05).
    observer_bandwidth : float, optional
        Shaft-torque observer bandwidth, rad/s (default 1000).
    learn_torque : float, optional
        Sampled servo (``dt`` set): the gap estimate learns only while the
        planned shaft torque of the move is beyond this, Nm, on the flank
        the estimated shaft torque is on (default 15). A gap crossing (the
        motor swinging from one flank to the other at the end of a move)
        leaves the observer's shaft-torque estimate on the contact model
        for a few samples; its flank reading is then garbage.
    probe_error : float, optional
        Sampled servo: the gap estimate widens at rest only while the load
        error is beyond this, rad (default 2e-4: four counts of a 17-bit
        load encoder). A contact asked for and made but read as the gap
        (the shaft-torque estimate's noise at a small load torque) then
        does not widen it.
    static_speed : float, optional
        Sampled servo: a flank reading counts as static below this
        ``|omega_m - omega_l|``, rad/s (default 0.1: in contact the shaft
        torque's rate over the stiffness, 1 rad/s along a 0.05 rad move).
    narrowing_band : float, optional
        Sampled servo: in a move a flank reading more than this below the
        estimate, rad, teaches it only where static (default 2e-3). The
        observer reads the motor's landing on a flank as a contact 10-20 ms
        early, the motor still in the gap: a reading narrower than the gap.
    rest_estimate_rate : float, optional
        Sampled servo: rate of the gap estimate at rest, 1/s, where it
        learns only from static readings while the load leans on the flank
        (an observed load torque beyond ``contact_torque`` of the shaft
        torque's sign; default 5, a tenth of `estimate_rate`: the reading's
        noise moves the motor, and the load, with the estimate). 0 learns
        only in moves.
    initial_half_gap : float or None, optional
        The gap estimate's first value, rad: a commissioned half-gap
        (`ctrl_lpv.twomass.identify_load_inertia`'s
        `~ctrl_lpv.twomass.LoadInertia.half_gap`), within ``[0,
        alpha_max]``; None (the default) starts from ``alpha_max / 2``.
        On the motor encoder alone a first contact far from the estimate
        throws the load (``docs/servo.rst``, "Commissioning the
        half-gap").
    shaft_torque_rate, load_torque_rate : float or None, optional
        Sampled servo on encoders: the intensities, Nm/s, of the random
        walks of the shaft torque and the load torque in the drive
        observer's model (`ctrl_lpv.twomass.drive_observer`); None (the
        default) takes them from
        `ctrl_lpv.twomass.sampled_tuning.sampled_tuning` for the sample
        time (the first of its intensities whose certified rest covers its
        target load torque).

    Raises
    ------
    TypeError, ValueError
        For a value that is not a real number in its range, or a
        `gap_estimate` that is not a bool, naming the field.
    """

    gap_estimate: bool = True
    contact_torque: float = 1.5
    estimate_rate: float = 50.0
    probe_rate: float = 0.05
    observer_bandwidth: float = 1000.0
    learn_torque: float = 15.0
    probe_error: float = 2e-4
    static_speed: float = 0.1
    narrowing_band: float = 2e-3
    rest_estimate_rate: float = 5.0
    initial_half_gap: float | None = None
    shaft_torque_rate: float | None = None
    load_torque_rate: float | None = None

    def __post_init__(self):
        _check(
            self,
            positive=(
                "contact_torque",
                "observer_bandwidth",
                "static_speed",
                "narrowing_band",
            ),
            nonnegative=(
                "estimate_rate",
                "probe_rate",
                "learn_torque",
                "probe_error",
                "rest_estimate_rate",
            ),
            flags=("gap_estimate",),
        )
        for name in ("shaft_torque_rate", "load_torque_rate"):
            if getattr(self, name) is not None:
                _check(self, positive=(name,))
        if self.initial_half_gap is not None:
            _check(self, nonnegative=("initial_half_gap",))


@dataclass(frozen=True)
class ServoStream:
    """Settings of the tracker of a streamed set-point (``reference="stream"``).

    The servo follows a set-point streamed every sample with the
    feedforward of the set-point's own speed, acceleration and jerk, taken
    from the alpha-beta-gamma-delta tracker of `ctrl_lpv.twomass.stream`.

    Parameters
    ----------
    bandwidth : float, optional
        Rate of the tracker's four equal poles, rad/s (default 100, 16 Hz).
        It trades lag against noise: a 1 Hz sine is tracked with an
        acceleration error of 2 % of its amplitude (``(w / bandwidth)^4``
        scaling: 0.1 % at 200 rad/s), while a set-point's own noise reaches
        the acceleration with a gain of order ``bandwidth^2`` (1e4 s^-2: a
        17-bit count of set-point noise gives about 3 Nm of torque through
        the inertias).

    Raises
    ------
    TypeError, ValueError
        For a value that is not a positive real number, naming the field.
    """

    bandwidth: float = 100.0

    def __post_init__(self):
        _check(self, positive=("bandwidth",))
