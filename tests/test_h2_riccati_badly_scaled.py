"""H2 observers and state feedback on badly scaled plants against Riccati.

Reference: the H2-optimal observer of a single-vertex plant is the Kalman
predictor (discrete time, ``L = (A X C' + B D')(C X C' + D D')^-1``) or
filter (continuous time, ``L = (X C' + B D')(D D')^-1``) with ``X`` the
stabilizing solution of scipy's ``solve_discrete_are`` /
``solve_continuous_are`` with the cross term ``s = B D'``; the H2 norm of
an error system is recomputed with scipy's Lyapunov solvers.

The plants are the two-mass drive's motor-encoder models
(`ctrl_lpv.twomass.motor_estimator.mode_model`): encoder noise of 1.7e-6
rad beside torques of order one, a random-walk load torque, an integrator
and the load angle's error weighted by 1e3. The optimum's Lyapunov matrix
has a condition number of 1e7 to 3e8; before the shaped coordinates of
`ctrl_lpv.synthesis.scaling.shaped_frame` the raw optimum's certified
bound was 1.4 times (gap mode) and 2.6 times (contact mode) the Riccati
value, and its gain 1 % to 40 % above it in H2 norm.
"""

import control as ct
import numpy as np
import pytest
import scipy.linalg as sl

import ctrl_lpv as lpv
import ctrl_lpv.twomass.motor_estimator as me
from ctrl_lpv import twomass

# scipy's direct discrete Lyapunov solve warns of I - kron(A, A) (poles
# within 1e-3 of the unit circle) but is exact here: it matched the summed
# series sum_k A^k B B' A'^k to 1e-13 on these plants.
pytestmark = pytest.mark.filterwarnings("ignore::scipy.linalg.LinAlgWarning")

# The certified bound, and the returned gain's own norm, against the
# Riccati optimum (measured after the fix: within 7e-5 and 1e-8 in discrete
# time, 9e-6 and 1e-8 in continuous time).
RTOL = 1e-3

CASES = [
    (counts, mode, rate)
    for counts in (2**20, 2**10)
    for mode, rate in (("gap", 300.0), ("contact", 300.0), ("contact", 3000.0))
]


def _model(counts, mode, rate, dt):
    # The encoder's quantization alone on the reading (no model error).
    return me.mode_model(
        twomass.Parameters(), mode, dt=dt, motor_counts=counts, reading_noise=0.0,
        load_torque_rate=rate, motor_torque_rate=20.0,
    )  # fmt: skip


def _parts(sys):
    """``(A, B_w, C_y, D_yw, C_z)``: input 0 is the known ``Tm``, output 0
    the measured ``theta_m``."""
    return sys.A, sys.B[:, 1:], sys.C[:1], sys.D[:1, 1:], sys.C[1:]


def _kalman(sys, discrete):
    A, B, C, D, _ = _parts(sys)
    if discrete:
        X = sl.solve_discrete_are(A.T, C.T, B @ B.T, D @ D.T, s=B @ D.T)
        return (A @ X @ C.T + B @ D.T) @ np.linalg.inv(C @ X @ C.T + D @ D.T)
    X = sl.solve_continuous_are(A.T, C.T, B @ B.T, D @ D.T, s=B @ D.T)
    return (X @ C.T + B @ D.T) @ np.linalg.inv(D @ D.T)


def _error_h2(sys, L, discrete):
    A, B, C, D, Cz = _parts(sys)
    Ae, Be = A - L @ C, B - L @ D
    if discrete:
        W = sl.solve_discrete_lyapunov(Ae, Be @ Be.T)
    else:
        assert np.all(np.linalg.eigvals(Ae).real < 0)
        W = sl.solve_continuous_lyapunov(Ae, -Be @ Be.T)
    return float(np.sqrt(np.trace(Cz @ W @ Cz.T)))


def _observer(sys):
    w = [s for s in sys.input_labels if s != "Tm"]
    return lpv.observer(
        lpv.PolytopicStateSpace([sys]), ["theta_m"], u="Tm", w=w,
        z=sys.output_labels[1:], objective=lpv.H2(), backoff=None,
    )  # fmt: skip


def _check_observer(sys, discrete):
    optimum = _error_h2(sys, _kalman(sys, discrete), discrete)
    design = _observer(sys)
    assert design.certificate.verified
    L = np.asarray(design.gain([]), float)
    own = _error_h2(sys, L, discrete)
    # The certified bound holds, and is the optimum within RTOL.
    assert own <= design.gamma * (1 + 1e-9)
    assert optimum * (1 - 1e-6) <= design.gamma <= optimum * (1 + RTOL)
    assert own <= optimum * (1 + RTOL)
    assert optimum * (1 - 1e-6) <= design.gamma_opt <= design.gamma


@pytest.mark.parametrize("counts, mode, rate", CASES)
def test_discrete_h2_observer_is_the_kalman_predictor(counts, mode, rate):
    _check_observer(_model(counts, mode, rate, 1e-3), discrete=True)


@pytest.mark.parametrize(
    "counts, mode, rate", [CASES[0], CASES[2], (2**10, "contact", 300.0)]
)
def test_continuous_h2_observer_is_the_kalman_filter(counts, mode, rate):
    _check_observer(_model(counts, mode, rate, None), discrete=False)


def _dual_plant(discrete):
    """State feedback whose optimum is the contact-mode Kalman predictor's:
    ``x+ = A' x + C_z' w + C_y' u``, ``z = B_w' x + D_yw' u``."""
    sys = _model(2**20, "contact", 3000.0, 1e-3 if discrete else None)
    A, B, C, D, Cz = _parts(sys)
    nw = Cz.shape[0]
    plant = ct.ss(
        A.T, np.hstack([Cz.T, C.T]), B.T, np.hstack([np.zeros((B.shape[1], nw)), D.T]),
        inputs=[*(f"w{i}" for i in range(nw)), "u"], dt=sys.dt,
    )  # fmt: skip
    return plant, (A.T, Cz.T, C.T, B.T, D.T), [f"w{i}" for i in range(nw)]


@pytest.mark.parametrize("discrete", [True, False])
def test_h2_state_feedback_badly_scaled_matches_riccati(discrete):
    plant, (A, B1, B2, C1, D12), w = _dual_plant(discrete)
    Q, R, S = C1.T @ C1, D12.T @ D12, C1.T @ D12
    if discrete:
        X = sl.solve_discrete_are(A, B2, Q, R, s=S)
    else:
        X = sl.solve_continuous_are(A, B2, Q, R, s=S)
    optimum = float(np.sqrt(np.trace(B1.T @ X @ B1)))
    design = lpv.h2_state_feedback(
        lpv.PolytopicStateSpace([plant]), w=w, u="u", backoff=None
    )
    assert design.certificate.verified
    K = design.gains[0]
    Acl, Ccl = A - B2 @ K, C1 - D12 @ K
    if discrete:
        G = sl.solve_discrete_lyapunov(Acl, B1 @ B1.T)
    else:
        G = sl.solve_continuous_lyapunov(Acl, -B1 @ B1.T)
    own = float(np.sqrt(np.trace(Ccl @ G @ Ccl.T)))
    assert own <= design.gamma * (1 + 1e-9)
    assert optimum * (1 - 1e-6) <= design.gamma <= optimum * (1 + RTOL)
