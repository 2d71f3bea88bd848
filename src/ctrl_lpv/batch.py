"""Scenario sweeps on local processes or any `concurrent.futures` executor.

`sweep` runs a picklable function over a list or a grid of scenarios, for
one or several controllers, and collects the metrics in a tidy
`pandas.DataFrame` (one row per controller and scenario). The work is cut
into chunks and sent to an executor: local processes by default, a Dask
cluster when given ``Client.get_executor()``. The rows come back in the
order of the scenarios whatever the executor, so results compare exactly.
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import math
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["sweep", "scenario_grid"]

#: Columns the engine adds to every table.
CONTROLLER = "controller"
STATUS = "status"

# Chunks per worker: enough to balance uneven run times (a stiff scenario
# can cost 20 times the median) and to move the progress bar, few enough
# that pickling and scheduling (~1 ms per task locally, more on Dask) stay
# small against the simulations.
_CHUNKS_PER_WORKER = 16


def scenario_grid(**values: Sequence[Any]) -> list[dict[str, Any]]:
    """Cartesian product of scenario values, as a list of dicts.

    The last keyword varies fastest, as in `itertools.product`.

    Parameters
    ----------
    **values : sequence
        Values of each scenario variable. A scalar (or string) is a single
        value.

    Returns
    -------
    list of dict
        One dict per combination.

    Raises
    ------
    ValueError
        If a sequence is empty.

    Examples
    --------
    >>> scenario_grid(alpha=[0.0, 0.03], Td=8.0)
    [{'alpha': 0.0, 'Td': 8.0}, {'alpha': 0.03, 'Td': 8.0}]
    """
    axes = {}
    for key, value in values.items():
        if isinstance(value, str | bytes) or not isinstance(value, Iterable):
            value = [value]
        axes[key] = list(value)
        if not axes[key]:
            raise ValueError(f"scenarios[{key!r}]: expected at least one value")
    return [dict(zip(axes, combo)) for combo in itertools.product(*axes.values())]


def _as_scenarios(scenarios) -> list[dict[str, Any]]:
    """Normalize a list of dicts, a dict of lists or a DataFrame."""
    if hasattr(scenarios, "to_dict") and hasattr(scenarios, "columns"):
        scenarios = scenarios.to_dict("records")  # a pandas DataFrame
    if isinstance(scenarios, Mapping):
        out = scenario_grid(**scenarios)
    elif isinstance(scenarios, Iterable) and not isinstance(scenarios, str | bytes):
        out = []
        for i, item in enumerate(scenarios):
            if not isinstance(item, Mapping):
                raise TypeError(
                    f"scenarios[{i}]: expected a dict of scenario values, "
                    f"got {type(item).__name__}"
                )
            out.append(dict(item))
    else:
        raise TypeError(
            "scenarios: expected a list of dicts or a dict of lists, "
            f"got {type(scenarios).__name__}"
        )
    if not out:
        raise ValueError("scenarios: no scenario to run")
    for i, item in enumerate(out):
        bad = [k for k in item if not isinstance(k, str)]
        if bad:
            raise TypeError(f"scenarios[{i}]: keys must be strings, got {bad!r}")
        clash = {CONTROLLER, STATUS} & set(item)
        if clash:
            raise ValueError(
                f"scenarios[{i}]: {sorted(clash)} are reserved column names"
            )
    return out


class _RunTimeout(BaseException):
    """A run exceeded the `timeout` of `sweep` (reported as its status).

    A `BaseException`, like `KeyboardInterrupt`, so that an ``except
    Exception`` inside the run does not swallow it.
    """

    def __str__(self) -> str:
        return "timeout"


def _interrupt(thread_id: int, exc) -> None:
    """Raise `exc` in a thread at its next bytecode (None: cancel)."""
    ctypes.pythonapi.PyThreadState_SetAsyncExc(
        ctypes.c_ulong(thread_id), ctypes.py_object(exc) if exc else None
    )


@contextlib.contextmanager
def _time_limit(seconds: float | None):
    """Raise `_RunTimeout` in the block after `seconds` of wall time.

    A timer thread raises the exception asynchronously in the calling
    thread, which works in any thread (process pools, Dask worker threads),
    unlike SIGALRM. Python code, such as an ODE right-hand side called by
    the solver, is interrupted at its next bytecode.
    """
    if seconds is None or not hasattr(ctypes, "pythonapi"):
        yield
        return
    target = threading.get_ident()
    lock = threading.Lock()
    state = {"active": True, "fired": False}

    def expire():
        with lock:
            if state["active"]:
                state["fired"] = True
                _interrupt(target, _RunTimeout)

    timer = threading.Timer(seconds, expire)
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        with lock:
            state["active"] = False
        timer.cancel()
        if state["fired"]:
            # Fired as the block ended: do not let it escape into the caller.
            _interrupt(target, None)


def _run_chunk(run, items, timeout=None) -> list[tuple[int, dict | None, str]]:
    """Worker side: run the items of one chunk, never raise for one item.

    A failing simulation becomes a row with its error as status, so that
    one bad scenario does not lose the whole sweep.
    """
    out = []
    for index, spec, has_spec, scenario in items:
        try:
            with _time_limit(timeout):
                result = run(spec, **scenario) if has_spec else run(**scenario)
            if not isinstance(result, Mapping):
                raise TypeError(
                    f"run: expected a dict of metrics, got {type(result).__name__}"
                )
            result = dict(result)
            status = str(result.pop(STATUS, "ok"))
            out.append((index, result, status))
        except _RunTimeout:
            out.append((index, None, f"timeout: run exceeded {timeout:g} s"))
        except Exception as exc:  # noqa: BLE001 -- reported as the row's status
            out.append((index, None, f"failed: {type(exc).__name__}: {exc}"))
    return out


class _Progress:
    """tqdm bar if installed, else a plain counter on stderr."""

    def __init__(self, total: int, enabled: bool, desc: str = "sweep"):
        self.total, self.done, self.bar, self.enabled = total, 0, None, enabled
        self._last = 0.0
        if not enabled:
            return
        try:
            from tqdm.auto import tqdm
        except ImportError:
            return
        self.bar = tqdm(total=total, desc=desc, unit="run", file=sys.stderr)

    def update(self, n: int) -> None:
        self.done += n
        if self.bar is not None:
            self.bar.update(n)
        elif self.enabled:
            now = time.monotonic()
            # Throttle: a line per 0.5 s is readable and costs nothing.
            if now - self._last > 0.5 or self.done == self.total:
                self._last = now
                end = "\n" if self.done == self.total else ""
                print(
                    f"\rsweep: {self.done}/{self.total}",
                    end=end,
                    file=sys.stderr,
                    flush=True,
                )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _workers(executor) -> int:
    """Best guess of the executor's parallelism, for chunking only."""
    count = getattr(executor, "_max_workers", None)  # concurrent.futures pools
    client = getattr(executor, "_client", None)  # distributed.ClientExecutor
    if count is None and client is not None:
        try:
            count = sum(client.nthreads().values())
        except Exception:  # noqa: BLE001 -- only a chunking hint
            count = None
    return max(1, int(count or os.cpu_count() or 1))


