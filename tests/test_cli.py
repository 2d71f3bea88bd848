"""The ``ctrl-lpv`` command, run as a user would."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ctrl_lpv import twomass
from ctrl_lpv.cli import EXIT_INFEASIBLE, EXIT_USAGE, main

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
    out = tmp_path_factory.mktemp("reproduce")
    code = main(["reproduce", "--out", str(out), "--formats", "png,svg", "-q"])
    return code, out


def test_reproduce_writes_every_artifact(reproduction):
    code, out = reproduction
    assert code == 0
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
    _, out = reproduction
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
    _, out = reproduction
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
    _, out = reproduction
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
