"""The mission file schema: pydantic models that reject unknown keys.

The models are the single source of truth for mission files; ``stlplan schema`` exports them to
``schemas/mission.schema.json``. Cross-field consistency (undefined names, shapes, horizons) is
checked in :mod:`stlplan.mission.checks`, after these models accept the document.
"""

from __future__ import annotations

import json
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    Strict,
    StrictBool,
    StrictInt,
    model_validator,
)

MAX_MAGNITUDE = 1e6
"""Largest magnitude of a number in a mission file (coordinates, matrices, weights); larger
numbers would make the solver's big-M constants meaningless."""
MAGNITUDE_TEXT = "1e6"
"""``MAX_MAGNITUDE`` as messages write it."""
MAX_SEED = 2**31 - 1
"""Largest random seed HiGHS takes."""
MAX_THREADS = 256
"""Most threads a run may ask for (HiGHS aborts the process when asked for 100,000)."""


def _integral(value: Any) -> Any:
    """A float with no fractional part (``8.0``) is the integer it equals, as in JSON Schema."""
    return int(value) if isinstance(value, float) and value.is_integer() else value


Integer = Annotated[StrictInt, BeforeValidator(_integral)]
"""An integer; ``8.0`` counts as 8 (JSON Schema's integers), ``true`` and ``"8"`` do not."""
Natural = Annotated[StrictInt, Field(ge=0), BeforeValidator(_integral)]
"""An :data:`Integer` >= 0."""
Number = Annotated[float, Strict(), Field(ge=-MAX_MAGNITUDE, le=MAX_MAGNITUDE)]
"""A number written as a number (not text, not true/false), of magnitude at most 1e6.

A field that needs a narrower range uses one of the types below: a ``Field(ge=0)`` given beside
``Number`` would be overridden by ``Number``'s own lower bound."""
NonNegative = Annotated[float, Strict(), Field(ge=0, le=MAX_MAGNITUDE)]
"""A :data:`Number` >= 0."""
Positive = Annotated[float, Strict(), Field(gt=0, le=MAX_MAGNITUDE)]
"""A :data:`Number` > 0."""
Fraction = Annotated[float, Strict(), Field(ge=0, lt=1)]
"""A number in [0, 1)."""
Threads = Annotated[StrictInt, Field(ge=1, le=MAX_THREADS), BeforeValidator(_integral)]
"""A number of threads: 1 to :data:`MAX_THREADS`."""
Bounds = tuple[Number, Number]
NonEmptyNames = Annotated[list[str], Field(min_length=1)]
FORMULA_NAME = r"^[A-Za-z_][A-Za-z0-9_]*$"
"""What a formula can name (a region): letters, digits and '_', not starting with a digit."""
RegionName = Annotated[str, Field(pattern=FORMULA_NAME)]


class _Strict(BaseModel):
    model_config = ConfigDict(
        extra="forbid", frozen=True, use_attribute_docstrings=True, allow_inf_nan=False
    )


class Dynamics(_Strict):
    """Discrete-time linear dynamics ``x(k+1) = A x(k) + B u(k)`` with box bounds."""

    A: list[list[Number]]
    """State matrix, n x n."""
    B: list[list[Number]]
    """Input matrix, n x m."""
    position: tuple[Integer, Integer] = (0, 1)
    """The two state components that are the planar position z (0-based)."""
    state_bounds: list[Bounds]
    """[low, high] for each of the n state components."""
    input_bounds: list[Bounds]
    """[low, high] for each of the m input components."""


class Agent(_Strict):
    """One member of the team."""

    name: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_\-]*$")
    """Unique agent name (letters, digits, '_' and '-')."""
    dynamics: str
    """Name of an entry of `dynamics`."""
    capabilities: list[str] = []
    """Capabilities the agent has, such as sensors (e.g. [UV])."""
    initial_state: list[Number]
    """Initial state x(0), one value per state component."""
    final: Literal["free", "at_rest"] = "free"
    """``at_rest``: the agent ends at rest, x(H) an equilibrium of its dynamics with zero input
    (``A x(H) = x(H)``: for a double integrator, zero velocity)."""


