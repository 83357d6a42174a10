"""Step 1's strategy, composed in one place from the configuration (:func:`build_strategy`).

Three strategies, each wrapping the one before:

* :class:`Direct`: build the MILP with every requirement and solve it once;
* :class:`LazyRounds`: build it with the step requirements of constraints and separation left
  out, and solve in rounds, adding what each round's plan violates
  (:mod:`stlplan.planner.core.lazy`); while no plan meets every requirement, a round's plan may be
  repaired agent by agent, as the :class:`~stlplan.planner.core.policy.RepairPolicy` says;
* :class:`Parts`: solve the independent parts of the team apart, each by the strategy inside,
  merging parts whose plans collide (a merge repaired by the same policy) and assembling the
  parts' plans in one model (:mod:`stlplan.planner.core.components`); a plan of the whole team to
  start from (a replan's) starts each part; when the parts' plans do not assemble into a plan
  of the whole (a part's plan that met its decisions only within HiGHS's integrality
  tolerance), the team is solved whole by the strategy inside. With a large part, a first plan
  of the whole team comes before the parts' proofs (:mod:`stlplan.planner.first_plan.hooks`),
  the only first-plan heuristics' object, built here.

Each strategy takes the problem, the configuration, the run's clock and a budget, and returns
the model with the plan loaded and the :class:`~stlplan.planner.run.outcome.Outcome`. Each describes
itself; ``summary.json`` records the line (``strategy``).
"""

from __future__ import annotations

from dataclasses import dataclass

from stlplan.mission.problem import Problem
from stlplan.planner.config import PlannerConfig
from stlplan.planner.core.components import Parts
from stlplan.planner.core.lazy import LazySolver, solve_step1
from stlplan.planner.core.parts import Strategy
from stlplan.planner.core.policy import RepairPolicy
from stlplan.planner.encoding.model import PlanModel, build_model
from stlplan.planner.first_plan.hooks import FirstPlan
from stlplan.planner.run.budget import Budget
from stlplan.planner.run.clock import Clock
from stlplan.planner.run.outcome import Outcome, Plan


def _built(problem: Problem, config: PlannerConfig, clock: Clock, budget: Budget) -> PlanModel:
    """The model as ``config`` declares it, its effort floors within ``budget.side_share``."""
    with clock.building():
        return build_model(problem, config, budget.share(config.budget.side_share).deadline)


@dataclass(frozen=True)
class Direct:
    """Every requirement in the model; one solve."""

    def solve(
        self,
        problem: Problem,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        start: Plan | None = None,
    ) -> tuple[PlanModel, Outcome]:
        up_front = config.with_overrides({"lazy.enabled": False})
        pm = _built(problem, up_front, clock, budget)
        solver = LazySolver(pm, up_front, clock, whole=True)
        return pm, solve_step1(solver, budget, start)

    def describe(self) -> str:
        return "direct"


@dataclass(frozen=True)
class LazyRounds:
    """Step requirements added as rounds' plans violate them; repairs by ``policy``."""

    policy: RepairPolicy

    def solve(
        self,
        problem: Problem,
        config: PlannerConfig,
        clock: Clock,
        budget: Budget,
        start: Plan | None = None,
    ) -> tuple[PlanModel, Outcome]:
        pm = _built(problem, config, clock, budget)
        return pm, solve_step1(self.rounds(pm, config, clock, whole=True), budget, start)

    def rounds(
        self, pm: PlanModel, config: PlannerConfig, clock: Clock, whole: bool = False
    ) -> LazySolver:
        """The lazy loop of ``pm``, repairing by the policy (a part's, for :class:`Parts`)."""
        return LazySolver(pm, config, clock, self.policy, whole)

    def describe(self) -> str:
        triggers = self.policy.describe()
        in_turn = f", repair in turn if {triggers}" if triggers else ""
        return f"lazy rounds(direct{_by_elements(self.policy)}{in_turn})"


def build_strategy(config: PlannerConfig) -> Strategy:
    """Step 1's strategy as ``config`` composes it (module docstring)."""
    if not config.lazy.enabled:
        return Direct()
    hooks = FirstPlan.of(config)
    rounds = LazyRounds(RepairPolicy.of(config, hooks))
    parts = Parts(rounds, config.parts.plan_first_agents, hooks)
    return parts if config.parts.enabled else rounds


def policy_of(config: PlannerConfig) -> RepairPolicy:
    """The repair policy of ``config``, with the first-plan heuristics as its hooks."""
    return RepairPolicy.of(config, FirstPlan.of(config))


def _by_elements(policy: RepairPolicy) -> str:
    """The repair by elements in the strategy line (empty when it is off)."""
    return "" if policy.repair.by_elements is None else ", by elements before a first plan"


def describe(config: PlannerConfig) -> str:
    """The whole run in one line, the model and step 1's strategy included (as CP-SAT logs its
    parameters)."""
    m = config.model
    cuts = [name for name, on in (("floors", m.floors), ("symmetry", m.symmetry)) if on]
    model = f"model({m.encoding}, {m.tasks}" + "".join(f", {c}" for c in cuts) + ")"
    after = "step 2" if config.continuous.two_step else "polish"
    return f"{model} -> {build_strategy(config).describe()} -> {after} -> strict retry if needed"
