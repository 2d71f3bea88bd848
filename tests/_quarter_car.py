"""A quarter-car suspension as a polytopic model, and a measured sampling error.

Shared by ``tests/test_discretization_bound.py`` and
``benchmarks/study_discretization_bound.py``. The measurement is written
here from the frozen systems (``sys.at(p)``) and `scipy.linalg.expm`, not
from the bound's code.
"""

import itertools

import control as ct
import numpy as np
import scipy.linalg

import ctrl_lpv as lpv


def quarter_car(
    sprung=300.0,
    unsprung=40.0,
    tyre=190e3,
    stiffness=(15e3, 30e3),
    damping=(1e3, 3e3),
    payload=None,
):
    """Quarter car with suspension stiffness ``ks`` and damping ``cs`` in boxes.

    States: suspension deflection ``zs - zu`` (m), sprung velocity (m/s),
    tyre deflection ``zu - zr`` (m), unsprung velocity (m/s). Inputs: road
    velocity ``w`` (m/s) and actuator force ``u`` (N) between the masses.
    Masses in kg, stiffnesses in N/m, damping in N s/m. With ``payload =
    (lo, hi)`` the inverse sprung mass ``1 / ms`` (1/kg) is a third
    parameter (``A`` and ``B`` are affine in it, not in ``ms``), and the
    ``ks, cs`` terms scale with it through the vertices (a multilinear
    model, which ``from_affine`` cannot write: built from its 8 vertices).
    """
    names = ["ks", "cs"] + (["inv_ms"] if payload else [])
    bounds = {"ks": stiffness, "cs": damping}
    if payload:
        bounds["inv_ms"] = payload
    box = lpv.ParameterBox(bounds)
    vertices = []
    for point in box.points:
        p = dict(zip(names, point))
        inv_ms = p.get("inv_ms", 1.0 / sprung)
        ks, cs = p["ks"], p["cs"]
        A = np.array(
            [
                [0.0, 1.0, 0.0, -1.0],
                [-ks * inv_ms, -cs * inv_ms, 0.0, cs * inv_ms],
                [0.0, 0.0, 0.0, 1.0],
                [ks / unsprung, cs / unsprung, -tyre / unsprung, -cs / unsprung],
            ]
        )
        B = np.array([[0.0, 0.0], [0.0, inv_ms], [-1.0, 0.0], [0.0, -1.0 / unsprung]])
        vertices.append(
            ct.ss(
                A, B, np.eye(4), 0, inputs=["w", "u"], states=["ds", "vs", "dt", "vu"]
            )
        )
    return lpv.PolytopicStateSpace(vertices, box, name="quarter_car")


def measured_errors(sys, sysd, points):
    """Largest ``||Phi(p) - model(p)||_2`` and the same for ``Gamma``.

    ``Phi(p), Gamma(p)``: exact ZOH (`scipy.linalg.expm` of the block
    matrix) of the frozen system ``sys.at(p)``; ``model(p)``: the sampled
    polytopic system's frozen matrices ``sysd.at(p)``.
    """
    n, m = sys.nstates, sys.ninputs
    phi = gamma = 0.0
    for p in points:
        frozen, model = sys.at(p), sysd.at(p)
        M = np.zeros((n + m, n + m))
        M[:n, :n], M[:n, n:] = frozen.A, frozen.B
        E = scipy.linalg.expm(sysd.dt * M)
        phi = max(phi, np.linalg.norm(E[:n, :n] - model.A, 2))
        gamma = max(gamma, np.linalg.norm(E[:n, n:] - model.B, 2))
    return phi, gamma


def box_grid(box, per_axis):
    """A grid of ``per_axis`` points per coordinate, with cell centres.

    The bound samples its own grid; the centres of a finer, different grid
    are where a sampled bound would miss the error if its remainder were
    wrong.
    """
    axes = [np.linspace(lo, hi, per_axis) for lo, hi in zip(box.lower, box.upper)]
    centres = [(a[1:] + a[:-1]) / 2.0 for a in axes]
    return list(itertools.product(*axes)) + list(itertools.product(*centres))
