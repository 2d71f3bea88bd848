"""design.save(path) / lpv.load(path): round trips re-certified, forgeries refused.

Independent facts: closed-loop eigenvalues recomputed with numpy from the
vertex matrices, H-infinity norms of the frozen loops from
`control.linfnorm`.
"""

import dataclasses
import json
import os
import re

import control as ct
import numpy as np
import pytest

import ctrl_lpv as lpv

DT = 0.05


def vertex(k, dt=0):
    A = np.array([[0.0, 1.0], [k, 0.0]])
    B = np.array([[0.0, 0.0], [1.0, 1.0]])
    C = np.array([[1.0, 0.0], [0.0, 0.0]])
    D = np.array([[0.0, 0.0], [0.0, 1.0]])
    if dt:
        A, B = np.eye(2) + dt * A, dt * B  # Euler: a discrete plant of its own
    return ct.ss(A, B, C, D, inputs=["w", "u"], outputs=["y", "u_w"],
                 states=["pos", "vel"], dt=dt)  # fmt: skip


def plant(dt=0):
    return lpv.PolytopicStateSpace(
        [vertex(1.0, dt), vertex(3.0, dt)], domain={"k": (1.0, 3.0)}, name="toy"
    )


CASES = {
    "common": (0, dict()),
    "scheduled": (0, dict(gains="scheduled")),
    "discrete": (DT, dict(gains="scheduled")),
    "affine": (0, dict(gains="scheduled", lyapunov="affine", rate_bounds={"k": 1.0})),
}


@pytest.fixture(scope="module")
def designs():
    out = {}
    for name, (dt, options) in CASES.items():
        out[name] = lpv.synthesize(plant(dt), "u", objective=lpv.Hinf("w"), **options)
    return out


@pytest.fixture(scope="module")
def files(designs, tmp_path_factory):
    folder = tmp_path_factory.mktemp("designs")
    return {name: d.save(folder / f"{name}.json") for name, d in designs.items()}


def forged(tmp_path, source, change):
    document = json.loads(source.read_text())
    change(document)
    path = tmp_path / "forged.json"
    path.write_text(json.dumps(document))
    return path


@pytest.mark.parametrize("name", list(CASES))
def test_round_trip_is_recertified(designs, files, name):
    design = designs[name]
    loaded = lpv.load(files[name])
    assert loaded.certificate.verified and loaded.certificate.npoints > 2
    assert loaded.gamma == design.gamma and loaded.method == design.method
    assert loaded.bounds == design.bounds and loaded.rate_bounds == design.rate_bounds
    for a, b in zip(loaded.gains, design.gains):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(loaded.system.vertex_data(), design.system.vertex_data()):
        for Ma, Mb in zip(a, b):
            np.testing.assert_array_equal(Ma, Mb)
    assert loaded.system.dt == design.system.dt
    assert loaded.system.state_labels == ["pos", "vel"]
    for k in (1.0, 1.7, 3.0):
        np.testing.assert_array_equal(loaded.gain({"k": k}), design.gain({"k": k}))


@pytest.mark.parametrize("name", list(CASES))
def test_closed_loop_is_named_and_bounded_by_gamma(designs, name):
    design = designs[name]
    dt, _ = CASES[name]
    for k in (1.0, 3.0):
        loop = design.closed_loop({"k": k})
        assert isinstance(loop, ct.StateSpace) and loop.dt == dt
        assert loop.input_labels == ["w"] and loop.output_labels == ["y", "u_w"]
        assert loop.state_labels == ["pos", "vel"]
        # Eigenvalues of A - B_u K, by hand from the vertex matrices.
        A, B, _, _ = ct.ssdata(vertex(k, dt))
        by_hand = np.linalg.eigvals(A - B[:, [1]] @ design.gain({"k": k}))
        np.testing.assert_allclose(
            np.sort_complex(loop.poles()), np.sort_complex(by_hand), rtol=1e-12
        )
        assert ct.linfnorm(loop)[0] < design.gamma


