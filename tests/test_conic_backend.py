"""The direct conic backend against independent facts and against cvxpy."""

import time

import control as ct
import cvxpy as cp
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv.lmi import LMIProblem
from ctrl_lpv.lmi.blocks import assemble, columns, unit_points
from ctrl_lpv.lmi.conic import CHORDAL, LIFTED, ConicData, conic_data
from ctrl_lpv.lmi.cvxpy_backend import solve_cvxpy
from ctrl_lpv.lmi.solvers import solver_chain, with_time_limit


def stable_system(seed, n=4):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(n, n))
    A -= (np.linalg.eigvals(A).real.max() + 0.5) * np.eye(n)
    return (
        A,
        rng.normal(size=(n, 2)),
        rng.normal(size=(3, n)),
        0.1 * rng.normal(size=(3, 2)),
    )


def bounded_real(A, B, C, D):
    """min g: [[A'P + PA, PB, C'], [., -g I, D'], [., ., -g I]] < 0, P > 0."""
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    lmi = LMIProblem(margin=1e-8)
    lmi.variable("P", (n, n), symmetric=True)
    lmi.variable("g", (1, 1))
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add(
        "bounded real",
        lambda v: [
            [A.T @ v.P + v.P @ A],
            [B.T @ v.P, -v.g * np.eye(m)],
            [C, D, -v.g * np.eye(p)],
        ],
    )
    return lmi


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("solver", ["CLARABEL", "SCS"])
def test_hinf_norm_of_a_stable_system(seed, solver):
    A, B, C, D = stable_system(seed)
    lmi = bounded_real(A, B, C, D)
    chain = solver_chain(
        [solver]
        if solver == "CLARABEL"
        else [(solver, {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 50_000})]
    )
    sol = lmi.solve(lambda v: v.g[0, 0], solvers=chain)
    assert sol.certified
    norm = ct.linfnorm(ct.ss(A, B, C, D))[0]
    assert sol.g[0, 0] >= norm * (1 - 1e-9)
    assert sol.g[0, 0] == pytest.approx(norm, rel=1e-4)


@pytest.mark.parametrize("form", [LIFTED, CHORDAL])
def test_clarabels_last_resort_forms_solve_the_same_problem(form):
    # The ladder's last rungs: Clarabel's lifted and chordal forms pose the
    # same LMIs (checked against control's norm) and take Clarabel's time
    # limit.
    A, B, C, D = stable_system(0)
    lmi = bounded_real(A, B, C, D)
    sol = lmi.solve(lambda v: v.g[0, 0], solvers=[(form, {})])
    assert sol.certified and sol.attempts[-1].solver == form
    norm = ct.linfnorm(ct.ss(A, B, C, D))[0]
    assert sol.g[0, 0] == pytest.approx(norm, rel=1e-4)
    assert with_time_limit(form, {}, time.perf_counter() + 5.0)["time_limit"] <= 5.0


def test_cvxpy_poses_the_same_problem():
    # The conic data read off the block functions, handed to cvxpy, and the
    # same LMI written in cvxpy by hand: the same optimum.
    A, B, C, D = stable_system(3)
    lmi = bounded_real(A, B, C, D)
    lmi.compile()
    data, _ = lmi._conic_data("default", True)
    c = lmi._objective_vector(lambda v: v.g[0, 0])
    result = solve_cvxpy("CLARABEL", c, data, lmi.margin, {})
    n, m, p = 4, 2, 3
    P = cp.Variable((n, n), symmetric=True)
    g = cp.Variable()
    M = cp.bmat([
        [A.T @ P + P @ A, P @ B, C.T],
        [B.T @ P, -g * np.eye(m), D.T],
        [C, D, -g * np.eye(p)],
    ])  # fmt: skip
    size = n + m + p
    problem = cp.Problem(
        cp.Minimize(g),
        [P >> lmi.margin * np.eye(n), M << -lmi.margin * np.eye(size)],
    )
    problem.solve(solver="CLARABEL")
    assert result.objective == pytest.approx(problem.value, rel=1e-6)
    values = lmi._values(result.x)
    assert values["g"][0, 0] == pytest.approx(g.value, rel=1e-6)


def _map(evaluate, F0, read, units, check):
    F0_read, (rows, cols, data) = columns(evaluate, F0, read, units, check)
    assert F0_read is F0
    nfree = sum(len(u) for u in units.values())
    M = np.zeros((F0.size, nfree))
    np.add.at(M, (rows, cols), data)
    return M


