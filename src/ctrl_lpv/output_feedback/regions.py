"""Pole regions of an output-feedback design (Chilali and Gahinet 1996).

A region ``{s : L + M s + M' conj(s) < 0}`` holds every eigenvalue of a
closed loop ``A_cl`` when ``kron(L, P) + kron(M, A_cl' P) + kron(M', P
A_cl) < 0`` for some ``P > 0`` (the primal form of
`ctrl_lpv.regions.LMIRegion`). With the design's own ``P`` and the
congruence by ``I (x) Pi1`` of `ctrl_lpv.output_feedback.lmis` it becomes
``kron(L, Xb) + kron(M, AA') + kron(M', AA) < 0``, affine in the variables
(Scherer, Gahinet and Chilali 1997, Sec. IV): one ``P`` with the
objective's inequalities, so the region and the bound share the
certificate. The closed loop being affine in the convex coordinates (the
plant's ``B2, C2, D12, D21`` constant), the vertex inequalities hold on the
polytope: every frozen closed loop has its eigenvalues in the region.

`RegionConstraint` implements the part of the objective protocol
(`ctrl_lpv.output_feedback.objectives`) a constraint needs: its LMIs after
the change of variables, the same inequality on the rebuilt closed loop in
float64, and a frozen cross-check of the eigenvalues.
"""

from __future__ import annotations

import numpy as np

from ..certificate import Check, negative_definite
from ..lmi import assemble, normalized_max_eig
from ..regions import LMIRegion, region_blocks
from ..synthesis.constraints import _require_unit_disk, pole_regions
from ..synthesis.frozen import verification_points
from ..synthesis.spec import Spec
from . import lmis
from .reconstruct import closed_loop

__all__ = ["RegionConstraint", "region_constraints"]


def region_constraints(constraints, continuous) -> tuple:
    """`RegionConstraint` of each pole region in `constraints`, checked
    (`ctrl_lpv.synthesis.constraints.pole_regions`; for a discrete-time
    plant a region must be a disk inside the unit circle)."""
    regions = pole_regions(constraints, "output feedback (y given)")
    if not continuous:
        for region in regions:
            _require_unit_disk(region)
    return tuple(RegionConstraint(region) for region in regions)


class RegionConstraint(Spec):
    """Every frozen closed-loop eigenvalue in `region` (module docstring)."""

    strictly_proper = False
    homogeneous = True  # in P

    def __init__(self, region: LMIRegion):
        self._region = region

    @property
    def region(self) -> LMIRegion:
        """The `~ctrl_lpv.regions.LMIRegion` imposed (`Spec.region`)."""
        return self._region

    def __str__(self) -> str:
        return str(self.region)

    def statement(self) -> str:
        return f"every frozen closed-loop eigenvalue in {self.region}"

    def plant_of(self, plant):
        return plant

    def check(self, plant) -> None:
        """Nothing to check beyond `region_constraints`."""

    def variables(self, declare) -> None:
        """No variables of its own."""

    def prescale(self, frame, dims) -> dict:
        """No constants (the region is in the plant's time units)."""
        return {}

    def coefficient_lmis(self, t, continuous) -> list:
        return []

    def lmis(self, t, continuous):
        """``(name, block function, ())`` of the region's LMI at vertex
        ``t.j`` (no performance blocks: every block row is a state row)."""
        L, M = self.region.L, self.region.M
        plant, j = t.plant, t.j

        def blocks(v):
            AA, _, _, _ = lmis.transformed_loop(plant, j, v.X, v.Y, *t.hats(v))
            Xb = [[v.X, np.eye(plant.n)], [np.eye(plant.n), v.Y]]
            return _blockwise(L, M, Xb, AA)

        return [(f"{self.region} vertex {j}", blocks, ())]

    def loop_checks(self, loop, P, values, j, continuous, margin=0.0, what=""):
        """The region's inequality on the closed loop at vertex `j`, float64.

        `margin` bounds the effect of a perturbation of the loop's matrices
        on a unit-``P`` inequality (`ctrl_lpv.output_feedback.checks`); the
        region's ``A`` enters through ``M``, so it is scaled by ``||M||``.
        """
        A = loop[0]
        L, M = self.region.L, self.region.M
        F = assemble(region_blocks(L, M, P, A.T @ P))
        F_abs = assemble(region_blocks(np.abs(L), np.abs(M), np.abs(P),
                                       np.abs(A.T) @ np.abs(P)))  # fmt: skip
        margin = margin * max(1.0, float(np.linalg.norm(M, 2)))
        return [negative_definite(F, margin=margin, absolute=np.abs(F_abs),
                                  what=f"{self.region} (closed loop{what})",
                                  where=f"vertex {j}", group="LMI")]  # fmt: skip

    def residual(self, loop, continuous) -> float:
        """Largest normalised eigenvalue of the region's inequality on the
        frozen closed loop."""
        A = loop.matrices()[0]
        L, M, P = self.region.L, self.region.M, loop.P
        return normalized_max_eig(assemble(region_blocks(L, M, P, A.T @ P))[None])

    def loop_lmis(self, loop, j, continuous):
        """``(name, block function)`` on the closed loop in a variable ``P``."""
        A = loop[0]
        L, M = self.region.L, self.region.M
        return [(f"{self.region} vertex {j}",
                 lambda v: region_blocks(L, M, v.P, A.T @ v.P))]  # fmt: skip

    def frozen_check(self, plant, controllers) -> Check:
        """Cross-check: eigenvalues of the frozen closed loops in the region."""
        outside, where = 0, "every verification point"
        for delta, p in verification_points(plant.system):
            K = tuple(
                np.tensordot(delta, np.array(M), axes=1) for M in zip(*controllers)
            )
            A = closed_loop(plant, plant.data(delta), K)[0]
            missed = int(np.sum(~self.region.contains(np.linalg.eigvals(A))))
            if missed > outside:
                point = delta if p is None else p
                outside, where = missed, f"p = {np.round(point, 6).tolist()}"
        return Check(f"frozen eigenvalues outside {self.region}", float(outside), 0.5,
                     strict=True, cross_check=True, units="count", where=where,
                     group="frozen")  # fmt: skip


def _blockwise(L, M, Xb, AA):
    """The lower block triangle of ``kron(L, Xb) + kron(M, AA') + kron(M',
    AA)`` with ``Xb`` and ``AA`` given as 2 x 2 lists of ``n x n`` blocks
    (so that the LMI layer reads it block by block)."""
    k = L.shape[0]
    rows = []
    for a in range(k):
        for r in range(2):
            row = []
            for b in range(a + 1):
                for s in range(2 if b < a else r + 1):
                    block = L[a, b] * Xb[r][s]
                    if a == b and r == s:
                        # A diagonal block stands for its symmetric part.
                        block = block + 2 * M[a, a] * AA[r][r]
                    else:
                        block = block + M[a, b] * AA[s][r].T + M[b, a] * AA[r][s]
                    row.append(block)
            rows.append(row)
    return rows