def test_load_against_a_given_plant(files):
    given = plant()
    loaded = lpv.load(files["scheduled"], plant=given)
    assert loaded.system is given and loaded.certificate.verified
    other = lpv.PolytopicStateSpace(
        [vertex(1.0), vertex(4.0)], domain={"k": (1.0, 3.0)}, name="toy"
    )
    with pytest.raises(ValueError, match="^plant: .*vertex 1: the A matrices differ"):
        lpv.load(files["scheduled"], plant=other)
    with pytest.raises(TypeError, match="^plant: "):
        lpv.load(files["scheduled"], plant=vertex(1.0))


def negate_gains(d):
    d["design"]["gains"] = (-np.array(d["design"]["gains"])).tolist()
    if d["design"].get("rational"):  # K(p) = -Z(p) W(p)^-1: negate Z too
        Z = d["design"]["rational"]["Z"]
        d["design"]["rational"]["Z"] = (-np.array(Z)).tolist()
    d["certificate"]["verified"] = True  # never read


def destabilise_plant(d):
    A = np.array(d["plant"]["vertices"][1]["A"])
    A[1, 0] += 1e4
    d["plant"]["vertices"][1]["A"] = A.tolist()


@pytest.mark.parametrize("name", ["common", "discrete", "affine"])
def test_forged_gains_do_not_load(designs, files, tmp_path, name):
    dt, _ = CASES[name]
    A, B, _, _ = ct.ssdata(vertex(3.0, dt))
    K = -designs[name].gain({"k": 3.0})
    eig = np.linalg.eigvals(A - B[:, [1]] @ K)
    assert (eig.real.max() > 0) if not dt else (np.abs(eig).max() > 1)
    with pytest.raises(
        ValueError, match=r"forged\.json: key 'design\.(gains|P)'.*does not hold"
    ):
        lpv.load(forged(tmp_path, files[name], negate_gains))


def test_forged_plant_does_not_load(designs, files, tmp_path):
    A, B, _, _ = ct.ssdata(vertex(3.0))
    A[1, 0] += 1e4
    K = designs["common"].gain()
    assert np.linalg.eigvals(A - B[:, [1]] @ K).real.max() > 0
    with pytest.raises(ValueError, match=r"key 'design\.gains'.*not stable"):
        lpv.load(forged(tmp_path, files["common"], destabilise_plant))


def test_gamma_below_the_true_norm_does_not_load(designs, files, tmp_path):
    design = designs["scheduled"]
    true = max(ct.linfnorm(design.closed_loop({"k": k}))[0] for k in (1.0, 3.0))

    def lower(d):
        d["design"]["gamma"] = d["design"]["specs"][0]["value"] = 0.9 * true

    with pytest.raises(ValueError, match=r"key 'design\.P'.*bounded-real"):
        lpv.load(forged(tmp_path, files["scheduled"], lower))


@pytest.mark.parametrize(
    "change, key",
    [
        (
            lambda d: d["plant"]["vertices"][0].update(A=[[1.0, True], [0.0, 1.0]]),
            "plant.vertices[0].A",
        ),
        (
            lambda d: d["plant"]["vertices"][0].update(B=[[0.0], [1.0]]),
            "plant.vertices[0].B",
        ),
        (lambda d: d["plant"]["vertices"].pop(), "plant.vertices"),
        (lambda d: d["plant"].update(dt="0"), "plant.dt"),
        (lambda d: d["plant"].update(states=["pos", "pos"]), "plant.states"),
        (lambda d: d["plant"]["domain"].update(lower=[3.0]), "plant.domain"),
        (lambda d: d["design"].update(gamma=True), "design.gamma"),
        (lambda d: d["design"].update(w=[], z=[]), "design.w"),
        (
            lambda d: d["design"]["specs"][0].update(w=["nonexistent"]),
            "design.specs[0]",
        ),
        (lambda d: d["design"].update(lyapunov="quadratic"), "design.lyapunov"),
        (lambda d: d.update(type="Design"), "type"),
    ],
)
def test_malformed_entries_name_the_key(files, tmp_path, change, key):
    path = forged(tmp_path, files["common"], change)
    with pytest.raises(ValueError, match=rf"forged\.json: key '{re.escape(key)}"):
        lpv.load(path)