@pytest.mark.parametrize(
    "blocks",
    [
        lambda v: [[v.X @ v.L + v.L.T @ v.X.T], [v.Y, -np.eye(3)]],
        lambda v: [[np.kron(np.eye(2), v.X) + 3.0 * v.s[0, 0] * np.eye(4)]],
        # Broadcasts wrongly (fixed axes): read one unit point at a time.
        lambda v: [[np.concatenate([v.X, v.X.T], axis=0).T @ np.ones((4, 2))]],
        lambda v: [[np.diag(np.diag(v.X)) + v.s[0, 0] * np.eye(2)]],
    ],
)
def test_batched_columns_are_the_unit_point_columns(blocks):
    rng = np.random.default_rng(0)
    L = rng.normal(size=(2, 2))
    shapes = {"X": ((2, 2), False), "Y": ((3, 2), False), "s": ((1, 1), False)}
    units = {k: unit_points(shape, sym) for k, (shape, sym) in shapes.items()}
    zero = {k: np.zeros(shape) for k, (shape, _) in shapes.items()}

    def evaluate(values):
        from types import SimpleNamespace

        return assemble(blocks(SimpleNamespace(L=L, **{**zero, **values})))

    F0 = evaluate({})
    fast = _map(evaluate, F0, set(shapes), units, True)
    exact = _map(evaluate, F0, set(shapes), units, False)
    np.testing.assert_allclose(fast, exact, atol=1e-14)
    # F0 read as the zero point of the batch (the names read known): the
    # same F0 and map (a block function that does not broadcast: read
    # point by point, F0 directly).
    F0_batch, (rows, cols, data) = columns(evaluate, None, set(shapes), units)
    np.testing.assert_allclose(F0_batch, F0, atol=1e-15)
    with_F0 = np.zeros_like(exact)
    np.add.at(with_F0, (rows, cols), data)
    np.testing.assert_allclose(with_F0, exact, atol=1e-14)
    # and both reproduce the block function at a random point
    x = rng.normal(size=fast.shape[1])
    values, offset = {}, 0
    for name, points in units.items():
        values[name] = np.tensordot(x[offset : offset + len(points)], points, 1)
        offset += len(points)
    np.testing.assert_allclose(
        F0.ravel() + exact @ x, evaluate(values).ravel(), atol=1e-12
    )


@pytest.mark.parametrize("upper", [True, False])
def test_dual_layout_round_trip(upper):
    rng = np.random.default_rng(5)
    Y = [rng.normal(size=(d, d)) for d in (1, 3, 4)]
    Y = [y + y.T for y in Y]
    pieces = [(-y, (np.zeros(0, int), np.zeros(0, int), np.zeros(0))) for y in Y]
    data = conic_data(pieces, [False] * 3, 1, upper)
    assert isinstance(data, ConicData)
    # b0 = svec(Y): inner products are preserved
    assert data.b0 @ data.b0 == pytest.approx(sum(np.sum(y * y) for y in Y))
    for a, b in zip(data.matrices(data.b0), Y):
        np.testing.assert_allclose(a, b, atol=1e-14)


def test_unknown_solver_option_is_named():
    with pytest.raises(ValueError, match="'bogus'"):
        solver_chain([("CLARABEL", {"bogus": 1})])
    with pytest.raises(ValueError, match="'bogus'"):
        solver_chain([("SCS", {"bogus": 1})])


# ----------------------------------------------------------------------
# Found by benchmarks/compare_backends.py and the review (issue 20)
# ----------------------------------------------------------------------
def test_ultimate_bound_of_a_zero_output_row_is_zero():
    # Objectives are now evaluated on float64 arrays only: the objective
    # ``cp.trace(v.W)`` of reachability.ultimate_bound (every output row
    # zero) raised TypeError; the old cvxpy layer returned the bound 0.
    A1 = np.array([[-1.0, 2.0], [-2.0, -1.0]])
    A2 = np.array([[-2.0, 1.0], [-1.0, -1.5]])
    E = np.array([[1.0], [0.5]])
    loop = lpv.pss([ct.ss(A1, E, np.eye(2), 0), ct.ss(A2, E, np.eye(2), 0)])
    result = lpv.ultimate_bound(loop, output=np.zeros((1, 2)))
    assert result.certificate.verified
    np.testing.assert_array_equal(result.bounds, [0.0])


