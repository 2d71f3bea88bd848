"""The paper's affine LPV model (30) of the two-mass drive, and its gain.

The backlash is written as ``theta_s = (1 + p) theta_d`` (26)-(27): ``p = -1``
in the gap, ``p -> 0`` far from it. The shaft torque of the model is
``Ts = ks (1 + p) theta_d + cs omega_d``; unlike the exact backlash model it
keeps the damping ``cs omega_d`` inside the gap.
"""

from __future__ import annotations

import numpy as np
from control import StateSpace

from .._checks import flag, real_number
from ..controllers import integral_augmentation
from ..systems import PolytopicStateSpace
from .parameters import Parameters

__all__ = ["lpv_model", "paper_gain", "PAPER_GAIN", "PAPER_GAMMA"]

#: The gain published in Section V, for ``u = K x`` (the paper's sign).
PAPER_GAIN = 1e4 * np.array([[-1.292820, -0.018157, -2.949388, -0.180820]])

#: The H-infinity level published with it (not certifiable, see the errata).
PAPER_GAMMA = 2.9734

#: Default weight of the motor torque in the tracking formulation's z.
TORQUE_WEIGHT = 2e-3

#: Default weight of the integral of the load-angle error in z.
INTEGRAL_WEIGHT = 10.0


def lpv_model(
    params: Parameters | None = None,
    p_bounds: tuple[float, float] = (-1.0, 0.0),
    formulation: str = "paper",
    integral: bool = False,
    *,
    torque_weight: float = TORQUE_WEIGHT,
    integral_weight: float = INTEGRAL_WEIGHT,
) -> PolytopicStateSpace:
    r"""Affine LPV model (30) of the two-mass drive with backlash.

    Parameters
    ----------
    params : `Parameters`, optional
        Drive data; default the paper's table.
    p_bounds : (float, float), optional
        Bounds of the backlash parameter ``p``; the paper uses ``[-1, 0]``,
        whose vertex ``p = -1`` is not stabilizable (see the errata):
        designs use ``[-1 + eps, 0]``.
    formulation : {"paper", "tracking"}, optional
        ``"paper"`` reproduces (30) with its missing first row of ``A``
        restored: states ``[theta_m, omega_m, theta_l - theta_r, omega_l]``,
        inputs ``["Td", "theta_r", "Tm"]``, output ``z = theta_l`` (that is
        ``C = [0 0 1 0]``, ``D1 = [0 1]``). ``"tracking"`` uses error
        coordinates ``[theta_m - theta_r, omega_m, theta_l - theta_r,
        omega_l]``, inputs ``["Td", "Tm"]`` and outputs ``e_l`` (load-angle
        error) and ``Tm_w`` (weighted motor torque).
    integral : bool, optional
        Tracking formulation only: append the state ``int_e_l``, the
        integral of the load-angle error, and the output ``int_e_l_w``
        (its weighted value) for integral action.
    torque_weight : float, optional
        Weight of the motor torque in ``Tm_w = torque_weight * Tm``.
    integral_weight : float, optional
        Weight in ``int_e_l_w = integral_weight * int_e_l``.

    Returns
    -------
    `ctrl_lpv.PolytopicStateSpace`
        Over the box ``{"p": p_bounds}``, nominal point the box center.

    Raises
    ------
    ValueError
        For an unknown formulation, bounds outside ``[-1, 0]`` or reversed,
        nonpositive weights, or ``integral=True`` with the paper
        formulation.

    Examples
    --------
    >>> sys = lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking")
    >>> sys.input_labels
    ['Td', 'Tm']
    """
    params = Parameters() if params is None else params
    if not isinstance(params, Parameters):
        raise TypeError(f"params: expected twomass.Parameters, got {type(params)!r}")
    if formulation not in ("paper", "tracking"):
        raise ValueError(
            f"formulation: expected 'paper' or 'tracking', got {formulation!r}"
        )
    try:
        lo, hi = p_bounds
    except (TypeError, ValueError):
        raise ValueError(
            f"p_bounds: expected (lower, upper), got {p_bounds!r}"
        ) from None
    lo, hi = (real_number(b, "p_bounds") for b in (lo, hi))
    if not (-1.0 <= lo < hi <= 0.0):
        raise ValueError(
            f"p_bounds: need -1 <= lower < upper <= 0 (p = -alpha/theta_d), "
            f"got {p_bounds!r}"
        )
    torque_weight = real_number(torque_weight, "torque_weight", positive=True)
    integral_weight = real_number(integral_weight, "integral_weight", positive=True)
    integral = flag(integral, "integral")
    if integral and formulation == "paper":
        raise ValueError("integral: only available with formulation='tracking'")

    Jm, Jl, cm, cl, ks, cs = (
        params.Jm, params.Jl, params.cm, params.cl, params.ks, params.cs
    )  # fmt: skip
    # A(p) = A0 + p A1 with theta_s = (1 + p) theta_d.
    A0 = np.array(
        [
            [0.0, 1.0, 0.0, 0.0],
            [-ks / Jm, -(cm + cs) / Jm, ks / Jm, cs / Jm],
            [0.0, 0.0, 0.0, 1.0],
            [ks / Jl, cs / Jl, -ks / Jl, -(cl + cs) / Jl],
        ]
    )
    A1 = np.zeros((4, 4))
    A1[1, [0, 2]] = [-ks / Jm, ks / Jm]
    A1[3, [0, 2]] = [ks / Jl, -ks / Jl]
    b_Td = np.array([[0.0], [0.0], [0.0], [-1.0 / Jl]])
    b_Tm = np.array([[0.0], [1.0 / Jm], [0.0], [0.0]])

    if formulation == "paper":
        # theta_r enters through theta_d = x1 - x3 - theta_r.
        b_r0 = np.array([[0.0], [ks / Jm], [0.0], [-ks / Jl]])
        B0 = np.hstack([b_Td, b_r0, b_Tm])
        B1 = np.hstack([np.zeros((4, 1)), b_r0, np.zeros((4, 1))])
        base = StateSpace(
            A0, B0, [[0.0, 0.0, 1.0, 0.0]], [[0.0, 1.0, 0.0]],
            inputs=["Td", "theta_r", "Tm"], outputs=["theta_l"],
            states=["theta_m", "omega_m", "e_l", "omega_l"], name="twomass_paper",
        )  # fmt: skip
        return PolytopicStateSpace.from_affine(
            base, {"p": (A1, B1, 0, 0)}, {"p": (lo, hi)}
        )

    C = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    D = np.array([[0.0, 0.0], [0.0, torque_weight]])
    base = StateSpace(
        A0, np.hstack([b_Td, b_Tm]), C, D,
        inputs=["Td", "Tm"], outputs=["e_l", "Tm_w"],
        states=["e_m", "omega_m", "e_l", "omega_l"], name="twomass_tracking",
    )  # fmt: skip
    sys = PolytopicStateSpace.from_affine(base, {"p": (A1, 0, 0, 0)}, {"p": (lo, hi)})
    if not integral:
        return sys
    sys = integral_augmentation(sys, "e_l", name="twomass_tracking_integral")
    # Weighted integral state as a third performance output (in place of
    # the unweighted one integral_augmentation appends).
    vertices = []
    for A, B, Cv, Dv in sys.vertex_data():
        row = np.zeros((1, A.shape[0]))
        row[0, -1] = integral_weight
        vertices.append((A, B, np.vstack([Cv[:-1], row]), Dv))
    return PolytopicStateSpace(
        vertices, sys.domain, inputs=["Td", "Tm"],
        outputs=["e_l", "Tm_w", "int_e_l_w"], states=sys.state_labels,
        name=sys.name,
    )  # fmt: skip


def paper_gain() -> np.ndarray:
    """The paper's published gain in python-control's sign, ``u = -K x``.

    The paper writes ``u = K_paper x``; this returns ``K = -K_paper``, for
    the states ``[theta_m - theta_r, omega_m, theta_l - theta_r, omega_l]``
    (the error coordinates with which the published figures are reproduced;
    see the errata).

    Returns
    -------
    ndarray
        Shape ``(1, 4)``.

    Examples
    --------
    >>> paper_gain().round(1)
    array([[12928.2,   181.6, 29493.9,  1808.2]])
    """
    return -PAPER_GAIN.copy()
