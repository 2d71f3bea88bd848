"""Hostile inputs (issue 19): a clear error naming the argument, or a true refusal.

One table: each row is a call with a bad argument, the exception class it
must raise and a regex its message must match (naming the argument). None
of them may come from inside numpy, scipy, cvxpy or python-control, and
none may be coerced into an answer (``"no"`` is not True, ``1 + 2j`` is not
1, ``b"w"`` is not the index 119).
"""

import math

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv
from ctrl_lpv import twomass
from ctrl_lpv.reachability import Ellipsoid
from ctrl_lpv.simulation import simulate
from ctrl_lpv.twomass import lpv_model, paper_gain, servo_design

A2 = np.array([[0.0, 1.0], [-2.0, -1.0]])
B2 = np.array([[0.0], [1.0]])


def unstable_plant(dt=None):
    """``dx/dt = x + u`` (or a sampled double integrator with ``dt``)."""
    if dt is None:
        return lpv.PolytopicStateSpace([ct.ss([[1.0]], [[1.0]], [[1.0]], 0)])
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    B = np.array([[0.005], [0.1]])
    return lpv.PolytopicStateSpace(
        [(A, B, np.eye(2), np.zeros((2, 1))), (A + 0.02 * np.eye(2), B, np.eye(2), 0)],
        dt=dt,
    )


def two_blocks(second_name="P"):
    P = ct.ss([[-1.0]], [[1.0]], [[1.0]], 0, inputs="u", outputs="y", name="P")
    K = ct.ss([], [], [], [[2.0]], inputs="y", outputs="u", name=second_name)
    return P, K


def servo(**kwargs):
    return servo_design(gain=paper_gain(), certify=False, **kwargs)


def stable_system():
    return ct.ss([[-1.0]], [[1.0]], [[1.0]], 0)


def affine_box(count):
    names = [f"p{i}" for i in range(count)]
    return lpv.PolytopicStateSpace.from_affine(
        ([[-1.0]], [[1.0]], [[1.0]], 0),
        {p: ([[0.01]], 0, 0, 0) for p in names},
        {p: (0.0, 1.0) for p in names},
    )


def quadratic_design():
    return lpv.quadratic_stabilization(unstable_plant(), u=0)