def _dense(pieces, nfree):
    out = []
    for F0, (rows, cols, data) in pieces:
        M = np.zeros((F0.size, nfree))
        np.add.at(M, (rows, cols), data)
        out.append(M)
    return out


def _trace_lmi(n, scale, rng):
    """A Lyapunov map with ``scale * P.trace() I``: ``ndarray.trace`` is a
    method, which `Batch` does not see (summed over the stack axis)."""
    A = rng.normal(size=(n, n))
    shapes = {"P": ((n, n), True)}
    units = {"P": unit_points((n, n), True)}

    def evaluate(values):
        from types import SimpleNamespace

        P = values.get("P", np.zeros((n, n)))
        v = SimpleNamespace(P=P)
        return assemble([[scale * (A.T @ v.P + v.P @ A + v.P.trace() * np.eye(n))]])

    return evaluate, shapes, units


@pytest.mark.parametrize("scale", [1.0, 1e-12])
def test_batched_map_check_does_not_depend_on_the_data_scale(scale):
    # The random-point check accepts a batched map when the miss is below
    # 1e-10 * (sum |F0| + sum |M x| + 1): the absolute "+ 1" lets any map
    # of a block function with small entries through (here the map of a
    # wrongly broadcast trace, rejected at scale 1, accepted at 1e-12).
    evaluate, shapes, units = _trace_lmi(4, scale, np.random.default_rng(7))
    F0 = evaluate({})
    fast = _map(evaluate, F0, set(shapes), units, True)
    exact = _map(evaluate, F0, set(shapes), units, False)
    np.testing.assert_allclose(fast, exact, rtol=1e-9, atol=0)


def test_block_function_trusted_by_its_code_is_checked_with_other_data():
    # `LMIProblem._pieces` skips the random-point check for a block function
    # whose code and shapes passed it once; the same code (a lambda made in
    # a loop or a factory) with other closure data may take another branch,
    # here one that does not broadcast: its wrong map goes to the solver.
    rng = np.random.default_rng(11)
    n = 3
    A = rng.normal(size=(n, n)) - 3 * np.eye(n)
    lmi = LMIProblem()
    lmi.variable("P", (n, n), symmetric=True)

    def lyapunov(weight):
        def blocks(v):
            extra = weight * v.P.trace() * np.eye(n) if weight else 0.0
            return [[A.T @ v.P + v.P @ A + extra]]

        return blocks

    lmi.add("plain", lyapunov(0.0))
    lmi.add("with trace", lyapunov(0.5))
    active = lmi._active("default")
    fast = _dense(lmi._pieces(active), lmi._nfree())
    exact = _dense(lmi._pieces(active, exact=True), lmi._nfree())
    for a, b in zip(fast, exact):
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-14)


# Clarabel's full-accuracy tolerances set out of reach: it stalls and ends
# "AlmostSolved" at its reduced ones (tight by default, loose and cut short
# in the second case).
_STALLED = {"tol_gap_abs": 1e-15, "tol_gap_rel": 1e-15, "tol_feas": 1e-15}
_CUT_SHORT = {
    **_STALLED,
    "reduced_tol_gap_abs": 1e-2,
    "reduced_tol_gap_rel": 1e-2,
    "reduced_tol_feas": 1e-2,
    "max_step_fraction": 0.5,
    "max_iter": 15,
}


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_an_almost_solved_point_counts_as_converged_only_near_the_optimum(seed):
    A, B, C, D = stable_system(seed)
    norm = ct.linfnorm(ct.ss(A, B, C, D))[0]
    for options, converged in ((_STALLED, True), (_CUT_SHORT, False)):
        lmi = bounded_real(A, B, C, D)
        sol = lmi.solve(
            lambda v: v.g[0, 0], solvers=solver_chain([("CLARABEL", options)])
        )
        attempt = sol.attempts[-1]
        assert attempt.status == "optimal_inaccurate"
        assert attempt.converged is converged
        if converged:
            assert sol.g[0, 0] == pytest.approx(norm, rel=1e-6)


