"""A simulation of many runs, on the sweep's machinery (:mod:`stlplan.sweep.runner`).

The mission is planned once; every run executes that plan (:mod:`stlplan.simulation.run`) in a
local process pool or on a Dask cluster. Each run's record is one line of ``OUT/runs.jsonl``
as it finishes, ``OUT/simulation.json`` records what the simulation is (mission, seed,
disturbance, policy, events, planner settings), and ``resume`` skips the runs on record (and is
refused for another simulation). At the end ``OUT/table.md`` and ``OUT/table.csv`` hold a row
per run, and when run 0 ran, ``OUT/run-0.png`` (its map: executed solid, planned dashed, events
marked), ``OUT/run-0-timeline.png`` and ``OUT/run-0.csv`` (its executed trajectory) show it.

:func:`robustness` reads every simulation of a mission below a folder and draws the fraction of
runs satisfied against the disturbance bound, one curve per policy (``OUT/robustness.png``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import signal
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stlplan.errors import UsageError
from stlplan.mission.loader import load_problem
from stlplan.mission.problem import Problem
from stlplan.outputs.directory import prepare_directory, write_all, write_text
from stlplan.pipeline import plan
from stlplan.planner.config import PlannerConfig
from stlplan.planner.overrides import Overrides
from stlplan.result import PlanResult
from stlplan.runtime import signals
from stlplan.simulation import report
from stlplan.simulation.run import SimulationSpec, judge, simulate_one, trajectory_from_record
from stlplan.simulation.settings import Simulated, check_runs
from stlplan.sweep.runner import RECORDS, read_records

OnRecord = Callable[[dict[str, Any]], None]


@dataclass(frozen=True)
class Simulation:
    """A simulation's outcome.

    Attributes
    ----------
    records
        The simulation's runs, by run (:func:`stlplan.simulation.run.simulate_one`'s records).
    first
        The plan every run executed; None when every run was on record already (nothing was
        planned). Without a trajectory (an infeasible mission, no plan in time), no run ran.
    out
        The folder of its records, table and figures.
    """

    records: tuple[dict[str, Any], ...]
    first: PlanResult | None
    out: Path

    def summary(self) -> dict[str, Any]:
        """The runs, how many satisfy the mission, and the replan times."""
        return report.overall(self.records)

    def document(self) -> dict[str, Any]:
        """The ``--json`` document: ``runs`` and ``satisfied_fraction``, among others."""
        return report.document(self.records)


def simulate(
    mission: str | Path,
    simulated: Simulated,
    runs: int = 20,
    seed: int = 0,
    out: str | Path = "out/simulate",
    workers: int | None = None,
    scheduler: str | None = None,
    resume: bool = False,
    overrides: Overrides | None = None,
    on_record: OnRecord | None = None,
    on_start: Callable[[int], None] | None = None,
) -> Simulation:
    """Plan ``mission`` once and execute the plan ``runs`` times (module docstring).

    ``overrides`` set the planner for the first plan and every replan; their ``robust_to``
    defaults to the mission's ``execution.disturbance``, whatever ``simulated.disturbance``.

    Raises
    ------
    SimulationError, EventError
        Settings that do not fit the mission, fewer than one run (nothing is written).
    UsageError
        ``workers`` with ``scheduler``; runs on record in ``out`` without ``resume``, or another
        simulation there with it.
    """
    from stlplan.sweep.identity import check_claim, claim
    from stlplan.sweep.runner import check_scheduler, execute, pending, workers_and_settings

    problem = load_problem(mission)
    simulated.check(problem)
    check_runs(runs)
    workers, overrides = workers_and_settings(workers, scheduler, runs, overrides or Overrides())
    overrides = _robust(problem, overrides)
    check_scheduler(scheduler)
    folder = Path(out)
    created = not folder.exists()
    prepare_directory(folder)
    specs = _specs(Path(mission), runs, seed, overrides, simulated)
    todo = pending(specs, folder, resume, what="simulation")
    check_claim(folder, specs, resume, what="simulation")
    if on_start is not None:  # every check passed; the first plan comes next
        on_start(len(todo))
    first = _first(problem, overrides) if todo else None
    if first is not None and first.trajectory is None:  # nothing to execute: nothing written
        if created:
            with contextlib.suppress(OSError):
                folder.rmdir()
        return Simulation((), first, folder)
    claim(folder, specs, resume, what="simulation")
    todo = [dataclasses.replace(s, first=first) for s in todo]
    execute(todo, folder, workers, scheduler, on_record, work=simulate_one)
    records = _mine(folder, specs)
    _write(folder, problem, records, simulated, first if any(s.run == 0 for s in todo) else None)
    return Simulation(tuple(records), first, folder)


def _specs(
    mission: Path, runs: int, seed: int, overrides: Overrides, simulated: Simulated
) -> list[SimulationSpec]:
    """Runs ``0..runs-1`` of the simulation (the mission travels as text)."""
    text = mission.read_text(encoding="utf-8")
    return [
        SimulationSpec(mission.stem, text, str(mission), r, seed, overrides, simulated)
        for r in range(runs)
    ]


def _first(problem: Problem, overrides: Overrides) -> PlanResult:
    """The plan every run executes; a signal that stops it stops the simulation."""
    first = plan(problem, overrides)[1]
    if first.status.interrupted:
        raise signals.Interrupted(signals.last_signal() or signal.SIGINT)
    return first


def _robust(problem: Problem, overrides: Overrides) -> Overrides:
    """``overrides`` with the disturbance plans are robust to set (the mission's by default)."""
    config = PlannerConfig.from_mission(problem.mission, overrides.dotted())
    return dataclasses.replace(overrides, robust_to=float(config.model.robust_to))


def _mine(out: Path, specs: Sequence[SimulationSpec]) -> list[dict[str, Any]]:
    """The records of ``specs``, by run."""
    wanted = {(s.mission_key, s.run, s.seed) for s in specs}
    mine = [r for r in read_records(out) if (r["mission"], r["run"], r["seed"]) in wanted]
    return sorted(mine, key=lambda r: r["run"])


def _write(
    out: Path,
    problem: Problem,
    records: Sequence[dict[str, Any]],
    simulated: Simulated,
    first: PlanResult | None,
) -> None:
    """The table, and (with ``first``, when run 0 ran) run 0's figures and trajectory."""
    from stlplan.outputs.plots import plot_timeline
    from stlplan.outputs.plots.executed import plot_executed
    from stlplan.outputs.trajio import write_trajectory_csv
    from stlplan.sweep.report import to_csv, to_markdown

    rows = [report.row(r) for r in records]
    files: dict[str, Callable[[Path], None]] = {
        "table.md": lambda p: write_text(p, to_markdown(rows, report.COLUMNS)),
        "table.csv": lambda p: write_text(p, to_csv(rows, report.COLUMNS)),
    }
    zero = next((r for r in records if r["run"] == 0 and "executed" in r), None)
    if first is not None and first.trajectory is not None and zero is not None:
        executed = trajectory_from_record(zero, problem.horizon)
        judged = judge(problem, executed, simulated)
        events = [(e.kind, e.name, e.step) for e in simulated.events]
        title = f"{problem.mission.name}: run 0, {_settings_text(zero)}: {zero['status']}"
        planned = first.trajectory
        files["run-0.png"] = lambda p: plot_executed(
            problem, executed, planned, judged, events, p, title
        )
        files["run-0-timeline.png"] = lambda p: plot_timeline(problem, executed, judged, p)
        files["run-0.csv"] = lambda p: write_trajectory_csv(problem, executed, p)
    write_all(out, files)


def _settings_text(record: dict[str, Any]) -> str:
    """``W = 0.05, replan every, robust to 0``."""
    return (
        f"W = {record['disturbance']:g}, replan {record['replan']}, "
        f"robust to {record['robust_to']:g}"
    )


def robustness(mission: str | Path, out: str | Path) -> list[dict[str, Any]]:
    """Draw ``OUT/robustness.png`` from every simulation of ``mission`` recorded in ``out`` or
    below it (each folder's ``runs.jsonl``): the fraction of runs satisfied against the
    disturbance bound, one curve per configuration (policy, robust margin, events). Returns the
    points (:func:`stlplan.simulation.report.points`).

    Raises
    ------
    UsageError
        No simulation of ``mission`` is recorded there.
    """
    problem = load_problem(mission)
    key, folder = Path(mission).stem, Path(out)
    records = [
        r
        for path in sorted(folder.rglob(RECORDS))
        for r in read_records(path.parent)
        if r.get("mission") == key and "disturbance" in r
    ]
    if not records:
        raise UsageError(
            f"no simulation of {key} is recorded in {folder} or below it: run "
            f"`stlplan simulate {mission} --out {folder}/NAME` first",
            source=str(folder),
        )
    found = report.points(records)
    title = problem.mission.name
    write_all(folder, {"robustness.png": lambda p: report.plot_robustness(found, title, p)})
    return found
