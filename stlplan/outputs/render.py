"""Human-readable rendering of verdicts and plans for the terminal (rich)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from rich.console import Console
from rich.table import Table

from stlplan.formula.boundary import EPSILON
from stlplan.monitor.dynamics import DYNAMICS_CHECKED
from stlplan.result import (
    Confirmation,
    Diagnosis,
    Dropped,
    MonitorReport,
    PlanResult,
    Verdict,
)
from stlplan.words import counted


def _num(value: float | None, digits: int = 3) -> str:
    if value is None:
        return "-"
    if abs(value) < 1e-9:
        return "0"  # round-off of a predicate held exactly on its boundary
    return f"{value:.{digits}g}" if abs(value) < 1e4 else f"{value:.3e}"


def _group(v: Verdict) -> str:
    if not v.group:
        return ""
    return group_text(v.group)


def group_text(group: tuple[tuple[str, ...], ...]) -> str:
    """``(uv1, ir1) (uv2, ir2)``; a task whose formula only counts holds for ``the team``."""
    if all(not e for e in group):
        return "the team"
    return " ".join("(" + ", ".join(e) + ")" for e in group)


def _sync(v: Verdict) -> str:
    if v.rho_s is None:
        return ""
    if not v.run_length or v.run_start is None:
        return f"rho_s {_num(v.rho_s)}, no run"
    capped = ""
    if v.counted is not None and v.counted < v.rho_s:
        capped = f" (counted up to gamma = {_num(v.counted)})"
    steps = f"steps {v.run_start}-{v.run_start + v.run_length - 1}"
    return f"rho_s {_num(v.rho_s)}{capped}, run {v.run_length}: {steps}"


def _rows(report: MonitorReport) -> list[Verdict]:
    """Verdicts to show: the dynamics checks fold into one row when every agent passes."""
    dynamics = [v for v in report.verdicts if v.kind == "dynamics"]
    rows = [v for v in report.verdicts if v.kind != "dynamics"]
    if dynamics and all(v.satisfied for v in dynamics):
        rows.append(Verdict("dynamics", "dynamics", True, 0.0, detail="every agent"))
    else:
        rows += dynamics
    return rows


def verdict_table(
    report: MonitorReport, title: str = "Monitor", dropped: Sequence[Dropped] = ()
) -> Table:
    """One row per task, constraint and physical check; a degraded plan's dropped tasks last."""
    table = Table(title=title, title_justify="left", header_style="bold")
    table.add_column("name", no_wrap=True)
    table.add_column("kind", no_wrap=True)
    table.add_column("verdict", no_wrap=True)
    table.add_column("robustness", justify="right", no_wrap=True)
    table.add_column("agents", overflow="fold")
    table.add_column("sync", overflow="fold")
    for v in _rows(report):
        mark = "[green]ok[/]" if v.satisfied else "[red]FAIL[/]"
        agents = _group(v) or (v.detail if v.kind == "dynamics" else "")
        table.add_row(v.name, v.kind, mark, _num(v.robustness), agents, _sync(v))
    for d in dropped:
        table.add_row(d.task, "task", "[yellow]dropped[/]", "", "", "")
    return table


def report_line(report: MonitorReport) -> str:
    """The monitor's verdict in one line (rich markup)."""
    failed = [v.name for v in report.verdicts if not v.satisfied]
    if failed:
        return (
            f"[red]not satisfied[/]: {len(failed)} of {counted(len(report.verdicts), 'check')} "
            f"{'fails' if len(failed) == 1 else 'fail'} "
            f"({', '.join(failed)})"
        )
    rho = "" if report.rho_s is None else f", rho_s(Phi) = {_num(report.rho_s)}"
    return (
        f"[green]satisfied[/]: every task and constraint holds{rho}, spatial "
        f"robustness {_num(report.spatial_robustness)}"
    )


