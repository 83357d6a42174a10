"""Plans as values: the value of each variable of a model, by key, read from and loaded into it.

A variable's key is its component's name and its index (``("x", ("vis1", 3, 0))``), the same in
every model built for the problem: a plan read from one model loads into another, or starts a
solve of it, whatever columns HiGHS gave each. Keys one model has and the other lacks (a lazy
requirement's indicators) are skipped; a start that misses some is completed by HiGHS. Between
models of other agents or tasks (a part's and the whole team's) only the states' and inputs'
keys name the same variables: a numbered component's index may stand for another one there.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Hashable, Iterable, Mapping

import numpy as np
from pyomo.core.base.objective import ObjectiveData
from pyomo.core.base.var import VarData
from pyomo.environ import ConcreteModel, Var, value

from stlplan.planner.run.outcome import Plan, VarKey


def var_key(var: VarData) -> VarKey:
    """The key of a Pyomo variable: its component's name and its index."""
    index: Hashable = var.index()
    return (var.parent_component().name, index)


def effort(model: ConcreteModel) -> float:
    """The L1 effort of the inputs loaded in ``model`` (the effort step 1 counts)."""
    return sum(abs(v) for k, v in model_values(model).items() if k[0] == "u")


def trajectory_values(
    values: Mapping[VarKey, float], agents: Collection[str] | None = None
) -> dict[VarKey, float]:
    """The states and inputs among ``values`` (keys ``("x", (agent, k, i))`` and ``("u", ...)``),
    of ``agents`` only when given: the values that mean the same in every model."""
    return {
        k: v
        for k, v in values.items()
        if k[0] in ("x", "u") and (agents is None or k[1][0] in agents)  # type: ignore[index]
    }


def model_values(model: ConcreteModel) -> dict[VarKey, float]:
    """The values loaded in ``model``, by key (variables without a value are left out)."""
    return {
        var_key(v): float(v.value) for v in model.component_data_objects(Var) if v.value is not None
    }


def load_values(model: ConcreteModel, values: Mapping[VarKey, float]) -> None:
    """Load ``values`` into ``model``'s variables of the same key (fixed ones keep theirs)."""
    for v in model.component_data_objects(Var):
        if not v.fixed:
            found = values.get(var_key(v))
            if found is not None:
                v.set_value(found, skip_validation=True)


class ColumnKeys:
    """The key of each of HiGHS's columns, for one model loaded in one session.

    Parameters
    ----------
    model
        The model; variables added later get keys at the next :meth:`keys`.
    columns
        A callable returning HiGHS's column of each variable, by ``id``.
    """

    def __init__(self, model: ConcreteModel, columns: Callable[[], Mapping[int, int]]) -> None:
        self.model, self.columns = model, columns
        self._keys: list[VarKey | None] = []
        self._by_id: dict[int, int] = {}

    def keys(self) -> list[VarKey | None]:
        """Keys by column (refreshed when the model's columns changed since last time: added,
        or removed with a block and the columns after them renumbered)."""
        by_id = self.columns()
        if by_id != self._by_id:
            self._by_id = dict(by_id)
            keys: list[VarKey | None] = [None] * (max(by_id.values(), default=-1) + 1)
            for v in self.model.component_data_objects(Var):
                column = by_id.get(id(v))
                if column is not None:
                    keys[column] = var_key(v)
            self._keys = keys
        return self._keys

    def values(self, x: np.ndarray) -> dict[VarKey, float]:
        """HiGHS's column vector ``x`` as values by key."""
        return {k: float(xi) for k, xi in zip(self.keys(), x, strict=False) if k is not None}

    def start(self, values: Mapping[VarKey, float]) -> tuple[np.ndarray, np.ndarray]:
        """The columns ``values`` gives and their values, for a (possibly partial) start."""
        pairs = [(c, values[k]) for c, k in enumerate(self.keys()) if k is not None and k in values]
        columns = np.array([c for c, _ in pairs], dtype=np.int32)
        return columns, np.array([v for _, v in pairs], dtype=float)


def plan_of(
    model: ConcreteModel,
    objective: ObjectiveData,
    added: Iterable[int] = (),
    meets_all: bool = True,
) -> Plan:
    """The plan loaded in ``model`` as a value, with the objective's value."""
    return Plan(float(value(objective)), model_values(model), frozenset(added), meets_all)
