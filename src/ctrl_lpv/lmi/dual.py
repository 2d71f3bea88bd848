"""`LMIProblem.farkas`: dual certificates of infeasibility, verified in float64.

The numerics are in `ctrl_lpv._farkas`; what a certificate proves is
`ctrl_lpv.lmi.FarkasCertificate`. The maps here are read one unit point at
a time (exact columns), not batched: the rounding bounds of a certificate
assume them.
"""

from __future__ import annotations

import time

import numpy as np

from .. import _farkas
from .certificates import _certificate, _stronger

__all__ = ["DualCertificates"]


class DualCertificates:
    """The dual-certificate methods of `ctrl_lpv.lmi.LMIProblem`."""

    def _best_farkas(self, dual_points, stage):
        best = None
        for duals in dual_points:
            proof = self.farkas(duals, stage)
            if proof is not None and (best is None or _stronger(proof, best)):
                best = proof
        return best

    def farkas(self, duals, stage: str = "default"):
        """Verify a dual certificate of infeasibility in float64.

        Parameters
        ----------
        duals : sequence of ndarray
            One symmetric matrix per active inequality of `stage`, in the
            order they were added (e.g. cvxpy's dual values after an
            infeasible solve). Each is projected on the PSD cone, then
            polished by alternating projections (PSD cone, null space of the
            adjoint map) and the certificate is evaluated as described in
            `FarkasCertificate`; both signs are tried, with and without the
            duals of the normalisations.
        stage : str, optional
            Stage name.

        Returns
        -------
        `FarkasCertificate` or None
            None if no variant gives a positive trace.
        """
        started = time.perf_counter()
        try:
            return self._farkas(duals, stage)
        finally:
            self.dual_seconds += time.perf_counter() - started

    def _farkas(self, duals, stage):
        active = self._active(stage)
        if len(duals) != len(active):
            raise ValueError(
                f"duals: expected {len(active)} matrices, got {len(duals)}"
            )
        full = self._affine_map(active)
        normalizing = np.array([name in self._normalizations for name, *_ in active])
        strict = np.array([is_strict for _, _, is_strict, _ in active])
        groups = self._column_groups()
        symmetric = full.stack(duals)
        # Without the normalisations (their inequalities dropped, so their
        # duals are exactly zero): a certificate that does not need them
        # refutes the LMIs themselves (for homogeneous strict LMIs the
        # normalisations are often what makes the solver's problem
        # infeasible).
        everything = np.arange(len(active))
        variants = [(full, everything, symmetric)]
        if normalizing.any() and not normalizing.all():
            reduced = full.restrict(~normalizing)
            kept = np.flatnonzero(~normalizing[full._owner])
            variants.append((reduced, np.flatnonzero(~normalizing), symmetric[kept]))
        best = None
        for sign in (1.0, -1.0):  # conventions differ
            for amap, members, y0 in variants:
                y = amap.polish(sign * y0)
                if y is None:
                    continue
                proof = _certificate(
                    stage, amap, y, members, full.sizes, normalizing, strict, groups
                )
                if best is None or _stronger(proof, best):
                    best = proof
        return best

    def _column_groups(self) -> list[tuple[str, slice]]:
        """Each variable's columns in the affine map (`_affine_map`)."""
        groups, start = [], 0
        for name, var in self._vars.items():
            groups.append((name, slice(start, start + var.free)))
            start += var.free
        return groups

    def _affine_map(self, active) -> _farkas.AffineMap:
        """``F_i(0)`` and the sparse map ``x -> vec(F_i(x) - F_i(0))``, exact.

        Read off the block functions one free entry of the variables at a
        time (`_pieces` with ``exact=True``); the stacked map, with its
        factored Gram matrix, is kept while no inequality's map changes.
        """
        pieces = self._pieces(active, exact=True)
        parts = tuple(part for _, part in pieces)
        key = ("map", tuple(name for name, *_ in active))
        last = self._exact.get(key)
        if last and len(last[0]) == len(parts) and all(map(id_equal, last[0], parts)):
            return last[1]
        amap = _farkas.stacked(pieces, self._nfree())
        self._exact[key] = (parts, amap)
        return amap


def id_equal(a, b) -> bool:
    """Whether `a` is `b` (the same cached columns)."""
    return a is b
