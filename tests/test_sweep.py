"""Scenario sweeps: table layout, order, failures, executors, Dask."""

import itertools
import math
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

pd = pytest.importorskip("pandas")

from ctrl_lpv import twomass  # noqa: E402
from ctrl_lpv.batch import scenario_grid, sweep  # noqa: E402
from ctrl_lpv.twomass import batch as tsweep  # noqa: E402


# Runners are module level so that worker processes can unpickle them.
def first_order(gain, a, t=1.0):
    """Step response of dx/dt = -(a + gain) x + 1 from 0, at time t."""
    rate = a + gain
    return {"y": (1.0 - math.exp(-rate * t)) / rate, "rate": rate}


def slow_first(gain, a, t=1.0):
    # The first scenarios finish last: the table must not follow completion.
    if a < 1.5:
        time.sleep(0.3)
    return first_order(gain, a, t)


def sometimes_fails(a):
    if a == 0:
        raise ZeroDivisionError("a = 0")
    if a < 0:
        return {"inv": 1.0 / a, "status": "negative"}
    return {"inv": 1.0 / a}


def no_engine(controller, *, params, model, alpha, theta_r, Td, T, npoints):
    raise AssertionError("not reached: the engine is refused before")


def sleepy(a):
    start = time.monotonic()
    while a > 1 and time.monotonic() - start < 60:  # a hung run
        time.sleep(0.01)
    return {"twice": 2 * a}


def no_controller(a, b):
    return {"s": a + b}


def test_grid_order_values_and_columns():
    gains = {"K1": 1.0, "K2": 3.0}
    table = sweep(
        first_order,
        {"a": [0.5, 2.0], "t": [0.1, 1.0]},
        controllers=gains,
        executor="serial",
        progress=False,
    )
    assert list(table.columns) == ["a", "t", "controller", "y", "rate", "status"]
    expected = [
        (a, t, name)
        for (a, t), name in itertools.product(
            itertools.product([0.5, 2.0], [0.1, 1.0]), gains
        )
    ]
    assert list(table[["a", "t", "controller"]].itertuples(False, None)) == expected
    for row in table.itertuples():
        rate = row.a + gains[row.controller]
        assert row.y == pytest.approx((1 - np.exp(-rate * row.t)) / rate, rel=1e-15)
    assert (table["status"] == "ok").all()
    assert table.attrs["sweep"]["runs"] == 8


def test_scenario_grid_and_list_agree():
    grid = scenario_grid(a=[1, 2], b=[10, 20, 30], c=5)
    assert grid == [
        {"a": a, "b": b, "c": 5} for a, b in itertools.product([1, 2], [10, 20, 30])
    ]
    by_dict = sweep(
        no_controller, {"a": [1, 2], "b": [3]}, executor="serial", progress=False
    )
    by_list = sweep(
        no_controller,
        [{"a": 1, "b": 3}, {"a": 2, "b": 3}],
        executor="serial",
        progress=False,
    )
    by_frame = sweep(
        no_controller,
        pd.DataFrame({"a": [1, 2], "b": [3, 3]}),
        executor="serial",
        progress=False,
    )
    pd.testing.assert_frame_equal(by_dict, by_list)
    pd.testing.assert_frame_equal(by_dict, by_frame)
    assert "controller" not in by_dict.columns
    assert by_dict["s"].tolist() == [4, 5]


def test_failures_are_rows_with_nan_metrics():
    with pytest.warns(UserWarning, match="1 of 3 runs failed"):
        table = sweep(
            sometimes_fails, {"a": [2.0, 0.0, -4.0]}, executor="serial", progress=False
        )
    assert table["status"].tolist()[0] == "ok"
    assert table["status"][1].startswith("failed: ZeroDivisionError: a = 0")
    assert table["status"][2] == "negative"
    assert np.isnan(table["inv"][1])
    assert table["inv"].tolist()[::2] == [0.5, -0.25]