def _table(scenarios, names, with_controller, results):
    """Assemble the tidy DataFrame in item order."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError(
            "ctrl_lpv.sweep needs pandas for its result table: pip install pandas"
        ) from None
    scenario_cols = list(dict.fromkeys(k for s in scenarios for k in s))
    metric_cols = list(dict.fromkeys(k for r, _ in results if r is not None for k in r))
    clash = set(metric_cols) & (set(scenario_cols) | {CONTROLLER})
    if clash:
        raise ValueError(
            f"run: returned metric(s) {sorted(clash)} named like scenario columns"
        )
    rows = []
    for (scenario, name), (result, status) in zip(
        itertools.product(scenarios, names), results
    ):
        row = {k: scenario.get(k, math.nan) for k in scenario_cols}
        if with_controller:
            row[CONTROLLER] = name
        result = result or {}
        row.update({k: result.get(k, math.nan) for k in metric_cols})
        row[STATUS] = status
        rows.append(row)
    columns = scenario_cols + ([CONTROLLER] if with_controller else [])
    return pd.DataFrame(rows, columns=columns + metric_cols + [STATUS])


def sweep(
    run: Callable[..., Mapping[str, Any]],
    scenarios: Sequence[Mapping[str, Any]] | Mapping[str, Sequence[Any]],
    *,
    controllers: Mapping[Hashable, Any] | None = None,
    executor: Executor | str | None = None,
    max_workers: int | None = None,
    progress: bool = True,
    chunksize: int | None = None,
    timeout: float | None = None,
) -> pd.DataFrame:
    """Run many scenarios and collect their metrics in a table.

    Parameters
    ----------
    run : callable
        ``run(spec, **scenario) -> dict`` of metrics for one controller spec
        and one scenario (``run(**scenario)`` without `controllers`). For
        process and cluster executors it must pickle: a module-level function
        or a `functools.partial` of one. It may return a ``"status"`` entry
        (default ``"ok"``). If it raises, the row gets status ``"failed:
        <error>"`` and NaN metrics.
    scenarios : list of dict, dict of lists, or DataFrame
        The scenarios: keyword arguments of `run`. A dict of lists is the
        Cartesian grid of its values (`scenario_grid`).
    controllers : dict, optional
        Controller name -> spec passed as first argument of `run`. Specs
        are sent to the workers, so they must pickle: a gain array, a small
        dataclass, a parameter tuple, not a python-control I/O system built
        with closures. Build the system inside `run` (and cache it there).
    executor : `concurrent.futures.Executor`, "processes" or "serial", optional
        Where to run. Default (None or "processes"): a
        `~concurrent.futures.ProcessPoolExecutor` with `max_workers`
        processes, shut down at the end. "serial": in this process, no
        pickling (for debugging). Any other executor is used as given and
        left open, e.g. a Dask cluster's ``Client.get_executor()``.
    max_workers : int, optional
        Processes of the default executor, default ``os.cpu_count()``;
        1 runs serially.
    progress : bool, optional
        Show a progress bar (tqdm if installed, else a counter on stderr).
    chunksize : int, optional
        Runs per task; default about 16 tasks per worker.
    timeout : float, optional
        Wall-time limit of one run, s: a run that exceeds it is stopped and
        gets status ``"timeout: ..."`` and NaN metrics, so that a stiff or
        chattering simulation does not hold up the sweep. It interrupts
        Python code (an ODE right-hand side, say) with any executor, not a
        long call into compiled code.

    Returns
    -------
    `pandas.DataFrame`
        One row per scenario and controller, scenarios in the given order
        and controllers in dict order within each scenario (independent of
        the executor). Columns: the scenario keys, ``"controller"`` (with
        `controllers`), the metrics returned by `run` (NaN for failed runs)
        and ``"status"``. ``DataFrame.attrs["sweep"]`` holds the wall time
        and the executor.

    Raises
    ------
    TypeError, ValueError
        For malformed `scenarios`, `controllers`, `executor`, `max_workers`
        or `chunksize`.
    ImportError
        If pandas is not installed.

    Warns
    -----
    UserWarning
        If some runs failed or timed out (their status says why).

    Notes
    -----
    On a Dask cluster, pass the executor of a `distributed.Client`; the
    package must be importable on the workers::

        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=4, threads_per_worker=1) as cluster, \\
                Client(cluster) as client:
            table = sweep(run, scenarios, executor=client.get_executor())

    For a remote cluster use ``Client("tcp://scheduler:8786")``. Use one
    thread per worker: simulations hold the GIL.

    Examples
    --------
    >>> def run(gain, a):   # module-level in real use, for pickling
    ...     return {"pole": -a - gain}
    >>> table = sweep(run, {"a": [1.0, 2.0]}, controllers={"K1": 1.0},
    ...               executor="serial", progress=False)
    >>> table[["a", "controller", "pole", "status"]].values.tolist()
    [[1.0, 'K1', -2.0, 'ok'], [2.0, 'K1', -3.0, 'ok']]
    """
    if not callable(run):
        raise TypeError(f"run: expected a callable, got {type(run).__name__}")
    scenarios = _as_scenarios(scenarios)
    if controllers is None:
        names, specs = [None], [None]
    elif isinstance(controllers, Mapping) and controllers:
        names, specs = list(controllers), list(controllers.values())
    else:
        raise TypeError("controllers: expected a non-empty dict name -> spec")
    if max_workers is not None and (
        isinstance(max_workers, bool) or not isinstance(max_workers, int)
        or max_workers < 1
    ):  # fmt: skip
        raise ValueError(f"max_workers: expected a positive int, got {max_workers!r}")
    if chunksize is not None and (
        isinstance(chunksize, bool) or not isinstance(chunksize, int) or chunksize < 1
    ):
        raise ValueError(f"chunksize: expected a positive int, got {chunksize!r}")
    if timeout is not None and not (
        isinstance(timeout, int | float) and 0 < timeout < math.inf
    ):
        raise ValueError(f"timeout: expected a positive number, got {timeout!r}")
    if executor is None:
        executor = "processes"
    if isinstance(executor, str):
        if executor not in ("processes", "serial"):
            raise ValueError(
                f"executor: expected an Executor, 'processes' or 'serial', "
                f"got {executor!r}"
            )
        if executor == "processes" and max_workers == 1:
            executor = "serial"
    elif not isinstance(executor, Executor):
        raise TypeError(
            "executor: expected a concurrent.futures.Executor, 'processes' or "
            f"'serial', got {type(executor).__name__}"
        )

    has_spec = controllers is not None
    items = [
        (index, spec, has_spec, scenario)
        for index, (scenario, spec) in enumerate(itertools.product(scenarios, specs))
    ]
    results: list[tuple[dict | None, str] | None] = [None] * len(items)
    start = time.perf_counter()
    own = bar = None
    try:
        if executor == "serial":
            label = "serial"
            bar = _Progress(len(items), progress)
            for item in items:
                for index, result, status in _run_chunk(run, [item], timeout):
                    results[index] = (result, status)
                bar.update(1)
        else:
            if executor == "processes":
                own = ProcessPoolExecutor(max_workers=max_workers or os.cpu_count())
                executor = own
            label = type(executor).__name__
            size = chunksize or max(
                1, math.ceil(len(items) / (_CHUNKS_PER_WORKER * _workers(executor)))
            )
            futures = {
                executor.submit(_run_chunk, run, items[i : i + size], timeout): min(
                    size, len(items) - i
                )
                for i in range(0, len(items), size)
            }
            # After the workers are forked: tqdm runs a monitor thread.
            bar = _Progress(len(items), progress)
            for future in as_completed(futures):
                for index, result, status in future.result():
                    results[index] = (result, status)
                bar.update(futures[future])
    finally:
        if bar is not None:
            bar.close()
        if own is not None:
            own.shutdown(cancel_futures=True)
    seconds = time.perf_counter() - start

    table = _table(scenarios, names, has_spec, results)
    failed = table[table[STATUS].str.startswith(("failed", "timeout"))]
    if len(failed):
        warnings.warn(
            f"sweep: {len(failed)} of {len(table)} runs failed; first: "
            f"{failed[STATUS].iloc[0]}",
            stacklevel=2,
        )
    table.attrs["sweep"] = {
        "seconds": seconds,
        "executor": label,
        "runs": len(items),
    }
    return table
