"""The one certificate type and its rounding-aware negative-definiteness test.

The test is checked against matrices whose eigenvalues are known exactly
(``-(d I + J)``, ``J`` the all-ones matrix: eigenvalues ``-d`` and ``-d -
k``), random orthogonal similarities of known spectra, and scalings that
must not change the verdict. The certificates of a design, a gain file, an
analysis, a saturated region, an ultimate bound and the servo are the one
type, and their verdicts are recomputed here with numpy.
"""

import json

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.certificate import (
    ROUNDING,
    Certificate,
    Check,
    negative_definite,
    negative_definite_each,
    negative_definite_stack,
    rounding_bound,
)
from ctrl_lpv.persistence import write_json

EPS = np.finfo(float).eps


def ones_matrix(k, d):
    """``-(d I + J)`` and its exact largest normalised eigenvalue.

    The diagonal ``-(1 + d)`` is rounded; with ``d' = fl(1 + d) - 1``
    (exact) the float matrix is exactly ``-(d' I + J)``, whose Jacobi
    normalisation divides by ``1 + d'``.
    """
    F = -(np.ones((k, k)) + d * np.eye(k))
    exact = (1.0 + d) - 1.0
    return F, -exact / (1.0 + exact)


# ----------------------------------------------------------------------
# negative_definite against known eigenvalues
# ----------------------------------------------------------------------
@pytest.mark.parametrize("k", [2, 5, 12])
def test_known_eigenvalue_just_below_and_above_the_rounding_bound(k):
    level = rounding_bound(k, k)  # ||D F D||_2 is about k here
    for factor, proved in [(8.0, True), (0.25, False), (-0.25, False), (-8.0, False)]:
        F, exact = ones_matrix(k, factor * level)
        check = negative_definite(F, what="ones")
        # The computed value is within its rounding of the exact one.
        assert abs(check.value - exact) <= check.rounding
        assert check.rounding == pytest.approx(level, rel=0.2)
        assert check.passed is proved
        assert check.strict and check.units == "normalised" and check.bound == 0.0
        # A cross-check fails only when float64 refutes F < 0.
        crossed = negative_definite(F, cross_check=True)
        assert crossed.passed is (factor > -1.0)


@pytest.mark.parametrize("seed", range(6))
def test_random_orthogonal_similarity(seed):
    rng = np.random.default_rng(seed)
    k = int(rng.integers(2, 30))
    Q, _ = np.linalg.qr(rng.standard_normal((k, k)))
    lam = -rng.uniform(0.1, 10.0, k)
    scale = 10.0 ** rng.uniform(-8, 8)
    F = scale * (Q * lam) @ Q.T
    margin = 0.05 * scale
    check = negative_definite(F, margin=margin)
    # With a margin the value is lambda_max(F), within its rounding.
    assert abs(check.value - scale * lam.max()) <= check.rounding
    assert check.rounding == pytest.approx(
        ROUNDING * k * EPS * scale * np.abs(lam).max(), rel=1e-6
    )
    assert check.bound == -margin and check.units == ""
    assert check.passed is bool(scale * lam.max() < -margin)
    # Without a margin: unit-free, and the verdict of the exact spectrum.
    assert negative_definite(F).passed
    assert not negative_definite(F + 2 * scale * lam.min() * -np.eye(k)).passed


@pytest.mark.parametrize("power", [-500, -60, 0, 60, 500])
def test_verdict_and_value_are_scale_invariant(power):
    F, _ = ones_matrix(6, 1e-9)
    # Powers of two scale exactly: the normalised value does not change.
    base = negative_definite(F)
    scaled = negative_definite(2.0**power * F)
    assert scaled.value == base.value and scaled.passed == base.passed
    # Nor do the units of the states (a diagonal congruence, 1e-150 to 1e150).
    T = np.diag(10.0 ** np.linspace(-150, 150, 6))
    congruent = negative_definite(T @ F @ T)
    assert congruent.passed and congruent.value == pytest.approx(base.value, rel=1e-6)


