"""Physical parameters of the two-mass drive with backlash."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from numbers import Real

__all__ = ["Parameters"]

# Field name -> (lower bound, bound is strict, physical meaning).  Used by
# `Parameters.__post_init__` to produce error messages that name the field.
_LIMITS = {
    "Jm": (0.0, True, "motor inertia"),
    "Jl": (0.0, True, "load inertia"),
    "cm": (0.0, False, "motor viscous friction"),
    "cl": (0.0, False, "load viscous friction"),
    "ks": (0.0, True, "shaft stiffness"),
    "cs": (0.0, True, "shaft damping"),
    "alpha": (0.0, False, "backlash half-gap"),
}


@dataclass(frozen=True)
class Parameters:
    """Physical data of a two-mass drive with backlash.

    The defaults are the data of the simulation example (section V) of the
    LPV two-mass paper that this package reproduces: a motor and a load
    connected by an elastic, damped shaft through a backlash of half-width
    `alpha`.

    Parameters
    ----------
    Jm : float, optional
        Motor moment of inertia in kg m^2 (> 0).  Default 0.4.
    Jl : float, optional
        Load moment of inertia in kg m^2 (> 0).  Default 5.6.
    cm : float, optional
        Viscous motor friction in Nm/(rad/s) (>= 0).  Default 0.1.
    cl : float, optional
        Viscous load friction in Nm/(rad/s) (>= 0).  Default 1.0.
    ks : float, optional
        Shaft stiffness in Nm/rad (> 0).  Default 3300.
    cs : float, optional
        Inner damping of the shaft in Nm/(rad/s) (> 0).  Default 2.0.
    alpha : float, optional
        Backlash half-gap in rad (>= 0): the backlash angle varies in
        ``[-alpha, alpha]``.  Default 0.03.

    Attributes
    ----------
    Jm, Jl, cm, cl, ks, cs, alpha : float
        The values above, converted to `float`.

    Raises
    ------
    TypeError
        If a value is not a real number.
    ValueError
        If a value is not finite or is outside its physical range; the
        message names the field.

    See Also
    --------
    ctrl_lpv.twomass.plant.plant

    Notes
    -----
    The instance is immutable; use `replace` to derive a variant, for
    example a load inertia 20 % above nominal.  The shaft damping `cs` must
    be positive because the exact backlash model relaxes the shaft twist in
    the gap at the rate ``ks / cs``.

    Examples
    --------
    >>> from ctrl_lpv.twomass.parameters import Parameters
    >>> p = Parameters()
    >>> p.ks, p.alpha
    (3300.0, 0.03)
    >>> heavy = p.replace(Jl=1.2 * p.Jl)
    >>> round(heavy.Jl, 6)
    6.72

    """

    Jm: float = 0.4
    Jl: float = 5.6
    cm: float = 0.1
    cl: float = 1.0
    ks: float = 3300.0
    cs: float = 2.0
    alpha: float = 0.03

    def __post_init__(self) -> None:
        for name, (lower, strict, meaning) in _LIMITS.items():
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, Real):
                raise TypeError(
                    f"Parameters: `{name}` ({meaning}) must be a real number, "
                    f"got {type(value).__name__}"
                )
            value = float(value)
            if not math.isfinite(value):
                raise ValueError(
                    f"Parameters: `{name}` ({meaning}) must be finite, got {value}"
                )
            if value < lower or (strict and value == lower):
                relation = ">" if strict else ">="
                raise ValueError(
                    f"Parameters: `{name}` ({meaning}) must be {relation} "
                    f"{lower:g}, got {value:g}"
                )
            # Frozen dataclass: store the normalized float through object.
            object.__setattr__(self, name, value)

    def replace(self, **changes: float) -> Parameters:
        """Return a copy with some fields changed.

        Parameters
        ----------
        **changes : float
            New values, by field name (``Jm``, ``Jl``, ``cm``, ``cl``,
            ``ks``, ``cs``, ``alpha``).  They are validated as in the
            constructor.

        Returns
        -------
        Parameters
            The modified copy; `self` is unchanged.

        Raises
        ------
        TypeError
            If a name is not a field, or a value is not a real number.
        ValueError
            If a value is not finite or not physical.

        Examples
        --------
        >>> from ctrl_lpv.twomass.parameters import Parameters
        >>> Parameters().replace(alpha=0.045).alpha
        0.045

        """
        unknown = sorted(set(changes) - set(_LIMITS))
        if unknown:
            raise TypeError(
                f"Parameters.replace: unknown field(s) {unknown}; "
                f"valid fields are {list(_LIMITS)}"
            )
        return dataclasses.replace(self, **changes)
