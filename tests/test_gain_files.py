"""Two-mass gain files: a tampered file never loads as certified.

Every attack below either raises a ValueError naming the file's key or
loads with ``check["certified"] is False``; the facts the attacks rest on
(a destabilizing gain, an uncontrollable mode) are recomputed here with
numpy from `lpv_model`, independently of the loader.
"""

import json
import os

import control as ct
import numpy as np
import pytest

from ctrl_lpv import twomass

MODEL = {"p_bounds": [-0.95, 0.0], "formulation": "tracking", "integral": True}


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    design = twomass.design()
    path = tmp_path_factory.mktemp("gains") / "robust.json"
    twomass.save_gains(design, path, model=MODEL)
    return design, path


def real_model(p_bounds=(-0.95, 0.0)):
    return twomass.lpv_model(p_bounds=p_bounds, formulation="tracking", integral=True)


def tampered(tmp_path, source, change):
    document = json.loads(source.read_text())
    change(document)
    path = tmp_path / "tampered.json"
    path.write_text(json.dumps(document))
    return path


def refused_or_uncertified(path, key):
    """The loader raises naming `key`, or loads uncertified: never certified."""
    try:
        loaded = twomass.load_gains(path)
    except ValueError as exc:
        assert f"'{key}" in str(exc) and "tampered.json" in str(exc), str(exc)
        return str(exc)
    assert loaded.check["certified"] is False
    return None


def max_real(model, K, p):
    G = model.at(p)
    iu = model.input_labels.index("Tm")
    return np.linalg.eigvals(G.A - G.B[:, [iu]] @ K).real.max()


def forge_model_data(document, K_new, p_bounds=(-0.95, 0.0)):
    """The issue's attack: vertex matrices rewritten so that K_new looks
    exactly like the certified K (A' = A - B_u K + B_u K_new, C' likewise)."""
    model = real_model(p_bounds)
    K = np.array(document["gains"][0])
    iu = model.input_labels.index("Tm")
    vertices = []
    for A, B, C, D in model.vertex_data():
        Bu, Du = B[:, [iu]], D[:, [iu]]
        vertices.append({
            "A": (A - Bu @ K + Bu @ K_new).tolist(), "B": B.tolist(),
            "C": (C - Du @ K + Du @ K_new).tolist(), "D": D.tolist(),
        })  # fmt: skip
    document["model_data"] = {
        "states": list(model.state_labels), "inputs": list(model.input_labels),
        "outputs": list(model.output_labels), "vertices": vertices,
    }  # fmt: skip


@pytest.mark.parametrize(
    "version", ["ctrl_lpv.twomass.gains/2", "ctrl_lpv.twomass.gains/1"]
)
@pytest.mark.parametrize("keep_model", [False, True])
def test_negated_gains_with_forged_model_data_never_certify(
    saved, tmp_path, version, keep_model
):
    design, source = saved
    K_new = -design.gain()
    # The independent fact: these gains destabilise the real plant.
    assert max_real(real_model(), K_new, 0.0) > 400.0

    def attack(d):
        d["format"] = version
        if version.endswith("/1"):
            d["model"].pop("params")
        if not keep_model:
            d.pop("model")
        d["gains"] = [K_new.tolist()]
        forge_model_data(d, K_new)

    path = tampered(tmp_path, source, attack)
    message = refused_or_uncertified(path, "model" if not keep_model else "gains")
    assert message is not None and ("not stable" in message or "'model'" in message)


def test_uncontrollable_interval_never_certifies(saved, tmp_path):
    design, source = saved
    # At p = -1 the mode Jl omega_l + (cl + cs) theta_l - cs theta_m does not
    # see Tm: [A, B_u] loses rank at s = 0 (PBH), so no gain stabilises it.
    G = real_model((-1.0, 0.0)).at(-1.0)
    iu = G.input_labels.index("Tm")
    pbh = np.hstack([G.A, G.B[:, [iu]]])
    assert np.linalg.matrix_rank(pbh, tol=1e-9 * np.linalg.norm(pbh)) < G.nstates
    only_vertices = tampered(
        tmp_path, source, lambda d: d.update(p_vertices=[-1.0, 0.0])
    )
    refused_or_uncertified(only_vertices, "p_vertices")

    def both(d):
        d["p_vertices"] = [-1.0, 0.0]
        d["model"]["p_bounds"] = [-1.0, 0.0]
        forge_model_data(d, np.array(d["gains"][0]), (-1.0, 0.0))

    message = refused_or_uncertified(tampered(tmp_path, source, both), "gains")
    assert message is not None and "not stable" in message


def test_model_data_of_another_box_is_ignored(saved, tmp_path):
    design, source = saved
    honest = twomass.load_gains(source)

    def other_box(d):
        forge_model_data(d, np.array(d["gains"][0]), (-0.5, 0.0))

    loaded = twomass.load_gains(tampered(tmp_path, source, other_box))
    assert loaded.check == honest.check  # checked on the rebuilt model only
    without_model = tampered(tmp_path, source, lambda d: (other_box(d), d.pop("model")))
    refused_or_uncertified(without_model, "model")


