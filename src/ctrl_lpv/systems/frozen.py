"""What a system given by data at points of its parameter domain offers.

`PolytopicStateSpace` (data at the vertices, combined with convex
coordinates) and `GriddedStateSpace` (data at grid points, combined
multilinearly) differ in their domain only: the domain's ``weights(p)``
says how the point data combine at ``p``. `FrozenDataMixin` is the rest,
written once: the parameters, the physical inputs, the weights, the frozen
system at ``p`` and the point data.
"""

from __future__ import annotations

import numpy as np
from control import StateSpace

from .._checks import flag, signal_labels, signal_name
from .vertices import combine_data

__all__ = ["FrozenDataMixin", "signal_names"]


def signal_names(points, data, kwargs: dict):
    """``(inputs, outputs, states, name)`` of a system of point data.

    The labels given in `kwargs` (popped from it), else those of the first
    point given as a `control.StateSpace`, else counts; checked here,
    because python-control's own message for a repeated or missing name is
    a dimension mismatch of A, B or C. Any other keyword is a `TypeError`.
    """
    first = next((v for v in points if isinstance(v, StateSpace)), None)
    n, m = data[0][1].shape
    ny = data[0][2].shape[0]
    inputs = kwargs.pop("inputs", first.input_labels if first else m)
    outputs = kwargs.pop("outputs", first.output_labels if first else ny)
    states = kwargs.pop("states", first.state_labels if first else n)
    name = kwargs.pop("name", None)
    if kwargs:
        raise TypeError(f"unexpected keyword arguments: {sorted(kwargs)}")
    inputs = signal_labels(inputs, m, "inputs") or inputs
    outputs = signal_labels(outputs, ny, "outputs") or outputs
    states = signal_labels(states, n, "states") or states
    if name is not None:
        signal_name(name, "name")
    return inputs, outputs, states, name


class FrozenDataMixin:
    """Parameters, weights and frozen systems of point data ``_data``.

    For a `control.StateSpace` subclass with a ``domain`` (``weights(p,
    clip)``, ``nparams``, ``names``), point data ``_data`` (``(A, B, C, D)``
    per point, in the domain's order) and ``_physical_inputs``.
    """

    def _name_points(self, data, labels, weights, dt) -> StateSpace:
        """Name the point data: the nominal frozen system (at `weights`,
        which checks the `labels` ``(inputs, outputs, states, name)``),
        ``vertices`` (one named system per point), ``_physical_inputs`` and
        the stacked ``[A B]``, ``[C D]`` of the hot path (one matmul per
        call). Returns the nominal system."""
        inputs, outputs, states, name = labels
        frozen = StateSpace(*self._combine(weights), inputs=inputs, outputs=outputs,
                            states=states, name=name, dt=dt,
                            remove_useless_states=False)  # fmt: skip
        self._physical_inputs = tuple(frozen.input_labels)
        self.vertices = tuple(
            StateSpace(
                *d,
                inputs=frozen.input_labels,
                outputs=frozen.output_labels,
                states=frozen.state_labels,
                name=f"{frozen.name}[{j}]",
                dt=dt,
                remove_useless_states=False,
            )  # fmt: skip
            for j, d in enumerate(data)
        )
        self._AB = np.stack([np.hstack(d[:2]) for d in data])
        self._CD = np.stack([np.hstack(d[2:]) for d in data])
        return frozen

    def _system_arguments(self, frozen, dt) -> tuple[tuple, dict]:
        """``(args, kwargs)`` of `control.StateSpace` for this system: the
        nominal `frozen` system with one zero input column per parameter
        when the parameters are scheduling inputs."""
        names = list(self.domain.names) if self.scheduling == "inputs" else []
        k = len(names)
        A, B, C, D = frozen.A, frozen.B, frozen.C, frozen.D
        args = (A, np.hstack([B, np.zeros((A.shape[0], k))]), C,
                np.hstack([D, np.zeros((C.shape[0], k))]))  # fmt: skip
        return args, dict(
            inputs=list(frozen.input_labels) + names,
            outputs=frozen.output_labels,
            states=frozen.state_labels,
            name=frozen.name,
            params=dict(zip(self.domain.names, self.nominal.tolist())),
            dt=dt,
            remove_useless_states=False,
        )

    @property
    def nparams(self) -> int:
        """Number of scheduling parameters."""
        return self.domain.nparams

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the scheduling parameters."""
        return self.domain.names

    @property
    def physical_inputs(self) -> tuple[str, ...]:
        """Input labels without the scheduling inputs."""
        return self._physical_inputs

    def weights(self, p, clip: bool = False) -> np.ndarray:
        """Weights of the point data at `p`, shape ``(N,)``.

        Nonnegative and summing to one: the convex coordinates of `p` for a
        polytope, the multilinear interpolation weights (nonzero only at
        the corners of the cell of `p`) for a grid.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value (for a simplex domain: the coordinates).
        clip : bool, optional
            Project `p` onto the domain instead of raising.

        Returns
        -------
        ndarray

        Raises
        ------
        ValueError
            If `p` has the wrong size or lies outside the domain.
        """
        return self.domain.weights(p, clip=flag(clip, "clip"))

    def _combine(self, delta: np.ndarray) -> tuple[np.ndarray, ...]:
        return combine_data(self._data, delta)

    def at(self, p, name: str | None = None) -> StateSpace:
        """Frozen system at parameter value `p`.

        Parameters
        ----------
        p : array_like or mapping
            Parameter value inside the domain.
        name : str, optional
            Name of the returned system.

        Returns
        -------
        `control.StateSpace`
            With the physical inputs, outputs and states of this system.
        """
        first = self.vertices[0]
        return StateSpace(
            *self._combine(self.weights(p)),
            inputs=first.input_labels,
            outputs=first.output_labels,
            states=first.state_labels,
            name=name,
            dt=self.dt,
            remove_useless_states=False,
        )

    def vertex_data(self) -> tuple[tuple[np.ndarray, ...], ...]:
        """Point matrices ``((A_j, B_j, C_j, D_j), ...)`` as float arrays."""
        return tuple(tuple(m.copy() for m in d) for d in self._data)

    def _repr_html_(self):
        return StateSpace._repr_html_(self)

    def _repr_eval_(self):
        return StateSpace._repr_eval_(self)

    # Text: the class, its points (`_points_text`) and the nominal system.
    def __str__(self) -> str:
        sched = ("params" if self.scheduling is None else
                 "inputs" if self.scheduling == "inputs" else "callable")  # fmt: skip
        head = (
            f"{type(self).__name__}: {self.name}, {self._points_text()} over "
            f"{self.domain!r}, scheduled by {sched}\n"
            f"Nominal p = {dict(zip(self.domain.names, self.nominal.tolist()))} "
            "(the A, B, C, D below)\n"
        )
        return head + StateSpace.__str__(self)

    def __repr__(self) -> str:
        return (
            f"<{type(self).__name__} {self.name}: {self._points_repr()}, "
            f"{self.nstates} states, inputs {list(self.input_labels)}, "
            f"outputs {list(self.output_labels)}"
            + (f", dt={self.dt}" if self.isdtime(strict=True) else "")
            + ">"
        )
