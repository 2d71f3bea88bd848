"""Sampling of polytopic systems, with a bound on the error between vertices.

The zero-order hold of the frozen system at ``p`` is not the interpolation
of the vertices' ZOH (``expm`` is not affine); `sampled` discretizes vertex
by vertex and attaches the certified bound of `ctrl_lpv.discretization`,
and `SamplingMixin.sample` is python-control's ``sample`` method on it.
"""

from __future__ import annotations

import warnings

import control as ct

from .._checks import real_number
from ..discretization import sampled_vertex_data

__all__ = ["sampled", "SamplingMixin"]


def sampled(sys, Ts: float, method: str, labels: dict):
    """Vertexwise discretization of `sys`, with ``discretization_error``.

    Parameters
    ----------
    sys : `PolytopicStateSpace`
        A continuous-time system.
    Ts : float
        Sampling period, positive.
    method : {"zoh", "euler"}
        Discretization.
    labels : dict
        ``inputs``, ``outputs``, ``states`` and ``name`` of the result.

    Returns
    -------
    `PolytopicStateSpace`
        Discrete time with ``dt = Ts``, the domain, nominal point and
        scheduling of `sys`.
    """
    vertices, bound = sampled_vertex_data(sys._data, sys.domain, Ts, method)
    result = type(sys)(
        vertices,
        sys.domain,
        scheduling=sys.scheduling,
        nominal=sys.nominal,
        dt=Ts,
        **labels,
    )
    result.discretization_error = bound
    return result


class SamplingMixin:
    """python-control's ``sample`` for a polytopic system.

    For `PolytopicStateSpace` (before `control.StateSpace` in its bases).
    """

    def sample(
        self,
        Ts,
        method="zoh",
        alpha=None,
        prewarp_frequency=None,
        name=None,
        copy_names=True,
        **kwargs,
    ):
        """Discretize vertex by vertex, with a bound on the error between them.

        Same signature as `control.StateSpace.sample` (so
        `control.sample_system` works too). The zero-order hold of the
        frozen system at ``p`` is not the interpolation of the vertices'
        ZOH (``expm`` is not affine), so the result carries a rigorous
        bound on that difference: ``sysd.discretization_error``, a
        `DiscretizationBound` with ``phi >= sup_p ||Phi(p) - sum_j
        delta_j(p) Phi_j||_2`` and ``gamma`` the same for ``Gamma``, where
        ``Phi(p), Gamma(p)`` is the ZOH of ``sys.at(p)`` (``C, D`` are
        unchanged, hence exact). The bound is second order in the period
        and the parameter range, derived in scaled norms (Lyapunov and
        balanced) where the 2-norm's logarithmic norm would overstate the
        growth; on a `ParameterBox` or a `Simplex` it is the error computed
        on a grid of about 1000 points plus a rigorous remainder for the
        cells between them (the derivation is in
        `ctrl_lpv.discretization`). Measured on a quarter car and on the
        two-mass drive at 0.5 to 10 ms
        (``benchmarks/study_discretization_bound.py``): 1.00 to 1.16 times
        the largest error on a dense grid with one or two parameters, up to
        2.9 times with three. It is looser with many parameters (the grid
        coarsens: none from 7 parameters on), for long periods, and on a
        `Polytope` (no grid: 36 to 49 times for ``Phi``, 45 to 600 for
        ``Gamma`` on the quarter car at 0.5, 2 and 10 ms). The bound is 0 for a
        single vertex (an LTI system) and for ``method="euler"``, whose
        model ``(I + T A_j, T B_j)`` is affine in the vertex data, hence
        exactly polytopic. A period too long for a meaningful bound gives a
        `UserWarning` (and ``inf`` where the growth factor overflows, never
        NaN).

        Use the bound to account for the sampling: the true sampled frozen
        system is ``sum_j delta_j (Phi_j, Gamma_j) + (E_Phi, E_Gamma)`` with
        ``||E_Phi|| <= phi``, ``||E_Gamma|| <= gamma``, a norm-bounded
        uncertainty.

        Parameters
        ----------
        Ts : float
            Sampling period, positive.
        method : {"zoh", "euler"}, optional
            Zero-order hold (default) or forward Euler. The other methods
            of python-control (``"bilinear"``, ``"tustin"``,
            ``"backward_diff"``, ``"gbt"`` with ``alpha != 0``) involve a
            matrix inverse, not affine in the vertex data, and have no
            bound here: a `ValueError`.
        alpha : float, optional
            For ``method="gbt"``: only ``alpha = 0`` (forward Euler) is
            accepted. Ignored otherwise, as in python-control.
        prewarp_frequency : float, optional
            Ignored with a warning (as python-control does for methods
            other than bilinear).
        name : str, optional
            Name of the result; default the name of this system with
            python-control's sampled-system prefix and suffix
            (``"$sampled"``) when `copy_names`.
        copy_names : bool, optional
            Copy the signal names (default True).
        **kwargs
            ``inputs``, ``outputs``, ``states``: signal names of the result
            (physical inputs only).

        Returns
        -------
        `PolytopicStateSpace`
            Discrete time with ``dt = Ts``, the same domain, nominal point
            and scheduling, and the attribute ``discretization_error`` (not
            kept by operations that build a new system from it).

        Raises
        ------
        ValueError
            If this system is already discrete time, `Ts` is not positive,
            `method` is not ``"zoh"`` or ``"euler"``, or the ZOH of a vertex
            overflows (`Ts` too long for an unstable vertex).

        Warns
        -----
        UserWarning
            If a bound is not below the largest norm of the sampled vertex
            matrices, or is ``inf``: `Ts` is too long for a meaningful bound.
        """
        if not self.isctime(strict=True):
            raise ValueError(
                "sample: the system is already discrete time "
                f"(dt = {self.dt!r}); sampling needs a continuous-time system"
            )
        Ts = real_number(Ts, "Ts", positive=True)
        if method == "gbt" and alpha in (0, 0.0):
            method = "euler"
        if method not in ("zoh", "euler"):
            raise ValueError(
                f"method: {method!r} is not available for a polytopic system: "
                "only 'zoh' (with a certified bound on the error between the "
                "vertices) and 'euler' (exactly polytopic) are; the other "
                "discretizations involve a matrix inverse, not affine in the "
                "vertex data, and have no error bound here"
            )
        if prewarp_frequency is not None:
            warnings.warn(
                "prewarp_frequency ignored: incompatible conversion",
                UserWarning,
                stacklevel=2,
            )
        unknown = sorted(set(kwargs) - {"inputs", "outputs", "states"})
        if unknown:
            raise TypeError(f"unexpected keyword arguments: {unknown}")
        first = self.vertices[0]
        if copy_names:
            defaults = ct.config.defaults
            labels = {
                "inputs": list(first.input_labels),
                "outputs": list(first.output_labels),
                "states": list(first.state_labels),
                "name": name
                if name is not None
                else defaults["iosys.sampled_system_name_prefix"]
                + self.name
                + defaults["iosys.sampled_system_name_suffix"],
            }
        else:
            labels = {
                "inputs": first.ninputs,
                "outputs": first.noutputs,
                "states": first.nstates,
                "name": name,
            }
        labels.update(kwargs)
        return sampled(self, Ts, method, labels)