def test_hostile_paths_name_path(tmp_path):
    for bad in (None, 3.0, b"x.json"):
        with pytest.raises(TypeError, match="^path: "):
            lpv.load(bad)
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(ValueError, match="^path: .*nested too deeply"):
        lpv.load(deep)
    other = tmp_path / "other.json"
    other.write_text("{}")
    with pytest.raises(ValueError, match="^path: .*not a ctrl_lpv design file"):
        lpv.load(other)


def test_save_refuses_what_it_cannot_recheck(designs, tmp_path):
    with_peak = dataclasses.replace(
        designs["common"], bounds={lpv.Peak("w", "y", bound=1.0): 0.5}
    )
    with pytest.raises(ValueError, match="^design: its Peak claim"):
        with_peak.save(tmp_path / "p.json")
    with pytest.raises(ValueError, match="^path: the folder"):
        designs["common"].save(tmp_path / "missing" / "d.json")
    assert not (tmp_path / "p.json").exists()


def test_interrupted_save_leaves_the_old_file(designs, tmp_path, monkeypatch):
    path = tmp_path / "d.json"
    path.write_text("old")

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        designs["common"].save(path)
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["d.json"]


@pytest.fixture(scope="module")
def saturated():
    one = lpv.PolytopicStateSpace(
        [ct.ss([[1.0]], [[1.0]], [[1.0]], 0, inputs=["u"], states=["x"])]
    )
    return lpv.saturated_state_feedback(one, u="u", u_max=1.0)


def test_saturated_design_round_trip(saturated, tmp_path):
    path = saturated.save(tmp_path / "sat.json")
    loaded = lpv.load(path)
    assert loaded.certificate.verified and loaded.beta == saturated.beta
    np.testing.assert_array_equal(loaded.gains[0], saturated.gains[0])
    # x' = x + sat(u): the region of attraction of u = -K x is |x| < 1
    # whatever K (sat(u) is at most 1 in size), so the region is inside it.
    assert loaded.beta < 1.0
    loop = loaded.closed_loop([1.0])
    assert loop.state_labels == ["x"] and loop.poles()[0] < 0
    np.testing.assert_allclose(loop.poles(), 1.0 - saturated.gains[0][0], rtol=1e-12)

    def larger(d):
        d["design"]["beta"] = 1.5

    with pytest.raises(ValueError, match=r"key 'design\.beta'"):
        lpv.load(forged(tmp_path, path, larger))
    with pytest.raises(ValueError, match=r"key 'design\.P'.*does not hold"):
        lpv.load(forged(tmp_path, path, negate_gains))


def test_sampled_saturated_design_round_trip(tmp_path):
    # x+ = 1.1 x + sat(u): the file's checks are the discrete-time sector
    # condition, recomputed on load; a doubled gain (the linear loop 1.1 -
    # 2 K outside the unit circle) fails them.
    sampled = lpv.PolytopicStateSpace(
        [ct.ss([[1.1]], [[1.0]], [[1.0]], 0, dt=0.1, inputs=["u"], states=["x"])]
    )
    design = lpv.saturated_state_feedback(sampled, u="u", u_max=1.0, backoff=None)
    path = design.save(tmp_path / "sampled.json")
    loaded = lpv.load(path)
    assert loaded.certificate.verified and loaded.beta == design.beta
    assert loaded.system.dt == 0.1
    K = float(design.gains[0][0, 0])
    assert abs(1.1 - K) < 1 and loaded.beta < 10.0  # no region reaches 10

    def doubled_gain(d):
        d["design"]["gains"] = (2 * np.array(d["design"]["gains"])).tolist()

    assert abs(1.1 - 2 * K) > 1
    with pytest.raises(ValueError, match=r"key 'design\.P'.*does not hold"):
        lpv.load(forged(tmp_path, path, doubled_gain))
