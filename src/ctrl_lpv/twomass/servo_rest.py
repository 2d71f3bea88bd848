r"""The certificate of the sampled servo at rest: the loop that runs.

At rest (the move ended, the reference constant) in contact (a load torque
of at least twice the contact torque holding the load on a flank, so that
the observer is scheduled on contact) the sampled servo is a linear
discrete-time loop of

* the drive in contact, sampled with the zero-order hold: ``theta_m,
  omega_m, theta_l, omega_l`` about the equilibrium (the load torque
  constant and the backlash angle at its flank, so both drop out of the
  deviations);
* the drive observer (`ctrl_lpv.twomass.drive_observer`, the contact
  vertex), reading the encoder angles with an error ``n`` bounded by
  ``counts_error`` counts (the quantization and its noise), its model on
  the load inertia the servo has learnt (`ctrl_lpv.twomass.inertia`): the
  nominal, as before the first move, or within ``learnt_tolerance`` of the
  load's (the learning itself is not certified: the simulation grid
  checks it);
* the command, computed from the estimate predicted to the instant it acts
  and held one sample (``delay=1``: the command on its way is a state);
* the discrete integral of the load error.

Quantization is a peak-bounded disturbance, ``|n_i| <= counts_error q_i``.
At a fixed load inertia and learnt inertia the loop is linear and
time-invariant, so the largest the load error and the torque's deviation
from its mean (half the ripple's peak-to-peak) can become is exactly the
peak-to-peak gain of the loop, the l1 norm of its impulse response times the
reading bounds (Dahleh and Diaz-Bobillo 1995). `rest_bound` sums the impulse
response in float64 and bounds the tail it leaves out with a Lyapunov matrix
that certifies the contraction of the loop (``A' P A < rho^2 P``); an
ellipsoid (`ctrl_lpv.ultimate_bound`) bounds the same quantities with a
quadratic function, looser on this 12-state loop (8.7e-4 rad and 21 Nm at
the lightest load, against 7.3e-4 rad and 12.5 Nm) and a hundred times
slower. What is not covered: the gap (a load at rest in the gap is not in
this loop), the contact detection, the planner, the gap estimate and the
flank latch at rest (`ctrl_lpv.twomass.rest_flank`, which engages only with
a load-torque estimate below its threshold: the load-torque floor keeps the
estimate above it); the simulations check those."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import control as ct
import numpy as np
import scipy.linalg as sla

from ..certificate import Certificate, Check, negative_definite
from ..exceptions import CertificationError
from .parameters import Parameters

__all__ = ["RestBound", "alternating_mode", "rest_bound"]


@dataclass(frozen=True)
class RestBound:
    """Certified ultimate bounds of the sampled servo at rest.

    Attributes
    ----------
    error_bound : float
        ``|theta_l - theta_r| <=`` this, rad, ultimately (the largest over
        `inertias`).
    ripple_bound : float
        ``|Tm - mean| <=`` this, Nm: half the torque's peak-to-peak.
    inertias : tuple of float
        Load inertias certified, multiples of the nominal.
    learnt_tolerance : float
        The observer's model is on the nominal load inertia or on one
        within this of the load's, as multiples of the nominal (0 without
        an inertia estimate: the nominal alone).
    counts_error : float
        The encoder reading error allowed for, in counts.
    min_load_torque : float
        The statement holds for a load torque ``|Td|`` at least this, Nm:
        then the shaft stays in contact, the observer's contact schedule at
        1 and the flank choice saturated along every admissible run (their
        deviations from the equilibrium are bounded the same way).
    time_constant : float
        Certified rate of approach, s: the loop contracts by
        ``exp(-dt / time_constant)`` per sample in the norm of the Lyapunov
        matrix of the tail bound (``A' P A < rho^2 P``), so the bounds are
        approached like ``exp(-t / time_constant)`` (the largest over
        `inertias`).
    certificate : `ctrl_lpv.Certificate`
        The float64 checks of every analysis, grouped by inertia.
    """

    error_bound: float
    ripple_bound: float
    inertias: tuple
    learnt_tolerance: float
    counts_error: float
    min_load_torque: float
    time_constant: float
    certificate: Certificate

    def __str__(self) -> str:
        inertias = ", ".join(f"{j:g}" for j in self.inertias)
        learnt = ""
        if self.learnt_tolerance > 0.0:
            learnt = (
                f", learnt Jl nominal or within {self.learnt_tolerance:g} x "
                "nominal of it"
            )
        return (
            f"rest (sampled loop in contact, |Td| >= {self.min_load_torque:.3g} Nm, "
            f"encoder error <= {self.counts_error:g} "
            f"counts, Jl = {inertias} x nominal{learnt}): |theta_l - theta_r| <= "
            f"{self.error_bound:.3g} rad, torque ripple |Tm - mean| <= "
            f"{self.ripple_bound:.3g} Nm, approached with a time constant <= "
            f"{self.time_constant:.3g} s"
        )


def rest_bound(
    params: Parameters,
    gain,
    sampling,
    *,
    Jl_range: tuple[float, float],
    encoder_counts=(2**20, 2**17),
    counts_error: float = 2.0,
    flank_width: float,
    contact_torque: float,
    latch_torque: float = 0.0,
    learnt_tolerance: float = 0.1,
) -> RestBound:
    """Certify the sampled servo's rest (see the module docstring).

    Parameters
    ----------
    params : `Parameters`
        Nominal drive data (the observer's model).
    gain : array_like
        The ``1 x 5`` feedback gain on ``[e_m, omega_m, e_l, omega_l, int
        e_l]``.
    sampling : `ctrl_lpv.twomass.servo_sampled.SampledServo`
        Sample time, delay and observer matrices.
    Jl_range : (float, float)
        Load inertias, multiples of ``params.Jl``: the loop is certified at
        both ends and at the nominal, each with the observer's model on the
        nominal inertia and, with an inertia estimate
        (``sampling.inertia``), on the load's and `learnt_tolerance` either
        side of it within `Jl_range`.
    encoder_counts : (int, int), optional
        Counts per revolution of the motor and load encoders.
    counts_error : float, optional
        Largest reading error, counts (default 2: half a count of rounding
        and three standard deviations of half a count of noise).
    flank_width, contact_torque : float
        The law's flank width and contact torque, Nm (`ServoTuning`): the
        load torque must keep the flank choice and the contact schedule
        saturated.
    latch_torque : float, optional
        The flank latch at rest (`ctrl_lpv.twomass.rest_flank`) engages
        only with the observer's load-torque estimate below this, Nm: the
        load torque must keep the estimate above it (default 0: no latch).
    learnt_tolerance : float, optional
        How far, as a multiple of the nominal, the learnt inertia may be
        from the load's (default 0.1; the inertia tests' moves learn it
        within 0.06 after one move and 0.05 after two,
        ``tests/test_servo_inertia.py``).

    Returns
    -------
    `RestBound`

    Raises
    ------
    CertificationError
        If the loop at some inertia is not certified (not Schur, or the
        impulse response's tail not negligible), naming the inertia.
    """
    K = np.asarray(gain, float).reshape(5)
    steps = 2.0 * math.pi / np.asarray(encoder_counts, float)
    inertias = (float(Jl_range[0]), 1.0, float(Jl_range[1]))
    tolerance = 0.0 if sampling.inertia is None else float(learnt_tolerance)
    lo, hi = (float(j) - 1.0 for j in Jl_range)

    def learnt(scale):
        """The learnt inertias (less one) certified with the load's `scale`:
        the nominal, the load's and `tolerance` either side, within range."""
        near = (min(max(scale - 1.0 + s * tolerance, lo), hi) for s in (-1, 0, 1))
        return sorted({0.0, *near})

    pairs = [(scale, delta) for scale in inertias for delta in learnt(scale)]
    errors, ripples, floors, rates, parts = [], [], [], [], []
    for scale, delta in pairs:
        plant = params.replace(Jl=scale * params.Jl)
        loop = _rest_loop(plant, K, sampling, learnt=delta)
        bounds, checks = _peak_to_peak(loop, counts_error * steps)
        where = f"Jl = {scale:g} x nominal, learnt {1.0 + delta:g} x"
        checks = [replace(check, where=where) for check in checks]
        if not all(check.passed for check in checks):
            raise CertificationError(
                f"rest_bound: the sampled loop at rest with {where} is not "
                f"certified: {next(c.what for c in checks if not c.passed)}"
            )
        # The contraction rate the check `A' P A < rho^2 P` certifies (rho
        # as `_peak_to_peak` chose it, from the same eigenvalues).
        radius = float(np.abs(np.linalg.eigvals(np.asarray(loop.A))).max())
        rates.append(-math.log(0.5 * (1.0 + radius)) / sampling.dt)
        errors.append(bounds[0])
        ripples.append(bounds[1])
        # The load torque that keeps the switches where the loop has them:
        # T* beyond the flank width, the estimate beyond twice the contact
        # torque, the shaft torque of one sign, and the load-torque estimate
        # above the flank latch's threshold (the latch never engages).
        floors.append(max(
            flank_width + bounds[2], 2.0 * contact_torque + bounds[3], bounds[4],
            latch_torque + bounds[5],
        ))  # fmt: skip
        parts.extend(checks)
    return RestBound(
        error_bound=max(errors), ripple_bound=max(ripples), inertias=inertias,
        learnt_tolerance=tolerance,
        counts_error=float(counts_error), min_load_torque=max(floors),
        time_constant=1.0 / min(rates),
        certificate=Certificate(tuple(parts)),
    )  # fmt: skip


def alternating_mode(params: Parameters, gain, sampling) -> float:
    """The largest modulus among the rest loop's eigenvalues with a negative
    real part: a mode that flips the command's sign every sample (the
    linear rest loop of `rest_bound`, nominal inertia).

    Parameters
    ----------
    params : `Parameters`
        Nominal drive data (the observer's model).
    gain : array_like
        The feedback gain ``K`` (1 x 5).
    sampling : `ctrl_lpv.twomass.servo_sampled.SampledServo`
        The sampled law's numbers (observer matrices, delay).

    Returns
    -------
    float
        0 when no eigenvalue has a negative real part; near 1, a mode at
        half the sample rate that barely decays.
    """
    K = np.asarray(gain, float).reshape(-1)
    poles = np.linalg.eigvals(_rest_loop(params, K, sampling).A)
    flipping = poles[poles.real < 0.0]
    return float(np.abs(flipping).max()) if flipping.size else 0.0


def _rest_loop(
    plant: Parameters, K: np.ndarray, sampling, learnt: float = 0.0
) -> ct.StateSpace:
    """The linear rest loop: states ``[drive (4), estimate (6), int e_l,
    command on its way]``, inputs the reading errors, outputs ``e_l``, ``Tm``
    (deviations from the equilibrium); the observer's model on the learnt
    inertia ``(1 + learnt)`` times the nominal (`sampling.inertia`)."""
    dt, delayed = sampling.dt, sampling.delay == 1
    Jm, Jl, cm, cl, ks, cs = (
        plant.Jm, plant.Jl, plant.cm, plant.cl, plant.ks, plant.cs
    )  # fmt: skip
    # The drive in contact, minimal: theta_m, omega_m, theta_l, omega_l, with
    # Ts = ks theta_d + cs omega_d about the equilibrium (the backlash angle
    # constant at its flank).
    A = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-ks / Jm, -(cm + cs) / Jm, ks / Jm, cs / Jm],
        [0.0, 0.0, 0.0, 1.0],
        [ks / Jl, cs / Jl, -ks / Jl, -(cl + cs) / Jl],
    ])  # fmt: skip
    B = np.array([[0.0], [1.0 / Jm], [0.0], [0.0]])
    drive = ct.c2d(ct.ss(A, B, np.eye(4), 0), dt, "zoh")
    Pp, Gp = drive.A, drive.B[:, 0]
    Po, Go, Mo = sampling.Phi[1], sampling.Gamma[1], sampling.M[1]
    if sampling.inertia is not None:
        Po = sampling.inertia.learnt_model(Po, learnt)
    Cp = np.zeros((2, 4))  # encoder angles of the drive
    Cp[0, 0] = Cp[1, 2] = 1.0
    Co = np.zeros((2, 6))  # the same rows of the estimate
    Co[0, 0] = Co[1, 3] = 1.0
    n = 4 + 6 + 2
    ip, io, ixi, iu = slice(0, 4), slice(4, 10), 10, 11

    # The filtered estimate x_f = (I - Mo Co) x_hat + Mo (Cp x + e).
    Xf = np.zeros((6, n))
    Xf[:, ip] = Mo @ Cp
    Xf[:, io] = np.eye(6) - Mo @ Co
    Ef = Mo
    # The estimate where the command acts, and the command.
    if delayed:
        Xa, Ea = Po @ Xf, Po @ Ef
        Xa[:, iu] += Go
    else:
        Xa, Ea = Xf, Ef
    rows = [0, 1, 3, 4]  # theta_m, omega_m, theta_l, omega_l of the estimate
    U = -K[:4] @ Xa[rows]
    U[ixi] -= K[4]
    Eu = -K[:4] @ Ea[rows]
    # Next state.
    An = np.zeros((n, n))
    En = np.zeros((n, 2))
    An[ip, ip] = Pp
    applied, applied_e = (np.eye(n)[iu], np.zeros(2)) if delayed else (U, Eu)
    An[ip] += np.outer(Gp, applied)
    En[ip] += np.outer(Gp, applied_e)
    An[io] = Po @ Xf + np.outer(Go, applied)
    En[io] = Po @ Ef + np.outer(Go, applied_e)
    An[ixi] = np.eye(n)[ixi] + dt * Xa[3]
    En[ixi] = dt * Ea[3]
    An[iu], En[iu] = U, Eu
    # Outputs: the load error, the torque, and what the law's switches read:
    # the asked shaft torque T* (flank choice), the predicted shaft-torque
    # estimate (contact schedule) and the shaft torque itself (contact).
    ratio = ks / K[0]
    tstar = -ratio * (K[2] * Xa[3] + K[3] * Xa[4])
    tstar[ixi] -= ratio * K[4]
    shaft = np.zeros(n)
    shaft[ip] = [ks, cs, -ks, -cs]
    # The load-torque estimate where the command acts (the flank latch reads
    # it): its deviation from the load torque.
    C = np.vstack([np.eye(n)[2], U, tstar, np.eye(n)[4 + 2], shaft, Xa[5]])
    D = np.vstack([
        np.zeros(2), Eu, -ratio * (K[2] * Ea[3] + K[3] * Ea[4]), np.zeros(2),
        np.zeros(2), Ea[5],
    ])  # fmt: skip
    return ct.ss(
        An, En, C, D, dt=dt, inputs=["n_m", "n_l"],
        outputs=["e_l", "Tm", "T_asked", "Ts_hat", "Ts", "Td_hat"], name="servo_rest",
    )  # fmt: skip