def test_processes_keep_the_order_of_scenarios():
    scenarios = {"a": [1.0, 2.0, 3.0, 4.0]}
    gains = {"K1": 0.5, "K2": 1.5}
    serial = sweep(
        slow_first, scenarios, controllers=gains, executor="serial", progress=False
    )
    procs = sweep(
        slow_first,
        scenarios,
        controllers=gains,
        max_workers=2,
        chunksize=2,
        progress=False,
    )
    threads = ThreadPoolExecutor(max_workers=3)
    with threads:
        other = sweep(
            slow_first,
            scenarios,
            controllers=gains,
            executor=threads,
            chunksize=1,
            progress=False,
        )
    pd.testing.assert_frame_equal(serial, procs, check_exact=True)
    pd.testing.assert_frame_equal(serial, other, check_exact=True)
    assert procs.attrs["sweep"]["executor"] == "ProcessPoolExecutor"


@pytest.mark.parametrize("where", ["serial", "processes", "threads"])
def test_timeout_stops_a_hung_run(where):
    kwargs = {"serial": dict(executor="serial"), "processes": dict(max_workers=2)}
    threads = ThreadPoolExecutor(max_workers=2)
    with threads, pytest.warns(UserWarning, match="1 of 3 runs failed"):
        table = sweep(
            sleepy,
            {"a": [1, 2, 1]},
            timeout=0.5,
            progress=False,
            chunksize=3,
            **kwargs.get(where, dict(executor=threads)),
        )
    assert table["status"].tolist() == ["ok", "timeout: run exceeded 0.5 s", "ok"]
    assert table["twice"].tolist()[::2] == [2, 2] and np.isnan(table["twice"][1])


def test_progress_counter_without_tqdm(monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)  # import fails
    sweep(no_controller, {"a": [1, 2, 3], "b": [0]}, executor="serial")
    assert "sweep: 3/3" in capsys.readouterr().err
    sweep(no_controller, {"a": [1], "b": [0]}, executor="serial", progress=False)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        (dict(scenarios=[]), ValueError, "scenarios: no scenario"),
        (dict(scenarios={"a": []}), ValueError, r"scenarios\['a'\]"),
        (dict(scenarios=[{"a": 1}, 3]), TypeError, r"scenarios\[1\]"),
        (dict(scenarios=[{"status": 1}]), ValueError, "reserved"),
        (dict(executor="cluster"), ValueError, "executor"),
        (dict(executor=object()), TypeError, "executor"),
        (dict(max_workers=0), ValueError, "max_workers"),
        (dict(chunksize=1.5), ValueError, "chunksize"),
        (dict(timeout=0), ValueError, "timeout"),
        (dict(controllers=[1.0]), TypeError, "controllers"),
        (dict(run=3), TypeError, "run"),
    ],
)
def test_bad_arguments_are_named(kwargs, error, match):
    args = (
        dict(
            run=no_controller,
            scenarios={"a": [1], "b": [2]},
            progress=False,
            executor="serial",
        )
        | kwargs
    )
    with pytest.raises(error, match=match):
        sweep(args.pop("run"), args.pop("scenarios"), **args)


# -- two-mass adapter ------------------------------------------------------

SHORT = dict(T=0.1, npoints=101)


@pytest.fixture(scope="module")
def designs():
    return twomass.comparison_designs()


@pytest.fixture(scope="module")
def specs(designs):
    return tsweep.comparison_specs(designs)