# (label, call, exception class, regex naming the argument)
CASES = [
    # servo_design: numbers and flags are validated, not coerced
    ("servo complex gain", lambda: servo_design(gain=paper_gain() + 1j),
     TypeError, r"^gain: complex"),
    ("servo anti_hunting 'no'", lambda: twomass.ServoAntiHunting(enabled="no"),
     TypeError, r"^ServoAntiHunting.enabled: expected True or False, got 'no'"),
    ("servo gap_estimate 0", lambda: twomass.ServoEstimator(gap_estimate=0),
     TypeError, r"^ServoEstimator.gap_estimate: expected True or False"),
    ("servo settings as a bool", lambda: servo(estimator=False),
     TypeError, r"^estimator: expected a ServoEstimator"),
    ("servo string torque", lambda: servo(torque_limit="500"),
     TypeError, r"^torque_limit: expected a real number, got '500'"),
    ("servo bool torque", lambda: servo(torque_limit=True),
     TypeError, r"^torque_limit: expected a real number"),
    ("servo string Td_max", lambda: servo(Td_max="10"),
     TypeError, r"^Td_max: expected a real number"),
    ("servo string in Jl_range", lambda: servo(Jl_range=("0.8", 1.2)),
     TypeError, r"^Jl_range: expected a real number"),
    ("servo scalar Jl_range", lambda: servo(Jl_range=1.0),
     TypeError, r"^Jl_range: expected \(low, high\)"),
    ("servo string p_bounds",
     lambda: twomass.ServoSynthesis(p_bounds="-0.5, 0"),
     TypeError, r"^ServoSynthesis.p_bounds: expected \(low, high\)"),
    ("servo string flank_width", lambda: twomass.ServoAntiHunting(flank_width="1"),
     TypeError, r"^ServoAntiHunting.flank_width: expected a real number"),
    ("servo string gain", lambda: servo_design(gain=["1", "2", "3", "4"]),
     TypeError, r"^gain: expected a numeric matrix"),
    # saturated_state_feedback and saturation_region
    ("saturated string u_max",
     lambda: lpv.saturated_state_feedback(unstable_plant(), u=0, u_max="1.0"),
     TypeError, r"^u_max: expected a real number, got '1.0'"),
    ("saturated string decay",
     lambda: lpv.saturated_state_feedback(unstable_plant(), u=0, u_max=1, decay="5"),
     TypeError, r"^decay: expected a real number"),
    ("saturated string backoff",
     lambda: lpv.saturated_state_feedback(
         unstable_plant(), u=0, u_max=1, backoff="0.1"),
     TypeError, r"^backoff: expected a real number"),
    ("saturated complex u_max",
     lambda: lpv.saturated_state_feedback(unstable_plant(), u=0, u_max=1 + 2j),
     TypeError, r"^u_max: expected a real number"),
    ("saturation_region string margin",
     lambda: lpv.saturation_region(
         unstable_plant(), [[2.0]], u=0, u_max=1, margin="1e-6"),
     TypeError, r"^margin: expected a real number"),
    # analysis: the margin is a number
    ("quadratic_stability string margin",
     lambda: lpv.quadratic_stability(
         lpv.PolytopicStateSpace([stable_system()]), margin="1e-6"),
     TypeError, r"^margin: expected a real number"),
    ("l2_gain_bound margin 0",
     lambda: lpv.l2_gain_bound(
         lpv.PolytopicStateSpace([stable_system()]), [[0.0]], [], 0, 0, margin=0),
     ValueError, r"^margin: "),
    # specs: bytes are not signal names
    ("Hinf bytes w", lambda: lpv.Hinf(w=b"w"),
     TypeError, r"^w: expected signal names .* got b'w'"),
    ("H2 bytes in z", lambda: lpv.H2(z=["e", b"u"]),
     TypeError, r"^z: expected signal names .* got b'u'"),
    ("Hinf bool w", lambda: lpv.Hinf(w=True),
     TypeError, r"^w: expected signal names"),
    # solver options: judged before any solve
    ("unknown Clarabel option",
     lambda: lpv.quadratic_stabilization(
         unstable_plant(), u=0, solvers=[("CLARABEL", {"bogus_option": 1})]),
     ValueError, r"^solvers: CLARABEL rejects the option\(s\) 'bogus_option'"),
    ("unknown SCS option",
     lambda: lpv.ultimate_bound(
         ([[-1.0]], [[1.0]]), solvers=[("SCS", {"bogus_option": 1})]),
     ValueError, r"^solvers: SCS rejects the option\(s\) 'bogus_option'"),
    # simulate
    ("simulate bogus method",
     lambda: simulate(stable_system(), np.linspace(0, 1, 5), method="bogus"),
     ValueError, r"^method: unknown solve_ivp method 'bogus'; use one of"),
    ("simulate method None",
     lambda: simulate(stable_system(), np.linspace(0, 1, 5), method=None),
     TypeError, r"^method: expected a solve_ivp method name"),
    ("simulate bool rtol",
     lambda: simulate(stable_system(), np.linspace(0, 1, 5), rtol=True),
     TypeError, r"^rtol: expected a real number"),
    ("simulate string transpose",
     lambda: simulate(stable_system(), np.linspace(0, 1, 5), transpose="no"),
     TypeError, r"^transpose: expected True or False"),
    # ultimate_bound
    ("ultimate_bound zero dynamics", lambda: lpv.ultimate_bound(([[0.0]], [[1.0]])),
     lpv.InfeasibleError, r"^sys: vertex 0: row 0 of A is zero"),
    ("ultimate_bound string w_max",
     lambda: lpv.ultimate_bound(([[-1.0]], [[1.0]]), w_max="1"),
     TypeError, r"^w_max: expected a real number"),
    ("ultimate_bound string decay",
     lambda: lpv.ultimate_bound(([[-1.0]], [[1.0]]), decay="1"),
     TypeError, r"^decay: expected a real number"),
    ("ultimate_bound discrete unstable",
     lambda: lpv.ultimate_bound(unstable_plant(0.1)),
     lpv.InfeasibleError, r"^sys: vertex \d is not Schur"),
    ("Ellipsoid.scaled string", lambda: Ellipsoid(np.eye(2)).scaled("2"),
     TypeError, r"^factor: expected a real number"),
    # PolytopicStateSpace
    ("0-input vertex among 1-input ones",
     lambda: lpv.PolytopicStateSpace(
         [(A2, B2, np.eye(2), 0), (A2, np.zeros((2, 0)), np.eye(2), 0)]),
     ValueError, r"^vertices\[1\]: dimensions"),
    ("duplicate state names",
     lambda: lpv.PolytopicStateSpace([(A2, B2, np.eye(2), 0)], states=["x", "x"]),
     ValueError, r"^states: repeated names \['x'\]"),
    ("duplicate output names",
     lambda: lpv.PolytopicStateSpace([(A2, B2, np.eye(2), 0)], outputs=["y", "y"]),
     ValueError, r"^outputs: repeated names"),
    ("too few input names",
     lambda: lpv.PolytopicStateSpace(
         [(A2, np.eye(2), np.eye(2), 0)], inputs=["u"]),
     ValueError, r"^inputs: 1 names given for 2 signals"),
    ("bytes state name",
     lambda: lpv.PolytopicStateSpace([(A2, B2, np.eye(2), 0)], states=[b"x", "v"]),
     TypeError, r"^states: expected signal names"),
    ("integer system name",
     lambda: lpv.PolytopicStateSpace([(A2, B2, np.eye(2), 0)], name=3),
     TypeError, r"^name: expected a non-empty string"),
    ("from_affine with 20 parameters", lambda: affine_box(20),
     ValueError, r"^bounds: 20 parameters \['p0', .*'p19'\] give a box of "
                 r"2\*\*20 = 1,048,576 vertices"),
    ("bool parameter value",
     lambda: simulate(affine_box(1), np.linspace(0, 1, 5), params={"p0": True}),
     TypeError, r"^params\['p0'\]: expected a real number"),
    ("string clip", lambda: affine_box(1).weights([0.5], clip="no"),
     TypeError, r"^clip: expected True or False"),
    ("string parameter bound", lambda: lpv.ParameterBox({"k": ("1", 4.0)}),
     TypeError, r"^bounds\['k'\]: expected a real number, got '1'"),
    ("string parameter point", lambda: affine_box(1).at({"p0": "0.5"}),
     TypeError, r"^p: expected a real number"),
    ("bool parameter point", lambda: affine_box(1).weights([True]),
     TypeError, r"^p: expected a real number"),
    # pole regions and the two-mass model
    ("string half-plane decay", lambda: lpv.halfplane("1"),
     TypeError, r"^decay: expected a real number, got '1'"),
    ("string disk radius", lambda: lpv.disk("1"),
     TypeError, r"^radius: expected a real number"),
    ("lpv_model integral 'no'",
     lambda: lpv_model(formulation="tracking", integral="no"),
     TypeError, r"^integral: expected True or False, got 'no'"),
    ("lpv_model string p_bounds", lambda: lpv_model(p_bounds=("-0.5", 0.0)),
     TypeError, r"^p_bounds: expected a real number"),
    ("lpv_model string weight", lambda: lpv_model(torque_weight="1e-3"),
     TypeError, r"^torque_weight: expected a real number"),
    # interconnect
    ("interconnect empty list", lambda: lpv.interconnect([]),
     ValueError, r"^syslist: the list is empty"),
    ("interconnect string", lambda: lpv.interconnect("P"),
     TypeError, r"^syslist: expected a list"),
    ("interconnect one system", lambda: lpv.interconnect(two_blocks()[0]),
     TypeError, r"^syslist: expected a list .* got StateSpace"),
    ("interconnect duplicate names",
     lambda: lpv.interconnect(list(two_blocks("P")), inplist="P.u", outlist="P.y"),
     ValueError, r"^syslist: systems 0 and 1 are both named 'P'"),
    ("interconnect NaN gain",
     lambda: lpv.interconnect(
         list(two_blocks("K")),
         connections=[["K.y", ("P", "y", math.nan)], ["P.u", "K.u"]],
         inplist="P.u", outlist="P.y"),
     ValueError, r"^connections\[0\]\[1\]: gain of \('P', 'y'\): must be finite"),
    ("interconnect string gain",
     lambda: lpv.interconnect(
         list(two_blocks("K")), connections=[["K.y", ("P", "y", "2")]],
         inplist="P.u", outlist="P.y"),
     TypeError, r"^connections\[0\]\[1\]: gain of \('P', 'y'\): expected a real"),
    ("interconnect infinite output gain",
     lambda: lpv.interconnect(
         list(two_blocks("K")), inplist="P.u", outlist=[("P", "y", math.inf)]),
     ValueError, r"^outlist\[0\]: gain of \('P', 'y'\): must be finite"),
    # controllers
    ("state_feedback string reference",
     lambda: quadratic_design().controller(reference="no"),
     TypeError, r"^reference: expected True or False"),
    ("integral name reuses an output",
     lambda: lpv.integral_augmentation(
         lpv.PolytopicStateSpace([(A2, B2, np.eye(2), 0)], outputs=["q", "int_x"],
                                 states=["x", "v"]), "x"),
     ValueError, r"^names: integral state labels must be new"),
]  # fmt: skip


