"""Elements and groups a Pattern allows (paper section 3, Table 1).

An **element** assigns one agent to each role of a task's inner logic; distinct roles get distinct
agents. A **group** is an unordered set of ``count`` elements; unless the task allows reuse, no agent
appears in two elements of a group. The task holds iff some group has every element satisfy phi.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

Element = tuple[str, ...]
"""Agent names, one per role, in the task's role order."""


@dataclass(frozen=True)
class RoleRule:
    """Who may fill a role: an agent with every capability listed, or one pinned agent."""

    capabilities: frozenset[str] = frozenset()
    agent: str | None = None

    def admits(self, name: str, capabilities: frozenset[str]) -> bool:
        """Whether the agent ``name`` with ``capabilities`` may fill the role."""
        if self.agent is not None:
            return name == self.agent
        return self.capabilities <= capabilities


def candidates(rule: RoleRule, team: Mapping[str, frozenset[str]]) -> tuple[str, ...]:
    """Agents of ``team`` (name to capabilities, in team order) that may fill a role."""
    return tuple(name for name, caps in team.items() if rule.admits(name, caps))


def elements(
    roles: Sequence[str], rules: Mapping[str, RoleRule], team: Mapping[str, frozenset[str]]
) -> tuple[Element, ...]:
    """Every assignment of distinct agents to ``roles``, in team order."""
    pools = [candidates(rules[r], team) for r in roles]
    return tuple(e for e in itertools.product(*pools) if len(set(e)) == len(e))


def iter_groups(
    elems: Sequence[Element], count: int, reuse_agents: bool = False
) -> Iterator[tuple[int, ...]]:
    """Yield each group as increasing indices into ``elems`` (so each set once)."""

    def extend(
        start: int, chosen: tuple[int, ...], used: frozenset[str]
    ) -> Iterator[tuple[int, ...]]:
        if len(chosen) == count:
            yield chosen
            return
        for i in range(start, len(elems)):
            if reuse_agents or used.isdisjoint(elems[i]):
                yield from extend(i + 1, chosen + (i,), used | frozenset(elems[i]))

    yield from extend(0, (), frozenset())


def count_groups(
    elems: Sequence[Element], count: int, reuse_agents: bool = False, limit: int | None = None
) -> int:
    """Number of groups, counting at most ``limit`` (then returning ``limit``)."""
    n = 0
    for _ in iter_groups(elems, count, reuse_agents):
        n += 1
        if limit is not None and n >= limit:
            break
    return n
