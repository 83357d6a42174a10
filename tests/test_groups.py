"""Elements and groups a Pattern admits (paper section 3, Table 1)."""

from __future__ import annotations

import itertools
from collections.abc import Mapping

from hypothesis import given, settings
from hypothesis import strategies as st

from stlplan.mission.groups import (
    Element,
    RoleRule,
    best_group,
    candidates,
    count_groups,
    elements,
    iter_groups,
    pack,
)

Team = Mapping[str, frozenset[str]]


def _team(**counts: int) -> dict[str, frozenset[str]]:
    """``_team(UV=3, IR=2)`` -> uv1, uv2, uv3 with {UV}, ir1, ir2 with {IR} (in that order)."""
    return {
        f"{cap.lower()}{i}": frozenset({cap}) for cap, n in counts.items() for i in range(1, n + 1)
    }


def _caps(*names: str) -> RoleRule:
    return RoleRule(capabilities=frozenset(names))


def _groups(
    roles: tuple[str, ...],
    rules: Mapping[str, RoleRule],
    team: Team,
    count: int,
    reuse: bool = False,
) -> list[tuple[Element, ...]]:
    elems = elements(roles, rules, team)
    return [tuple(elems[i] for i in g) for g in iter_groups(elems, count, reuse)]


def _brute_force(elems: tuple[Element, ...], count: int, reuse: bool) -> set[frozenset[Element]]:
    """Every set of ``count`` distinct elements, disjoint in agents unless reuse is allowed."""
    out = set()
    for combo in itertools.combinations(elems, count):
        agents = [a for e in combo for a in e]
        if reuse or len(agents) == len(set(agents)):
            out.add(frozenset(combo))
    return out


def test_table_1_crop_b_has_six_groups() -> None:
    # Phi_B: roles p (UV) and q (IR), count 2, with 3 UV and 2 IR agents
    rules = {"p": _caps("UV"), "q": _caps("IR")}
    team = _team(UV=3, IR=2, Vis=3)
    elems = elements(("p", "q"), rules, team)
    assert len(elems) == 6
    groups = _groups(("p", "q"), rules, team, 2)
    assert len(groups) == 6
    for group in groups:
        first, second = group
        assert not set(first) & set(second)  # no agent in both elements
    # each group uses both IR agents, and two distinct UV agents out of three
    assert {frozenset(e[0] for e in g) for g in groups} == {
        frozenset(p) for p in itertools.combinations(["uv1", "uv2", "uv3"], 2)
    }


def test_crop_c_three_vis_count_two() -> None:
    groups = _groups(("p",), {"p": _caps("Vis")}, _team(UV=3, IR=2, Vis=3), 2)
    assert len(groups) == 3


def test_case_two_and_three_counts() -> None:
    assert len(_groups(("p",), {"p": _caps("Vis")}, _team(UV=3, IR=2, Vis=4), 3)) == 4
    assert len(_groups(("p",), {"p": _caps("UV")}, _team(UV=4, IR=2, Vis=3), 2)) == 6


def test_distinct_roles_take_distinct_agents() -> None:
    # two roles with the same capability: ordered assignments of distinct agents
    elems = elements(("p", "q"), {"p": _caps("UV"), "q": _caps("UV")}, _team(UV=3))
    assert len(elems) == 6
    assert all(p != q for p, q in elems)


def test_pinned_role() -> None:
    team = _team(UV=3, IR=2)
    rules = {"p": RoleRule(agent="uv2"), "q": _caps("IR")}
    elems = elements(("p", "q"), rules, team)
    assert elems == (("uv2", "ir1"), ("uv2", "ir2"))
    assert len(_groups(("p", "q"), rules, team, 1)) == 2
    assert len(_groups(("p", "q"), rules, team, 2)) == 0  # uv2 cannot serve twice
    assert len(_groups(("p", "q"), rules, team, 2, reuse=True)) == 1


def test_multi_capability_role_needs_all() -> None:
    team = {
        "uv1": frozenset({"UV"}),
        "both1": frozenset({"UV", "IR"}),
        "ir1": frozenset({"IR"}),
        "all1": frozenset({"UV", "IR", "Vis"}),
    }
    assert candidates(_caps("UV", "IR"), team) == ("both1", "all1")
    assert candidates(_caps("UV"), team) == ("uv1", "both1", "all1")
    assert candidates(_caps("UV", "Lidar"), team) == ()