def test_nonnegative_diagonal_and_non_finite_entries_fail():
    check = negative_definite(np.diag([-1.0, 0.0]))
    assert not check.passed and check.value >= 0.0
    assert not negative_definite(np.diag([-1.0, np.nan])).passed
    assert not negative_definite([[-1.0, np.inf], [np.inf, -1.0]]).passed


def test_absolute_sizes_enlarge_the_rounding():
    # A' + A with a large skew part: the sum cancels to -2 I, but forming
    # it rounds by eps * (|A'| + |A|), about eps * 1e17, which may be 1.
    A = np.array([[-1.0, 1e17], [-1e17, -1.0]])
    F = A.T + A
    plain = negative_definite(F)
    aware = negative_definite(F, absolute=np.abs(A.T) + np.abs(A))
    assert plain.value == aware.value == pytest.approx(-1.0)
    assert aware.rounding == pytest.approx(rounding_bound(2, 1e17), rel=1e-12)
    assert plain.passed and not aware.passed  # undecided


def test_bad_input_names_the_argument():
    with pytest.raises(ValueError, match="F"):
        negative_definite(np.ones(3))
    with pytest.raises(ValueError, match="F"):
        negative_definite_stack(np.ones((0, 2, 2)))
    with pytest.raises(ValueError, match="margin"):
        negative_definite(-np.eye(2), margin=-1.0)
    with pytest.raises(ValueError, match="absolute"):
        negative_definite(-np.eye(2), absolute=np.eye(3))
    with pytest.raises(ValueError, match="where"):
        negative_definite_stack(-np.ones((2, 1, 1)), where=["a"])


def test_stack_reports_its_worst_matrix():
    good, _ = ones_matrix(4, 1e-3)
    bad, _ = ones_matrix(4, -1e-3)
    stack = np.stack([good, bad, good])
    check = negative_definite_stack(stack, where=["a", "b", "c"], what="stack")
    single = negative_definite(bad, what="stack", where="b")
    assert check == single and not check.passed
    assert negative_definite_stack(stack[[0, 2]]).where == "[0]"


def test_each_matrix_of_a_stack_gets_its_own_verdict():
    """The stacked check (one eigvalsh) gives every matrix the verdict,
    value and rounding of the matrix checked alone, on random matrices and
    on nearly singular ones whose sign is at the rounding level."""
    rng = np.random.default_rng(7)
    k = 5
    matrices, exact = [], []
    for d in (1e-3, -1e-3, 1e-15, -1e-15, 3 * EPS, 0.0, 1e-9):
        F, top = ones_matrix(k, d)
        matrices.append(F)
        exact.append(top)
    for scale in (1e-8, 1.0, 1e8):
        Q, _ = np.linalg.qr(rng.standard_normal((k, k)))
        spectrum = -scale * np.abs(rng.standard_normal(k))
        spectrum[-1] = rng.choice([-1, 1]) * scale * 1e-14
        matrices.append(Q @ np.diag(spectrum) @ Q.T)
        exact.append(None)  # the sign is below the rounding: undecided
        A = rng.standard_normal((k, k))
        matrices.append(-scale * (A @ A.T + 0.1 * np.eye(k)))
        exact.append(None)
    stack = np.stack(matrices)
    for margin in (0.0, 1e-6):
        checks = negative_definite_each(stack, margin=margin, what="F")
        assert len(checks) == len(matrices)
        for i, (F, check) in enumerate(zip(matrices, checks)):
            alone = negative_definite(F, margin=margin, what="F", where=f"[{i}]")
            assert check == alone
            # Recomputed here: the largest eigenvalue of the matrix alone
            # (Jacobi-normalised without a margin) and its rounding.
            d = np.ones(k)
            if margin == 0 and np.all(np.diag(F) < 0):
                d = 1 / np.sqrt(-np.diag(F))
            eig = np.linalg.eigvalsh(F * np.outer(d, d))
            # Two float64 eigen-solves of one matrix (LAPACK's batched and
            # single drivers differ in the last bits, 4e-16 at numpy 2.4):
            # each within the rounding bound of the exact value.
            assert abs(check.value - eig[-1]) <= check.rounding
            assert check.rounding == pytest.approx(
                rounding_bound(k, np.abs(eig).max()), rel=1e-9
            )
            if margin == 0 and exact[i] is not None and check.passed:
                assert exact[i] < 0  # never passes a matrix that is not < 0
    # The stack's single check is its worst matrix's.
    worst = negative_definite_stack(stack, what="F")
    assert worst in negative_definite_each(stack, what="F")
    assert not worst.passed