def print_report(
    console: Console,
    report: MonitorReport,
    dropped: Sequence[Dropped] = (),
    broken: Sequence[str] = (),
) -> None:
    """The per-task table, how the dynamics were checked, a one-line verdict and what fails;
    for a degraded plan, each task dropped and why, and what the executed past broke."""
    console.print(verdict_table(report, dropped=dropped))
    console.print(f"{DYNAMICS_CHECKED[report.known]}; tolerance {report.tolerance:g}")
    if dropped or broken:
        console.print(f"[yellow]degraded[/]: not satisfied, {degraded_words(dropped, broken)}")
        for d in dropped:
            console.print(f"  {d.task} dropped: {d.reason}")
    else:
        console.print(report_line(report))
    for v in report.verdicts:
        if not v.satisfied:
            console.print(f"  {v.name}: {v.detail}")


def degraded_words(dropped: Sequence[Dropped], broken: Sequence[str]) -> str:
    """What a degraded plan gave up and what the executed past broke, and what the plan meets."""
    given_up = [f"the executed past broke {', '.join(broken)}"] if broken else []
    given_up += [f"{counted(len(dropped), 'task')} dropped"] if dropped else []
    tasks = "every other task" if dropped else "every task"
    constraints = "every other constraint" if broken else "every constraint"
    return f"{' and '.join(given_up)}; the plan meets {tasks} and {constraints}"


def print_plan(
    console: Console, result: PlanResult, verbose: bool = False, seconds: float | None = None
) -> None:
    """Status, step 1's objective and bound, step 2's effort, the margin, assignments, sizes and
    the time of the run (``seconds`` in all) and of its stages; with ``verbose``, what happened
    on the way too (events, confirmations beside a plan)."""
    status = result.status.value
    if result.status.value == "feasible":
        status += f" (not proven optimal, gap {_num(result.gap)})"
    console.print(f"[bold]status[/]     {status}: {result.message}")
    if result.replan is not None:
        r = result.replan
        events = f"; {', '.join(r.events)}" if r.events else ""
        took = f"{r.seconds:.2f} s"
        if r.deadline is not None:
            took += f" of a {r.deadline:g} s deadline: {r.came_back}"
        console.print(
            f"[bold]replan[/]     from step {r.step}: executed steps 0..{r.step} kept{events} "
            f"({took})"
        )
    print_figures(console, result)
    for a in result.assignments:
        run = (
            ""
            if a.run_length is None
            else (
                f"  synchronized steps {a.run_start}-{a.run_start + a.run_length - 1} "
                f"(run {a.run_length}, rho_s = {_num(a.rho_s)})"
                if a.run_start is not None
                else ""
            )
        )
        console.print(f"[bold]task[/]       {a.task}: " + group_text(a.group) + run)
    size = result.model_size
    if size is not None:
        console.print(
            f"[bold]model[/]      {counted(size.variables, 'variable')} ({size.binaries} "
            f"binary), {counted(size.constraints, 'constraint')}"
        )
    console.print(f"[bold]time[/]       {time_line(result, seconds)}")
    if verbose:
        for event in result.events:
            console.print(f"[bold]run[/]        {event}")
        print_trace(console, result.trace)
    print_confirmations(console, result, verbose)
    if result.report is not None:
        print_report(console, result.report, result.dropped, result.broken_by_the_past)
    if result.diagnosis is not None:
        print_diagnosis(console, result.diagnosis)


def time_line(result: PlanResult, seconds: float | None = None) -> str:
    """The run's time, ``seconds`` in all when given, then each stage's (step 1, the degraded
    search, the continuous stage, the monitor's check) and the rest (reading the mission,
    writing the outputs)."""
    spent = result.stage_seconds
    stages = ", ".join(f"{name} {t:.2f} s" for name, t in spent.items())
    if not stages:
        stages = f"build {result.build_seconds:.2f} s, solve {result.solve_seconds:.2f} s"
    if seconds is None:
        return stages
    rest = max(0.0, seconds - sum(spent.values()))
    return f"{seconds:.2f} s in all: {stages}; reading and writing {rest:.2f} s"


