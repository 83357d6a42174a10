"""Sweeps: reproducible initial states, records as runs finish, resume, Dask on loopback."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.errors import UsageError
from stlplan.mission.loader import load_mission
from stlplan.sweep.initial import draw_positions, with_initial_positions
from stlplan.sweep.runner import read_records
from tests.helpers.paths import MISSIONS, PAIR


def test_initial_positions_are_reproducible_separated_and_inside() -> None:
    mission = load_mission(MISSIONS / "farm.yaml")
    first = draw_positions(mission, seed=3, run=7)
    again = draw_positions(mission, seed=3, run=7)
    other = draw_positions(mission, seed=3, run=8)
    assert np.array_equal(first, again)
    assert not np.array_equal(first, other)
    assert first.shape == (len(mission.agents), 2)
    assert np.all((first >= [0, 4]) & (first <= [1, 5]))  # Init = [0,1] x [4,5]
    for i in range(len(first)):
        for j in range(i + 1, len(first)):
            assert np.max(np.abs(first[i] - first[j])) >= mission.separation


def test_drawn_states_are_at_rest() -> None:
    mission = load_mission(MISSIONS / "farm.yaml")
    moved = with_initial_positions(mission, draw_positions(mission, 0, 0))
    for agent in moved.agents:
        assert agent.initial_state[2:] == [0.0, 0.0]


@pytest.mark.heavy
def test_sweep_records_every_run_and_resumes(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    rows = api.sweep([PAIR], runs=2, out=out, workers=1, overrides=Overrides(seed=1))
    records = read_records(out)
    assert sorted(r["run"] for r in records) == [0, 1]
    assert all(r["monitor_satisfied"] for r in records)
    assert rows[0]["runs"] == 2
    assert (out / "table.md").read_text().startswith("| mission")
    assert (out / "solve-times.png").stat().st_size > 1000
    with pytest.raises(UsageError):
        api.sweep([PAIR], runs=2, out=out, workers=1, overrides=Overrides(seed=1))
    seen: list[dict] = []
    api.sweep(
        [PAIR],
        runs=3,
        out=out,
        workers=1,
        resume=True,
        on_record=seen.append,
        overrides=Overrides(seed=1),
    )
    assert [r["run"] for r in seen] == [2]
    assert len(read_records(out)) == 3


@pytest.mark.heavy
def test_sweep_on_a_local_dask_cluster_matches_local_runs(tmp_path: Path) -> None:
    distributed = pytest.importorskip(
        "distributed", reason="Dask is an optional extra: pip install 'stlplan[dask]'"
    )
    cluster = distributed.LocalCluster(
        host="127.0.0.1",
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
    )
    try:
        api.sweep(
            [PAIR],
            runs=2,
            out=tmp_path / "dask",
            scheduler=cluster.scheduler_address,
            overrides=Overrides(seed=5),
        )
    finally:
        cluster.close()
    api.sweep([PAIR], runs=2, out=tmp_path / "local", workers=2, overrides=Overrides(seed=5))
    by_run = {r["run"]: r for r in read_records(tmp_path / "dask")}
    for record in read_records(tmp_path / "local"):
        remote = by_run[record["run"]]
        assert remote["initial_positions"] == record["initial_positions"]
        assert remote["status"] == record["status"]
        assert json.dumps(remote["rho_s"]) == json.dumps(record["rho_s"])


def test_workers_with_a_scheduler_are_refused(tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="--workers sets the local processes"):
        api.sweep([PAIR], runs=1, out=tmp_path, workers=2, scheduler="tcp://127.0.0.1:1")
    assert not (tmp_path / "runs.jsonl").exists()


def test_a_scheduler_without_dask_says_how_to_install_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    import sys

    from stlplan.sweep.runner import execute

    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(UsageError, match=r"pip install 'stlplan\[dask\]'"):
        execute([], tmp_path, 1, scheduler="tcp://127.0.0.1:1")


def test_resume_refuses_another_seed_or_time_limit(tmp_path: Path) -> None:
    out = tmp_path / "sweep"
    api.sweep([PAIR], runs=1, seed=1, out=out, workers=1)
    with pytest.raises(UsageError, match="already holds 1 run; pass --resume"):
        api.sweep([PAIR], runs=1, seed=1, out=out, workers=1)
    with pytest.raises(UsageError, match="seed 1 recorded, 2 now"):
        api.sweep([PAIR], runs=2, seed=2, out=out, workers=1, resume=True)
    with pytest.raises(UsageError, match="time_limit"):
        api.sweep(
            [PAIR], runs=2, seed=1, out=out, workers=1, resume=True,
            overrides=Overrides(time_limit=7.0),
        )  # fmt: skip
    with pytest.raises(UsageError, match="missions"):
        api.sweep([PAIR, MISSIONS / "farm.yaml"], 2, 1, out, 1, resume=True)
    rows = api.sweep([PAIR], runs=2, seed=1, out=out, workers=1, resume=True)
    assert sum(r["runs"] for r in rows) == 2
    found = CliRunner().invoke(
        app,
        ["sweep", str(PAIR), "--runs", "1", "--seed", "1", "--out", str(out), "--resume"]
        + ["--workers", "1", "-q"],
    )  # run 0 is on record: nothing is solved
    assert found.exit_code == 0, found.output
    assert found.stdout.startswith("sweep of 1 run over 1 mission in 1 local process: records")


@pytest.mark.parametrize(("given", "used"), [([], None), (["--threads", "2"], 2)])
def test_the_sweeps_threads_reach_every_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, given: list[str], used: int | None
) -> None:
    import stlplan.pipeline as pipeline

    seen: list[int | None] = []
    real = pipeline.plan

    def spied(problem: object, overrides: Overrides) -> object:
        seen.append(overrides.threads)
        return real(problem, overrides)  # type: ignore[arg-type]

    monkeypatch.setattr(pipeline, "plan", spied)
    args = ["sweep", str(PAIR), "--runs", "1", "--workers", "1", "--out", str(tmp_path / "s")]
    found = CliRunner().invoke(app, [*args, "-q", *given])
    assert found.exit_code == 0, found.output
    assert seen == [used]
