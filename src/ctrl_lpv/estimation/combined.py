"""Observer-based state feedback, certified on the combined loop.

With a time-varying parameter the separation principle does not hold: the
state-feedback design and the observer are each certified, but the loop
that runs, plant plus estimator plus ``u = -K(p) x_hat``, is neither. In
the coordinates ``(x, e = x - x_hat)``

    x' = (A - B_u K) x + B_u K e,     e' = (A - L C_y) e,

a block-triangular system whose diagonal blocks are stable at every frozen
point; for a varying parameter its stability needs one Lyapunov function
of the whole, which `observer_based` asks of the library's analysis
(`ctrl_lpv.quadratic_stability`, certified in float64) or refuses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._checks import signal_name
from ..certificate import Certificate, Check
from ..exceptions import SynthesisError
from ..systems import PolytopicStateSpace

__all__ = ["observer_based", "ObserverBasedController"]


@dataclass(frozen=True)
class ObserverBasedController:
    """A state-feedback gain and an observer, certified together.

    Attributes
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        The state feedback ``u = -K(p) x``.
    observer : `ctrl_lpv.ObserverDesign`
        The observer whose estimate replaces ``x``.
    certificate : `ctrl_lpv.Certificate`
        Float64 checks that the combined loop (plant, estimator, gain) is
        stable for every parameter trajectory in the polytope.
    P : ndarray
        Its Lyapunov matrix, in the coordinates ``(x, x - x_hat)``.
    """

    design: object
    observer: object
    certificate: Certificate
    P: np.ndarray

    def controller(self, name: str = "controller") -> PolytopicStateSpace:
        """The observer-based controller as a python-control I/O system.

        ``x_hat' = (A - B_u K - L C_y) x_hat + L y``, ``u = -K x_hat`` (one
        vertex system per plant vertex, exact in between). Inputs: the
        measured outputs (the plant's names), then one scheduling input per
        parameter for a plant with several vertices; outputs: the control
        inputs; states ``<state>_hat``.

        Parameters
        ----------
        name : str, optional
            System name (default ``"controller"``).

        Returns
        -------
        `PolytopicStateSpace`
        """
        signal_name(name, "name")
        sys = self.design.system
        vertices = [
            (Acl_hat, L, -K, np.zeros((K.shape[0], L.shape[1])))
            for Acl_hat, L, K in _controller_vertices(self.design, self.observer)
        ]
        hats = [f"{s}_hat" for s in sys.state_labels]
        return PolytopicStateSpace(
            vertices, sys.domain,
            scheduling="inputs" if sys.nvertices > 1 else None,
            inputs=list(self.observer.y), outputs=list(self.design.u),
            states=hats, name=name, dt=sys.dt,
        )  # fmt: skip


def observer_based(
    design, observer, *, margin: float = 1e-6
) -> ObserverBasedController:
    """Combine a state-feedback design and an observer, certified together.

    Parameters
    ----------
    design : `ctrl_lpv.StateFeedbackDesign`
        Its gains ``K(p)``, common or one per vertex (a rational gain of a
        parameter-dependent Lyapunov design is refused).
    observer : `ctrl_lpv.ObserverDesign`
        An observer of the same plant whose known inputs are exactly the
        design's control inputs.
    margin : float, optional
        Margin of the combined loop's Lyapunov inequalities (relative).

    Returns
    -------
    `ObserverBasedController`
        ``.controller()`` the controller I/O system, ``.certificate`` the
        combined loop's stability checks.

    Raises
    ------
    ValueError
        Designs of different plants or time bases, known inputs that are not
        the control inputs, or a combination whose loop is not exact between
        the vertices (vertex gains with a parameter-dependent ``B_u``, or
        vertex gains and vertex observer gains with ``D_yu != 0``).
    CertificationError, InfeasibleError
        If no common Lyapunov function of the combined loop certifies: the
        separation principle does not hold for a time-varying parameter.

    Examples
    --------
    >>> import control as ct
    >>> import ctrl_lpv as lpv
    >>> G = lpv.pss([ct.ss([[0.0, 1.0], [-1.0, 0.1]], [[0.0], [1.0]],
    ...                    [[1.0, 0.0]], 0, inputs="u", outputs="y")])
    >>> sf = lpv.synthesize(G, "u")
    >>> obs = lpv.observer(G, "y", u="u")
    >>> lpv.observer_based(sf, obs).certificate.verified
    True
    """
    from ..analysis import quadratic_stability

    _check_compatible(design, observer)
    sys = design.system
    vertices = []
    for (A, Bu, Cy, _), (_, L, K) in zip(
        _plant_vertices(design, observer), _controller_vertices(design, observer)
    ):
        Acl = np.block([[A - Bu @ K, Bu @ K], [np.zeros_like(A), A - L @ Cy]])
        vertices.append((Acl, np.zeros((Acl.shape[0], 0)),
                         np.zeros((0, Acl.shape[0])), np.zeros((0, 0))))  # fmt: skip
    loop = PolytopicStateSpace(vertices, sys.domain, dt=sys.dt)
    try:
        result = quadratic_stability(loop, margin)
    except SynthesisError as exc:
        exc.args = (
            "observer_based: no common Lyapunov function of the combined loop "
            "(plant, estimator and gain) certifies; for a time-varying "
            "parameter the separation principle does not hold. " + exc.args[0],
            *exc.args[1:],
        )
        raise
    checks = tuple(
        Check.from_lmi_check(c, group="combined loop") for c in result.checks
    )
    return ObserverBasedController(
        design, observer,
        Certificate(checks, statement=(
            "the combined loop (plant, estimator, u = -K x_hat) is stable for "
            "every parameter trajectory in the polytope (one quadratic "
            "Lyapunov function in (x, x - x_hat))")),
        np.asarray(result.P),
    )  # fmt: skip


def _check_compatible(design, observer):
    a, b = design.system, observer.system
    if a.dt != b.dt:
        raise ValueError("observer: its plant's time base differs from the design's")
    if a.nvertices != b.nvertices or any(
        not all(np.array_equal(x, y) for x, y in zip(p, q))
        for p, q in zip(a.vertex_data(), b.vertex_data())
    ):
        raise ValueError("observer: designed for another plant than `design`")
    if set(observer.u) != set(design.u):
        raise ValueError(
            f"observer: its known inputs {list(observer.u)} must be the design's "
            f"control inputs {list(design.u)}"
        )
    if getattr(design, "rational", None) is not None:
        raise ValueError(
            "design: a vertex-scheduled gain with a parameter-dependent Lyapunov "
            "function is rational in the parameter; the combined loop is not "
            "exact between the vertices"
        )
    Bu = [B for _, B, _, _ in _plant_vertices(design, observer)]
    if len(design.gains) > 1 and any(not np.array_equal(Bu[0], B) for B in Bu):
        raise ValueError(
            "design: vertex gains with an input matrix of u that depends on the "
            "parameter make B_u(p) K(p) quadratic in it; use a common gain"
        )
    Dyu = [D[np.ix_(_y(a, observer), _u(a, design))] for *_, D in a.vertex_data()]
    if len(design.gains) > 1 and len(observer.L) > 1 and any(np.any(D) for D in Dyu):
        raise ValueError(
            "observer: vertex observer gains, vertex gains and a feedthrough from "
            "u to y make L(p) D_yu K(p) quadratic in the parameter"
        )


def _u(sys, design):
    return [sys.physical_inputs.index(s) for s in design.u]


def _y(sys, observer):
    return [sys.output_labels.index(s) for s in observer.y]


def _plant_vertices(design, observer):
    sys = design.system
    iu, iy = _u(sys, design), _y(sys, observer)
    return [(A, B[:, iu], C[iy], D[np.ix_(iy, iu)]) for A, B, C, D in sys.vertex_data()]


def _controller_vertices(design, observer):
    """``(A - B_u K - L C_y + L D_yu K, L, K)`` at each vertex."""
    out = []
    for j, (A, Bu, Cy, Dyu) in enumerate(_plant_vertices(design, observer)):
        K = design.gains[j if len(design.gains) > 1 else 0]
        L = observer.L[j if len(observer.L) > 1 else 0]
        out.append((A - Bu @ K - L @ Cy + L @ Dyu @ K, L, K))
    return out
