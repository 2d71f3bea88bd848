r"""Sampling a polytopic system, with a bound on the error between vertices.

Zero-order hold of a frozen system ``(A, B)`` gives

.. math::

    \begin{bmatrix} \Phi & \Gamma \\ 0 & I \end{bmatrix}
    = e^{T M}, \qquad
    M = \begin{bmatrix} A & B \\ 0 & 0 \end{bmatrix},

which is not affine in ``(A, B)``: the vertexwise ZOH model
``sum_j delta_j (Phi_j, Gamma_j)`` is exact at the vertices only. This
module bounds its error over the whole domain,

.. math::

    e_\Phi = \sup_p \bigl\|\Phi(p) - \textstyle\sum_j \delta_j(p)\,\Phi_j\bigr\|_2,
    \qquad
    e_\Gamma = \sup_p \bigl\|\Gamma(p) - \textstyle\sum_j \delta_j(p)\,
    \Gamma_j\bigr\|_2,

where ``Phi(p)``, ``Gamma(p)`` are the exact ZOH of the frozen system
``A(p) = sum_j delta_j(p) A_j`` (the system the class holds). ``C`` and
``D`` are unchanged by sampling, so the polytopic model is exact for them.

**Derivation.** Write ``F(p) = expm(T M(p))`` with ``M(p) = sum_j delta_j(p)
M_j``, and ``mu(X) = lambda_max((X + X') / 2)`` the logarithmic 2-norm, so
that ``||expm(t X)|| <= exp(t mu(X))`` for ``t >= 0``; ``mu`` is convex, so
``mu(M(p)) <= mu* = max_j mu(M_j)``.

1. *Second derivative along a direction.* If ``M(s) = M + s E``, the
   Dyson expansion gives ``F''(s) = 2 T^2 \int_{\tau_1 + \tau_2 + \tau_3 = 1}
   e^{\tau_1 T M(s)} E e^{\tau_2 T M(s)} E e^{\tau_3 T M(s)} d\sigma`` over
   the 2-simplex (area 1/2), hence ``||F''(s)|| <= T^2 ||E||^2 exp(T mu*)``.
2. *Box* (`ParameterBox`, ``delta`` multilinear in ``p``): along coordinate
   ``i`` (others fixed) ``M(p)`` is affine with slope ``E_i = D_i / w_i``,
   where ``w_i`` is the width and ``D_i(p)`` a convex combination of the
   differences ``M_j' - M_j`` over the box edges along ``i``; so ``||D_i||
   <= d_i = max over those edges of ||M_j' - M_j||``. The vertexwise model
   is the multilinear interpolant ``I_1 ... I_k F`` (``I_i`` the linear
   interpolation in ``p_i``). Telescoping, ``F - I_1...I_k F = sum_i I_1
   ... I_{i-1} (F - I_i F)``; each ``I_i`` is a convex combination, so it
   does not increase the sup norm, and the Peano-kernel form of the
   one-dimensional interpolation error (valid for matrix-valued functions)
   gives ``||F - I_i F|| <= w_i^2 / 8 sup ||d^2 F / dp_i^2||``. Hence

   .. math::

       e \le \frac{T^2}{8}\, e^{T \mu^*} \sum_i d_i^2 .

3. *Any polytope* (`Simplex`, `Polytope`, or a box): at ``x = sum_j
   lambda_j v_j`` (vertices ``v_j`` in the convex coordinates), Taylor's
   formula with integral remainder at ``x`` and ``sum_j lambda_j (v_j - x)
   = 0`` give ``sum_j lambda_j F(v_j) - F(x) = sum_j lambda_j R_j``, with
   ``||R_j|| <= 1/2 T^2 ||M_j - M(x)||^2 exp(T mu*)`` by step 1, and
   ``||M_j - M(x)|| <= max_l ||M_j - M_l||``. Hence

   .. math::

       e \le \frac{T^2}{2}\, e^{T \mu^*} \max_{j, l} \|M_j - M_l\|_2^2 .

   On a box the smaller of the two bounds is reported.

For ``e_Phi`` the same argument runs with ``A`` in place of ``M`` (``Phi =
expm(T A)``; ``mu*`` then is ``max_j mu(A_j)``, negative for strongly
stable vertices). For ``e_Gamma`` the bound with ``M`` (it bounds the whole
block row ``[Phi, Gamma]``) is ``O(T^2)``, while ``Gamma`` only changes at
``O(T^3)`` when ``B`` is constant; a second bound is taken from
``Gamma(p) = \int_0^T expm(s A(p)) ds B(p)``: along a direction with
slopes ``(E_A, E_B)`` (``B`` affine along it, so no ``B''`` term),
``||Gamma''|| <= ||E_A||^2 b I_2 + 2 ||E_A|| ||E_B|| I_1`` with ``b =
max_j ||B_j||``, ``I_k = \int_0^T s^k exp(s mu_A*) ds``, from
``||d^2/ds^2 expm(s A)|| <= s^2 ||E_A||^2 exp(s mu_A*)`` and
``||d/ds expm(s A)|| <= s ||E_A|| exp(s mu_A*)``. Steps 2 and 3 then give
``sum_i (a_i^2 b I_2 + 2 a_i b_i I_1) / 8`` on a box (``a_i, b_i`` the
largest edge changes of ``A`` and ``B`` along ``i``) and ``(a^2 b I_2 + 2 a
b' I_1) / 2`` on any polytope (``a, b'`` the largest vertex-pair changes).
The smallest of the valid bounds is reported. The forward-Euler model ``(I + T A_j, T B_j)`` is affine
in the vertex data, so it is exactly polytopic (both errors 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .polytope import ParameterBox

__all__ = ["DiscretizationBound", "sampled_vertex_data"]


@dataclass(frozen=True)
class DiscretizationBound:
    """Bound on the error of a vertexwise discretization between vertices.

    Attributes
    ----------
    Ts : float
        Sampling period.
    method : str
        ``"zoh"`` or ``"euler"``.
    phi : float
        Upper bound on ``sup_p ||Phi(p) - sum_j delta_j(p) Phi_j||_2``, where
        ``Phi(p)`` is the discretization (by `method`) of the frozen
        continuous-time system at ``p``.
    gamma : float
        The same for the input matrix ``Gamma``.
    exact : bool
        True when the polytopic model equals the frozen discretization at
        every point (a single vertex, vertices with equal ``A, B``, or
        ``method="euler"``).
    """

    Ts: float
    method: str
    phi: float
    gamma: float
    exact: bool


def _mu(X: np.ndarray) -> float:
    """Logarithmic 2-norm ``lambda_max((X + X') / 2)``."""
    return float(np.linalg.eigvalsh((X + X.T) / 2.0).max())


def _pairwise(mats) -> float:
    """``max_{j,l} ||M_j - M_l||_2`` (0 for one vertex)."""
    N = len(mats)
    return max(
        (np.linalg.norm(mats[j] - mats[k], 2) for j in range(N) for k in range(j)),
        default=0.0,
    )


def _edges(mats, domain) -> list[float]:
    """Per box coordinate ``i``: ``max ||M_j' - M_j||_2`` over its edges."""
    k = domain.nparams
    out = []
    for i in range(k):
        step = 1 << (k - 1 - i)  # the first parameter varies slowest
        out.append(
            max(
                np.linalg.norm(mats[j ^ step] - mats[j], 2)
                for j in range(len(mats))
                if not domain._bits[j, i]
            )
        )
    return out


def _moments(T: float, mu: float) -> tuple[float, float]:
    """``I_1, I_2`` with ``I_k = int_0^T s^k exp(mu s) ds``."""
    x = mu * T
    if abs(x) <= 1.0:  # series, no cancellation
        i1 = i2 = 0.0
        term = 1.0  # x^k / k!
        for k in range(40):
            i1 += term / (k + 2)
            i2 += term / (k + 3)
            term *= x / (k + 1)
        return T**2 * i1, T**3 * i2
    e = np.exp(x)
    return (
        (e * (x - 1.0) + 1.0) / mu**2,
        (e * (x * x - 2.0 * x + 2.0) - 2.0) / mu**3,
    )


def _expm_bound(mats, domain, T: float) -> float:
    """Interpolation error bound of ``expm(T M(p))`` (steps 1 to 3)."""
    grow = T**2 * np.exp(T * max(_mu(M) for M in mats))
    bound = grow * _pairwise(mats) ** 2 / 2.0
    if isinstance(domain, ParameterBox):
        bound = min(bound, grow * sum(d * d for d in _edges(mats, domain)) / 8.0)
    return bound


def _gamma_bound(As, Bs, domain, T: float) -> float:
    """Interpolation error bound of ``Gamma(p)`` from its integral form."""
    i1, i2 = _moments(T, max(_mu(A) for A in As))
    b = max(np.linalg.norm(B, 2) for B in Bs)
    a, db = _pairwise(As), _pairwise(Bs)
    bound = (a * a * b * i2 + 2.0 * a * db * i1) / 2.0
    if isinstance(domain, ParameterBox):
        box = sum(
            ai * ai * b * i2 + 2.0 * ai * bi * i1
            for ai, bi in zip(_edges(As, domain), _edges(Bs, domain))
        )
        bound = min(bound, box / 8.0)
    return bound


def sampled_vertex_data(data, domain, Ts: float, method: str):
    """Vertexwise discretization and its `DiscretizationBound`.

    Parameters
    ----------
    data : sequence of (A, B, C, D)
        Continuous-time vertex matrices, in the domain's vertex order.
    domain : `ParameterBox`, `Polytope` or `Simplex`
        The parameter domain (its type selects the bound; see the module).
    Ts : float
        Sampling period, positive.
    method : {"zoh", "euler"}
        Discretization.

    Returns
    -------
    vertices : list of (Phi_j, Gamma_j, C_j, D_j)
    bound : `DiscretizationBound`
    """
    n = data[0][0].shape[0]
    m = data[0][1].shape[1]
    if method == "euler":
        vertices = [(np.eye(n) + Ts * A, Ts * B, C, D) for A, B, C, D in data]
        return vertices, DiscretizationBound(Ts, method, 0.0, 0.0, True)
    Ms = []
    vertices = []
    for A, B, C, D in data:
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = A, B
        E = scipy.linalg.expm(Ts * M)
        Ms.append(M)
        vertices.append((E[:n, :n], E[:n, n:], C, D))
    As = [M[:n, :n] for M in Ms]
    Bs = [M[:n, n:] for M in Ms]
    block = _expm_bound(Ms, domain, Ts)  # the block row [Phi, Gamma]
    phi = min(_expm_bound(As, domain, Ts), block)
    gamma = min(_gamma_bound(As, Bs, domain, Ts), block)
    return vertices, DiscretizationBound(
        float(Ts), method, float(phi), float(gamma), bool(gamma == 0.0)
    )