def print_trace(console: Console, trace: Mapping[str, Any]) -> None:
    """Each incumbent of step 1 with the stage that found it, then each stage's seconds."""
    for found in trace.get("incumbents", ()):
        parts = found.get("parts") or {}
        made = f" from {', '.join(f'{n} by {s}' for s, n in parts.items())}" if parts else ""
        console.print(
            f"[bold]plan[/]       {_num(found['objective'], 6)} at {found['at']:.2f} s by "
            f"{found['stage']} ({found['part']}){made}"
        )
    stages = trace.get("stages") or {}
    if stages:
        spent = ", ".join(f"{stage} {seconds:.2f} s" for stage, seconds in stages.items())
        console.print(f"[bold]stages[/]     {spent}")


def figure(value: float | None) -> str:
    """A figure as it means: four significant digits, a round-off of zero as 0 (the full
    precision is in ``summary.json``)."""
    return _num(value, 4)


def _margin(value: float) -> str:
    """The margin, named for what it is when it is the boundary's epsilon (a plan that holds
    its predicates on their boundaries)."""
    if abs(value - EPSILON) <= EPSILON * 1e-3:
        return f"{EPSILON:g} (the boundary epsilon; monitor)"
    return f"{figure(value)} (monitor)"


def _percent(gap: float | None) -> str:
    return "-" if gap is None else f"{gap:.2%}"


def print_figures(console: Console, result: PlanResult) -> None:
    """Step 1's objective, bound and gap; step 2's effort and what the plan written scores on
    step 1's objective when that is another figure; the monitor's margin; a fallback with its
    reason and cost."""
    solver = result.solver
    claimed = solver.objective if solver is not None and solver.objective is not None else None
    step1 = claimed if claimed is not None else result.objective
    if step1 is not None:
        console.print(
            f"[bold]step 1[/]     objective {figure(step1)}, bound {figure(result.bound)}, "
            f"gap {_percent(result.gap)}"
        )
    if result.effort is not None:
        own = result.objective
        scored = (
            f"; the plan written scores {figure(own)} on step 1's objective"
            if own is not None and step1 is not None and figure(own) != figure(step1)
            else ""
        )
        which = "step 2" if result.steps == 2 else "effort"
        console.print(f"[bold]{which:<10}[/] effort {figure(result.effort)}{scored}")
    if result.margin is not None:
        console.print(f"[bold]margin[/]     {_margin(result.margin)}")
    fallback = result.fallback
    if fallback is not None:
        cost = ", ".join(f"{k} {figure(v)}" for k, v in fallback.cost.items()) or "unknown"
        console.print(
            f"[bold]fallback[/]   {fallback.step} failed ({fallback.reason}); {fallback.kept} "
            f"is kept, costing {cost}"
        )


def print_confirmations(console: Console, result: PlanResult, verbose: bool = False) -> None:
    """Each infeasible verdict of HiGHS and how it was checked. Beside a plan, a verdict came
    from an intermediate solve (a lazy round, a step 2 redone after a stricter step 1): it is a
    note, not the outcome, printed only when ``verbose``."""
    for confirmation in result.confirmations:
        if result.trajectory is None:
            console.print(f"[bold]infeasible[/] {confirmation_text(confirmation)}")
            continue
        if not verbose:
            continue
        later = "; the plan comes from a later solve" if confirmation.outcome == "confirmed" else ""
        console.print(f"[bold]note[/]       infeasible {confirmation_text(confirmation)}{later}")


def confirmation_text(confirmation: Confirmation) -> str:
    """One line: which solve said infeasible, each check's settings and verdict, the outcome."""
    solves = "; ".join(
        ", ".join(f"{k} {v}" for k, v in c.settings) + f": {c.verdict}" for c in confirmation.checks
    )
    return f"verdict of {confirmation.where} {confirmation.outcome} ({solves})"


def print_diagnosis(console: Console, diagnosis: Diagnosis) -> None:
    """Why the mission is infeasible."""
    for reason in diagnosis.reasons:
        console.print(f"[bold]reason[/]     {reason}")
    if diagnosis.conflict:
        note = "" if diagnosis.complete else " (some checks timed out: may not be minimal)"
        console.print(
            f"[bold]conflict[/]   these cannot hold together: {', '.join(diagnosis.named())}{note}"
        )
