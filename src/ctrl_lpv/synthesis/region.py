"""The size of the design's ellipsoid as an objective: `RegionSize`.

`RegionSize` is the objective of `ctrl_lpv.saturated_state_feedback` and
`ctrl_lpv.saturation_region` (with a `~.constraints.Saturation`
constraint): it makes the ellipsoid ``E = {x : x' P x <= 1}`` large
against a reference set, or small along output rows. Its channel is the
peak-bounded disturbance ``w`` (none, or inputs with ``|w_i| <=
w_max_i``) and has no output: the spec carries the disturbance the
saturation sector must be invariant under (`Spec.disturbance`, as `Peak`:
a decay ``lambda`` the engine searches, multipliers ``mu`` with
``sum(mu) <= lambda``).

Sizes (``W = P^-1``; the squared bound ``g`` is the spec's variable):

* ``beta * {x' R x <= 1}`` inside ``E`` (``R`` = `shape`) iff ``P <= eta
  R`` with ``eta = 1 / beta^2``: ``[[eta R, I], [I, W]] >= 0``;
* every ``beta v_k`` inside ``E`` (`points`) iff ``v_k' P v_k <= eta``:
  ``[[eta, v_k'], [v_k, W]] >= 0``;
* along output rows ``c_i`` (`rows`): ``c_i W c_i' / |c_i|^2 <= eta``, the
  squared half-width of ``E`` along ``c_i``, with the reference set kept
  at a given ``beta_min``.

The bound the engine minimises is ``sqrt(eta)``: ``1 / beta``, or the
largest half-width along the rows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from .._checks import per_input
from .spec import Spec, unit
from .specs import LAMBDAS

__all__ = ["RegionSize", "region_size"]


def region_size(P, shape=None, points=None) -> float:
    """Largest ``beta`` with ``beta * {x' R x <= 1}`` (or every ``beta v_k``)
    inside ``{x' P x <= 1}``."""
    if points is None:
        return float(1.0 / np.sqrt(eigh(P, shape, eigvals_only=True)[-1]))
    return float(1.0 / np.sqrt(np.einsum("ij,jk,ik->i", points, P, points).max()))


@dataclass(frozen=True, eq=False)
class RegionSize(Spec):
    """The size of ``E = {x' P x <= 1}``: an objective (see the module doc).

    Parameters
    ----------
    shape : ndarray, optional
        ``R`` (positive definite) of the reference set ``{x' R x <= 1}``.
    points : ndarray, optional
        Instead of `shape`: rows ``v_k`` of the reference points.
    rows : ndarray, optional
        Output rows ``c_i``: minimise ``E``'s half-width along them instead,
        keeping ``beta_min`` times the reference set inside ``E``.
    beta_min : float, optional
        With `rows`: the size of the reference set kept inside ``E`` (None:
        none kept).
    w_max : sequence of float, optional
        Peaks of the channel's disturbance inputs (empty: no disturbance).
    lambdas : sequence of float, optional
        With a disturbance: the decays ``lambda`` searched, in the model's
        units (1/s, or per sample); default `Peak`'s grid.
    cap : float, optional
        ``W <= cap W_ref`` (``W_ref`` the reference set's ``R^-1``, or
        ``diag`` of the points' squared sizes): ``E`` stays within
        ``sqrt(cap)`` times the reference set, so that a region that could be
        unbounded (a stable loop) stays finite (default 1e4).
    """

    channel = True
    unique = True

    shape: np.ndarray | None = None
    points: np.ndarray | None = None
    rows: np.ndarray | None = None
    beta_min: float | None = None
    w_max: tuple = ()
    bound: float | None = None
    lambdas: tuple | None = None
    cap: float = 1e4

    def __str__(self) -> str:
        what = "output size" if self.rows is not None else "region size"
        w = f", w_max={list(self.w_max)}" if self.w_max else ""
        return f"RegionSize({what}{w})"

    def structure(self) -> tuple:
        return (
            *super().structure(),
            None if self.points is None else len(self.points),
            None if self.rows is None else len(self.rows),
            self.rows is not None and self.beta_min is not None,
            len(self.w_max),
        )

    def reference(self) -> np.ndarray:
        """``W_ref``: the reference set's own ellipsoid's inverse matrix."""
        if self.points is None:
            return np.linalg.inv(self.shape)
        return np.diag(self.state_scaling(len(self.points[0])) ** 2)

    @property
    def _keeps_region(self) -> bool:
        return self.rows is None or self.beta_min is not None

    def state_scaling(self, n: int):
        """The reference set's half-axes along the states: ``1 / sqrt(R_ii)``
        or the largest ``|v_k,i|`` (1 where every point is zero)."""
        if self.points is None:
            if self.shape is None:
                return None
            return 1.0 / np.sqrt(np.diag(self.shape))
        size = np.abs(np.asarray(self.points, float)).max(axis=0)
        return np.where(size > 0, size, 1.0)

    # -- the disturbance (as `Peak`) -------------------------------------
    def weights(self, nw: int) -> np.ndarray:
        """``1 / w_max_i^2``, one per disturbance input."""
        return 1.0 / per_input(self.w_max, nw, "w_max", "inputs w") ** 2

    def decays(self, continuous):
        """`lambdas` or `Peak`'s grid with a disturbance; else None."""
        if not self.w_max:
            return None
        return self.lambdas if self.lambdas is not None else LAMBDAS[continuous]

    def decay_grid(self, continuous, frame):
        """`lambdas` in the frame's time units (``lambda~ = lambda / a``)."""
        if self.lambdas is None or not self.w_max:
            return self.decays(continuous)
        return tuple(lam / frame.a for lam in self.lambdas)

    def disturbance(self, t):
        """``(lambda, Bw, -diag(mu / w_max^2))`` (prescaled), or None."""
        if not self.w_max:
            return None
        weights, mu = t.var("weights"), t.var("mu")
        nw = t.nw()
        D = sum(weights[i] * mu[i, 0] * unit(nw, i) for i in range(nw))
        return t.var("lam"), t.data("Bw"), -t.const(D)

    # -- the protocol -----------------------------------------------------
    def variables(self, declare) -> None:
        """``mu`` (with a disturbance), the parameters ``lam``, ``weights``,
        the reference set (``R``, or ``v{k}``), ``rows`` and ``eta``."""
        n = declare.n
        if self.w_max:
            declare.variable("mu", (declare.nw, 1))
            declare.parameter("lam", (), nonneg=True)
            declare.parameter("weights", (declare.nw,), nonneg=True)
        if self._keeps_region:
            if self.points is None:
                declare.parameter("R", (n, n))
            else:
                for k in range(len(self.points)):
                    declare.parameter(f"v{k}", (n, 1))
        if self.rows is not None:
            declare.parameter("rows", (len(self.rows), n))
        declare.parameter("cap", (n, n))

    def prescale(self, frame, dims) -> dict:
        """The reference set, rows and disturbance weights in a rung's units.

        With ``W = k T W~ T'`` (``P~ = k T' P T``) and ``sz`` the channel's
        output scaling: ``v' P v = v~' P~ v~`` for ``v~ = T^-1 v / sqrt(k)``
        and ``P <= eta R`` iff ``P~ <= eta k T' R T``. The objective's
        squared bound is ``g = eta / sz^2`` (the engine rescales ``sz`` to
        make it of order one); a kept region's ``eta = 1 / beta_min^2`` is
        folded into its data (``eta R``, ``v / sqrt(eta)``).
        """
        sc = frame.scaling
        k, sz, T = sc.w_factor, frame.sz(dims.i), sc.matrix
        Ti = np.linalg.inv(T)
        # The reference set in units of g (the objective), or of 1 (kept:
        # 1/unit_of^2 = eta).
        unit_of = sz if self.rows is None else self._kept_beta
        # W <= cap W_ref with W = k T W~ T'.
        out = {"cap": self.cap * Ti @ self.reference() @ Ti.T / k}
        if self.w_max:
            out["weights"] = self.weights(dims.nw) * frame.rho(dims.i) * frame.a
        if self._keeps_region:
            if self.points is None:
                out["R"] = k * unit_of**2 * (T.T @ self.shape @ T)
            else:
                for q, v in enumerate(self.points):
                    out[f"v{q}"] = (Ti @ v / (np.sqrt(k) * unit_of))[:, None]
        if self.rows is not None:
            c = self.rows / np.linalg.norm(self.rows, axis=1)[:, None]
            out["rows"] = np.sqrt(k) * (c @ T) / sz
        return out

    @property
    def _kept_beta(self) -> float:
        return 1.0 if self.beta_min is None else 1.0 / self.beta_min

    def lmis(self, t, continuous):
        """None: the `Saturation` sector carries the disturbance."""
        return []

    def coefficient_lmis(self, t, continuous):
        """The reference set inside ``E``, and the rows' half-widths."""
        n, W = t.n, t.W()
        if self.rows is not None:
            g = t.const(t.g()[0, 0] * np.eye(1))
            CW = t.var("rows") @ W
            out = [(f"output size {i}", [[-g], [CW[i : i + 1].T, -W]])
                   for i in range(len(self.rows))]  # fmt: skip
            size = 1.0
        else:
            out, size = [], t.g()[0, 0]
        out.append(("W < cap", [[W - t.const(t.var("cap"))]]))
        if self._keeps_region:
            if self.points is None:
                R = t.const(size * t.var("R"))
                out.append(("region shape", [[-R], [-t.identity(n), -W]]))
            else:
                for q in range(len(self.points)):
                    out.append((f"region point {q}",
                                [[-t.const(size * np.eye(1))],
                                 [t.const(t.var(f"v{q}")), -W]]))  # fmt: skip
        return out

    def problem_lmis(self, t):
        """``sum(mu) <= lambda`` (non-strict), with a disturbance."""
        if not self.w_max:
            return []
        ones = np.ones((1, t.nw()))
        return [("sum(mu) <= lambda",
                 [[ones @ t.var("mu") - t.var("lam") * np.eye(1)]], False)]  # fmt: skip

    def to_model(self, g: float, frame, i: int) -> float:
        """``sqrt(eta) = sqrt(g) sz``: ``1 / beta`` or the largest half-width."""
        return float(np.sqrt(max(g, 0.0)) * frame.sz(i))

    def to_scaled(self, bound: float, frame, i: int) -> float:
        """The inverse of `to_model`."""
        return (bound / frame.sz(i)) ** 2

    def loop_fields(self, here) -> dict:
        """The disturbance input ``Bd``, the decay ``lam`` and ``mu_w = mu /
        w_max^2`` in the model's units (the `Saturation` sector reads them)."""
        if not self.w_max:
            return {}
        return {
            "Bd": here.mix("Bw"),
            "lam": float(here.var("lam")) * here.frame.a,
            "mu_w": here.frame.a * np.ravel(here.var("mu")) * self.weights(here.nw),
        }

    def residual(self, loop, continuous) -> float:
        """Relative excesses, in the model's units, of the sizes stated.

        ``eta / bound^2 - 1`` for the reference set (``eta`` the largest
        ``v_k' P v_k``, or of the eigenvalues of ``P`` against ``R``) or the
        rows (``c_i W c_i' / |c_i|^2``), ``eta beta_min^2 - 1`` for a kept
        region, ``sum(mu) / lambda - 1`` with a disturbance.
        """
        worst = -np.inf
        if self._keeps_region:
            beta = region_size(loop.P, self.shape, self.points)
            if self.rows is None:
                worst = (1.0 / beta) ** 2 / loop.bound**2 - 1
            elif self.beta_min is not None:
                worst = (self.beta_min / beta) ** 2 - 1
        if self.rows is not None:
            c = self.rows / np.linalg.norm(self.rows, axis=1)[:, None]
            sizes = np.einsum("ij,jk,ik->i", c, loop.W, c)
            worst = max(worst, float(sizes.max()) / loop.bound**2 - 1)
        if self.w_max:
            mu = loop.mu_w / self.weights(loop.Bd.shape[1])
            worst = max(worst, float(mu.sum() / loop.lam) - 1)
        return float(worst)

    def model_values(self, frame, read) -> dict:
        """With a disturbance: ``decay`` (``lambda``), ``mu`` and ``level``
        (``sum(mu) / lambda``, model units)."""
        if not self.w_max:
            return {}
        decay = float(read("lam")) * frame.a
        mu = frame.a * np.ravel(read("mu")).astype(float)
        return {"decay": decay, "mu": mu, "level": float(mu.sum() / decay)}
