"""The physical checks of one agent: initial state, dynamics and bounds, with a tolerance.

A trajectory's numbers may be off by a little (the solver's round-off, a CSV rounded to a few
decimals, another tool's integrator). With tolerance ``T`` each number ``v`` of the trajectory
may be off by ``s(v) = T max(1, |v|)`` (``T`` absolute up to 1, relative above), and every check
allows exactly what those errors can add up to:

* initial state: ``|x(0) - x_init| <= s(x(0))``;
* bounds: ``lo - s(v) <= v <= hi + s(v)`` for every state and input value;
* with the inputs: ``|x(k+1) - A x(k) - B u(k)| <= s(x(k+1)) + |A| s(x(k)) + |B| s(u(k))``.

Without the inputs (``known = "states"``) the transition ``r(k) = x(k+1) - A x(k)`` must be
``B u(k)`` for some admissible input: ``u(k) = B^+ r(k)`` (least squares, the only candidate when
``B`` has full column rank), the residual ``|r - B u| <= |I - B B^+| e`` and the input bounds
widened by ``|B^+| e``, where ``e = s(x(k+1)) + |A| s(x(k))`` bounds the error of ``r``. With the
positions only, the initial position and the position bounds are checked and the dynamics are
not.

An executed trajectory under a disturbance bounded by ``W`` per state component and step
(:func:`disturbed_verdict`) is judged up to that bound: ``|x(k+1) - A x(k) - B u(k)| <= W``
plus the tolerance above.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from stlplan.mission.problem import AgentModel, Past
from stlplan.result import Known, Trajectory, Verdict

DYNAMICS_CHECKED: dict[Known, str] = {
    "inputs": "dynamics checked with the inputs",
    "states": "dynamics checked on the states only (inputs recovered from x(k+1) - A x(k))",
    "positions": "dynamics not checked (positions only); initial positions and position "
    "bounds checked",
}
"""How the dynamics of a trajectory are checked, by what it gives."""

Violation = tuple[int, int, int, float, str]
"""``(step, check order, component, size, message)`` of one dynamics violation."""


def slack(values: np.ndarray, tol: float) -> np.ndarray:
    """``s(v) = tol * max(1, |v|)``: how far each number may be off."""
    return tol * np.maximum(1.0, np.abs(values))


def _violations(
    steps: np.ndarray,
    order: int,
    error: np.ndarray,
    allowed: np.ndarray,
    describe: Callable[[int, int], str],
) -> list[Violation]:
    """Entries ``(r, i)`` whose ``error`` exceeds ``allowed`` (NaN counts as a violation).

    ``steps[r]`` is row ``r``'s step; ``describe(r, i)`` says what was found and expected.
    """
    out: list[Violation] = []
    for r, i in np.argwhere(~(error <= allowed)):
        size = float(error[r, i]) if np.isfinite(error[r, i]) else float("inf")
        out.append((int(steps[r]), order, int(i), size, describe(int(r), int(i))))
    return out


def _bounds(
    values: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray],
    allowed: np.ndarray,
    symbol: str,
    order: int,
    components: list[int] | None = None,
) -> list[Violation]:
    # lo - allowed <= v <= hi + allowed, on the listed components (all by default)
    lo, hi = bounds
    keep = list(range(values.shape[1])) if components is None else components
    excess = np.maximum(np.maximum(lo[keep] - values[:, keep], values[:, keep] - hi[keep]), 0.0)
    return _violations(
        np.arange(len(values)),
        order,
        excess,
        np.broadcast_to(allowed, values.shape)[:, keep],
        lambda r, j: (
            f"{symbol}[{keep[j]}] = {values[r, keep[j]]:.6g}, expected within "
            f"[{lo[keep[j]]:g}, {hi[keep[j]]:g}]"
        ),
    )


def _initial(agent: AgentModel, x: np.ndarray, tol: float, keep: list[int]) -> list[Violation]:
    # |x(0) - x_init| <= s(x(0)) on the listed components
    init = agent.initial_state
    return _violations(
        np.zeros(1, dtype=int),
        0,
        np.abs(x[:1, keep] - init[keep]),
        slack(x[:1, keep], tol),
        lambda r, j: (
            f"x[{keep[j]}] = {x[0, keep[j]]:.6g}, expected the initial state {init[keep[j]]:.6g}"
        ),
    )


def _at_rest(agent: AgentModel, x: np.ndarray, tol: float, bound: float = 0.0) -> list[Violation]:
    """Violations of ``(A - I) x(H) = 0`` for an agent that must end at rest (up to what a
    disturbance ``bound`` on every component of ``x(H)`` can add)."""
    if not agent.at_rest:
        return []
    rows = agent.rest_rows()
    residual = np.abs(x[-1:] @ rows.T)
    allowed = (slack(x[-1:], tol) + bound) @ np.abs(rows).T
    return _violations(
        np.array([len(x) - 1]),
        4,
        residual,
        allowed,
        lambda r, i: f"not at rest at the last step: (A - I) x(H) is {residual[r, i]:.3g} off 0",
    )


def _with_inputs(agent: AgentModel, x: np.ndarray, u: np.ndarray, tol: float) -> list[Violation]:
    """Violations of ``x(0) = x_init``, ``x(k+1) = A x(k) + B u(k)`` and the bounds."""
    everything = list(range(agent.n))
    expected = x[:-1] @ agent.A.T + u @ agent.B.T
    allowed = (
        slack(x[1:], tol)
        + slack(x[:-1], tol) @ np.abs(agent.A).T
        + slack(u, tol) @ np.abs(agent.B).T
    )
    found = _initial(agent, x, tol, everything)
    found += _violations(
        np.arange(1, len(x)),
        1,
        np.abs(x[1:] - expected),
        allowed,
        lambda r, i: f"x[{i}] = {x[r + 1, i]:.6g}, expected A x(k) + B u(k) = {expected[r, i]:.6g}",
    )
    found += _bounds(x, (agent.state_lo, agent.state_hi), slack(x, tol), "x", 2)
    found += _bounds(u, (agent.input_lo, agent.input_hi), slack(u, tol), "u", 3)
    return found


def recovered_inputs(agent: AgentModel, x: np.ndarray) -> np.ndarray:
    """``u(k) = B^+ (x(k+1) - A x(k))``: the inputs that explain the states (least squares)."""
    return (x[1:] - x[:-1] @ agent.A.T) @ np.linalg.pinv(agent.B).T


def _with_states(agent: AgentModel, x: np.ndarray, tol: float) -> list[Violation]:
    """Violations of ``x(0) = x_init``, ``x(k+1) - A x(k) = B u(k)`` with ``u(k)`` in its bounds,
    and the state bounds."""
    pinv = np.linalg.pinv(agent.B)
    u = recovered_inputs(agent, x)
    residual = np.abs(x[1:] - x[:-1] @ agent.A.T - u @ agent.B.T)
    error = slack(x[1:], tol) + slack(x[:-1], tol) @ np.abs(agent.A).T  # bounds the error of r(k)
    off_range = np.abs(np.eye(agent.n) - agent.B @ pinv)
    found = _initial(agent, x, tol, list(range(agent.n)))
    found += _violations(
        np.arange(1, len(x)),
        1,
        residual,
        error @ off_range.T,
        lambda r, i: (
            f"x[{i}] = {x[r + 1, i]:.6g}: no input u(k) gives x(k+1) - A x(k) "
            f"(off by {residual[r, i]:.3g})"
        ),
    )
    found += _bounds(x, (agent.state_lo, agent.state_hi), slack(x, tol), "x", 2)
    found += _bounds(
        u, (agent.input_lo, agent.input_hi), error @ np.abs(pinv).T, "u (recovered)", 3
    )
    return found


def _with_positions(agent: AgentModel, x: np.ndarray, tol: float) -> list[Violation]:
    """Violations of the initial position and the position bounds."""
    keep = list(agent.position)
    found = _initial(agent, x, tol, keep)
    found += _bounds(x, (agent.state_lo, agent.state_hi), slack(x, tol), "x", 2, keep)
    return found


def _found(
    agent: AgentModel, x: np.ndarray, u: np.ndarray, known: Known, tol: float
) -> list[Violation]:
    if known == "inputs":
        return _with_inputs(agent, x, u, tol) + _at_rest(agent, x, tol)
    if known == "states":
        return _with_states(agent, x, tol) + _at_rest(agent, x, tol)
    return _with_positions(agent, x, tol)


def _replanned(
    agent: AgentModel, x: np.ndarray, u: np.ndarray, known: Known, tol: float, past: Past
) -> list[Violation]:
    """A replan's checks: the executed states kept, then the dynamics from ``K`` on (from the
    executed ``x(K)``), or, for a lost agent, its state of ``K`` kept to the end."""
    K = past.step
    executed = past.states[agent.name]
    found = _violations(
        np.arange(K + 1), 0, np.abs(x[: K + 1] - executed), slack(x[: K + 1], tol),
        lambda r, i: f"x[{i}] = {x[r, i]:.6g}, expected the executed {executed[r, i]:.6g}",
    )  # fmt: skip
    if agent.name in past.lost:
        return found + _violations(
            np.arange(K, len(x)), 1, np.abs(x[K:] - executed[K]), slack(x[K:], tol),
            lambda r, i: f"x[{i}] = {x[K + r, i]:.6g}: a lost agent stays where it was last seen",
        )  # fmt: skip
    rest = replace(agent, initial_state=executed[K])
    later = _found(rest, x[K:], u[K:], known, tol)
    return found + [(step + K, *more) for step, *more in later]  # type: ignore[misc]


def dynamics_verdict(
    agent: AgentModel, trajectory: Trajectory, tol: float, past: Past | None = None
) -> Verdict:
    """The agent's physical verdict; robustness ``-(largest violation)``, 0 when all hold.

    A replan's trajectory (``past``) is checked against the executed states, and its dynamics
    from ``K`` on only: the executed past is measured, disturbances included.
    """
    x = np.asarray(trajectory.states[agent.name], dtype=float)
    u = np.asarray(trajectory.inputs[agent.name], dtype=float)
    if past is None:
        found = _found(agent, x, u, trajectory.known, tol)
    else:
        found = _replanned(agent, x, u, trajectory.known, tol, past)
    steps = "0.." if past is None else f"{past.step}.."
    detail = f"{agent.name}: {_held(trajectory.known)} for steps {steps}{trajectory.horizon}"
    if past is not None:
        detail += f" (steps 0..{past.step} executed)"
    return _verdict(agent.name, found, detail)


def _verdict(agent: str, found: list[Violation], held: str) -> Verdict:
    """The verdict ``dynamics AGENT``: ``held`` when nothing is ``found``, else the first
    violation with robustness ``-(largest violation)``."""
    name = f"dynamics {agent}"
    if not found:
        return Verdict(name, "dynamics", True, 0.0, detail=held)
    step, _, _, _, text = min(found)
    worst = max(v[3] for v in found)
    more = f" ({len(found)} violations in all)" if len(found) > 1 else ""
    return Verdict(name, "dynamics", False, -worst, detail=f"{agent} step {step}: {text}{more}")


def disturbed_verdict(
    agent: AgentModel, trajectory: Trajectory, tol: float, bound: float, lost_at: int | None = None
) -> Verdict:
    """The physical verdict on an executed trajectory whose every state component was disturbed
    by at most ``bound`` per step (:mod:`stlplan.simulation`).

    Checks ``x(0) = x_init``; ``|x(k+1) - A x(k) - B u(k)| <= bound`` (plus the tolerance of
    :func:`_with_inputs`) before ``lost_at``; ``x(k+1) = x(k)`` from ``lost_at`` on (a lost agent
    stays where it was); the state and input bounds; and, for an agent that must end at rest,
    ``|(A - I) x(H)| <= |A - I| bound`` (not for a lost agent, which stays as it was).
    """
    x = np.asarray(trajectory.states[agent.name], dtype=float)
    u = np.asarray(trajectory.inputs[agent.name], dtype=float)
    K = len(u) if lost_at is None else lost_at
    expected = x[:-1] @ agent.A.T + u @ agent.B.T
    expected[K:] = x[K:-1]
    allowed = (
        slack(x[1:], tol)
        + slack(x[:-1], tol) @ np.abs(agent.A).T
        + slack(u, tol) @ np.abs(agent.B).T
    )
    allowed[:K] += bound
    found = _initial(agent, x, tol, list(range(agent.n)))
    found += _violations(
        np.arange(1, len(x)), 1, np.abs(x[1:] - expected), allowed,
        lambda r, i: (
            f"x[{i}] = {x[r + 1, i]:.6g}, expected A x(k) + B u(k) = {expected[r, i]:.6g} "
            f"up to the disturbance {bound:g}"
            if r < K else f"x[{i}] = {x[r + 1, i]:.6g}: a lost agent stays where it was"
        ),
    )  # fmt: skip
    found += _bounds(x, (agent.state_lo, agent.state_hi), slack(x, tol), "x", 2)
    found += _bounds(u, (agent.input_lo, agent.input_hi), slack(u, tol), "u", 3)
    found += _at_rest(agent, x, tol, bound) if lost_at is None else []
    lost = "" if lost_at is None else f"; lost at step {lost_at}, then still"
    held = (
        f"{agent.name}: initial state, x(k+1) = A x(k) + B u(k) + w(k) with |w| <= {bound:g} "
        f"and bounds hold{lost}"
    )
    return _verdict(agent.name, found, held)


def _held(known: Known) -> str:
    if known == "inputs":
        return "initial state, x(k+1) = A x(k) + B u(k) and bounds hold"
    if known == "states":
        return "initial state, bounds and x(k+1) - A x(k) = B u(k) with u(k) in bounds hold"
    return "initial position and position bounds hold (positions only: dynamics not checked)"
