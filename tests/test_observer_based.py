"""Observer-based state feedback certified on the combined loop.

Independent facts: for an LTI plant the combined loop's eigenvalues are
those of ``A - B K`` and of ``A - L C`` (separation); the controller
connected by name to the plant by python-control has the same closed loop;
a simulation with a fast, switching parameter converges.
"""

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv


def plant(ks=(1.0, 4.0), dt=0):
    def vertex(k):
        A = [[0.0, 1.0], [-k, -0.2]]
        if dt:
            A = np.eye(2) + dt * np.array(A)
        return ct.ss(A, [[0.0], [1.0 if not dt else dt]], [[1.0, 0.0]], 0, dt,
                     inputs="u", outputs="y", states=["q", "v"])  # fmt: skip

    if len(ks) == 1:
        return lpv.pss([vertex(ks[0])])
    return lpv.PolytopicStateSpace([vertex(k) for k in ks], domain={"k": ks})


def test_lti_separation():
    G = plant(ks=(2.0,))
    sf = lpv.synthesize(G, "u", constraints=[lpv.halfplane(0.5)])
    obs = lpv.observer(G, "y", u="u", constraints=[lpv.halfplane(1.0)])
    combined = lpv.observer_based(sf, obs)
    assert combined.certificate.verified
    A, B, C = G.vertices[0].A, G.vertices[0].B, G.vertices[0].C
    expected = np.concatenate([np.linalg.eigvals(A - B @ sf.gains[0]),
                               np.linalg.eigvals(A - obs.L[0] @ C)])  # fmt: skip
    # u = K(y): the controller's output is u itself, positive feedback.
    loop = ct.feedback(G.vertices[0], combined.controller().at([1.0]), sign=1)
    got = np.linalg.eigvals(loop.A)
    np.testing.assert_allclose(np.sort_complex(got), np.sort_complex(expected),
                               rtol=1e-8, atol=1e-10)  # fmt: skip


@pytest.mark.filterwarnings("ignore::ctrl_lpv.ParameterClipWarning")  # k = 0 at build
@pytest.mark.parametrize("dt", [0, 0.05])
def test_scheduled_gains_and_observer_switching_parameter(dt):
    sys = plant(dt=dt)
    sf = lpv.synthesize(sys, "u", gains="scheduled")
    obs = lpv.observer(sys, "y", u="u", gains="scheduled")
    combined = lpv.observer_based(sf, obs)
    assert combined.certificate.verified
    P = combined.P
    assert np.linalg.eigvalsh(P).min() > 0
    controller = combined.controller()
    assert controller.input_labels == ["y", "k"]
    assert controller.output_labels == ["u"]
    # The plant and the controller, scheduled by the same switching k.
    scheduled = lpv.PolytopicStateSpace(sys.vertices, domain=sys.domain,
                                        scheduling="inputs")  # fmt: skip
    loop = ct.interconnect([scheduled, controller], inplist=["k"], outlist=["y"])
    T = np.arange(0.0, 30.0, dt or 0.01)
    k = np.where(np.sin(5.0 * T) > 0, 4.0, 1.0)
    x0 = np.array([1.0, 0.0, 0.0, 0.0])
    r = ct.input_output_response(loop, T, k, x0)
    assert np.abs(r.states[:, -1]).max() < 1e-3


def test_other_plant_is_refused():
    sf = lpv.synthesize(plant(), "u")
    obs = lpv.observer(plant(ks=(1.0, 3.0)), "y", u="u")
    with pytest.raises(ValueError, match="observer: designed for another plant"):
        lpv.observer_based(sf, obs)


def test_known_inputs_must_be_the_control_inputs():
    sys = plant()
    sf = lpv.synthesize(sys, "u")
    obs = lpv.observer(sys, "y")
    with pytest.raises(ValueError, match="known inputs"):
        lpv.observer_based(sf, obs)