def test_each_names_its_matrices():
    stack = -np.stack([np.eye(2), 2 * np.eye(2)])
    checks = negative_definite_each(stack, what=["a", "b"], where=["x", "y"])
    assert [(c.what, c.where) for c in checks] == [("a", "x"), ("b", "y")]
    with pytest.raises(ValueError, match="what"):
        negative_definite_each(stack, what=["a"])


# ----------------------------------------------------------------------
# The type: table, composition, files
# ----------------------------------------------------------------------
def sample():
    F, _ = ones_matrix(3, 1e-3)
    return Certificate(
        (
            negative_definite(F, what="decay", where="vertex 0", group="ellipsoid"),
            Check("rho", 0.5, 1.0, group="ellipsoid"),
            Check("T > 0", -2.0, 0.0, strict=True, units="Nm", group="ellipsoid"),
        ),
        "an invariant ellipsoid",
    )


def test_check_pass_rules():
    assert Check("x", 1.0, 1.0).passed and not Check("x", 1.0, 1.0, strict=True).passed
    assert not Check("x", 0.9, 1.0, rounding=0.2).passed
    assert Check("x", 1.1, 1.0, rounding=0.2, cross_check=True).passed
    assert not Check("x", np.nan, 1.0).passed
    assert Check("x", 0.25, 1.0).slack == 0.75
    with pytest.raises(ValueError, match="rounding"):
        Check("x", 0.0, 1.0, rounding=-1.0)


def test_table_printing():
    cert = sample() + Certificate((Check("inclusion", 2.0, 1.0, where="input 0"),))
    lines = str(cert).splitlines()
    assert lines[0] == "an invariant ellipsoid"
    assert lines[1].startswith("NOT verified: 1 of 4 checks fail, worst inclusion")
    header, rule, *rows = lines[2:]
    assert header.split() == ["group", "check", "where", "value", "bound", "rounding",
                              "units"]  # fmt: skip
    assert set(rule) <= {"-", " "} and len(rows) == 4
    assert rows[0].split()[-1] == "ok" and rows[-1].split()[-1] == "FAIL"
    # Fixed width: every value ends in the same column.
    ends = {row.index(cell) + len(cell) for row, cell in
            zip(rows, [f"{c.value:.4g}" for c in cert])}  # fmt: skip
    assert len(ends) == 1
    assert "<table>" in cert._repr_html_() and "&lt;" in cert._repr_html_()


def test_composition():
    a = sample()
    b = Certificate((Check("gamma", 2.0, 1.0),), "a bound")
    both = a + b
    assert isinstance(both, Certificate) and len(both) == 4
    assert list(both) == list(a) + list(b)
    assert both.statement == "an invariant ellipsoid\na bound"
    assert a.verified and bool(a) and not b and not both
    assert both.failed == tuple(b) and both.worst == b[0]
    named = Certificate.combine(a.regrouped("region"), b, statement="the servo")
    assert named.statement == "the servo"
    assert {c.group for c in named} == {"region: ellipsoid", ""}
    assert not Certificate() and Certificate().worst is None
    with pytest.raises(TypeError, match="checks"):
        Certificate((1.0,))


