"""Words in what stlplan prints: counted nouns (``1 agent``, ``2 agents``), and many agents named in a
few words."""

from __future__ import annotations

from collections.abc import Sequence


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, in the plural (``plural``, by default ``noun + "s"``) unless ``n``
    is 1: ``counted(1, "agent") == "1 agent"``, ``counted(3, "agent") == "3 agents"``."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"


def agent_names(agents: Sequence[str], order: Sequence[str], shown: int = 3) -> str:
    """A part's agents in a few words: all of them up to ``shown``, ``16 agents a01..a16``
    for a run of the mission's ``order``, else the first ``shown`` and how many."""
    if len(agents) <= shown:
        return ", ".join(agents)
    place = {name: i for i, name in enumerate(order)}
    steps = [place.get(b, -2) - place.get(a, -2) for a, b in zip(agents, agents[1:], strict=False)]
    if all(step == 1 for step in steps):
        return f"{len(agents)} agents {agents[0]}..{agents[-1]}"
    return f"{len(agents)} agents {', '.join(agents[:shown])}, ..."
