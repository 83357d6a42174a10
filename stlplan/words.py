"""Counted nouns in what stlplan prints: ``1 agent``, ``2 agents``."""

from __future__ import annotations


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, in the plural (``plural``, by default ``noun + "s"``) unless ``n``
    is 1: ``counted(1, "agent") == "1 agent"``, ``counted(3, "agent") == "3 agents"``."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
