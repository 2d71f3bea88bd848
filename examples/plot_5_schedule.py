"""
Is my gain schedule stable?
===========================

A gain schedule stable at every frozen parameter value can still be
destabilised by a parameter that moves. `ctrl_lpv.certify` takes the
schedule you already have, a python-control controller built by
`control.create_statefbk_iosystem` or a table of gains at points, and
answers: stable for arbitrarily fast parameters, or up to a certified
rate, with a trajectory that destabilises it above that rate.
"""

import control as ct
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

import ctrl_lpv as lpv

# %%
# A python-control schedule
# -------------------------
# A spring-damper whose stiffness ``a`` varies in [1, 3], with LQR gains at
# three values of ``a``, interpolated linearly by python-control. The
# controller object itself is certified: stable for arbitrary rates.


def spring(a):
    return ct.ss([[0.0, 1.0], [-a, -0.5]], [[0.0], [1.0]], np.eye(2), 0,
                 inputs="u", states=["x0", "x1"], outputs=["x0", "x1"])  # fmt: skip


points = [1.0, 2.0, 3.0]
gains = [ct.lqr(spring(a), np.eye(2), 1.0)[0] for a in points]
ctrl, _ = ct.create_statefbk_iosystem(spring(2.0), (gains, points),
                                      gainsched_indices=["xd[0]"])  # fmt: skip
plant = lpv.PolytopicStateSpace.from_affine(
    spring(0.0), {"a": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)}, {"a": (1.0, 3.0)}
)
print(lpv.certify(ctrl, plant))

# %%
# Frozen-stable, destabilised by fast variation
# ---------------------------------------------
# The closed loop ``(1 - p) A1 + p A2`` is stable for every frozen ``p``
# but has no common Lyapunov function: `certify` refuses arbitrary rates,
# certifies a rate bound, and finds a periodic parameter trajectory above
# it along which the state grows.
A1 = np.array([[-0.1, 1.0], [-2.0, -0.1]])
A2 = np.array([[-0.1, 2.0], [-1.0, -0.1]])
switched = lpv.PolytopicStateSpace.from_affine(
    ct.ss(np.zeros((2, 2)), np.eye(2), np.eye(2), 0, inputs=["u0", "u1"]),
    {"p": (np.zeros((2, 2)), 0, 0, 0)},
    {"p": (0.0, 1.0)},
)
verdict = lpv.certify(([-A1, -A2], [0.0, 1.0]), switched)
print(verdict)
nu, bad = verdict.rate_bound["p"], verdict.counterexample


def response(p_of_t, T):
    sol = solve_ivp(lambda t, x: ((1 - p_of_t(t)) * A1 + p_of_t(t) * A2) @ x,
                    (0.0, T), [1.0, 0.0], max_step=0.01, dense_output=True)  # fmt: skip
    t = np.linspace(0.0, T, 1500)
    return t, np.linalg.norm(sol.sol(t), axis=0)


T = 12 * bad.period
slow = 0.9 * nu  # a sine within the certified rate


def within(t):
    return 0.5 + 0.5 * np.sin(2 * slow * t)


fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
t, norm_bad = response(lambda t: bad([t])[0, 0], T)
top.plot(t, bad(t)[0], label=f"counterexample, rate {bad.rate:.3g}")
top.plot(t, within(t), label=f"within the bound, rate {slow:.3g}")
top.set_ylabel("p")
top.legend(loc="upper right")
bottom.semilogy(t, norm_bad, label="counterexample: grows")
bottom.semilogy(*response(within, T), label="rate-bounded: decays")
bottom.set_xlabel("t")
bottom.set_ylabel("|x|")
bottom.legend(loc="lower left")
fig.suptitle(f"certified |dp/dt| <= {nu:.3g}; destabilised at {bad.rate:.3g}")
fig.tight_layout()