def test_round_trip_through_a_file(tmp_path):
    cert = sample() + Certificate((Check("eig", np.inf, 0.0, strict=True),))
    path = write_json(tmp_path / "certificate.json", cert.to_dict())
    data = json.loads(path.read_text())
    assert data["verified"] is False
    again = Certificate.from_dict(data)
    assert again == cert and str(again) == str(cert)
    with pytest.raises(ValueError, match=r"checks'\]\[0\]"):
        Certificate.from_dict({"checks": [{"what": "x"}]})


# ----------------------------------------------------------------------
# Every result's certificate is the one type, with numpy's verdict
# ----------------------------------------------------------------------
def numpy_normalised_max_eig(M):
    d = 1.0 / np.sqrt(-np.diag(M))
    return np.linalg.eigvalsh(0.5 * (M + M.T) * np.outer(d, d))[-1]


def test_design_certificate(mass_spring, tmp_path):
    design = lpv.hinf_state_feedback(mass_spring, w="w", u="u", z=["x", "uw"])
    cert = design.certificate
    assert isinstance(cert, Certificate) and cert.verified
    assert all(isinstance(c, Check) and c.group == "LMI" for c in cert.lmi_checks)
    assert cert.worst_lmi.value == max(c.max_eig for c in cert.lmi_checks if c.strict)
    # Recomputed at the vertices: the closed loops and the bounded-real
    # inequality with P and gamma (the certificate covers more points).
    K, P, g = design.gains[0], design.P, design.gamma
    worst_real = worst_br = -np.inf
    for A, B, C, D in mass_spring.vertex_data():
        Acl, Ccl = A - B[:, [1]] @ K, C - D[:, [1]] @ K
        worst_real = max(worst_real, np.linalg.eigvals(Acl).real.max())
        M = np.block([[Acl.T @ P + P @ Acl, P @ B[:, [0]], Ccl.T],
                      [B[:, [0]].T @ P, -np.eye(1), D[:, [0]].T],
                      [Ccl, D[:, [0]], -g**2 * np.eye(2)]])  # fmt: skip
        worst_br = max(worst_br, numpy_normalised_max_eig(M))
    assert worst_real <= cert.max_closed_loop_real < 0
    assert worst_br <= cert.max_original_eig + 1e-12 and worst_br < 0
    assert cert.npoints >= mass_spring.nvertices
    # The file's certificate section is its table's data; the load re-checks.
    path = design.save(tmp_path / "design.json")
    saved = Certificate.from_dict(json.loads(path.read_text())["certificate"])
    assert saved.checks == cert.checks
    loaded = lpv.load(path)
    assert isinstance(loaded.certificate, Certificate) and loaded.certificate.verified
    assert not loaded.certificate.lmi_checks  # recomputed from the data alone


def test_general_engine_certificate(mass_spring):
    design = lpv.synthesize(mass_spring, "u", objective=lpv.H2(w="w", z=["x", "uw"]))
    cert = design.certificate
    assert isinstance(cert, Certificate) and cert.verified
    names = {c.what for c in cert.group("closed loop")}
    assert names >= {"closed-loop eigenvalues", "Lyapunov inequality"}
    worst = max(
        np.linalg.eigvals(A - B[:, [1]] @ design.gains[0]).real.max()
        for A, B, *_ in mass_spring.vertex_data()
    )
    assert worst <= cert.max_closed_loop_real < 0


def test_gain_file_certificate(tmp_path):
    design = twomass.design()
    path = twomass.save_gains(design, tmp_path / "gains.json")
    loaded = twomass.load_gains(path)
    cert = loaded.design.certificate
    assert isinstance(cert, Certificate) and cert.verified
    assert loaded.check["certified"] is cert.verified
    assert loaded.check["lyapunov_max_eig"] == cert.max_original_eig
    # A gain file without P: stability at the points only, never verified.
    document = json.loads(path.read_text())
    del document["P"]
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps(document))
    with pytest.warns(UserWarning, match="not certified"):
        unproved = twomass.load_gains(bare)
    assert unproved.check["certified"] is False


