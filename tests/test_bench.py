"""The benchmark's report: side-by-side comparison of formulations on the same states."""

from __future__ import annotations

from pathlib import Path

import pytest

from stlplan import bench, bench_report


def row(run: int, name: str, wall: float, status: str, objective: float | None) -> dict:
    return {"case": "farm", "run": run, "formulation": name, "wall_s": wall,
            "status": status, "objective": objective, "accepted": True}  # fmt: skip


def test_side_by_side_ratio_and_agreement() -> None:
    rows = [
        row(0, "default", 10.0, "optimal", 4.2000),
        row(0, "straightforward", 150.0, "optimal", 4.19999),
        row(1, "default", 20.0, "optimal", 4.1),
        row(1, "straightforward", 600.0, "feasible", 4.0),  # stopped at its limit, lower
        row(2, "default", 5.0, "optimal", 4.0),
        row(2, "straightforward", 50.0, "optimal", 4.1),  # a better optimum: disagreement
        row(3, "default", 5.0, "optimal", 4.0),  # no comparison for this state
    ]
    pairs = {p["run"]: p for p in bench_report.side_by_side(rows)}
    assert sorted(pairs) == [0, 1, 2]
    assert pairs[0]["speed_up"] == 15.0 and pairs[0]["agree"] is True
    assert pairs[1]["speed_up"] == 30.0 and pairs[1]["agree"] is True
    assert pairs[2]["agree"] is False


def test_render_rewrites_markdown_from_csv(tmp_path: Path) -> None:
    import csv

    rows = [
        row(0, "default", 10.0, "optimal", 4.2),
        row(0, "straightforward", 90.0, "optimal", 4.2),
    ]
    with open(tmp_path / "b.csv", "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=bench.COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    (tmp_path / "b.md").write_text("# old\n\nHiGHS 9.9, machine\n\nCommand: `python -m x`\n")
    assert bench.main(["--out", str(tmp_path), "--name", "b", "--render"]) == 0
    text = (tmp_path / "b.md").read_text()
    assert "HiGHS 9.9, machine" in text and "`python -m x`" in text
    assert "| farm | 0 | straightforward | 10 | 90 | 9 | optimal |" in text


def test_suite_cases_run_once_as_written() -> None:
    args = bench.parse_args(["--cases", "suite", "farm", "--runs", "3", "--compare-runs", "0",
                             "--formulations", "log", "standard"])  # fmt: skip
    assert set(bench.SUITE) <= set(args.cases) and "stl/patrol" in bench.SUITE
    jobs = list(bench.plan_jobs(args))
    patrol = [(j.run, j.formulation) for j in jobs if j.case == "stl/patrol"]
    assert patrol == [(0, "log"), (0, "standard")]
    assert len([j for j in jobs if j.case == "farm"]) == 6
    problem = bench.initial_problem("stl/patrol", seed=0, run=0)
    assert list(problem.agents[0].initial_state) == [2.0, 2.0]


def test_side_by_side_infeasible_on_both_sides_agrees() -> None:
    rows = [
        {**row(0, "log", 3.0, "infeasible", None), "case": "stl/door-locked"},
        {**row(0, "standard", 1.5, "infeasible", None), "case": "stl/door-locked"},
    ]
    (pair,) = bench_report.side_by_side(rows, base="log")
    assert pair["speed_up"] == 0.5 and pair["agree"] is True


def test_crowd_cases_run_once_as_written() -> None:
    args = bench.parse_args(["--cases", "crowd/crowd-16", "--runs", "3", "--compare-runs", "0"])
    assert [(j.case, j.run) for j in bench.plan_jobs(args)] == [("crowd/crowd-16", 0)]
    problem = bench.initial_problem("crowd/crowd-16", seed=0, run=0)
    assert len(problem.agents) == 16
    assert list(problem.agents[0].initial_state) == [7.5, 4.0]


def test_the_summary_counts_plans_and_gives_the_latest_first_plan_and_largest_gap() -> None:
    rows = [
        {
            **row(0, "default", 600.0, "feasible", 2.5),
            "first_plan_s": 50.9,
            "gap": 0.02,
            "bound": 2.6,
        },
        {
            **row(1, "default", 300.0, "optimal", 2.4),
            "first_plan_s": 26.2,
            "gap": 1e-5,
            "bound": 2.4001,
        },
        {**row(2, "default", 600.0, "no_plan", None), "first_plan_s": None, "gap": None},
    ]
    (summary,) = bench_report.summary_rows(rows)
    assert summary["runs"] == 3 and summary["with_plan"] == 2 and summary["optimal"] == 1
    assert summary["max_first_plan_s"] is None  # a run without a plan has no first plan
    assert summary["max_gap"] == 0.02
    assert summary["max_step1_gap"] == 0.04  # (2.6 - 2.5) / 2.5: step 1's plan to the bound
    (planned,) = bench_report.summary_rows(rows[:2])
    assert planned["max_first_plan_s"] == 50.9 and planned["with_plan"] == 2


def test_a_solve_row_records_step_1_objective_and_the_bound_it_ended_with() -> None:
    job = bench.Job("stl/dwell", 0, "default", 60.0)
    solved = bench.solve_job(job, seed=0, threads=1)
    assert solved["status"] == "optimal" and solved["accepted"] is True
    objective, bound = solved["objective"], solved["bound"]
    assert isinstance(bound, float) and isinstance(objective, float)
    assert bound >= objective - 1e-9
    assert bound - objective <= bench_report.GAP * max(1.0, abs(objective)) + 1e-6


@pytest.mark.heavy
def test_a_deterministic_row_names_its_decisions_alike_run_after_run() -> None:
    job = bench.Job("stl/either-or", 0, "deterministic", 60.0)
    first, second = (bench.solve_job(job, seed=0, threads=2) for _ in range(2))
    assert first["status"] == "optimal" and first["rounds"] >= 1
    assert first["decisions"] == second["decisions"] and len(first["decisions"]) == 12
    assert first["objective"] == second["objective"]
    log = [{"part": "a", "stage": "lazy rounds", "ended": "ok", "nodes": 3, "held": {}}]
    other = [{**log[0], "nodes": 4}]
    assert bench.decisions(log) != bench.decisions(other)  # a digest of what was decided
