"""Running a sweep: one full solve per (mission, run), records appended as runs finish.

Runs execute in a local process pool, or on a Dask distributed cluster when a scheduler address is
given. Each record is one JSON line in ``runs.jsonl``; an interrupted sweep loses at most the runs
in flight, and ``resume`` skips the runs already recorded. Other batches of runs (simulations,
:mod:`stlplan.simulation`) run on the same machinery with their own run function.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import signal
import time
from collections.abc import Callable, Generator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol, TypeVar

from stlplan.errors import SolverError, StlplanError, UsageError
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult
from stlplan.runtime import signals
from stlplan.words import counted

RECORDS = "runs.jsonl"


class Spec(Protocol):
    """One run's description: a :class:`RunSpec`, or another batch's. Its mission, run and seed
    name its record (``mission``, ``run``, ``seed``); its settings are what the batch is."""

    @property
    def mission_key(self) -> str: ...
    @property
    def mission_text(self) -> str: ...
    @property
    def run(self) -> int: ...
    @property
    def seed(self) -> int: ...
    def settings(self) -> dict[str, Any]: ...


S = TypeVar("S", bound=Spec)
Work = Callable[[Any], dict[str, Any]]
"""What runs one spec and returns its record (it never raises for a failed run)."""


@dataclass(frozen=True)
class RunSpec:
    """One solve of a sweep: which mission (as text, so remote workers need no files), run, seed."""

    mission_key: str
    mission_text: str
    source: str
    run: int
    seed: int
    overrides: Overrides = field(default_factory=Overrides)

    def settings(self) -> dict[str, Any]:
        """The settings that change the run's answer (threads change only its time)."""
        return {k: v for k, v in self.overrides.given().items() if k != "threads"}


def run_one(spec: RunSpec) -> dict[str, Any]:
    """Draw the run's initial state, plan and verify; never raises for a failed solve."""
    from stlplan.mission.loader import problem_from_text
    from stlplan.mission.problem import build_problem
    from stlplan.pipeline import plan
    from stlplan.sweep.initial import draw_positions, with_initial_positions

    record: dict[str, Any] = {"mission": spec.mission_key, "run": spec.run, "seed": spec.seed}
    started = time.monotonic()
    try:
        base = problem_from_text(spec.mission_text, spec.source).mission
        positions = draw_positions(base, spec.seed, spec.run)
        record["initial_positions"] = {
            a.name: [float(v) for v in z] for a, z in zip(base.agents, positions, strict=False)
        }
        problem = build_problem(with_initial_positions(base, positions), source=spec.source)
        _, result = plan(problem, spec.overrides)
    except StlplanError as exc:
        record.update(status="error", message=str(exc), wall_seconds=time.monotonic() - started)
        return record
    if result.status.interrupted or signals.requested():  # not a result: --resume runs it again
        raise signals.Interrupted(signals.last_signal() or signal.SIGINT)
    record.update(_figures(result), wall_seconds=time.monotonic() - started)
    return record


def _figures(result: PlanResult) -> dict[str, Any]:
    """What a record keeps of a verified plan result."""
    report = result.report
    size = result.model_size
    return dict(
        status=result.status.value,
        message=result.message,
        objective=result.objective,
        gap=result.gap,
        rho_s=None if report is None else report.rho_s,
        runs={
            v.name: [v.run_start, v.run_length]
            for v in (report.verdicts if report else ())
            if v.rho_s is not None
        },
        effort=result.effort,
        monitor_satisfied=None if report is None else report.satisfied,
        variables=None if size is None else size.variables,
        binaries=None if size is None else size.binaries,
        constraints=None if size is None else size.constraints,
        build_seconds=result.build_seconds,
        solve_seconds=result.solve_seconds,
    )


def workers_and_settings(
    workers: int | None, scheduler: str | None, runs: int, overrides: Overrides
) -> tuple[int, Overrides]:
    """The local worker processes (default: one per core, at most one per run) and the settings
    of each run: HiGHS on one thread when runs share the machine or go to a cluster, unless
    ``overrides`` sets the threads.

    Raises
    ------
    UsageError
        ``workers`` with a ``scheduler``: the cluster's workers run the runs.
    """
    if workers is not None and scheduler:
        raise UsageError(
            "--workers sets the local processes; with --scheduler the Dask cluster's workers run "
            "the solves (start them with `dask worker ... --nworkers N`)"
        )
    workers = workers or max(1, min(os.cpu_count() or 1, runs))
    if (workers > 1 or scheduler) and overrides.threads is None:
        overrides = dataclasses.replace(overrides, threads=1)
    return workers, overrides


