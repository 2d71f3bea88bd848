"""Block-diagram algebra of polytopic systems: vertex by vertex, or refused.

An operation on a polytopic system (negation, sums, products, indexing,
`append`, `feedback`, `lft`) applied to each vertex gives the operation
on the interpolated system only where it is affine in the vertex data;
`vertexwise` applies it and checks that at interior points, and
`OperationsMixin` exposes it as python-control's operators and methods.
Operations that would leave the polytopic class refuse with `TypeError`
instead of returning a frozen system.
"""

from __future__ import annotations

import numpy as np
from control import NonlinearIOSystem, StateSpace

from .vertices import combine_data, ss_data

__all__ = ["vertexwise", "OperationsMixin"]


def _frozen(sys, delta) -> StateSpace:
    return StateSpace(*sys._combine(delta), dt=sys.dt, remove_useless_states=False)


def vertexwise(sys, operation, other=None, label="operation"):
    """Apply `operation` per vertex and check the result is polytopic.

    The vertex-wise result equals the operation on the interpolated
    system only where the operation is affine in the vertex data; this
    is checked at interior points rather than assumed.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        The left operand.
    operation : callable
        ``operation(vertex, other_or_its_vertex) -> control.StateSpace``.
    other : optional
        The right operand: a polytopic system of the same type and domain
        (combined vertex with vertex), or anything `operation` accepts.
    label : str, optional
        Name of the operation in error messages.

    Returns
    -------
    `PolytopicStateSpace` or NotImplemented
        NotImplemented when a vertex result is not a `control.StateSpace`
        (Python then tries the reflected operation).

    Raises
    ------
    TypeError
        For a system scheduled by a callable, two polytopic systems on
        different domains, or a result that is not affine in the vertex
        data.
    """
    if sys.scheduling is not None and callable(sys.scheduling):
        raise TypeError(
            f"{label}: a system scheduled by a callable of its state cannot be "
            "combined vertex by vertex; combine the unscheduled system and "
            "schedule the result with .scheduled()"
        )
    if isinstance(other, type(sys)):
        if other.domain != sys.domain:
            raise TypeError(
                f"{label}: the two polytopic systems have different parameter "
                "domains; their combination is not polytopic"
            )
        results = [operation(v, w) for v, w in zip(sys.vertices, other.vertices)]

        def interpolated(delta):
            return operation(_frozen(sys, delta), _frozen(other, delta))

    else:
        results = [operation(v, other) for v in sys.vertices]

        def interpolated(delta):
            return operation(_frozen(sys, delta), other)

    if not all(isinstance(r, StateSpace) for r in results):
        return NotImplemented
    out_data = [ss_data(r, label) for r in results]
    rng = np.random.default_rng(0)
    checks = [np.full(sys.nvertices, 1.0 / sys.nvertices)]
    checks += list(rng.dirichlet(np.ones(sys.nvertices), size=2))
    for delta in checks:
        expected = ss_data(interpolated(delta), label)
        for got, ref in zip(combine_data(out_data, delta), expected):
            if got.shape != ref.shape or not np.allclose(
                got, ref, rtol=1e-9, atol=1e-12 * max(1.0, np.abs(ref).max())
            ):
                raise TypeError(
                    f"{label}: the result is not affine in the vertex data, so "
                    "it is not a polytopic system over the same domain; apply "
                    "it to a frozen system sys.at(p) instead"
                )
    return type(sys)(
        results,
        sys.domain,
        scheduling=sys.scheduling,
        nominal=sys.nominal,
    )


class OperationsMixin:
    """python-control's operators and block-diagram methods, kept polytopic.

    For `PolytopicStateSpace` (before `control.StateSpace` in its bases).
    """

    def _binary(self, other, op, label):
        if isinstance(other, NonlinearIOSystem) and not isinstance(other, StateSpace):
            # A nonlinear partner: python-control's interconnection keeps this
            # system's scheduled dynamics.
            return getattr(NonlinearIOSystem, f"__{label}__")(self, other)
        return vertexwise(self, op, other, label=label)

    def __neg__(self):
        return vertexwise(self, lambda v, _: -v, label="neg")

    def __add__(self, other):
        return self._binary(other, lambda v, w: v + w, "add")

    def __radd__(self, other):
        return self._binary(other, lambda v, w: w + v, "radd")

    def __sub__(self, other):
        return self._binary(other, lambda v, w: v - w, "sub")

    def __rsub__(self, other):
        return self._binary(other, lambda v, w: w - v, "rsub")

    def __mul__(self, other):
        return self._binary(other, lambda v, w: v * w, "mul")

    def __rmul__(self, other):
        return self._binary(other, lambda v, w: w * v, "rmul")

    def __truediv__(self, other):
        return vertexwise(self, lambda v, w: v / w, other, label="truediv")

    def __rtruediv__(self, other):
        raise TypeError("division by a polytopic system is not polytopic")

    def __pow__(self, other):
        if other == 1:
            return self.scheduled(self.scheduling)
        raise TypeError("powers of a polytopic system are not polytopic")

    def __getitem__(self, key):
        return vertexwise(self, lambda v, _: v[key], label="getitem")

    def feedback(self, other=1, sign=-1):
        """Feedback interconnection, kept polytopic where exact.

        The closed loop of the vertices is the closed loop of the polytopic
        system only when it is affine in the vertex data (for example a
        constant input matrix with a static output feedback); otherwise a
        `TypeError` is raised.
        """
        return vertexwise(self, lambda v, w: v.feedback(w, sign), other, "feedback")

    def append(self, other):
        """Block-diagonal append, kept polytopic."""
        return vertexwise(self, lambda v, w: v.append(w), other, "append")

    def lft(self, other, nu=-1, ny=-1):
        """Linear fractional transformation, kept polytopic where exact."""
        return vertexwise(self, lambda v, w: v.lft(w, nu, ny), other, "lft")

    def minreal(self, *args, **kwargs):
        """Not available: vertex realizations would differ.

        Raises
        ------
        TypeError
            Always; use ``sys.at(p).minreal()`` for a frozen system.
        """
        raise TypeError(
            "minreal: a minimal realization per vertex would break the common "
            "state basis; use sys.at(p).minreal() for a frozen parameter value"
        )

    def returnScipySignalLTI(self, *args, **kwargs):  # noqa: N802 (python-control name)
        """Not available: scipy's LTI classes are frozen systems."""
        raise TypeError(
            "returnScipySignalLTI: use sys.at(p).returnScipySignalLTI() for a "
            "frozen parameter value"
        )