class Region(_Strict):
    """A convex region of the plane: a box, or a polytope ``{z : G z <= h}``."""

    model_config = ConfigDict(
        json_schema_extra={"oneOf": [{"required": ["box"]}, {"required": ["G", "h"]}]}
    )

    box: tuple[Bounds, Bounds] | None = None
    """[[x_lo, x_hi], [y_lo, y_hi]]."""
    G: list[tuple[Number, Number]] | None = None
    """Polytope rows: each row [g_x, g_y] of G in G z <= h."""
    h: list[Number] | None = None
    """Polytope right-hand sides, one per row of G."""

    @model_validator(mode="after")
    def _one_shape(self) -> Region:
        if (self.box is None) == (self.G is None and self.h is None):
            raise ValueError("give either 'box' or both 'G' and 'h'")
        if self.box is None and (self.G is None or self.h is None):
            raise ValueError("a polytope needs both 'G' and 'h'")
        return self


class PinnedRole(_Strict):
    """A role filled by one named agent."""

    agent: str
    """Name of the agent that fills the role."""


RoleRule = str | NonEmptyNames | PinnedRole


class Synchronous(_Strict):
    """Makes a task synchronous: ``F[a,b] <G[0,d] phi, count, Pattern>``."""

    within: tuple[Integer, Integer]
    """[a, b]: the steps at which the synchronized run may start."""
    hold: Integer = Field(default=0, ge=0)
    """d: every element must satisfy phi for d+1 consecutive steps together."""
    gamma: Natural | None = None
    """Upper bound on this task's synchronous robustness, a natural number (default:
    objective.gamma)."""


class Task(_Strict):
    """A global task ``<phi, count, Pattern>``, synchronous when `synchronous` is given."""

    formula: str
    """Inner logic phi over the roles (see the formula language in the README)."""
    count: Integer = Field(default=1, ge=1)
    """c: how many elements must satisfy phi."""
    roles: dict[str, RoleRule] = {}
    """Pattern: each role's capability, list of capabilities (all required), or {agent: name}."""
    reuse_agents: StrictBool = False
    """Allow one agent in several elements of a group (the paper forbids it by default)."""
    synchronous: Synchronous | None = None
    """Synchronization window and hold; absent for an ordinary task."""
    priority: Integer = 0
    """When not every task can be met (a degraded plan), tasks of a higher priority are kept
    first; among equal priorities, as many as possible."""


class Constraint(_Strict):
    """Plain STL that must hold at step 0, for every agent or for named agents."""

    formula: str
    """STL formula over the roles below."""
    for_each: str | None = None
    """A role that ranges over agents: the formula must hold for each of them."""
    agents: NonEmptyNames | None = None
    """Agents `for_each` ranges over (default: every agent)."""
    roles: dict[str, str] = {}
    """Roles pinned to named agents."""


class Margin(_Strict):
    """Spatial robustness: the margin by which every enforced predicate holds."""

    minimum: NonNegative = 0.0
    """Required margin (0 enforces predicates exactly, as the paper does)."""
    maximize: StrictBool = False
    """Maximize the margin (weighted by `weight`) instead of only requiring `minimum`."""
    weight: NonNegative = 1.0
    """Weight of the margin in the objective when maximized."""


class Objective(_Strict):
    """Problem (step1): maximize rho_s(Phi) - beta * effort subject to every task."""

    beta: NonNegative = 0.05
    """Weight of the control effort."""
    gamma: Natural = 8
    """Default upper bound on each synchronous task's robustness, a natural number as in the
    paper (rho_s counts steps); 0 leaves the synchronous robustness out of the objective."""
    effort: Literal["l1", "l2", "linf"] = "l2"
    """Norm of the effort minimized in step 2 (step 1 always uses l1)."""
    two_step: StrictBool = True
    """Run step 2: fix step 1's decisions and minimize the effort norm."""
    margin: Margin = Margin()
    """Spatial robustness requirement or goal."""


