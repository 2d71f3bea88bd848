"""The frozen system python-control sees: the nominal point, or ``params``.

A `PolytopicStateSpace` is a `control.StateSpace` whose ``A, B, C, D`` are
the frozen system at its nominal point, with one `NominalPointWarning` per
python-control call that reads them, or the frozen system at the
``params`` of an enclosing time response. `NominalPointMixin` holds these
matrices and `linearize`; `params_point` and `inside_or_raise` turn a
``params`` dict into a checked parameter point.
"""

from __future__ import annotations

import sys as _sys
from collections.abc import Mapping

import numpy as np

from .._checks import real_number
from ..exceptions import NominalPointWarning
from .frames import call_name, given, in_package, reader, warn_at

__all__ = ["NominalPointMixin", "params_point", "inside_or_raise"]

# The last nominal-point warning, so that one call warns once, whatever
# systems it reads: (the frame of the call, line for direct accesses).
_last_nominal_warning: list = [None]


def params_point(sys, params) -> tuple[np.ndarray, list[str]]:
    """Parameter point of a ``params`` dict; missing names are nominal.

    Raises
    ------
    TypeError, ValueError
        Naming ``params`` when it is not a mapping, names none of the
        parameters, or holds a value that is not a finite real number.
    """
    if not isinstance(params, Mapping):
        raise TypeError(
            "params: expected a dict {parameter name: value}, got "
            f"{type(params).__name__}"
        )
    names = sys.domain.names
    if not any(name in params for name in names):
        raise ValueError(
            f"params: none of {sorted(map(str, params))} is a parameter of "
            f"{sys.name!r}; its parameters are {list(names)}"
        )
    values = []
    for name, nominal in zip(names, sys.nominal):
        values.append(real_number(params.get(name, nominal), f"params[{name!r}]"))
    return np.array(values), [name for name in names if name not in params]


def inside_or_raise(sys, point: np.ndarray, label: str = "params") -> None:
    """Refuse a frozen parameter value outside the domain of `sys`."""
    if not sys.domain.contains(point):
        values = dict(zip(sys.domain.names, point.tolist()))
        raise ValueError(
            f"{label}: {values} is outside the domain {sys.domain!r} of "
            f"{sys.name!r}; a frozen parameter value must lie in it"
        )


def _matrix_property(index: int, label: str) -> property:
    def getter(self):
        return self._matrices_for(_sys._getframe(1), label)[index]

    def setter(self, value):
        data = list(self.__dict__.get("_ss_data", (None,) * 4))
        data[index] = value
        self.__dict__["_ss_data"] = tuple(data)

    return property(
        getter,
        setter,
        doc=f"""``{label}`` matrix at the nominal point `nominal` (see the class).

        Read by python-control's linear tools, which then warn with
        `NominalPointWarning`; inside a time response with ``params`` it is
        ``sys.at(params).{label}``.""",
    )


