"""Prescaling of the vertex data, and the prescalings tried.

Diagonal prescalings are powers of two, so applying and undoing them is
exact in floating point. The Riccati prescaling is a full change of state
coordinates (not exact); it only shapes the solver's problem, since every
point is verified in the model's own units.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import (
    matrix_balance,
    solve_continuous_are,
    solve_continuous_lyapunov,
    solve_discrete_are,
    solve_discrete_lyapunov,
)


def pow2(x: float) -> float:
    """Nearest power of two, so that scaling is exact in floating point."""
    return float(2.0 ** np.round(np.log2(x))) if x > 0 else 1.0


def channel_scales(vertices, T, Su, a) -> tuple[float, float]:
    """Powers of two ``(sw, sz)`` that normalise a channel's ``B1`` and ``C, D``.

    `T` is the state scaling, a diagonal (1-D) or a full matrix.
    """
    T = np.diag(T) if T.ndim == 1 else T
    # Stacked over the vertices: the same solves and norms, one call each.
    B1 = np.stack([v[1] for v in vertices])
    nb1 = _largest_norm(np.linalg.solve(T, B1) if B1.size else B1)
    sw = pow2(a / nb1) if nb1 > 0 else 1.0
    C = np.stack([v[3] for v in vertices])
    D1 = np.stack([v[4] for v in vertices])
    D2 = np.stack([v[5] for v in vertices])
    nz = _largest_norm(np.concatenate([C @ T, D1 * sw, D2 * Su], axis=2))
    sz = pow2(nz) if nz > 0 else 1.0
    return sw, sz


def _largest_norm(stack) -> float:
    """The largest spectral norm of a stack of matrices (0 if empty)."""
    if not stack.size:
        return 0.0
    return float(np.linalg.norm(stack, 2, axis=(1, 2)).max())


@dataclass(frozen=True)
class Scaling:
    """Exact (power-of-two) prescaling; see the module docstring."""

    T: np.ndarray  # state scaling, x = T x~: a diagonal (1-D) or a full matrix
    Su: np.ndarray  # input scaling, u = Su u~
    sw: float  # w = sw w~
    sz: float  # z = sz z~
    a: float  # time scaling, t~ = a t

    @classmethod
    def of(cls, vertices, balance: bool = True, time_scaling: bool = True) -> Scaling:
        """The prescaling of vertex data ``(A, B1, B2, C, D1, D2)``.

        `time_scaling` False (discrete time) keeps ``a = 1``.
        """
        n = vertices[0][0].shape[0]
        if balance:
            absA = sum(np.abs(v[0]) for v in vertices)
            _, (t, _) = matrix_balance(absA, permute=False, separate=True)
            T = np.array([pow2(x) for x in t])
        else:
            T = np.ones(n)
        A = np.stack([v[0] for v in vertices])
        a = pow2(_largest_norm(A * (T / T[:, None]))) if time_scaling else 1.0
        Su = np.array(
            [
                pow2(a / c) if c > 0 else 1.0
                for c in np.max(
                    [np.linalg.norm(v[2] / T[:, None], axis=0) for v in vertices],
                    axis=0,
                )
            ]
        )
        sw, sz = channel_scales(vertices, T, Su, a)
        return cls(T, Su, sw, sz, a)

    @property
    def matrix(self) -> np.ndarray:
        """The state scaling as a matrix: ``x = matrix @ x~``."""
        return np.diag(self.T) if self.T.ndim == 1 else self.T

    def _inverse(self) -> np.ndarray:
        return np.diag(1.0 / self.T) if self.T.ndim == 1 else np.linalg.inv(self.T)

    def apply(self, v):
        A, B1, B2, C, D1, D2 = v
        if self.T.ndim == 1:
            Ti = 1.0 / self.T
            A, B1, B2, C = (
                Ti[:, None] * A * self.T,
                Ti[:, None] * B1,
                Ti[:, None] * B2,
                C * self.T,
            )
        else:
            Ti = self._inverse()
            A, B1, B2, C = Ti @ A @ self.T, Ti @ B1, Ti @ B2, C @ self.T
        return (
            A / self.a,
            B1 * self.sw / self.a,
            B2 * self.Su / self.a,
            C / self.sz,
            D1 * self.sw / self.sz,
            D2 * self.Su / self.sz,
        )

    @property
    def w_factor(self) -> float:
        """W = w_factor * T W~ T' and Z = w_factor * Su Z~ T'."""
        return self.a / self.sw**2

    def unscale_W(self, Wt):
        T = self.matrix
        return self.w_factor * (T @ Wt @ T.T)

    def unscale_P(self, Pt):
        """``P = W^-1`` from ``P~ = W~^-1``, exactly symmetric.

        ``x' P x`` sees only the symmetric part of ``P``, and a float inverse
        is not exactly symmetric: a check of ``P A + A' P'`` with it is not
        the Lyapunov inequality of any storage function (fuzz case 2026:14,
        settled in exact arithmetic by ``benchmarks/study_disputed_brl.py``).
        """
        if self.T.ndim == 1:
            P = Pt / (self.w_factor * self.T[:, None] * self.T)
        else:
            Ti = self._inverse()
            P = Ti.T @ Pt @ Ti / self.w_factor
        return 0.5 * (P + P.T)

    def unscale_K(self, Kt):
        # u = -K x with u = Su u~, x = T x~ and u~ = -K~ x~.
        return self.Su[:, None] * (Kt @ self._inverse())

    def then(self, other: Scaling) -> Scaling:
        """This scaling followed by `other` (applied to the scaled data)."""
        return Scaling(
            self.matrix @ other.matrix,
            self.Su * other.Su,
            self.sw * other.sw,
            self.sz * other.sz,
            self.a * other.a,
        )


def lqr_riccati(A, B, C, D, continuous: bool = True):
    """``(X, K)``: the stabilizing LQR solution of ``(A, B)`` with output ``C x + D u``.

    The weights ``C'C``, ``D'D`` and cross term ``C'D`` are regularised
    by 1e-6 of their norms (identities when ``C`` has no rows), so that the
    equation has a stabilizing solution whenever ``(A, B)`` is
    stabilizable; ``X`` is symmetrised and ``u = -K x``. With `continuous`
    False the discrete-time equation. Raises ValueError or LinAlgError
    (scipy's) when there is no usable solution.
    """
    n, m = B.shape
    if C.shape[0]:
        Q, R, S = C.T @ C, D.T @ D, C.T @ D
    else:
        Q, R, S = np.eye(n), np.eye(m), np.zeros((n, m))
    Q = Q + 1e-6 * max(1.0, np.linalg.norm(Q, 2)) * np.eye(n)
    R = R + 1e-6 * max(1.0, np.linalg.norm(R, 2)) * np.eye(m)
    if continuous:
        X = solve_continuous_are(A, B, Q, R, s=S)
        K = np.linalg.solve(R, B.T @ X + S.T)
    else:
        X = solve_discrete_are(A, B, Q, R, s=S)
        K = np.linalg.solve(R + B.T @ X @ B, B.T @ X @ A + S.T)
    return 0.5 * (X + X.T), K


def riccati_scaling(original, base: Scaling, continuous: bool = True) -> Scaling | None:
    """`base` followed by coordinates from a Riccati solution at the centre.

    ``X`` is the stabilizing solution of the centre vertex's LQR equation
    (weights ``C'C`` and ``D2'D2`` of the performance channel, regularised;
    identities without one) and ``K`` its gain. The candidate
    ``W0 = X^-1 + G``, with ``G`` the Gramian of ``B1`` under ``A - B2 K``
    (a bounded-real ``W`` is at least that Gramian), becomes the identity in
    the new coordinates ``x = W0^(1/2) x~``: a well-conditioned ``W`` exists
    there for the centre and its neighbours. This is what a diagonal
    scaling cannot give when modes are weakly controllable along a
    direction that is not a coordinate axis (the minimum-gamma point of
    such a problem missed its LMIs by 1e-2 in balanced coordinates; an H2
    optimum, whose ``W`` is about that Gramian, by far more). With
    `continuous` False the discrete-time equations are used. None when the
    Riccati equation has no usable solution.
    """
    data = [base.apply(v) for v in original]
    A, B1, B2, C, _, D2 = (sum(v[i] for v in data) / len(data) for i in range(6))
    m = B2.shape[1]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            X, K = lqr_riccati(A, B2, C, D2, continuous)
            W0 = np.linalg.inv(X)
            if B1.size:
                Acl, BB = A - B2 @ K, B1 @ B1.T
                W0 = W0 + (
                    solve_continuous_lyapunov(Acl, -BB)
                    if continuous
                    else solve_discrete_lyapunov(Acl, BB)
                )
    except (ValueError, np.linalg.LinAlgError):
        return None
    if not np.all(np.isfinite(W0)):
        return None
    e, V = np.linalg.eigh(0.5 * (W0 + W0.T))
    if not e[0] > 1e-14 * e[-1]:
        return None
    shape = Scaling(V * np.sqrt(e), np.ones(m), 1.0, 1.0, 1.0)
    shaped = [shape.apply(v) for v in data]
    return base.then(shape).then(
        Scaling.of(shaped, balance=False, time_scaling=continuous)
    )


def shaped_frame(frame, W, plant):
    """`frame` followed by coordinates in which the prescaled `W` is ``I``.

    ``x~ = W^(1/2) x~~``, then the powers of two of `Scaling.of` for the
    inputs and ``z`` (neither a time scaling, so that the rung's
    structure, which depends on it, still fits, nor one of ``w``, which
    would scale ``W``). A Lyapunov matrix far from the identity
    costs the solvers what the diagonal prescalings cannot give back: the
    strict LMIs' margin, absolute, is of the order of its small
    eigenvalues (a 5-state Kalman filter's H2 optimum, ``W`` of condition
    3e8: 2.6 times the Riccati value at the margin 1e-6), and the
    solvers' tolerances, relative to its large ones, leave the small
    directions unsolved (2 states, condition 7e6: 1.4 times). Shaped by
    a solution near the optimum, the optimum's ``W`` is near ``I``, where
    neither matters. Like the Riccati prescaling it is not exact, and
    need not be: every point is verified in the model's units.
    """
    e, V = np.linalg.eigh(0.5 * (W + W.T))
    e = np.maximum(e, 1e-300)
    shape = Scaling(V * np.sqrt(e), np.ones(plant.m), 1.0, 1.0, 1.0)
    first = plant.six(0 if plant.channels else None)
    data = [shape.apply(frame.scaling.apply(v)) for v in first]
    # The inputs and z by powers of two, as always, but not w: its scale
    # would scale W (W~~ = sw^-2 I), whose identity is the point.
    sc = replace(Scaling.of(data, balance=False, time_scaling=False), sw=1.0)
    return _frame(
        f"{frame.name}, shaped", frame.scaling.then(shape).then(sc), plant, False
    )


@dataclass(frozen=True)
class Frame:
    """The prescaling of one rung: a base `Scaling` and each channel's.

    Channel ``i`` is scaled by the powers of two ``w = sw_i w~`` and
    ``z = sz_i z~``; the first channel's are the base's. With one
    ``W = kappa T W~ T'`` for every channel (``kappa`` the base's
    `~Scaling.w_factor`), the prescaled LMIs are congruent to the model's
    when the identity block of channel ``i``'s ``w`` is weighted by
    `rho` (congruence by ``diag(T^-1 / sqrt(a kappa), sw_i sqrt(kappa /
    a), ...)``); all factors are powers of two, so the congruence is exact
    in floating point.
    """

    name: str
    scaling: Scaling
    channels: tuple[tuple[float, float], ...] = ()

    @property
    def a(self) -> float:
        """The time scaling ``t~ = a t`` (1 in discrete time)."""
        return self.scaling.a

    @property
    def kappa(self) -> float:
        """``W = kappa T W~ T'``."""
        return self.scaling.w_factor

    def rho(self, i: int) -> float:
        """Weight of channel `i`'s identity block (a power of two)."""
        return self.channels[i][0] ** 2 * self.kappa / self.a

    def sz(self, i: int) -> float:
        return self.channels[i][1]

    def with_sz(self, i: int, sz: float) -> Frame:
        """This frame with channel `i`'s ``z`` scaled by `sz` instead."""
        channels = list(self.channels)
        channels[i] = (channels[i][0], sz)
        return replace(self, channels=tuple(channels))

    def scaled(self, plant) -> dict:
        """The prescaled vertex data of a `~.channels.Partition`.

        ``"A"``, ``"B2"`` (stacks over the vertices) and, per channel
        ``i``, ``("Bw", i)``, ``("Cz", i)``, ``("Dzw", i)``, ``("Dzu", i)``.
        """
        sc = self.scaling
        T = sc.matrix
        Ti = np.diag(1.0 / sc.T) if sc.T.ndim == 1 else np.linalg.inv(T)
        a, Su = sc.a, sc.Su
        out = {"A": Ti @ plant.A @ T / a, "B2": Ti @ plant.B2 * Su / a}
        for i, c in enumerate(plant.channels):
            sw, sz = self.channels[i]
            out["Bw", i] = Ti @ c.Bw * sw / a
            out["Cz", i] = c.Cz @ T / sz
            out["Dzw", i] = c.Dzw * sw / sz
            out["Dzu", i] = c.Dzu * Su / sz
        return out