@pytest.mark.parametrize(
    "call, error, pattern", [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_hostile_input(call, error, pattern):
    with pytest.raises(error, match=pattern):
        call()


# ----------------------------------------------------------- behaviour changes


@pytest.mark.parametrize("decay", [0.0, 5.0])
def test_saturation_certificate_of_discrete_time_plants(decay):
    """A sampled plant gets the discrete-time sector LMIs.

    Before the refusal that preceded them, ``x[k+1] = 0.9 x[k] + sat(u)``
    with ``decay=5`` got ``K = 6.17`` from the continuous-time LMIs
    (``0.9 - K = -5.27``: an unstable sampled loop) and an "invariant"
    ellipsoid ``|x| <= 0.154`` from whose inside the saturated loop went to
    0.526 and stayed there. Now the sampled loop is what is certified: from
    the boundary of the ellipsoid (at random parameters) ``V(x+) <=
    exp(-2 decay dt) V(x)`` at every sample, and the linear loop is Schur.
    """
    rng = np.random.default_rng(5)
    scalar = lpv.PolytopicStateSpace([ct.ss([[0.9]], [[1.0]], [[1.0]], 0, dt=0.1)])
    for plant in (scalar, unstable_plant(dt=0.1)):
        assert plant.isdtime(strict=True)
        data = plant.vertex_data()
        design = lpv.saturated_state_feedback(plant, u=0, u_max=1.0, decay=decay)
        K, P = design.gains[0], design.P
        r = np.exp(-2 * decay * 0.1)
        for A, B, _, _ in data:
            assert np.abs(np.linalg.eigvals(A - B @ K)).max() < 1
        for _ in range(8):
            x = rng.standard_normal(plant.nstates)
            x /= np.sqrt(x @ P @ x)
            for _ in range(100):
                delta = rng.dirichlet(np.ones(len(data)))
                A = sum(w * v[0] for w, v in zip(delta, data))
                B = sum(w * v[1] for w, v in zip(delta, data))
                nxt = A @ x + B @ np.clip(-K @ x, -1.0, 1.0)
                assert nxt @ P @ nxt <= r * (x @ P @ x) * (1 + 1e-9) + 1e-300
                x = nxt


def test_ultimate_bound_refuses_zero_dynamics_with_the_reason():
    """A zero row or column of A is the eigenvalue 0: no attractive set."""
    cases = [
        np.zeros((1, 1)),
        np.array([[0.0, 1.0], [0.0, 0.0]]),  # double integrator: row 1
        np.array([[-1.0, 0.0], [1.0, 0.0]]),  # column 1
    ]
    for A in cases:
        assert np.min(np.abs(np.linalg.eigvals(A))) == 0.0  # the fact refused on
        with pytest.raises(lpv.InfeasibleError, match=r"A has the eigenvalue 0"):
            lpv.ultimate_bound((A, np.ones((A.shape[0], 1))))
    # An eigenvalue within rounding of the axis: a refusal that says so.
    with pytest.raises(lpv.CertificationError, match=r"imaginary axis"):
        lpv.ultimate_bound(([[1e-12]], [[1.0]]))


def test_integral_states_are_outputs_that_z_can_weight():
    base = ct.ss(
        [[0.0, 1.0], [0.0, -0.5]], [[0.0, 0.0], [1.0, 1.0]],
        [[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]], [[0.0, 0.0], [0.0, 0.0], [0.0, 0.1]],
        inputs=["w", "u"], outputs=["q", "v", "uw"], states=["q", "v"],
    )  # fmt: skip
    plant = lpv.PolytopicStateSpace.from_affine(
        base, {"k": ([[0.0, 0.0], [-1.0, 0.0]], 0, 0, 0)}, {"k": (1.0, 4.0)}
    )
    aug = lpv.integral_augmentation(plant, "q")
    assert aug.output_labels == ["q", "v", "uw", "int_q"]
    for vertex in aug.vertices:  # the new output is the integral state itself
        np.testing.assert_array_equal(vertex.C[-1], [0.0, 0.0, 1.0])
        np.testing.assert_array_equal(vertex.D[-1], [0.0, 0.0])
    design = lpv.synthesize(
        aug, u="u", objective=lpv.Hinf(w="w", z=["q", "int_q", "uw"])
    )
    K = design.gains[0]
    slowest = max(
        np.linalg.eigvals(aug.at(k).A - aug.at(k).B[:, [1]] @ K).real.max()
        for k in np.linspace(1.0, 4.0, 13)
    )
    assert slowest < -0.1


def test_h2_feedthrough_refusal_names_the_pair():
    """Only w 'd2' -> z 'e2' feeds through, and only at vertex 1."""
    A = np.array([[0.0, 1.0], [-1.0, -1.0]])
    B = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    C = np.eye(2)
    D0 = np.zeros((2, 3))
    D1 = D0.copy()
    D1[1, 1] = 0.5
    plant = lpv.PolytopicStateSpace(
        [(A, B, C, D0), (A, B, C, D1)],
        inputs=["d1", "d2", "u"], outputs=["e1", "e2"],
    )  # fmt: skip
    with pytest.raises(ValueError, match="H2") as info:
        lpv.synthesize(plant, u="u", objective=lpv.H2(w=["d1", "d2"], z=["e1", "e2"]))
    message = str(info.value)
    assert "from w 'd2' to z 'e2'" in message and "vertex 1" in message
    assert "0.5" in message


def test_from_affine_refuses_a_large_box_before_enumerating():
    with pytest.raises(ValueError, match=r"2\*\*13 = 8,192 vertices") as info:
        affine_box(13)
    assert "fewer parameters" in str(info.value)
    assert affine_box(3).nvertices == 8


def test_unknown_solver_option_is_refused_before_any_solve(monkeypatch):
    def no_solve(*args, **kwargs):
        raise AssertionError("a solve was attempted")

    monkeypatch.setattr(lpv.lmi.LMIProblem, "_attempt", no_solve)
    with pytest.raises(ValueError, match="bogus_option"):
        lpv.quadratic_stabilization(
            unstable_plant(), u=0, solvers=["SCS", ("CLARABEL", {"bogus_option": 1})]
        )
    # Options the solver accepts pass, also with a wrong value refused.
    chain = lpv.lmi.solver_chain([("CLARABEL", {"max_iter": 50})])
    assert chain == [("CLARABEL", {"max_iter": 50})]
    with pytest.raises(ValueError, match=r"^solvers: CLARABEL rejects .*'max_iter'"):
        lpv.lmi.solver_chain([("CLARABEL", {"max_iter": "many"})])


def test_an_empty_input_matrix_means_no_inputs():
    sys = lpv.PolytopicStateSpace([(A2, [], np.eye(2), [])])
    assert sys.ninputs == 0 and sys.vertices[0].B.shape == (2, 0)
    assert sys.vertices[0].D.shape == (2, 0)
    P = lpv.quadratic_stability(sys).P  # an autonomous system is analysed
    assert np.linalg.eigvalsh(A2.T @ P + P @ A2).max() < 0 < np.linalg.eigvalsh(P).min()