def read_records(out: Path) -> list[dict[str, Any]]:
    """Records written so far (a torn last line, from a hard stop, is ignored)."""
    path = out / RECORDS
    if not path.exists():
        return []
    records = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return records


def pending(specs: Sequence[S], out: Path, resume: bool, what: str = "sweep") -> list[S]:
    """The specs still to run; refuses to mix with an earlier ``what`` (sweep, simulation) unless
    ``resume``."""
    done = {
        (r["mission"], r["run"], r["seed"])
        for r in read_records(out)
        if not str(r.get("status", "")).startswith("interrupted")
    }
    if done and not resume:
        raise UsageError(
            f"{out / RECORDS} already holds {counted(len(done), 'run')}; pass --resume to "
            f"continue that {what} or choose another --out"
        )
    return [s for s in specs if (s.mission_key, s.run, s.seed) not in done]


def _append(out: Path, record: dict[str, Any]) -> None:
    line = json.dumps(record) + "\n"
    with signals.held(), open(out / RECORDS, "a", encoding="utf-8") as handle:
        handle.write(line)
        handle.flush()
        os.fsync(handle.fileno())


def _leave_interrupts_to_parent() -> None:
    """Pool workers ignore Ctrl-C and die on SIGTERM: the parent stops them all and says so."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler, inherited by fork
    signals.leave_signals_alone()


def _terminate(pool: ProcessPoolExecutor) -> None:
    """Stop the pool's workers now, runs in flight included (no public API before 3.14)."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        process.terminate()


def _local(
    specs: Sequence[Spec], workers: int, work: Work
) -> Generator[dict[str, Any], None, None]:
    if workers <= 1:
        yield from (work(s) for s in specs)
        return
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_leave_interrupts_to_parent)
    futures = [pool.submit(work, s) for s in specs]
    try:
        for future in as_completed(futures):
            yield future.result()
    except BrokenProcessPool:
        raise SolverError(
            "a sweep worker process died (out of memory, or killed); the finished runs are "
            "recorded: run the sweep again with --resume"
        ) from None
    except BaseException:  # interrupted, or the caller stopped reading
        _terminate(pool)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def connect(scheduler: str) -> Any:
    """A Dask client of ``scheduler``; :class:`UsageError` when Dask is missing or the address
    is malformed or cannot be reached."""
    try:
        from distributed import Client
    except ImportError:
        raise UsageError(
            "--scheduler runs the sweep on a Dask cluster, and Dask is not installed: "
            "pip install 'stlplan[dask]'"
        ) from None
    try:
        return Client(scheduler, timeout="20s")
    except ValueError as exc:  # an address Dask cannot parse
        raise UsageError(f"--scheduler {scheduler}: {exc}; expected tcp://HOST:PORT") from None
    except OSError as exc:
        raise UsageError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None


def check_scheduler(scheduler: str | None) -> None:
    """Connect to ``scheduler`` once, before anything is written (see :func:`connect`)."""
    if scheduler:
        connect(scheduler).close()


def _dask(
    specs: Sequence[Spec], scheduler: str, work: Work
) -> Generator[dict[str, Any], None, None]:
    client = connect(scheduler)  # Dask is there: it says how to install it when it is not
    from distributed import as_completed as dask_completed

    with client:
        futures = client.map(work, list(specs), pure=False)
        for future in dask_completed(futures):
            yield future.result()


def execute(
    specs: Sequence[Spec],
    out: Path,
    workers: int,
    scheduler: str | None = None,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    work: Work = run_one,
) -> None:
    """Run ``work`` on each of ``specs`` and append each record to ``out/runs.jsonl`` as it
    finishes.

    ``work`` (default: a sweep's solve, :func:`run_one`) is a module-level function, so that
    worker processes and Dask workers can call it. Ctrl-C or SIGTERM stops the runs
    (:class:`stlplan.runtime.signals.Interrupted`); the runs in flight are lost, the recorded ones
    kept.
    """
    out.mkdir(parents=True, exist_ok=True)
    stream = _dask(specs, scheduler, work) if scheduler else _local(specs, workers, work)
    with signals.stop_on_signals(), contextlib.closing(stream):
        for record in stream:
            _append(out, record)
            if on_record is not None:
                on_record(record)