def test_specs_pickle_and_build_the_same_controllers(designs, specs):
    import pickle

    step = twomass.alpha_step(0.03, 0.045, at=0.05)
    direct = {
        "paper K": twomass.lpv_controller(torque_limit=2000.0),
        "LPV robust": twomass.lpv_controller(
            designs["LPV robust"], torque_limit=2000.0
        ),
        "LPV scheduled": twomass.lpv_controller(
            designs["LPV scheduled"], alpha_estimate=0.03, torque_limit=2000.0
        ),
        "backstepping": twomass.backstepping_controller(
            Td_hat=8.0, torque_limit=2000.0
        ),
    }
    assert list(specs) == list(direct)
    for name, spec in specs.items():
        clone = pickle.loads(pickle.dumps(spec))
        assert clone == spec
        built = clone.build(torque_limit=2000.0)
        ours = twomass.simulate(built, alpha=step, engine="fast", **SHORT)
        ref = twomass.simulate(direct[name], alpha=step, engine="fast", **SHORT)
        np.testing.assert_array_equal(ours.outputs, ref.outputs, err_msg=name)


# twomass.sweep simulates with the "auto" engine (compiled where numba is
# installed, else fast) unless told otherwise.
@pytest.mark.parametrize(
    "engine, used", [(None, "auto"), ("fast", "fast"), ("control", "control")]
)
def test_run_scenario_matches_a_direct_simulation(designs, specs, engine, used):
    scenario = dict(
        alpha=0.02,
        alpha_after=0.05,
        alpha_at=0.05,
        Td=3.0,
        theta_r=0.4,
        torque_limit=1500.0,
        Jl_scale=1.2,
        cs=3.0,
        **SHORT,
    )
    table = tsweep.sweep(
        [scenario],
        {"LPV scheduled": specs["LPV scheduled"]},
        engine=engine,
        executor="serial",
        progress=False,
    )
    params = twomass.Parameters().replace(Jl=5.6 * 1.2, cs=3.0)
    controller = twomass.lpv_controller(
        designs["LPV scheduled"], alpha_estimate=0.03, torque_limit=1500.0
    )
    response = twomass.simulate(
        controller,
        params=params,
        alpha=twomass.alpha_step(0.02, 0.05, at=0.05),
        Td=3.0,
        theta_r=0.4,
        engine=used,
        **SHORT,
    )
    expected = twomass.metrics(response, 0.4).as_dict()
    row = table.iloc[0]
    for key, value in expected.items():
        assert row[key] == value or (np.isnan(value) and np.isnan(row[key])), key
    assert row["peak_input"] <= 1500.0
    assert row["Jl_scale"] == 1.2 and row["controller"] == "LPV scheduled"


def test_run_scenario_status_and_keys():
    # 20 ms after the step the load has not moved: flagged at the final time.
    result = tsweep.run_scenario(tsweep.lpv_spec(), T=0.02)
    assert result["status"] == "diverged"
    with pytest.raises(TypeError, match="'Jx_scale'"):
        tsweep.sweep({"Jx_scale": [1.0]}, {"K": tsweep.lpv_spec()}, progress=False)
    with pytest.raises(TypeError, match="engine"):
        tsweep.run_scenario(tsweep.lpv_spec(), engine="warp", simulate=no_engine)
    with pytest.raises(ValueError, match="alpha_estimate"):
        tsweep.lpv_spec(alpha_estimate=0.03)  # a common gain is not scheduled


def test_dask_local_cluster_matches_local_processes(specs):
    distributed = pytest.importorskip("distributed")
    scenarios = {"alpha": [0.0, 0.045], "Jl_scale": [0.8, 1.2], **SHORT}
    chosen = {k: specs[k] for k in ("LPV scheduled", "backstepping")}
    local = tsweep.sweep(
        scenarios, chosen, engine="fast", max_workers=2, progress=False
    )
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        remote = tsweep.sweep(
            scenarios,
            chosen,
            engine="fast",
            executor=client.get_executor(),
            progress=False,
        )
    assert len(remote) == 8 and not remote["status"].str.startswith("failed").any()
    assert remote.attrs["sweep"]["executor"] == "ClientExecutor"
    pd.testing.assert_frame_equal(
        local, remote, check_exact=False, rtol=1e-12, atol=0.0
    )
