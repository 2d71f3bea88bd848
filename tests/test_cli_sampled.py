"""``ctrl-lpv simulate --controller servo --dt``: the servo as a drive runs it."""

import csv
import json

import numpy as np
import pytest

from ctrl_lpv.cli import EXIT_USAGE, main


def test_sampled_servo_on_encoders_writes_one_row_per_sample(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["simulate", "--controller", "servo", "--dt", "2e-3", "--T", "1.5",
            "--Td", "8", "--theta-r", "0.5", "--seed", "4", "--out", str(out),
            "--formats", "png"]  # fmt: skip
    assert main(argv) == 0
    with open(out / "response.csv") as fh:
        rows = list(csv.reader(fh))
    header, data = rows[0], np.array(rows[1:], dtype=float)
    t = data[:, 0]
    # Samples of the 2 ms controller, not the 1 ms grid of the continuous runs.
    assert np.allclose(np.diff(t), 2e-3)
    assert t[-1] == pytest.approx(1.5)
    theta_l = data[:, header.index("theta_l")]
    torque = data[:, header.index("Tm")]
    # Reached and held the target (issue 22: settling <= 0.3 s at 2 ms).
    tail = t >= 0.3
    assert np.max(np.abs(theta_l[tail] - 0.5)) <= 0.02 * 0.5
    assert abs(theta_l[-1] - 0.5) < 1e-3
    assert np.max(np.abs(torque)) <= 500.0 + 1e-9
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["settling_time"] <= 0.3
    printed = capsys.readouterr().out
    assert "settling time 2 %" in printed
    # The rest over the last half of this 1.5 s run, from the samples written.
    rest = t >= 0.75
    assert metrics["rest_torque_std"] == pytest.approx(np.std(torque[rest]))
    error = 0.5 - theta_l[rest]
    assert metrics["rest_error_peak_to_peak"] == pytest.approx(np.ptp(error))
    assert metrics["rest_max_error"] == pytest.approx(np.abs(error).max())
    assert metrics["units"]["rest_torque_std"] == "Nm"
    assert "at rest: Tm standard deviation" in printed


@pytest.mark.parametrize(
    "argv, named",
    [
        (["--controller", "paper", "--dt", "1e-3"], "--dt"),
        (["--controller", "servo", "--dt", "1e-3", "--model", "deadzone"], "--dt"),
        (["--controller", "servo", "--sensors", "motor"], "--sensors"),
        (["--controller", "servo", "--delay", "0"], "--delay"),
        (["--controller", "servo", "--dt", "0.5"], "--dt"),
        (["--controller", "servo", "--dt", "1e-3", "--delay", "2"], "--delay"),
    ],
)
def test_sampled_options_refused_with_the_option_named(argv, named, capsys):
    try:
        code = main(["simulate", *argv])
    except SystemExit as stop:  # argparse's own refusals
        code = stop.code
    assert code == EXIT_USAGE
    assert named in capsys.readouterr().err