def test_a_kept_clarabel_solver_serves_identical_re_solves_only():
    # An identical re-solve (the same c, b and options; another time limit)
    # runs on the solver kept with the data and gives the first solve's
    # point bit for bit; another margin (b) or objective (c) sets up anew,
    # as a fresh solver for those numbers would.
    from ctrl_lpv.lmi import conic

    options = {"chordal_decomposition_enable": False}
    for seed in (4, 5, 6):
        A, B, C, D = stable_system(seed)
        lmi = bounded_real(A, B, C, D)
        data, _ = lmi._conic_data("default", True)
        g_only = lmi._objective_vector(lambda v: v.g[0, 0])
        first = conic.solve_direct("CLARABEL", g_only, data, 1e-8, options)
        solver = data.solvers["CLARABEL"].solver
        again = conic.solve_direct(
            "CLARABEL", g_only, data, 1e-8, {**options, "time_limit": 50.0}
        )
        assert data.solvers["CLARABEL"].solver is solver
        assert first.status == again.status == "optimal"
        np.testing.assert_array_equal(first.x, again.x)
        # The kept solver's optimum of min g is the H-infinity norm.
        norm = ct.linfnorm(ct.ss(A, B, C, D))[0]
        assert lmi._values(again.x)["g"][0, 0] == pytest.approx(norm, rel=1e-5)
        # Other numbers: a new solver, the point of a fresh one.
        traced = lmi._objective_vector(lambda v: v.g[0, 0] + 1e-2 * np.trace(v.P))
        for c, margin in ((g_only, 1e-6), (traced, 1e-8)):
            kept = conic.solve_direct("CLARABEL", c, data, margin, options)
            assert data.solvers["CLARABEL"].solver is not solver
            copy = ConicData(data.A, data.b0, data.b_margin, data.sizes, True)
            fresh = conic.solve_direct("CLARABEL", c, copy, margin, options)
            np.testing.assert_array_equal(kept.x, fresh.x)


def _clear_kept(monkeypatch, conic):
    monkeypatch.setattr(conic, "KEPT_BYTES", 0)
    monkeypatch.setattr(conic, "KEPT_COSTLY", 0)
    conic._make_room()


@pytest.mark.parametrize("costly", [False, True])
def test_kept_clarabel_solvers_are_bounded(monkeypatch, costly):
    # Solvers are freed, least recently used first, after a solve and
    # before a setup: down to KEPT_BYTES of quickly set up ones, or
    # KEPT_COSTLY costly ones (here every setup counts as costly when
    # `costly`).
    from ctrl_lpv.lmi import conic

    A, B, C, D = stable_system(5)
    lmi = bounded_real(A, B, C, D)
    data, _ = lmi._conic_data("default", True)
    c = lmi._objective_vector(lambda v: v.g[0, 0])
    _clear_kept(monkeypatch, conic)
    if costly:
        monkeypatch.setattr(conic, "COSTLY_SETUP", 0.0)
        monkeypatch.setattr(conic, "KEPT_COSTLY", 3)
    else:
        monkeypatch.setattr(conic, "COSTLY_SETUP", np.inf)
        monkeypatch.setattr(conic, "KEPT_BYTES", 3 * conic._size(data))
    copies = [
        ConicData(data.A, data.b0, data.b_margin, data.sizes, True) for _ in range(6)
    ]
    for copy in copies[:4]:
        conic.solve_direct("CLARABEL", c, copy, 1e-8, {})
    # A re-solve, on the kept solver, makes copies[1] the most recently used.
    solver = copies[1].solvers["CLARABEL"].solver
    conic.solve_direct("CLARABEL", c, copies[1], 1e-8, {})
    assert copies[1].solvers["CLARABEL"].solver is solver
    for copy in copies[4:]:
        conic.solve_direct("CLARABEL", c, copy, 1e-8, {})
    holding = [k for k, copy in enumerate(copies) if "CLARABEL" in copy.solvers]
    assert holding == [1, 4, 5]
    # Data no longer alive leave no record behind.
    del copies, copy
    with conic._lock:
        conic._sweep()
    assert len(conic._kept) == 0


def test_a_cheap_solver_over_the_budget_is_freed_after_its_solve(monkeypatch):
    # Not left beside the next stage's reading and setup.
    from ctrl_lpv.lmi import conic

    A, B, C, D = stable_system(6)
    lmi = bounded_real(A, B, C, D)
    data, _ = lmi._conic_data("default", True)
    c = lmi._objective_vector(lambda v: v.g[0, 0])
    _clear_kept(monkeypatch, conic)
    monkeypatch.setattr(conic, "COSTLY_SETUP", np.inf)
    result = conic.solve_direct("CLARABEL", c, data, 1e-8, {})
    assert result.status == "optimal"
    assert "CLARABEL" not in data.solvers
    assert len(conic._kept) == 0