def _peak_to_peak(sys: ct.StateSpace, w_max: np.ndarray):
    """Certified peak-to-peak gains of a discrete-time LTI system, per output.

    ``sup_k |y_i[k]| <= sum_m (|D_im| + sum_j |C_i A^j B_m|) w_max_m`` for
    every input with ``|w_m| <= w_max_m``, and the bound is attained in the
    limit. The sum runs until the tail, bounded by ``||C_i L^-T|| ||L' A^N
    B_m|| / (1 - rho)`` with ``P = L L'`` and ``A' P A < rho^2 P`` (checked
    in float64), is below ``1e-10`` of it. Returns the bounds and the checks.
    """
    A, B, C, D = (np.asarray(m, float) for m in (sys.A, sys.B, sys.C, sys.D))
    # Balanced coordinates (a diagonal similarity: the gains do not change):
    # the loop mixes angles of 1e-6 rad with torques of 1e2 Nm.
    A, T = sla.matrix_balance(A, permute=False)
    B, C = B / np.diag(T)[:, None], C * np.diag(T)
    radius = float(np.abs(np.linalg.eigvals(A)).max())
    if not radius < 1.0:
        return np.full(C.shape[0], np.inf), [
            Check("rest loop spectral radius < 1", radius, 1.0, strict=True)
        ]
    rho = 0.5 * (1.0 + radius)
    P = sla.solve_discrete_lyapunov((A / rho).T, np.eye(len(A)), method="bilinear")
    P = 0.5 * (P + P.T)
    decrease = negative_definite(
        A.T @ P @ A - rho**2 * P,
        absolute=np.abs(A.T) @ np.abs(P) @ np.abs(A) + rho**2 * np.abs(P),
        what=f"A' P A < rho^2 P (rho = {rho:.6f})",
    )
    Lc = np.linalg.cholesky(P)
    row = np.linalg.norm(np.linalg.solve(Lc, C.T), axis=0)  # ||C_i L^-T||
    total = np.abs(D).copy()
    X = B.copy()
    for _ in range(1_000_000):
        total += np.abs(C @ X)
        X = A @ X
        tail = np.outer(row, np.linalg.norm(Lc.T @ X, axis=0)) / (1.0 - rho)
        if np.all(tail <= 1e-10 * np.maximum(total, 1e-300)):
            break
    bounds = (total + tail) @ w_max
    # The sum is formed in float64: a relative rounding of a few eps per
    # term, far below the 1e-9 added here.
    bounds = bounds * (1.0 + 1e-9)
    share = float(np.max(tail / np.maximum(total, 1e-300)))
    return bounds, [
        decrease,
        Check("impulse-response tail / sum", share, 1e-9, units="relative"),
    ]
