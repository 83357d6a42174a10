"""Ctrl-C and SIGTERM: a solve stops cleanly, keeps its best verified plan or nothing, exits 128+N.

The signal is sent from the planner's progress callback, which HiGHS calls while it works, so it
arrives mid-solve at a reproducible point (the first plan HiGHS reports).
"""

from __future__ import annotations

import json
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from stlplan import api
from stlplan.api import Overrides
from stlplan.cli import app
from stlplan.result import PlanStatus
from stlplan.runtime import signals
from stlplan.sweep.runner import pending
from tests.helpers.paths import MISSIONS, PAIR

# With the paper's group encoding HiGHS's first plan of the pair mission without its clearance
# (margin.minimum 0) meets every requirement, so a signal at that plan has a verified plan to
# keep (the search path depends on the encoding and the mission).
KEEPABLE = ("--threads", "1", "--tasks", "groups")
CASE2 = MISSIONS / "farm-case2.yaml"


@pytest.fixture(scope="module")
def exact_pair(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The pair mission with its predicates enforced exactly (no margin), as the paper does."""
    text = PAIR.read_text(encoding="utf-8")
    kept = [line for line in text.splitlines(keepends=True) if "margin:" not in line]
    assert len(kept) == len(text.splitlines()) - 1
    path = tmp_path_factory.mktemp("pair") / "sync-pair.yaml"
    path.write_text("".join(kept), encoding="utf-8")
    return path


@pytest.fixture(autouse=True)
def _default_handlers() -> Iterator[None]:
    """Run each test with Python's default SIGINT and SIGTERM handlers, and restore them."""
    saved = {s: signal.getsignal(s) for s in signals.CAUGHT}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    yield
    for s, handler in saved.items():
        signal.signal(s, handler)


def signal_at_first_plan(signum: int = signal.SIGINT, times: int = 1) -> Callable[[Any], None]:
    """A progress callback that sends ``signum`` ``times`` when step 1 first reports a plan."""
    sent: list[int] = []

    def progress(update: Any) -> None:
        if update.phase == "step1" and update.incumbent is not None and not sent:
            sent.append(signum)
            for _ in range(times):
                os.kill(os.getpid(), signum)

    return progress


def test_signal_outside_a_solve_raises_with_the_shell_exit_code() -> None:
    with signals.stop_on_signals(), pytest.raises(signals.Interrupted) as caught:
        os.kill(os.getpid(), signal.SIGTERM)
    assert caught.value.exit_code == 143
    assert signal.getsignal(signal.SIGTERM) is signal.SIG_DFL  # restored
    assert signals.Interrupted(signal.SIGINT).exit_code == 130


def test_signal_during_a_solve_is_recorded_and_a_second_one_is_hard() -> None:
    with signals.stop_on_signals(), signals.solving():
        os.kill(os.getpid(), signal.SIGINT)
        assert signals.requested() and signals.should_interrupt()
        with signals.finishing():
            assert not signals.should_interrupt()  # a first request lets finishing solves end
            os.kill(os.getpid(), signal.SIGINT)
            assert signals.should_interrupt()
        with pytest.raises(signals.Interrupted):
            signals.raise_if_hard()


def test_an_ignored_signal_stays_ignored() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    with signals.stop_on_signals():
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        os.kill(os.getpid(), signal.SIGINT)
        assert not signals.requested()


def test_interrupted_solve_keeps_its_best_plan_verified(exact_pair: Path) -> None:
    _, result = api.plan(
        exact_pair, progress=signal_at_first_plan(), overrides=Overrides(threads=1, tasks="groups")
    )
    assert result.status is PlanStatus.INTERRUPTED
    assert result.trajectory is not None
    assert result.report is not None and result.report.satisfied
    assert "stop request" in result.message


def test_interrupted_lazy_round_without_a_full_plan_keeps_nothing() -> None:
    # Case II's first round leaves obstacle and collision rows out: its first plan violates
    # some, so it is not a plan of the mission and is not kept.
    _, result = api.plan(CASE2, progress=signal_at_first_plan(), overrides=Overrides(threads=1))
    assert result.status is PlanStatus.INTERRUPTED_NO_PLAN
    assert result.trajectory is None and result.report is None


def test_cli_ctrl_c_writes_the_plan_marked_interrupted(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, exact_pair: Path
) -> None:
    from stlplan.outputs.progress import ProgressLine

    monkeypatch.setattr(ProgressLine, "update", lambda self, p: hook(p))
    hook = signal_at_first_plan()
    out = tmp_path / "plan"
    args = ["solve", str(exact_pair), "--out", str(out), "--no-animation", *KEEPABLE]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 130, result.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert (out / "trajectory.csv").exists()
    checked = CliRunner().invoke(app, ["check", str(exact_pair), str(out / "trajectory.csv")])
    assert checked.exit_code == 0, checked.output


def test_cli_sigterm_exits_143(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, exact_pair: Path
) -> None:
    from stlplan.outputs.progress import ProgressLine

    hook = signal_at_first_plan(signal.SIGTERM)
    monkeypatch.setattr(ProgressLine, "update", lambda self, p: hook(p))
    out = tmp_path / "plan"
    args = ["solve", str(exact_pair), "--out", str(out), "--no-animation", *KEEPABLE]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 143, result.output
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


def test_second_signal_stops_hard_and_writes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "plan"
    with pytest.raises(signals.Interrupted):
        api.solve(
            PAIR, out=out, progress=signal_at_first_plan(times=2), overrides=Overrides(threads=1)
        )
    assert not out.exists()


def test_resume_runs_interrupted_records_again(tmp_path: Path) -> None:
    from stlplan.sweep.runner import RunSpec

    specs = [RunSpec("pair", "", "pair.yaml", run, 0) for run in range(3)]
    lines = [
        {"mission": "pair", "run": 0, "seed": 0, "status": "optimal"},
        {"mission": "pair", "run": 1, "seed": 0, "status": "interrupted"},
    ]
    (tmp_path / "runs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lines))
    assert [s.run for s in pending(specs, tmp_path, resume=True)] == [1, 2]


@pytest.mark.heavy
@pytest.mark.parametrize("workers", [1, 2])
def test_interrupted_sweep_keeps_finished_runs_stops_workers_and_resumes(
    tmp_path: Path, workers: int
) -> None:
    import multiprocessing

    from stlplan.sweep.runner import read_records

    def stop_after_three(record: dict[str, Any]) -> None:
        if len(read_records(tmp_path)) == 3:
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(signals.Interrupted):
        api.sweep([PAIR], 40, 0, tmp_path, workers, on_record=stop_after_three)
    assert multiprocessing.active_children() == []
    kept = read_records(tmp_path)
    assert 3 <= len(kept) < 40
    assert all(r["status"] == "optimal" for r in kept)
    api.sweep([PAIR], 6, 0, tmp_path, workers, resume=True)
    runs = [r["run"] for r in read_records(tmp_path)]
    assert set(runs) >= set(range(6)) and len(runs) == len(set(runs))


def test_held_signal_arrives_after_the_critical_section() -> None:
    done = []
    with signals.stop_on_signals(), pytest.raises(signals.Interrupted):
        with signals.held():
            # sent to this thread, which holds it: a signal sent to the process may be taken by
            # another thread (numpy's or HiGHS's pool), which does not hold it
            signal.pthread_kill(threading.get_ident(), signal.SIGINT)
            done.append("inside")  # not interrupted while held
        done.append("after")  # the signal lands on leaving the section
    assert done == ["inside"]


def test_held_signal_waits_when_another_thread_receives_it() -> None:
    """A solver's worker thread does not block the signal, so the kernel delivers it there; the
    handler still runs in the main thread and must wait for the end of the section."""
    release = threading.Event()
    worker = threading.Thread(target=release.wait)  # started before the mask: receives signals
    worker.start()
    done = []
    try:
        with signals.stop_on_signals(), pytest.raises(signals.Interrupted):
            with signals.held():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.2)  # the handler runs in the main thread during this sleep
                done.append("inside")
            done.append("after")
    finally:
        release.set()
        worker.join()
    assert done == ["inside"]