def frames(plant, continuous: bool, hint=None) -> list:
    """The prescalings tried in turn: balanced, Riccati, unbalanced, none.

    With `hint` (state scales in the model's units, from a spec's
    `~ctrl_lpv.synthesis.spec.Spec.state_scaling`) a "reference" prescaling
    in those units comes first.

    The first channel shapes them (none: the control inputs alone);
    "unbalanced" (the time and input scalings alone) only where it differs
    from the others. The last keeps the model's units: a time scaling by
    the fastest mode leaves a mode 1e15 times slower no margin the solvers
    can see.
    """
    first = plant.six(0 if plant.channels else None)
    balanced = Scaling.of(first, time_scaling=continuous)
    out = [("balanced", balanced)]
    if hint is not None:
        # A spec's own units first (`Spec.state_scaling`): a region's
        # reference set, whose size along each state the data do not show.
        base = Scaling(np.array([pow2(x) for x in hint]), np.ones(plant.m), 1.0,
                       1.0, 1.0)  # fmt: skip
        shaped = [base.apply(v) for v in first]
        out.insert(0, ("reference", base.then(
            Scaling.of(shaped, time_scaling=continuous))))  # fmt: skip
    if plant.m:
        shaped = riccati_scaling(first, balanced, continuous)
        if shaped is not None:
            out.append(("Riccati", shaped))
    plain = Scaling.of(first, balance=False, time_scaling=continuous)
    none = Scaling(np.ones(plant.n), np.ones(plant.m), 1.0, 1.0, 1.0)
    if not np.array_equal(plain.T, balanced.T) and not (
        np.array_equal(none.Su, plain.Su)
        and (none.sw, none.sz, none.a) == (plain.sw, plain.sz, plain.a)
    ):
        out.append(("unbalanced", plain))
    # Always last, even where another is the same: a refusal says what
    # holds in the model's own units.
    out.append(("none", none))
    return [_frame(name, sc, plant, name == "none") for name, sc in out]


def _frame(name, sc, plant, unit) -> Frame:
    channels = []
    for i in range(len(plant.channels)):
        if unit:
            channels.append((1.0, 1.0))
        elif i == 0:
            channels.append((sc.sw, sc.sz))
        else:
            channels.append(channel_scales(plant.six(i), sc.T, sc.Su, sc.a))
    return Frame(name, sc, tuple(channels))
