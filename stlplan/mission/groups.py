"""Elements and groups a Pattern allows (paper section 3, Table 1).

An **element** assigns one agent to each role of a task's inner logic; distinct roles get distinct
agents. A **group** is an unordered set of ``count`` elements; unless the task allows reuse, no agent
appears in two elements of a group. The task holds iff some group has every element satisfy phi.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Iterator, Mapping, Sequence
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


def pack(
    elems: Sequence[Element], candidates: Sequence[int], count: int, reuse_agents: bool = False
) -> tuple[int, ...] | None:
    """``count`` of the ``candidates`` (indices into ``elems``) that form a group, or None.

    An exact depth-first search: elements are tried in order, an element sharing an agent with
    those chosen is skipped (unless ``reuse_agents``), and a branch stops as soon as some role
    position has fewer distinct agents left than elements still to choose (each chosen element
    takes a distinct agent at every position).
    """
    if count == 0:
        return ()
    if reuse_agents or all(len(elems[i]) <= 1 for i in candidates):
        return tuple(candidates[:count]) if len(candidates) >= count else None

    def search(pool: list[int], chosen: tuple[int, ...]) -> tuple[int, ...] | None:
        need = count - len(chosen)
        if need == 0:
            return chosen
        if _position_room(elems, pool) < need:
            return None
        for n, i in enumerate(pool):
            rest = [j for j in pool[n + 1 :] if set(elems[j]).isdisjoint(elems[i])]
            found = search(rest, chosen + (i,))
            if found is not None:
                return found
        return None

    return search(list(candidates), ())


def _position_room(elems: Sequence[Element], pool: Sequence[int]) -> int:
    """Least number of distinct agents at one role position among the ``pool`` elements."""
    if not pool:
        return 0
    width = len(elems[pool[0]])
    return min(len({elems[i][r] for i in pool}) for r in range(width))


def best_group(
    elems: Sequence[Element], scores: Iterable[float], count: int, reuse_agents: bool = False
) -> tuple[float, tuple[int, ...] | None]:
    """``max over groups of min over its elements of scores``, and a group attaining it.

    No group is enumerated: the answer is the largest score ``s`` such that the elements scoring
    at least ``s`` still hold a group (:func:`pack`), found by bisection over the sorted scores.
    NaN scores count as ``-inf``. Returns ``(-inf, None)`` when the Pattern admits no group.
    """
    values = [float("-inf") if v != v else float(v) for v in scores]
    order = sorted(range(len(values)), key=lambda i: -values[i])
    found = pack(elems, sorted(order), count, reuse_agents)
    if found is None:
        return float("-inf"), None
    lo, hi = count - 1, len(order) - 1  # the best `lo + 1` elements may already hold a group
    best = found
    while lo < hi:
        mid = (lo + hi) // 2
        group = pack(elems, sorted(order[: mid + 1]), count, reuse_agents)
        if group is None:
            lo = mid + 1
        else:
            hi, best = mid, group
    return min(values[i] for i in best), best