def test_analysis_checks_compose(mass_spring):
    design = lpv.hinf_state_feedback(mass_spring, w="w", u="u", z=["x", "uw"])
    bound = lpv.l2_gain_bound(mass_spring, list(design.gains), "w", "u", ["x", "uw"])
    cert = Certificate(tuple(c if isinstance(c, Check) else Check.from_lmi_check(c)
                             for c in bound.checks))  # fmt: skip
    assert cert.verified
    assert [c.passed for c in cert] == [c.passed for c in bound.checks]


def test_region_and_ultimate_bound_certificates():
    # A scalar loop whose checks are known: dx/dt = a x + b u, |u| <= 1.
    plant = lpv.PolytopicStateSpace([ct.ss([[1.0]], [[1.0]], [[1.0]], 0)], inputs="u")
    region = lpv.saturation_region(plant, [[2.0]], "u", 1.0)
    cert = region.certificate
    assert isinstance(cert, Certificate) and cert.verified
    # The engine's certificate: its closed-loop row of the sector condition,
    # recomputed here (x' = -x - psi, psi' T (psi + G x) <= 0).
    P, G, T = region.P, region.G[0], region.T
    sector = next(c for c in cert.group("closed loop")
                  if c.what.startswith("Saturation"))  # fmt: skip
    M = np.block([[-2 * P, -(P + G.T @ T)], [-(P + T @ G), -2 * T]])
    assert numpy_normalised_max_eig(M) < 0
    assert numpy_normalised_max_eig(M) <= sector.value + 1e-12
    assert ((2.0 - G) @ np.linalg.inv(P) @ (2.0 - G).T).item() <= 1.0
    # The ultimate bound of x' = -x + w, |w| <= 1: the engine's certificate,
    # whose closed-loop row covers the invariance inequality, recomputed here.
    ub = lpv.reachability.ultimate_bound(([[-1.0]], [[1.0]]), w_max=1.0)
    row = next(c for c in ub.certificate.group("closed loop")
               if c.what.startswith("OutputPeaks"))  # fmt: skip
    Pu, lam, mu = ub.P, ub.decay, ub.mu
    M = np.block([[-2 * Pu + lam * Pu, Pu], [Pu, -np.diag(mu)]])
    assert numpy_normalised_max_eig(M) < 0
    assert numpy_normalised_max_eig(M) <= row.value + 1e-12
    assert row.passed and ub.certificate.verified
    assert all(isinstance(c, Check) for c in ub.certificate.lmi_checks)


def test_servo_certificate_composes_its_parts():
    from ctrl_lpv.twomass.servo import servo_polytope
    from ctrl_lpv.twomass.servo_certificate import servo_certificate

    params, Jl_range = twomass.Parameters(), (0.8, 1.2)
    model = servo_polytope(params, p_bounds=(-0.5, 0.0), Jl_range=Jl_range)
    feedback = lpv.hinf_state_feedback(model, w=["Td"], u=["Tm"])
    cert = servo_certificate(
        params, feedback.gains[0], feedback, alpha_max=0.06, Jl_range=Jl_range,
        Td_max=10.0, torque_limit=500.0,
    )  # fmt: skip
    assert isinstance(cert, Certificate) and cert.feedback is feedback.certificate
    parts = {"feedback": cert.feedback, "ultimate bound": cert.ultimate.certificate}
    if cert.region is not None:
        parts["region"] = cert.region.certificate
    assert len(cert) == sum(len(p) for p in parts.values())
    assert cert.verified == all(p.verified for p in parts.values()) is True
    assert {c.group.split(":")[0] for c in cert} == set(parts)
    assert "not certified" in str(cert) and cert.error_bound > 0
    # The feedback part's verdict, recomputed: Hurwitz at every vertex.
    for v in model.vertices:
        Acl = np.asarray(v.A) - np.asarray(v.B)[:, [1]] @ feedback.gains[0]
        assert np.linalg.eigvals(Acl).real.max() < 0
