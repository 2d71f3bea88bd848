"""The ``ctrl-lpv`` command, run as a user would."""

import contextlib
import io
import json
import shutil
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from ctrl_lpv import twomass
from ctrl_lpv.cli import EXIT_INFEASIBLE, EXIT_INTERRUPTED, EXIT_USAGE, main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
P = twomass.Parameters()


def published_gain_equilibrium(alpha, Td=8.0, theta_r=0.5):
    """Load angle at rest under the published gain (no integral action).

    At rest the load needs Ts = Td: the shaft is in contact with
    theta_d = alpha + Td / ks, and Td = -(K1 (e_l + theta_d) + K3 e_l).
    """
    K = twomass.paper_gain()
    K1, K3 = K[0, 0], K[0, 2]
    theta_d = alpha + Td / P.ks
    return theta_r - (Td + K1 * theta_d) / (K1 + K3)


@pytest.fixture(scope="module")
def reproduction(tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce") / "results"
    stdout, stderr = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(stdout), contextlib.redirect_stderr(stderr):
        code = main(["reproduce", "--out", str(out), "--formats", "png,svg", "-q"])
    return code, out, stdout.getvalue() + stderr.getvalue()


def test_reproduce_writes_every_artifact(reproduction):
    code, out, printed = reproduction
    assert code == 0
    assert printed == ""  # -q: nothing at all
    # Written atomically: no temporary folder left beside the result.
    assert sorted(p.name for p in out.parent.iterdir()) == ["results"]
    stems = [
        "coordinates",
        "paper_gain",
        "designs",
        "alpha_step",
        "backstepping",
        "torque_limit",
    ]
    for stem in stems:
        assert (out / f"{stem}.png").read_bytes()[:8] == PNG_MAGIC
        assert b"<svg" in (out / f"{stem}.svg").read_bytes()[:500]
    report = (out / "report.md").read_text()
    for stem in stems:
        assert f"({stem}.png)" in report
    for name in (
        "errata.json",
        "comparison.json",
        "comparison.md",
        "design_robust.json",
        "design_scheduled.json",
    ):
        assert (out / name).stat().st_size > 0


def test_reproduce_errata_agree_with_independent_facts(reproduction):
    _, out, _ = reproduction
    errata = json.loads((out / "errata.json").read_text())
    # p = -1: the published gain leaves the uncontrollable mode at 0.
    poles = np.array(errata["eigenvalues"]["-1"])
    assert np.min(np.hypot(poles[:, 0], poles[:, 1])) < 1e-8
    for p in ("-0.95", "0"):
        assert max(re for re, _ in errata["eigenvalues"][p]) < 0
    assert "vertex 0" in errata["infeasible"]
    assert "eigenvalue 0" in errata["infeasible"]
    reading = errata["coordinates"]["x1 = theta_m - theta_r"]
    assert reading["theta_l_5s"] == pytest.approx(
        published_gain_equilibrium(0.03), abs=1e-4
    )
    assert errata["coordinates"]["x1 = theta_m"]["rise_time"] is None


def test_reproduce_comparison_table(reproduction):
    _, out, _ = reproduction
    rows = json.loads((out / "comparison.json").read_text())
    controllers = {"paper K", "LPV robust", "LPV scheduled", "backstepping"}
    scenarios = {"paper", "paper alpha step", "Tmax=2000", "Tmax=500"}
    assert {(r["scenario"], r["controller"]) for r in rows} == {
        (s, c) for s in scenarios for c in controllers
    }
    assert all(r["status"] == "ok" for r in rows)
    for r in rows:
        if r["torque_limit"] is not None:
            assert r["peak_input"] <= r["torque_limit"] + 1e-9
        if r["controller"].startswith("LPV"):  # integral action against Td
            assert abs(r["steady_state_error"]) < 1e-3
    paper = next(
        r for r in rows if r["scenario"] == "paper" and r["controller"] == "paper K"
    )
    assert 0.5 - paper["steady_state_error"] == pytest.approx(
        published_gain_equilibrium(0.03), abs=1e-4
    )
    table = (out / "comparison.md").read_text().splitlines()
    assert len(table) == 2 + len(rows)


def test_saved_designs_stabilize_the_model(reproduction):
    _, out, _ = reproduction
    model = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    iu = model.input_labels.index("Tm")
    for name in ("design_robust.json", "design_scheduled.json"):
        gains = twomass.load_gains(out / name)
        assert gains.states == tuple(model.state_labels)
        for p in np.linspace(-0.95, 0.0, 7):
            G = model.at(p)
            poles = np.linalg.eigvals(G.A - G.B[:, [iu]] @ gains.gain(p))
            assert poles.real.max() < 0


def test_design_save_then_simulate(tmp_path, capsys):
    path = tmp_path / "gains.json"
    assert main(["design", "--scheduled", "--save", str(path)]) == 0
    printed = capsys.readouterr().out
    assert "Theorem 2" in printed and "verified" in printed
    saved = twomass.load_gains(path)
    assert saved.scheduled and saved.gains.shape == (2, 1, 5)
    assert list(saved.p_vertices) == [-0.95, 0.0]
    run = tmp_path / "run"
    code = main(
        [
            "simulate",
            "--controller",
            str(path),
            "--T",
            "1",
            "--out",
            str(run),
            "--formats",
            "png",
        ]
    )
    assert code == 0
    data = np.loadtxt(run / "response.csv", delimiter=",", skiprows=1)
    header = (run / "response.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["time", "theta_l", "Tm"]
    assert data[0, 0] == 0.0 and data[-1, 0] == pytest.approx(1.0)
    assert (run / "response.png").read_bytes()[:8] == PNG_MAGIC
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["peak_input"] == pytest.approx(np.abs(data[:, 2]).max())


def test_simulate_engines_give_the_same_response(tmp_path):
    csv = {}
    for engine in ("control", "fast"):
        out = tmp_path / engine
        argv = ["simulate", "--controller", "paper", "--alpha", "0.03", "--T", "1"]
        assert (
            main(argv + ["--engine", engine, "--out", str(out), "--formats", "png"])
            == 0
        )
        csv[engine] = np.loadtxt(out / "response.csv", delimiter=",", skiprows=1)
    control, fast = csv["control"], csv["fast"]
    np.testing.assert_array_equal(fast[:, 0], control[:, 0])
    assert np.abs(fast[:, 1] - control[:, 1]).max() <= 1e-6  # theta_l, rad


def test_saved_scheduled_gains_give_the_design_controller(tmp_path):
    design = twomass.design(scheduled=True)
    path = twomass.save_gains(design, tmp_path / "g.json")
    loaded = twomass.load_gains(path)
    for p in (-0.95, -0.5, -0.1, 0.0):
        np.testing.assert_allclose(loaded.gain(p), design.gain(p), rtol=1e-12)
    kwargs = dict(alpha=0.03, T=1.0, npoints=101)
    a = twomass.simulate(loaded.controller(alpha_estimate=0.03), **kwargs)
    b = twomass.simulate(twomass.lpv_controller(design, alpha_estimate=0.03), **kwargs)
    np.testing.assert_allclose(
        np.asarray(a.outputs), np.asarray(b.outputs), rtol=1e-9, atol=1e-9
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["design", "--p-min", "0", "--p-max", "-0.5"],
        ["design", "--p-min", "-1.5"],
        ["design", "--backoff", "-1"],
        ["design", "--torque-weight", "nan"],
        ["design", "--formulation", "other"],
        ["simulate", "--controller", "no-such-controller"],
        ["simulate", "--alpha", "-0.1"],
        ["simulate", "--alpha-step", "0.045"],
        ["simulate", "--T", "0"],
        ["simulate", "--alpha-estimate", "-1"],
        ["simulate", "--alpha-estimate", "0.03"],  # the paper gain is common
        ["simulate", "--controller", "robust", "--alpha-estimate", "0.03"],
        ["simulate", "--controller", "backstepping", "--alpha-estimate", "0.03"],
        ["simulate", "--alpha-step", "0.045@6", "--T", "5"],
        ["simulate", "--alpha-step", "0.045@5", "--T", "5"],
        ["reproduce"],
        ["frobnicate"],
    ],
)
def test_bad_options_exit_2_with_a_message(argv, capsys):
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's own usage errors
        code = exc.code
    assert code == EXIT_USAGE
    err = capsys.readouterr().err
    assert "error" in err


def test_infeasible_design_exits_3(capsys):
    code = main(["design", "--formulation", "paper", "--p-min", "-1"])
    assert code == EXIT_INFEASIBLE
    assert "not stabilizable" in capsys.readouterr().err


def test_help_lists_commands(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    for command in ("reproduce", "design", "simulate", "exit codes"):
        assert command in text


def test_installed_entry_point_runs():
    """The console script (installed by pip) and ``python -m ctrl_lpv``."""
    script = shutil.which("ctrl-lpv", path=str(Path(sys.executable).parent))
    commands = [[sys.executable, "-m", "ctrl_lpv", "--version"]]
    if script:
        commands.append([script, "--version"])
    for command in commands:
        result = subprocess.run(command, capture_output=True, text=True, check=True)
        assert result.stdout.startswith("ctrl-lpv ")


# ----------------------------------------------------------------------
# Atomic reproduce, Ctrl-C, lazy imports
# ----------------------------------------------------------------------
def interrupted_reproduce(monkeypatch, capsys, out):
    """``reproduce`` interrupted after the errata files were written."""
    import importlib

    # The module (the package's attribute of that name is the function).
    module = importlib.import_module("ctrl_lpv.twomass.reproduce")

    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(module, "comparison_designs", interrupt)
    code = main(["reproduce", "--out", str(out), "--engine", "fast"])
    return code, capsys.readouterr()


def test_ctrl_c_during_reproduce_exits_130_and_leaves_nothing(
    tmp_path, monkeypatch, capsys
):
    out = tmp_path / "results"
    code, printed = interrupted_reproduce(monkeypatch, capsys, out)
    assert code == EXIT_INTERRUPTED == 130
    lines = printed.err.splitlines()
    assert lines[-1] == "ctrl-lpv: interrupted"
    assert all(line.startswith("[") for line in lines[:-1])  # progress only
    assert "Traceback" not in printed.err
    assert list(tmp_path.iterdir()) == []  # no half-written or temporary folder


def test_ctrl_c_keeps_a_previous_reproduction(tmp_path, monkeypatch, capsys):
    out = tmp_path / "results"
    out.mkdir()
    (out / "report.md").write_text("previous run\n")
    code, _ = interrupted_reproduce(monkeypatch, capsys, out)
    assert code == 130
    assert [p.name for p in tmp_path.iterdir()] == ["results"]
    assert [p.name for p in out.iterdir()] == ["report.md"]
    assert (out / "report.md").read_text() == "previous run\n"


def test_reproduce_refuses_a_folder_of_other_files(tmp_path, capsys):
    (tmp_path / "thesis.tex").write_text("keep me\n")
    assert main(["reproduce", "--out", str(tmp_path), "-q"]) == EXIT_USAGE
    assert "--out" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["thesis.tex"]


HEAVY = ("control", "cvxpy", "matplotlib", "scipy")


def imported_after(code: str) -> list[str]:
    """Heavy modules imported by `code`, run in a fresh interpreter."""
    script = (
        "import sys\n"
        + code
        + f"\nprint('HEAVY=' + ','.join(m for m in {HEAVY!r} if m in sys.modules))\n"
    )
    result = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, check=True
    )
    line = result.stdout.splitlines()[-1]
    assert line.startswith("HEAVY="), result.stdout
    return [m for m in line.removeprefix("HEAVY=").split(",") if m]


@pytest.mark.parametrize("option", ["--version", "--help"])
def test_version_and_help_import_no_heavy_module(option):
    code = (
        "import runpy\n"
        f"sys.argv = ['ctrl-lpv', {option!r}]\n"
        "try:\n"
        "    runpy.run_module('ctrl_lpv', run_name='__main__', alter_sys=True)\n"
        "except SystemExit as exc:\n"
        "    assert exc.code == 0, exc.code\n"
    )
    assert imported_after(code) == []


def test_package_imports_lazily_and_exports_everything():
    code = (
        "import ctrl_lpv, ctrl_lpv.twomass, ctrl_lpv.cli\n"
        "assert 'hinf_state_feedback' in dir(ctrl_lpv)\n"
        "assert set(ctrl_lpv.twomass.__all__) <= set(dir(ctrl_lpv.twomass))\n"
    )
    assert imported_after(code) == []
    code = (
        "import ctrl_lpv, ctrl_lpv.twomass\n"
        "ns = {}\n"
        "exec('from ctrl_lpv import *', ns)\n"
        "assert set(ctrl_lpv.__all__) <= set(ns), set(ctrl_lpv.__all__) - set(ns)\n"
        "ns = {}\n"
        "exec('from ctrl_lpv.twomass import *', ns)\n"
        "assert set(ctrl_lpv.twomass.__all__) <= set(ns)\n"
        "assert callable(ctrl_lpv.hinf_state_feedback)\n"
        # A function named like its module keeps the name after the import.
        "import ctrl_lpv.twomass.reproduce, ctrl_lpv.twomass.plant\n"
        "assert callable(ctrl_lpv.twomass.reproduce), ctrl_lpv.twomass.reproduce\n"
        "assert callable(ctrl_lpv.twomass.plant)\n"
        "assert ctrl_lpv.lmi.__name__ == 'ctrl_lpv.lmi'\n"
        "assert not hasattr(ctrl_lpv, 'no_such_name')\n"
    )
    assert "control" in imported_after(code)


# ----------------------------------------------------------------------
# Gain files: validated and re-checked on load
# ----------------------------------------------------------------------
MODEL = {"p_bounds": [-0.95, 0.0], "formulation": "tracking", "integral": True}


@pytest.fixture(scope="module")
def gain_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gains")
    files = {}
    for scheduled in (False, True):
        design = twomass.design(scheduled=scheduled)
        path = folder / f"{'scheduled' if scheduled else 'robust'}.json"
        twomass.save_gains(design, path, model=MODEL)
        files[scheduled] = (design, path)
    return files


def tampered(tmp_path, source, change, name="tampered.json"):
    document = json.loads(source.read_text())
    change(document)
    path = tmp_path / name
    path.write_text(json.dumps(document))
    return path


def frozen_hinf_lower_bound(K, p):
    """max over a frequency grid of sigma_max of the closed loop at p (w = Td)."""
    model = twomass.lpv_model(
        p_bounds=(-0.95, 0.0), formulation="tracking", integral=True
    )
    G = model.at(p)
    iw, iu = model.input_labels.index("Td"), model.input_labels.index("Tm")
    A = G.A - G.B[:, [iu]] @ K
    B = G.B[:, [iw]]
    C = G.C - G.D[:, [iu]] @ K
    D = G.D[:, [iw]]
    n = A.shape[0]
    return max(
        np.linalg.norm(C @ np.linalg.solve(1j * w * np.eye(n) - A, B) + D, 2)
        for w in np.concatenate([[0.0], np.logspace(-3, 4, 3000)])
    )


@pytest.mark.parametrize("scheduled", [False, True])
def test_valid_gain_file_is_rechecked_and_certified(gain_files, scheduled):
    design, path = gain_files[scheduled]
    loaded = twomass.load_gains(path)
    assert loaded.check["certified"] is True
    assert loaded.check["max_closed_loop_real"] < 0
    assert loaded.check["lyapunov_max_eig"] < -loaded.check["rounding_bound"]
    for p in (-0.95, -0.3, 0.0):
        np.testing.assert_allclose(loaded.gain(p), design.gain(p), rtol=1e-12)
    # The certified gamma bounds the frozen H-infinity norms from above.
    for p in (-0.95, 0.0):
        assert frozen_hinf_lower_bound(loaded.gain(p), p) < loaded.gamma


def test_missing_gains_key_names_the_file_and_key(gain_files, tmp_path, capsys):
    path = tampered(tmp_path, gain_files[True][1], lambda d: d.pop("gains"))
    with pytest.raises(ValueError, match=r"tampered\.json.*'gains'"):
        twomass.load_gains(path)
    code = main(["simulate", "--controller", str(path), "--T", "0.1"])
    assert code == EXIT_USAGE
    err = capsys.readouterr().err
    assert "'gains'" in err and "Traceback" not in err


def test_sign_u_eq_Kx_is_honoured(gain_files, tmp_path):
    design, source = gain_files[True]

    def paper_sign(d):
        d["sign"] = "u = K x"
        d["gains"] = (-np.array(d["gains"])).tolist()

    loaded = twomass.load_gains(tampered(tmp_path, source, paper_sign))
    np.testing.assert_allclose(loaded.gain(-0.5), design.gain(-0.5), rtol=1e-12)


def test_sign_flipped_without_the_gains_is_refused(gain_files, tmp_path):
    # "u = K x" with python-control's gains: u = +K x destabilizes (the
    # closed loop A + B K has an eigenvalue with positive real part).
    design, source = gain_files[False]
    G = twomass.lpv_model(p_bounds=(-0.95, 0.0), formulation="tracking", integral=True)
    frozen = G.at(0.0)
    iu = G.input_labels.index("Tm")
    wrong = frozen.A + frozen.B[:, [iu]] @ design.gain()
    assert np.linalg.eigvals(wrong).real.max() > 0
    path = tampered(tmp_path, source, lambda d: d.update(sign="u = K x"))
    with pytest.raises(ValueError, match="not stable"):
        twomass.load_gains(path)
    path = tampered(tmp_path, source, lambda d: d.update(sign="u = +K x"))
    with pytest.raises(ValueError, match="'sign'"):
        twomass.load_gains(path)


@pytest.mark.parametrize(
    "change, key",
    [
        (lambda d: d.update(p_vertices=[-1.5, 0.0]), "p_vertices"),
        (lambda d: d.update(p_vertices=[0.0, -0.95]), "p_vertices"),
        (lambda d: d.update(p_vertices=[-0.5, 0.0]), "p_vertices"),
        (lambda d: d["states"].__setitem__(0, "theta_m"), "states"),
        (lambda d: d.update(states=d["states"][::-1]), "states"),
        (lambda d: d.update(gains=[[[1.0, 2.0]]]), "gains"),
        (lambda d: d.update(gains="many"), "gains"),
        (lambda d: d.update(u=["Td"]), "u"),
        (lambda d: d.update(P=(-np.array(d["P"])).tolist()), "P"),
        (lambda d: d.update(model={"formulation": "paper"}), "model.params"),
        (lambda d: d["model"].update(torque_weight=1.0), "P"),
    ],
)
def test_inconsistent_gain_file_is_refused(gain_files, tmp_path, change, key):
    path = tampered(tmp_path, gain_files[True][1], change)
    with pytest.raises(ValueError, match=rf"tampered\.json.*'{key}'"):
        twomass.load_gains(path)


def test_verified_flag_is_not_trusted(gain_files, tmp_path):
    design, source = gain_files[False]

    def destabilize(d):
        d["gains"] = (-np.array(d["gains"])).tolist()
        d["certificate"]["verified"] = True

    with pytest.raises(ValueError, match="not stable"):
        twomass.load_gains(tampered(tmp_path, source, destabilize))
    # A gamma below a frozen H-infinity norm cannot be certified by any P.
    K = design.gain()
    below = 0.99 * max(frozen_hinf_lower_bound(K, p) for p in (-0.95, 0.0))
    assert below < design.gamma
    path = tampered(tmp_path, source, lambda d: d.update(gamma=below))
    with pytest.raises(ValueError, match="bounded-real inequality"):
        twomass.load_gains(path)


def test_file_without_certificate_data_warns(gain_files, tmp_path):
    def old_format(d):
        d.pop("P")

    path = tampered(tmp_path, gain_files[True][1], old_format)
    with pytest.warns(UserWarning, match="no Lyapunov matrix"):
        loaded = twomass.load_gains(path)
    assert loaded.check["certified"] is False
    assert loaded.check["max_closed_loop_real"] < 0


def test_common_gain_file_refuses_alpha_estimate(gain_files, capsys):
    _, path = gain_files[False]
    code = main(
        ["simulate", "--controller", str(path), "--alpha-estimate", "0.03", "--T", "1"]
    )
    assert code == EXIT_USAGE
    assert "--alpha-estimate" in capsys.readouterr().err


def test_gain_outside_the_interval_is_refused(gain_files):
    loaded = twomass.load_gains(gain_files[True][1])
    with pytest.raises(ValueError, match="p: "):
        loaded.gain(0.5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loaded.gain(0.0)


def test_reproduce_servo_comparison(reproduction):
    _, out, _ = reproduction
    for stem in ("servo_500", "servo_2000"):
        assert (out / f"{stem}.png").read_bytes()[:8] == PNG_MAGIC
    rows = json.loads((out / "servo_comparison.json").read_text())
    assert (out / "servo_comparison.md").stat().st_size > 0
    by = {(r["torque_limit"], r["controller"]): r for r in rows}
    for limit in (500.0, 2000.0):
        servo = by[limit, "servo"]
        assert servo["peak_torque"] <= limit + 1e-9
        assert servo["peak_command"] <= limit + 1e-9
        # The published K has no integral action: it rests off target under Td.
        published = by[limit, "published K"]
        assert servo["error_5s"] < 1e-5 < published["error_5s"]
        settle = published["settling"]
        assert servo["settling"] < (settle if settle is not None else np.inf)