def test_reuse_agents() -> None:
    rules = {"p": _caps("UV"), "q": _caps("IR")}
    team = _team(UV=1, IR=2)
    assert len(_groups(("p", "q"), rules, team, 2)) == 0
    assert _groups(("p", "q"), rules, team, 2, reuse=True) == [(("uv1", "ir1"), ("uv1", "ir2"))]


def test_count_larger_than_possible_gives_no_group() -> None:
    team = _team(Vis=3)
    assert _groups(("p",), {"p": _caps("Vis")}, team, 4) == []
    assert _groups(("p",), {"p": _caps("Vis")}, team, 4, reuse=True) == []
    assert _groups(("p",), {"p": _caps("UV")}, team, 1) == []


def test_count_groups_limit() -> None:
    elems = elements(("p",), {"p": _caps("UV")}, _team(UV=6))
    assert count_groups(elems, 3) == 20
    assert count_groups(elems, 3, limit=5) == 5


TEAMS = st.dictionaries(
    st.sampled_from([f"a{i}" for i in range(6)]),
    st.frozensets(st.sampled_from(["UV", "IR", "Vis"]), min_size=1, max_size=2),
    min_size=1,
    max_size=6,
)
RULES = st.lists(
    st.frozensets(st.sampled_from(["UV", "IR", "Vis"]), min_size=1, max_size=2),
    min_size=1,
    max_size=2,
)


@settings(max_examples=150, deadline=None)
@given(TEAMS, RULES, st.integers(1, 3), st.booleans())
def test_groups_are_unordered_sets_matching_brute_force(
    team: Team, rule_caps: list[frozenset[str]], count: int, reuse: bool
) -> None:
    roles = tuple(f"r{i}" for i in range(len(rule_caps)))
    rules = {r: RoleRule(capabilities=c) for r, c in zip(roles, rule_caps, strict=True)}
    elems = elements(roles, rules, team)
    groups = list(iter_groups(elems, count, reuse))
    as_sets = [frozenset(elems[i] for i in g) for g in groups]
    # each group is `count` distinct elements listed once, never again as a permutation
    assert all(len(s) == count for s in as_sets)
    assert len(set(as_sets)) == len(groups)
    assert all(list(g) == sorted(set(g)) for g in groups)
    assert set(as_sets) == _brute_force(elems, count, reuse)
    assert count_groups(elems, count, reuse) == len(groups)


@settings(max_examples=150, deadline=None)
@given(
    uv=st.integers(1, 4),
    ir=st.integers(1, 3),
    count=st.integers(1, 3),
    reuse=st.booleans(),
    two_roles=st.booleans(),
    data=st.data(),
)
def test_best_group_matches_enumerating_every_group(
    uv: int, ir: int, count: int, reuse: bool, two_roles: bool, data: st.DataObject
) -> None:
    team = _team(UV=uv, IR=ir)
    roles = ("p", "q") if two_roles else ("p",)
    rules = {"p": _caps("UV"), "q": _caps("IR")}
    elems = elements(roles, rules, team)
    scores = data.draw(
        st.lists(
            st.sampled_from([-2.0, -0.5, 0.0, 0.5, 1.0, 3.0]),
            min_size=len(elems),
            max_size=len(elems),
        )
    )
    groups = list(iter_groups(elems, count, reuse))
    value, group = best_group(elems, scores, count, reuse)
    if not groups:
        assert group is None and value == float("-inf")
        return
    assert value == max(min(scores[i] for i in g) for g in groups)
    assert group is not None and tuple(sorted(group)) in groups
    assert min(scores[i] for i in group) == value


def test_pack_finds_a_group_only_where_one_exists() -> None:
    team = _team(UV=2, IR=2)
    rules = {"p": _caps("UV"), "q": _caps("IR")}
    elems = elements(("p", "q"), rules, team)  # (uv1,ir1) (uv1,ir2) (uv2,ir1) (uv2,ir2)
    assert pack(elems, [0, 1], 2) is None  # both use uv1
    assert pack(elems, [0, 1, 3], 2) == (0, 3)
    assert pack(elems, [0, 1, 2, 3], 3) is None  # two UV agents at most
    assert pack(elems, [0, 1], 2, reuse_agents=True) == (0, 1)
