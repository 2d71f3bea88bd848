r"""What is certified about the servo on the exact backlash plant.

The exact plant, seen from the servo's motor reference (which includes the
backlash offset ``delta``), is the contact model (shaft torque ``ks
(theta_d - delta) + cs omega_d``, the LPV model at ``p = 0``) plus a
departure

.. math::

    \tilde w = k_s (\theta_d - \delta) + c_s \omega_d - T_s ,

which is ``ks (theta_b - delta)`` in contact (at most ``2 ks alpha_max``,
and zero when the offset matches the flank) and ``ks (theta_d - delta) + cs
omega_d`` in the gap.  With the move ended (the reference at rest, ``delta``
constant), a constant load torque, the integral running and the torque
unsaturated, the error ``x = [theta_m - r - delta, omega_m, theta_l - r,
omega_l, int e_l]`` about its equilibrium (where ``e_l = 0``) obeys ``dx/dt
= (A_j - B_j K) x + E_j w~``.  `servo_certificate` asks
`ctrl_lpv.reachability.ultimate_bound` for an invariant attractive
ellipsoid for ``|w~| <= 1 Nm``, common to both inertia vertices (so valid
for any load inertia in the range, also varying); by homogeneity ``|e_l|
<= beta sup|w~|`` ultimately, with the certified ``beta`` in rad/Nm.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..certificate import Certificate
from ..exceptions import SynthesisError
from ..reachability import UltimateBound, ultimate_bound
from ..saturation import SaturatedDesign, saturation_region
from ..synthesis import StateFeedbackDesign
from ..systems import pss
from .model import lpv_model
from .parameters import Parameters
from .servo_rest import RestBound

__all__ = ["ServoCertificate", "servo_certificate", "contact_loop"]


@dataclass(frozen=True)
class ServoCertificate(Certificate):
    """The servo's certified statements: one `ctrl_lpv.Certificate`.

    Its checks are those of its parts, grouped ``"feedback"``,
    ``"ultimate bound"`` and ``"region"``; `statement` says what each part
    covers and what is not certified. A servo without any part (a given
    gain, nothing computed) has no checks and is not verified.

    Attributes
    ----------
    feedback : `ctrl_lpv.Certificate` or None
        The synthesis certificate of the gain (quadratic H-infinity bound
        from ``Td`` for every ``(p, Jl)`` of the design box); None for a
        given gain.
    gamma : float or None
        Its certified H-infinity bound.
    ultimate : `ctrl_lpv.reachability.UltimateBound` or None
        Invariant attractive ellipsoid of the contact loop for ``|w~| <=
        1`` Nm; its bounds are per Nm of ``sup |w~|``.
    w_max : ndarray
        The peak bound used, ``[1.0]``.
    statement : str
        The statements in words.
    region : `ctrl_lpv.SaturatedDesign` or None
        Region of attraction of the contact loop under the torque limit
        (generalized sector condition, both inertia vertices), with the
        feedback's share ``torque_limit - Td_max`` of the limit; None if it
        was not computed or did not certify.
    rest : `ctrl_lpv.twomass.servo_rest.RestBound` or None
        A sampled design's certified rest: the loop that runs (observer,
        delay, encoder errors); None in continuous time.
    """

    feedback: Certificate | None = None
    gamma: float | None = None
    ultimate: UltimateBound | None = field(default=None, compare=False)
    w_max: np.ndarray = field(default_factory=lambda: np.ones(1), compare=False)
    region: SaturatedDesign | None = field(default=None, compare=False)
    rest: RestBound | None = field(default=None, compare=False)

    @property
    def rest_error_bound(self) -> float | None:
        """Certified ``|theta_l - theta_r|`` at rest of a sampled design, rad."""
        return None if self.rest is None else self.rest.error_bound

    @property
    def rest_ripple_bound(self) -> float | None:
        """Certified half peak-to-peak of the torque at rest (sampled), Nm."""
        return None if self.rest is None else self.rest.ripple_bound

    @property
    def error_bound(self) -> float | None:
        """Certified ultimate ``|theta_l - theta_r|`` per Nm of ``sup|w~|``."""
        return None if self.ultimate is None else float(self.ultimate.bounds[0])

    @property
    def torque_bound(self) -> float | None:
        """Certified ultimate feedback torque ``|K x|`` per Nm of ``sup|w~|``."""
        return None if self.ultimate is None else float(self.ultimate.bounds[1])


def contact_loop(params: Parameters, gain, Jl_range) -> tuple[list, np.ndarray]:
    """Closed-loop contact-model matrices at the two inertia vertices.

    Parameters
    ----------
    params : `Parameters`
        Nominal data.
    gain : array_like
        ``1 x 5`` gain on the tracking-error state (``u = -K x``).
    Jl_range : (float, float)
        Inertia multiples.

    Returns
    -------
    (list of ndarray, list of ndarray)
        ``A_j - B_j K`` and the input column ``E_j`` of ``w``, one per
        vertex.
    """
    K = np.asarray(gain, float).reshape(1, 5)
    As, Es = [], []
    for f in Jl_range:
        p = params.replace(Jl=f * params.Jl)
        m = lpv_model(p, p_bounds=(-0.5, 0.0), formulation="tracking", integral=True)
        v = m.vertices[-1]  # p = 0: contact
        B_tm = np.asarray(v.B[:, [1]])
        As.append(np.asarray(v.A) - B_tm @ K)
        e_w = np.zeros((5, 1))
        e_w[1, 0], e_w[3, 0] = 1.0 / p.Jm, -1.0 / p.Jl
        Es.append(e_w)
    return As, Es


def servo_certificate(
    params: Parameters,
    gain,
    feedback: StateFeedbackDesign | None,
    *,
    alpha_max: float,
    Jl_range: tuple[float, float],
    Td_max: float,
    torque_limit: float,
    bound: bool = True,
    dt: float | None = None,
    rest: RestBound | None = None,
) -> ServoCertificate:
    """Collect the servo's certified statements (see the module docstring).

    Parameters
    ----------
    params : `Parameters`
        Nominal data.
    gain : array_like
        ``1 x 5`` feedback gain.
    feedback : `ctrl_lpv.StateFeedbackDesign` or None
        The synthesis behind `gain`, if any.
    alpha_max, Jl_range, Td_max, torque_limit
        As in `servo_design`.
    bound : bool, optional
        Compute the ultimate bound (an SDP line search, about a second).
    dt : float, optional
        Sample time of a sampled design (its gain certified on the
        zero-order-hold model).
    rest : `RestBound`, optional
        A sampled design's certified rest.

    Returns
    -------
    `ServoCertificate`
    """
    K = np.asarray(gain, float).reshape(1, 5)
    w_max = np.array([1.0])
    lines = ["certificate:"]
    fb_cert = gamma = None
    if feedback is not None:
        fb_cert, gamma = feedback.certificate, feedback.gamma
        where = (
            "for every (p, Jl) of the design box, time-varying" if dt is None
            else f"at the vertices of the design box sampled every {dt:g} s "
            "(zero-order hold) and their convex hull"
        )  # fmt: skip
        lines.append(
            f"  feedback: quadratic H-inf bound {gamma:.4g} from Td to (e_l, Tm_w, "
            f"int_e_l_w) {where} "
            f"[{'verified' if fb_cert.verified else 'NOT verified'}]"
        )
    else:
        lines.append("  feedback: a given gain (no synthesis certificate)")
    ultimate = None
    if bound:
        As, Es = contact_loop(params, K, Jl_range)
        C = np.vstack([np.eye(5)[2], K])
        ultimate = ultimate_bound((As, Es), w_max=w_max, output=C)
        beta = float(ultimate.bounds[0])
        worst = 2.0 * params.ks * alpha_max
        lines.append(
            f"  ultimate bound (contact loop; move ended, constant Td, integral "
            f"running, |Tm| < {torque_limit:g} Nm): |theta_l - theta_r| <= "
            f"{beta:.4g} rad per Nm of sup|w~| (w~ = ks (theta_d - delta) + cs "
            f"omega_d - Ts), feedback torque change <= {ultimate.bounds[1]:.4g} "
            f"Nm per Nm, rate {ultimate.decay:.3g}/s, for every Jl in the range; "
            f"for any alpha <= {alpha_max:g} in contact sup|w~| <= 2 ks alpha_max "
            f"= {worst:.4g} Nm, so |theta_l - theta_r| <= {beta * worst:.4g} rad "
            f"[{'verified' if ultimate.certificate.verified else 'NOT verified'}]"
        )
    region = None
    if bound:
        region, text = _saturation_region(params, K, Jl_range, torque_limit, Td_max)
        lines.append(text)
    if rest is not None:
        lines.append(
            f"  {rest} [{'verified' if rest.certificate.verified else 'NOT verified'}]"
        )
    lines.append(
        "  not certified: the gap crossings, the planner or the set-point "
        "tracker, the flank choice, the "
        "gap estimate and the contact-aware, held integral (checked by "
        "simulation)"
    )
    parts = {
        "feedback": fb_cert,
        "ultimate bound": None if ultimate is None else ultimate.certificate,
        "region": None if region is None else region.certificate,
        "rest": None if rest is None else rest.certificate,
    }
    whole = Certificate.combine(
        *(part.regrouped(name) for name, part in parts.items() if part is not None)
    )
    return ServoCertificate(
        whole.checks, "\n".join(lines), feedback=fb_cert, gamma=gamma,
        ultimate=ultimate, w_max=w_max, region=region, rest=rest,
    )  # fmt: skip


def _saturation_region(params, K, Jl_range, torque_limit, Td_max):
    """The contact loop's certified region under the torque limit."""
    vertices = []
    for f in Jl_range:
        p = params.replace(Jl=f * params.Jl)
        m = lpv_model(p, p_bounds=(-0.5, 0.0), formulation="tracking", integral=True)
        vertices.append(m.vertices[-1])  # p = 0: contact
    loop = pss(vertices, {"Jl": tuple(float(f) for f in Jl_range)})
    share = torque_limit - Td_max  # the rest holds the load torque
    # The reference set in the servo's units: 10 mrad, 1 rad/s, 1 mrad s.
    axes = np.array([1e-2, 1.0, 1e-2, 1.0, 1e-3])
    try:
        region = saturation_region(loop, K, "Tm", share, shape=np.diag(axes**-2.0))
    except SynthesisError as exc:
        return None, f"  region under the torque limit: not certified ({exc})"
    e_l, speed = region.ellipsoid.support(np.eye(5)[[2, 3]])
    text = (
        f"  region under the torque limit (contact loop, feedback share "
        f"|K x| <= {share:g} Nm of {torque_limit:g} Nm, every Jl in the range, "
        f"generalized sector condition): every tracking error in the ellipsoid "
        f"x'Px <= 1 returns to rest, with |theta_l - r| up to {e_l:.3g} rad "
        f"and |omega_l| up to {speed:.3g} rad/s in it "
        f"[{'verified' if region.certificate.verified else 'NOT verified'}]"
    )
    return region, text
