"""The nonlinear I/O behaviour of a polytopic system: scheduled matrices.

In simulation (`control.input_output_response`, `dynamics`, `output`) a
polytopic system follows ``sum_j delta_j(p) (A_j, B_j, C_j, D_j)`` with the
parameter ``p`` from its `scheduling` source: the ``params`` dict (a
frozen value), extra inputs, or a callable ``f(t, x, u)``. Scheduled values
outside the domain are projected onto it, with one `ParameterClipWarning`
per simulation.
"""

from __future__ import annotations

import sys as _sys
from collections.abc import Callable, Mapping

import numpy as np

from ..exceptions import ParameterClipWarning
from .frames import given, user_frame, warn_at
from .nominal import inside_or_raise, params_point

__all__ = ["Scheduling", "SchedulingMixin"]

Scheduling = None | str | Callable


class SchedulingMixin:
    """Scheduling source and scheduled dynamics of a polytopic system.

    For `PolytopicStateSpace` (before `control.StateSpace` in its bases):
    it uses its ``vertices``, ``domain``, ``nominal``, ``name``, the
    stacked vertex data ``_AB`` and ``_CD`` and ``_physical_inputs``.
    """

    def _set_scheduling(self, scheduling: Scheduling) -> None:
        if not (scheduling is None or scheduling == "inputs" or callable(scheduling)):
            raise ValueError(
                "scheduling: expected None, 'inputs' or a callable f(t, x, u) -> p, "
                f"got {scheduling!r}"
            )
        self.scheduling = scheduling

    def scheduled(self, by: Scheduling):
        """Return a copy with another scheduling source.

        Parameters
        ----------
        by : None, "inputs" or callable
            Where the parameter comes from in simulation: None, the system
            parameters ``params`` (a frozen parameter, default the nominal
            value); ``"inputs"``, one extra input per parameter, named after
            it and appended after the physical inputs; or a callable
            ``p = f(t, x, u)`` of time, state and physical input returning
            the parameter values (array in the domain's order, or a dict
            ``{name: value}``). Scheduled values outside the domain are
            projected onto it.

        Returns
        -------
        `PolytopicStateSpace`
            The same vertices, domain, nominal point, name and signal
            names (plus the scheduling inputs for ``"inputs"``), with
            `scheduling` set to `by`.

        Raises
        ------
        ValueError
            If `by` is not None, ``"inputs"`` or a callable.
        """
        return type(self)(
            self.vertices,
            self.domain,
            scheduling=by,
            nominal=self.nominal,
            name=self.name,
        )

    def _update_params(self, params):
        super()._update_params(params)
        self._clip_warned = False
        # Parameters from the params dict are constant during a simulation:
        # combine the vertex matrices once, not on every RHS call. Names that
        # are not parameters of this system are ignored (python-control
        # passes one dict to every block of an interconnection).
        if self.scheduling is None:
            if given(params):
                # A block of an interconnection always receives its own
                # names; a direct call naming none of them is a typo.
                params_point(self, params)
            own = {k: self._current_params[k] for k in self.domain.names}
            point, _ = params_point(self, own)
            inside_or_raise(self, point)
            self._params_delta = self.domain._weights(point)
            self._params_AB = np.tensordot(self._params_delta, self._AB, axes=1)
            self._params_CD = np.tensordot(self._params_delta, self._CD, axes=1)

    def _scheduled_point(self, value) -> np.ndarray:
        """Parameter point returned by a scheduling callable (dict or array)."""
        names = self.domain.names
        if type(value) is np.ndarray and value.shape == (len(names),):
            return value.astype(float, copy=False)
        if isinstance(value, Mapping):
            if set(value) != set(names):
                raise ValueError(
                    f"scheduling: the callable returned keys {sorted(map(str, value))}"
                    f"; expected the parameter names {list(names)}"
                )
            value = [value[name] for name in names]
        point = np.asarray(value, dtype=float).reshape(-1)
        if point.size != len(names):
            raise ValueError(
                f"scheduling: the callable returned {point.size} value(s); expected "
                f"{len(names)} for the parameters {list(names)}"
            )
        return point

    def _delta(self, t, x, u) -> np.ndarray:
        if self.scheduling is None:
            return self._params_delta
        if self.scheduling == "inputs":
            point = u[len(self._physical_inputs) :]
            source = "scheduling input"
        else:
            point = self._scheduled_point(
                self.scheduling(t, x, u[: len(self._physical_inputs)])
            )
            source = "scheduling callable"
        delta, report = self.domain._weights_report(point)
        if report is None:
            return delta
        if not np.all(np.isfinite(point)):
            values = dict(zip(self.domain.names, point.tolist()))
            raise ValueError(
                f"scheduling: non-finite parameter value {values} from the "
                f"{source} of {self.name!r} at t = {float(t):.6g}"
            )
        if not self._clip_warned:
            self._clip_warned = True
            warn_at(
                f"{self.name!r}: the {source} gives {report} at t = {float(t):.6g}; "
                "it is projected onto the parameter domain (later values outside "
                "the domain in this simulation are projected without a warning)",
                ParameterClipWarning,
                user_frame(_sys._getframe(1)),
            )
        return delta

    # The hot path: python-control passes float vectors; one matrix-vector
    # product per call when the parameter comes from `params`.
    def _rhs(self, t, x, u):
        if type(u) is not np.ndarray:
            u = np.asarray(u, dtype=float).reshape(-1)
        xu = np.concatenate((x, u[: len(self._physical_inputs)]))
        if self.scheduling is None:
            return self._params_AB @ xu
        return self._delta(t, x, u) @ (self._AB @ xu)

    def _out(self, t, x, u):
        if type(u) is not np.ndarray:
            u = np.asarray(u, dtype=float).reshape(-1)
        xu = np.concatenate((x, u[: len(self._physical_inputs)]))
        if self.scheduling is None:
            return self._params_CD @ xu
        return self._delta(t, x, u) @ (self._CD @ xu)

    @property
    def _feedthrough(self) -> np.ndarray:
        """Which inputs reach the outputs directly, ``(noutputs, ninputs)``.

        Read by `ctrl_lpv.interconnect`: ``D != 0`` at some vertex for the
        physical inputs; when ``C`` or ``D`` vary over the vertices, the
        scheduling inputs (``"inputs"``) or, through a callable
        ``f(t, x, u)``, all physical inputs reach the varying output rows.
        """
        n = self.nstates
        direct = np.any(self._CD[:, :, n:] != 0.0, axis=0)
        varying = np.any(self._CD != self._CD[:1], axis=(0, 2))[:, None]
        if self.scheduling == "inputs":
            k = self.ninputs - direct.shape[1]
            return np.hstack([direct, np.repeat(varying, k, axis=1)])
        if callable(self.scheduling):
            return direct | varying
        return direct

    def _checked_call(self, method, t, x, u, params):
        x = np.asarray(x, dtype=float).reshape(-1)
        u = np.zeros(self.ninputs) if u is None else np.asarray(u, float).reshape(-1)
        if x.size != self.nstates:
            raise ValueError(f"x: expected {self.nstates} states, got {x.size}")
        if u.size != self.ninputs:
            raise ValueError(f"u: expected {self.ninputs} inputs, got {u.size}")
        self._update_params(params)
        return method(t, x, u)

    def dynamics(self, t, x, u=None, params=None):
        """State derivative (continuous time) or next state (discrete time).

        Parameters
        ----------
        t : float
            Time (used by a callable scheduling).
        x : array_like
            State.
        u : array_like, optional
            Input (physical, then scheduling inputs); zero if omitted.
        params : dict, optional
            Parameter values (for ``scheduling=None``).

        Returns
        -------
        ndarray
        """
        return self._checked_call(self._rhs, t, x, u, params)

    def output(self, t, x, u=None, params=None):
        """Output of the scheduled system (see `dynamics`)."""
        return self._checked_call(self._out, t, x, u, params)