class SolverOptions(_Strict):
    """HiGHS options."""

    time_limit: Positive = 300.0
    """Wall-clock limit of the whole run (building, solving, step 2, diagnosis), seconds."""
    gap: Fraction = 1e-4
    """Relative optimality gap at which HiGHS stops (0 <= gap < 1)."""
    threads: Threads | None = None
    """Threads HiGHS may use (default: HiGHS decides)."""
    seed: Integer = Field(default=0, ge=0, le=MAX_SEED)
    """HiGHS random seed (0 .. 2147483647)."""
    encoding: Literal["log", "standard"] = "standard"
    """Disjunctions with one binary per disjunct (``standard``, measured the faster on the
    general-STL suite and the farm cases) or as a logarithmic SOS1 (``log``)."""
    tasks: Literal["selection", "groups"] = "selection"
    """Tasks by selecting elements (no group enumerated) or by enumerating groups (the paper)."""


class Safety(_Strict):
    """How safety requirements (avoid a region, keep separated) are judged."""

    inter_sample: StrictBool = True
    """Judge them on the straight segment between consecutive steps, the path a robot tracking
    the waypoints follows; false keeps the paper's semantics (the sampled steps only)."""


class Execution(_Strict):
    """How the plan will be executed: the disturbance it must withstand."""

    disturbance: NonNegative = 0.0
    """W: a bound on an additive disturbance of every state component at every step; plans keep
    margins that one step of it cannot break (0: plans as tight as the tasks allow)."""


class SweepOptions(_Strict):
    """Where sweeps draw random initial positions."""

    initial_region: str
    """Region in which initial positions are drawn (at rest)."""


class Mission(_Strict):
    """A stlplan mission: team, map, tasks, constraints and objective."""

    name: str
    """Short name of the mission."""
    description: str = ""
    """Free text."""
    horizon: Integer = Field(ge=1)
    """H: states x(0..H), inputs u(0..H-1)."""
    dynamics: dict[str, Dynamics]
    """Named dynamics models agents refer to."""
    agents: list[Agent] = Field(min_length=1)
    """The team."""
    regions: dict[RegionName, Region] = Field(
        default={}, json_schema_extra={"additionalProperties": False}
    )
    """Named regions of the map."""
    tasks: dict[str, Task] = {}
    """Global tasks <phi, c, Pattern>, some synchronous."""
    constraints: dict[str, Constraint] = {}
    """Bottom-up STL constraints on named agents or every agent (e.g. obstacle avoidance)."""
    separation: NonNegative | None = None
    """Minimum pairwise distance between agents' positions (infinity norm), at every step."""
    objective: Objective = Objective()
    """What the plan optimizes."""
    safety: Safety = Safety()
    """How safety requirements are judged between steps."""
    execution: Execution = Execution()
    """How the plan will be executed (the disturbance it must withstand)."""
    solver: SolverOptions = SolverOptions()
    """Solver options (the command line may override them)."""
    sweep: SweepOptions | None = None
    """Settings for `stlplan sweep`."""


def _without_null(node: Any) -> Any:
    """``node`` with every ``{"type": "null"}`` branch and ``"default": null`` removed.

    Optional fields are left out of a mission file, never written as null (which the loader
    refuses), so the schema offers no null branch for validators to report ("is not of type
    'null'").
    """
    if isinstance(node, list):
        return [_without_null(item) for item in node]
    if not isinstance(node, dict):
        return node
    out = {k: _without_null(v) for k, v in node.items() if not (k == "default" and v is None)}
    branches = [b for b in out.get("anyOf", []) if b != {"type": "null"}]
    if "anyOf" in out and len(branches) == 1:
        del out["anyOf"]
        out = {**branches[0], **out}
    elif "anyOf" in out:
        out["anyOf"] = branches
    return out


def json_schema() -> str:
    """The JSON Schema of mission files, as text (stable key order, trailing newline)."""
    schema = _without_null(Mission.model_json_schema())
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = "https://stlplan.dev/schemas/mission.schema.json"
    return json.dumps(schema, indent=2, sort_keys=True) + "\n"