def test_reread_maps_with_new_numbers_are_the_exact_maps():
    # A re-read after new parameter values and new numbers in constants
    # (`invalidate` with same_code) skips the random-point check of the
    # inequalities that passed it: its maps are still the unit-point maps,
    # and a block function that does not broadcast is still read point by
    # point.
    A0, B, C, D = stable_system(4)
    lmi = LMIProblem(margin=1e-8)
    lmi.variable("P", (4, 4), symmetric=True)
    lmi.variable("g", (1, 1))
    lmi.parameter("A", (4, 4), A0)
    gains = {"c": 1.0}  # a constant the functions read (not a parameter)
    lmi.add("P > 0", lambda v: [[-v.P]])
    lmi.add("bounded real", lambda v: [
        [v.A.T @ v.P + v.P @ v.A],
        [B.T @ v.P, -gains["c"] * v.g * np.eye(2)],
        [C, D, -gains["c"] * v.g * np.eye(3)],
    ])  # fmt: skip

    def odd(v):  # an entry set into a fixed array: read point by point
        Q = np.zeros((4, 4))
        Q[0, 0] = v.P[0, 0]
        return [[Q - 1e6 * np.eye(4)]]

    lmi.add("odd", odd, strict=False)
    lmi.compile()
    assert lmi._trusted == {"P > 0", "bounded real"}
    A1, *_ = stable_system(5)
    lmi.set_parameter("A", A1)
    gains["c"] = 2.0
    lmi.invalidate("default", same_code=True)
    assert lmi._trusted == {"P > 0", "bounded real"}
    active = lmi._active("default")
    nfree = lmi._nfree()
    fast, exact = lmi._pieces(active), lmi._pieces(active, exact=True)
    for (F0, _), (F0_exact, _) in zip(fast, exact):
        np.testing.assert_allclose(F0, F0_exact, atol=1e-14)
    for M, M_exact in zip(_dense(fast, nfree), _dense(exact, nfree)):
        np.testing.assert_allclose(M, M_exact, atol=1e-14)
    # and the solve with the new numbers: the new system's norm is c g
    sol = lmi.solve(lambda v: v.g[0, 0])
    assert sol.certified
    norm = ct.linfnorm(ct.ss(A1, B, C, D))[0]
    assert 2.0 * sol.g[0, 0] == pytest.approx(norm, rel=1e-4)


def test_invalidate_finds_a_new_code_path_again():
    # A constant that changes a block function's branch (here to one whose
    # batched reading is silently wrong: ``.sum()`` of a stack sums it all):
    # after a plain
    # `invalidate` the batched map is checked again and read point by point.
    rng = np.random.default_rng(11)
    A = rng.normal(size=(3, 3)) - 3 * np.eye(3)
    weight = {"w": 0.0}
    lmi = LMIProblem()
    lmi.variable("P", (3, 3), symmetric=True)

    def blocks(v):
        extra = weight["w"] * v.P.sum() * np.eye(3) if weight["w"] else 0.0
        return [[A.T @ v.P + v.P @ A + extra]]

    lmi.add("lyapunov", blocks)
    lmi.compile()
    assert lmi._trusted == {"lyapunov"}
    weight["w"] = 0.5
    lmi.invalidate("default")
    active = lmi._active("default")
    fast = _dense(lmi._pieces(active), lmi._nfree())
    exact = _dense(lmi._pieces(active, exact=True), lmi._nfree())
    np.testing.assert_allclose(fast[0], exact[0], rtol=1e-12, atol=1e-14)


def test_random_point_check_sets_every_variable(caplog):
    # The batched map's check evaluates the function with every variable at
    # a random value: a function that reads a variable it was not declared
    # to read fails it (and is read point by point), one that reads only
    # what it declared passes.
    import logging

    shapes = {"X": (2, 2), "Y": (2, 2)}
    units = {k: unit_points(shape, True) for k, shape in shapes.items()}
    zero = {k: np.zeros(shape) for k, shape in shapes.items()}

    def evaluate(values):
        from types import SimpleNamespace

        v = SimpleNamespace(**{**zero, **values})
        return assemble([[v.X + v.Y - np.eye(2)]])

    with caplog.at_level(logging.DEBUG, logger="ctrl_lpv.lmi"):
        columns(evaluate, None, {"X", "Y"}, units)
        assert "rejected" not in caplog.text
        columns(evaluate, None, {"X"}, units)
        assert "rejected at a random point" in caplog.text
