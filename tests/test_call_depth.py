"""The path from the API to the solver stays short: frames between ``api.solve`` and the first
MILP solve (a maintainer reads every one of them)."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Any

import pytest

from stlplan import api
from stlplan.planner.backend import session
from tests.helpers.paths import MISSIONS

MOST_FRAMES = 10
"""Frames from ``api.solve`` to ``HighsSession.solve`` on Case I, both counted."""

MOST_FRAMES_IN_A_TURN = 14
"""The same, to the first solve of a turn (a prioritized repair's) on a crowd."""


class _Reached(Exception):
    """Raised at the first solve (standing in for it), with the frames from it up to
    ``api.solve``."""


def _depth_at_first_solve(mission: Path, monkeypatch: pytest.MonkeyPatch) -> list[str]:
    def solve(self: Any, *args: Any, **kwargs: Any) -> Any:
        names = [f"{Path(f.filename).name}:{f.function}" for f in inspect.stack()[1:]]
        raise _Reached(["session.py:solve", *names[: names.index("api.py:solve") + 1]])

    monkeypatch.setattr(session.HighsSession, "solve", solve)
    with pytest.raises(_Reached) as reached:
        api.solve(mission)
    return list(reached.value.args[0])


def test_case_i_reaches_its_first_solve_within_the_frame_budget(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    frames = _depth_at_first_solve(MISSIONS / "farm.yaml", monkeypatch)
    assert frames[0] == "session.py:solve" and frames[-1] == "api.py:solve"
    assert len(frames) <= MOST_FRAMES, "\n".join(reversed(frames))


@pytest.mark.heavy
def test_a_crowds_first_turn_is_within_its_frame_budget(monkeypatch: pytest.MonkeyPatch) -> None:
    # the parts' solves run; the first solve of a turn stands in for the solve
    solve = session.HighsSession.solve

    def solve_unless_a_turn(self: Any, *args: Any, **kwargs: Any) -> Any:
        names = [f"{Path(f.filename).name}:{f.function}" for f in inspect.stack()[1:]]
        if any(name.startswith(("prioritized.py", "in_turn.py")) for name in names):
            raise _Reached(["session.py:solve", *names[: names.index("api.py:solve") + 1]])
        return solve(self, *args, **kwargs)

    monkeypatch.setattr(session.HighsSession, "solve", solve_unless_a_turn)
    with pytest.raises(_Reached) as reached:
        api.solve(MISSIONS / "crowd" / "crowd-16.yaml", overrides=api.Overrides(threads=1))
    frames = list(reached.value.args[0])
    assert any(name.startswith("prioritized.py") for name in frames)
    assert len(frames) <= MOST_FRAMES_IN_A_TURN, "\n".join(reversed(frames))