class NominalPointMixin:
    """``A, B, C, D`` and `linearize` of a polytopic system, frozen.

    For `PolytopicStateSpace` (before `control.StateSpace` in its bases):
    it uses its ``domain``, ``nominal``, ``scheduling``, ``name`` and
    ``_combine``.
    """

    # ------------------------------------------------------------------
    # The StateSpace matrices: nominal, or frozen at a time response's params
    # ------------------------------------------------------------------
    #: What the warnings call the system.
    _kind = "polytopic"

    A = _matrix_property(0, "A")
    B = _matrix_property(1, "B")
    C = _matrix_property(2, "C")
    D = _matrix_property(3, "D")

    def _matrices_for(self, frame, attribute: str) -> tuple[np.ndarray, ...]:
        """The matrices as the code at `frame` should see them.

        Inside a `control.timeresp` call given ``params`` (the linear path of
        `control.forced_response`, which `step_response` and
        `initial_response` use): the frozen system at ``params``. Otherwise
        the nominal matrices, with a `NominalPointWarning` when the reader is
        not ctrl_lpv itself.
        """
        entry, caller, params = reader(frame)
        if params is not None:
            return self._frozen_for_params(params, entry, caller)
        if not in_package(caller):
            self._warn_nominal(entry, caller, call_name(entry, attribute))
        return self._ss_data

    def _nominal_text(self) -> str:
        point = dict(zip(self.domain.names, self.nominal.tolist()))
        return f"p = {point} ({self._nominal_source})"

    def _warn_nominal(self, entry, caller, what: str, detail: str = "") -> None:
        """Warn once per call that `what` reads the nominal frozen system."""
        anchor = entry if entry is not None else caller
        line = None if entry is not None or caller is None else caller.f_lineno
        last = _last_nominal_warning[0]
        if last is not None and last[0] is anchor and last[1] == line:
            return
        _last_nominal_warning[0] = (anchor, line)
        message = detail or (
            f"{what}: the {self._kind} system {self.name!r} is read at its nominal "
            f"point {self._nominal_text()}, i.e. as the frozen system "
            "sys.at(sys.nominal), not as the LPV system; use sys.at(p) to "
            "choose the point (time responses: params={...})"
        )
        warn_at(message, NominalPointWarning, caller)

    def _frozen_for_params(self, params, entry, caller) -> tuple[np.ndarray, ...]:
        if self.scheduling is not None:
            how = "its inputs" if self.scheduling == "inputs" else "a callable"
            raise ValueError(
                f"params: {self.name!r} is scheduled by {how}, so params= does "
                "not freeze its parameter; use sys.at(p) for the frozen system "
                "or control.input_output_response for the scheduled simulation"
            )
        point, missing = params_point(self, params)
        inside_or_raise(self, point)
        if missing and not in_package(caller):
            nominal = {
                n: float(v)
                for n, v in zip(self.domain.names, self.nominal)
                if n in missing
            }
            self._warn_nominal(
                entry,
                caller,
                "params",
                detail=(
                    f"params: {missing} not given for {self.name!r}; the nominal "
                    f"value(s) {nominal} are used"
                ),
            )
        return self._combine(self.domain._weights(point))

    def linearize(self, x0, u0=None, t=0, params=None, **kwargs):
        """Linearize about ``(x0, u0)``, frozen at ``params``.

        With ``scheduling=None`` the result is the frozen system at ``params``
        (``sys.at(params)`` with the scheduling inputs, if any); without
        ``params`` it is the nominal one, with a `NominalPointWarning`. With
        a scheduling by inputs or by a callable it is the Jacobian of the
        scheduled (quasi-LPV) dynamics at ``(x0, u0)``.

        Parameters
        ----------
        x0 : array_like or `control.OperatingPoint`
            State at which to linearize (need not be an equilibrium); an
            operating point gives both the state and the input.
        u0 : array_like, optional
            Input at which to linearize, one entry per input of this system
            (physical inputs, then the scheduling inputs for
            ``scheduling="inputs"``); default 0 (or the operating point's).
        t : float, optional
            Time of the linearization, default 0 (it matters only for a
            time-dependent scheduling callable).
        params : dict, optional
            ``{parameter name: value}`` at which the matrices are frozen
            with ``scheduling=None``; names that are missing keep their
            nominal value (with a `NominalPointWarning`). Default: the
            nominal point, with a `NominalPointWarning`. Ignored by the
            dynamics with a scheduling by inputs or by a callable.
        **kwargs
            Passed to `control.NonlinearIOSystem.linearize`: ``eps``
            (finite-difference step, default 1e-6), ``copy_names``
            (copy the signal names, default False), ``name``, ``inputs``,
            ``outputs``, ``states``.

        Returns
        -------
        `control.StateSpace`
            The linearization, computed by finite differences.

        Raises
        ------
        TypeError
            If `params` is not a mapping or holds a value that is not a
            real number.
        ValueError
            If `params` names none of the parameters, or lies outside the
            domain.
        """
        if self.scheduling is None:
            entry, caller, _ = reader(_sys._getframe(1))
            if given(params):
                point, missing = params_point(self, params)
                inside_or_raise(self, point)
                if missing and not in_package(caller):
                    self._warn_nominal(
                        entry,
                        caller,
                        "linearize",
                        detail=f"params: {missing} not given; nominal value used",
                    )
            elif not in_package(caller):
                self._warn_nominal(entry, caller, call_name(entry, "linearize"))
        return super().linearize(x0, u0, t=t, params=params, **kwargs)
