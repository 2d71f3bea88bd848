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
load-torque model becomes ``Td + delta_hat Jl a_r`` (``a_r`` the planned
load acceleration), and the correction the load encoder asks of it is
shared between the two by how much the move accelerates: at rest
(``a_r = 0``; the planner's ``a_r`` is 1e-26 rad/s^2 there) all of it
goes to ``Td`` and the rest loop is the certified six-state observer's
(`servo_rest`), while the load accelerates by more than ``accel_floor``
most of it goes to ``delta_hat`` (``gain`` times faster than ``Td``
learns), in contact and while the shaft pushes the way the plan
accelerates (a gap crossing's impact is not inertia). ``delta_hat`` is
projected on the design's inertia range and kept between moves, so the
next move starts with it. The feedforward uses ``(1 + delta_hat) Jl``
(`flat_feedforward`'s ``scale``).

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

from .._checks import flag, real_number

__all__ = ["ServoInertia", "InertiaAdaptation", "inertia_adaptation"]

#: Indices of the shaft and load torques in `DRIVE_STATES`.
_TS, _TD = 2, 5


@dataclass(frozen=True)
class ServoInertia:
    """Settings of the sampled servo's online load-inertia estimate.

    Parameters
    ----------
    enabled : bool, optional
        Learn the load inertia along moves (default True; used with
        ``sensors="encoders"``). False: the nominal inertia throughout.
    gain : float, optional
        How much faster the inertia learns than the observer's load
        torque (default 4): the share of the load-torque correction moved
        to the inertia while the load accelerates.
    accel_floor : float, optional
        Planned load acceleration, rad/s^2, at which half of the
        correction goes to the inertia (default 3): below it the load
        torque learns, above it the inertia.
    """

    enabled: bool = True
    gain: float = 1.0
    accel_floor: float = 3.0

    def __post_init__(self):
        object.__setattr__(self, "enabled", flag(self.enabled, "ServoInertia.enabled"))
        for name in ("gain", "accel_floor"):
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
    gain, accel_floor : float
        As in `ServoInertia`.
    bounds : (float, float)
        Range of ``delta_hat`` (the design's ``Jl_range`` less one).
    """

    Jl: float
    gain: float
    accel_floor: float
    bounds: tuple[float, float]

    def correct(self, xhat, delta, correction, accel, contact=1.0):
        """Filtered estimate and ``delta_hat`` after a measurement.

        Parameters
        ----------
        xhat : ndarray
            The predicted drive-observer state (`DRIVE_STATES`).
        delta : float
            The predicted ``delta_hat``.
        correction : ndarray
            The observer's correction ``M (y - C x_hat)`` of `xhat`.
        accel : float
            The planned load acceleration, rad/s^2.
        contact : float, optional
            The observer's contact weight in ``[0, 1]``: in the gap no
            torque reaches the load, and its motion says nothing of the
            inertia.

        Returns
        -------
        filtered : ndarray
            The corrected state; its ``Td`` is the load torque without
            the inertia's share.
        delta : float
            The corrected ``delta_hat``.
        """
        filtered = xhat + correction
        torque = self.Jl * accel
        floor = self.Jl * self.accel_floor
        # Only while the shaft pushes the way the plan accelerates: just
        # after a gap crossing the estimate reads the impact as contact.
        share = contact * torque * torque / (torque * torque + floor * floor)
        share *= xhat[_TS] * accel > 0.0
        if share > 0.0:
            step = correction[_TD]
            filtered[_TD] -= share * step
            delta = delta + self.gain * share * step / torque
            delta = min(max(delta, self.bounds[0]), self.bounds[1])
        return filtered, delta

    def predict(self, Phi, Gamma, filtered, u, delta, accel):
        """``x_hat[k+1|k]``: the observer's model with the inertia's share
        of the load torque, ``delta_hat Jl a_r``, over the sample."""
        shift = delta * self.Jl * accel
        state = filtered.copy()
        state[_TD] += shift
        ahead = Phi @ state + Gamma * u
        ahead[_TD] -= shift
        return ahead


def inertia_adaptation(
    settings: ServoInertia, Jl: float, Jl_range: tuple[float, float]
) -> InertiaAdaptation | None:
    """The `InertiaAdaptation` of `settings` (None when disabled)."""
    if not isinstance(settings, ServoInertia):
        raise TypeError(f"inertia: expected a ServoInertia, got {settings!r}")
    if not settings.enabled:
        return None
    lo, hi = (float(f) - 1.0 for f in Jl_range)
    return InertiaAdaptation(
        Jl=float(Jl), gain=settings.gain, accel_floor=settings.accel_floor,
        bounds=(lo, hi),
    )  # fmt: skip