@pytest.mark.parametrize(
    "change, key",
    [
        (lambda d: d.update(w=[], z=[], gamma=1e-9), "w"),
        (lambda d: d.update(z=[]), "z"),
        (lambda d: d.update(z=["nonexistent"]), "z"),
        (lambda d: d.pop("w"), "w"),
        (lambda d: d.update(gamma=True), "gamma"),
        (lambda d: d.update(gamma="0.03"), "gamma"),
        (lambda d: d.update(gamma=-1.0), "gamma"),
        (lambda d: d["model"].update(integral="false"), "model.integral"),
        (lambda d: d["model"].update(integral=0), "model.integral"),
        (lambda d: d["model"].update(torque_weight=True), "model.torque_weight"),
        (lambda d: d["model"]["params"].update(Jl="5.6"), "model.params.Jl"),
        (lambda d: d["model"]["params"].update(Jl=-1.0), "model"),
        (lambda d: d["model"].update(formulation=["tracking"]), "model.formulation"),
        (lambda d: d["model"].pop("params"), "model.params"),
        (lambda d: d["model"].update(extra=1), "model"),
        (lambda d: d.update(model=[1, 2]), "model"),
        (lambda d: d.update(gains=[[[True] * 5]]), "gains"),
        (lambda d: d.update(P=[[1.0] * 5] * 5), "P"),
        (
            lambda d: d.update(states=["e_m", "e_m", "e_l", "omega_l", "int_e_l"]),
            "states",
        ),
    ],
)
def test_malformed_entries_are_refused_naming_the_key(saved, tmp_path, change, key):
    path = tampered(tmp_path, saved[1], change)
    with pytest.raises(ValueError, match=rf"tampered\.json: key '{key}'"):
        twomass.load_gains(path)


def test_gamma_below_the_true_norm_is_refused(saved, tmp_path):
    design, source = saved
    model = real_model()
    G = model.at(0.0)
    iw, iu = [model.input_labels.index(s) for s in ("Td", "Tm")]
    K = design.gain()
    loop = ct.ss(G.A - G.B[:, [iu]] @ K, G.B[:, [iw]], G.C - G.D[:, [iu]] @ K,
                 G.D[:, [iw]])  # fmt: skip
    true_norm = ct.linfnorm(loop)[0]
    assert true_norm < design.gamma
    path = tampered(tmp_path, source, lambda d: d.update(gamma=0.5 * true_norm))
    with pytest.raises(ValueError, match="'P'.*bounded-real"):
        twomass.load_gains(path)


def test_honest_file_certifies_on_custom_drive_data(tmp_path):
    params = twomass.Parameters(Jl=6.5)
    design = twomass.design(params)
    with pytest.raises(ValueError, match="model: lpv_model"):
        twomass.save_gains(design, tmp_path / "g.json", model=MODEL)
    path = twomass.save_gains(design, tmp_path / "g.json", model={"params": params})
    loaded = twomass.load_gains(path)
    assert loaded.check["certified"] is True
    assert json.loads(path.read_text())["model"]["params"]["Jl"] == 6.5
    # The rebuilt design is the plant with Jl = 6.5: its closed loop at a
    # vertex has the eigenvalues of A - B_u K computed by hand.
    G = twomass.lpv_model(params, (-0.95, 0.0), "tracking", True).at(0.0)
    iu = G.input_labels.index("Tm")
    by_hand = np.sort_complex(np.linalg.eigvals(G.A - G.B[:, [iu]] @ design.gain()))
    np.testing.assert_allclose(
        np.sort_complex(loaded.design.closed_loop(0.0).poles()), by_hand, rtol=1e-9
    )


def test_format_1_needs_its_model_entry(saved, tmp_path):
    def version1(d):
        d["format"] = "ctrl_lpv.twomass.gains/1"
        d["model"].pop("params")

    loaded = twomass.load_gains(tampered(tmp_path, saved[1], version1))
    assert loaded.check["certified"] is True  # rebuilt with the default drive
    path = tampered(tmp_path, saved[1], lambda d: (version1(d), d.pop("model")))
    with pytest.raises(ValueError, match="missing key 'model'"):
        twomass.load_gains(path)


@pytest.mark.parametrize("path, error", [(None, TypeError), (12, TypeError),
                                         (b"g.json", TypeError)])  # fmt: skip
def test_path_of_the_wrong_type_names_path(path, error):
    with pytest.raises(error, match="^path: "):
        twomass.load_gains(path)


def test_unreadable_files_name_path(tmp_path):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 200_000 + "]" * 200_000)
    nan = tmp_path / "nan.json"
    nan.write_text('{"format": "ctrl_lpv.twomass.gains/2", "gamma": NaN}')
    for path, why in ((deep, "nested too deeply"), (nan, "non-finite"),
                      (tmp_path / "missing.json", "no such file"),
                      (tmp_path, "folder")):  # fmt: skip
        with pytest.raises(ValueError, match=f"^path: .*{why}"):
            twomass.load_gains(path)


def test_interrupted_save_leaves_the_old_file(saved, tmp_path, monkeypatch):
    design, source = saved
    path = tmp_path / "g.json"
    path.write_text("old")

    def interrupted(src, dst):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        twomass.save_gains(design, path, model=MODEL)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.json"]
