"""Benchmark of plans executed in a loop: how often they survive a bounded disturbance.

Case I (by default) is simulated ``--runs`` times under a disturbance bounded by ``W``
(``stlplan simulate``, :mod:`stlplan.simulation`), once per configuration:

* replanning at every step a plan robust to ``W`` (target: at least 95% of runs satisfied,
  median replan time at most 1 s);
* the same without robust margins;
* open loop (never replanning), robust and nominal;
* replanning at every step a robust plan, with an agent lost at a step in every run (target: at
  least 95% satisfied).

Then the price of robustness: the objective and ``rho_s`` of the plan robust to ``W`` against
the nominal one, both from the mission's initial states.

With ``--curves``, it also simulates the three policies on nominal plans, and replanning every
step a plan robust to the benchmark's ``W``, for a range of ``W``, and draws the fraction of runs
satisfied against ``W`` (``robustness.png``).

This is a benchmark, not a test: it only measures. Each configuration's runs go to a folder of
their own below ``--out`` (``bench-results/simulation`` by default: ``targets/`` for the table,
``curves/`` for the figure), resumable with ``--resume``; the table goes to ``simulation.md``
and ``simulation.csv`` there, the figure to ``curves/robustness.png``.
Run ``python -m stlplan.sim_bench --help``; ``make bench-simulate``.
"""

from __future__ import annotations

import argparse
import csv
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stlplan.mission.loader import load_problem
from stlplan.online import Policy
from stlplan.pipeline import plan
from stlplan.planner.overrides import Overrides
from stlplan.simulation.batch import robustness, simulate
from stlplan.simulation.settings import Simulated, events

FIELDS = (
    "configuration", "runs", "satisfied", "fraction", "replans", "smaller_margins",
    "replan_median_s", "replan_max_s", "came_back", "target", "met",
)  # fmt: skip

LATE = 0.2
"""How far past its deadline a replan may answer and still meet a row's target, s."""


@dataclass(frozen=True)
class Configuration:
    """One row of the table: a policy, the margin plans keep, events, and the target."""

    name: str
    policy: Policy
    robust: bool
    lose: tuple[str, ...] = ()
    fraction: float | None = None
    """Least fraction of runs satisfied the target asks (None: no target)."""
    median_s: float | None = None
    """Largest median replan time the target allows, s (None: no target)."""
    deadline: float | None = None
    """Each replan's deadline, s (None: none); the target then asks every replan to answer
    within :data:`LATE` of it."""

    def folder(self) -> str:
        """The configuration's folder below the benchmark's."""
        lost = "".join(f"-{e.replace('@', '-at-')}" for e in self.lose)
        by = "" if self.deadline is None else f"-deadline-{self.deadline:g}"
        return f"{self.policy}-{'robust' if self.robust else 'nominal'}{lost}{by}"

    def target(self) -> str:
        """The target in words (empty when there is none)."""
        words = [f">= {self.fraction:.0%} satisfied"] if self.fraction is not None else []
        words += [f"median <= {self.median_s:g} s"] if self.median_s is not None else []
        if self.deadline is not None:
            words.append(f"max <= {self.deadline + LATE:g} s")
        return ", ".join(words)

    def met(self, found: dict[str, Any]) -> bool | None:
        """Whether ``found`` (:func:`stlplan.simulation.report.overall`) meets the target."""
        if self.fraction is None and self.median_s is None:
            return None
        fraction_ok = self.fraction is None or (found["satisfied_fraction"] or 0) >= self.fraction
        median, most = found["replan_median_s"], found.get("replan_max_s")
        median_ok = self.median_s is None or (median is not None and median <= self.median_s)
        late_ok = self.deadline is None or most is None or most <= self.deadline + LATE
        return fraction_ok and median_ok and late_ok


def configurations(lose: Sequence[str]) -> list[Configuration]:
    """The table's rows (module docstring)."""
    rows = [
        Configuration("replan every step, robust plan", "every", True, (), 0.95, 1.0),
        Configuration(
            "replan every step at a 1 s deadline, robust plan",
            "every",
            True,
            (),
            0.95,
            deadline=1.0,
        ),
        Configuration("replan every step, nominal plan", "every", False),
        Configuration("open loop, robust plan", "never", True),
        Configuration("open loop, nominal plan", "never", False),
    ]
    for event in lose:
        name = f"replan every step, robust plan, {event.replace('@', ' lost at step ')}"
        rows.append(Configuration(name, "every", True, (event,), 0.95))
    return rows


def _simulated(
    args: argparse.Namespace, c: Configuration, disturbance: float, where: str = "targets"
) -> Any:
    """The simulation of ``c`` under ``disturbance``, resumed when ``--resume`` says so."""
    overrides = Overrides(
        time_limit=args.time_limit, threads=args.threads,
        robust_to=args.disturbance if c.robust else 0.0,
    )  # fmt: skip
    out = Path(args.out) / where / f"W{disturbance:g}" / c.folder()
    simulated = Simulated(disturbance, c.policy, events(c.lose, ()), c.deadline)
    return simulate(
        args.mission, simulated, args.runs, args.seed, out,
        workers=args.workers, resume=args.resume, overrides=overrides,
    )  # fmt: skip


def run(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Every configuration's simulation, the table, the price of robustness and (``--curves``)
    the figure."""
    chosen = configurations(args.lose)
    problem = load_problem(args.mission)
    for c in chosen:  # bad events are refused before anything runs
        Simulated(args.disturbance, c.policy, events(c.lose, ())).check(problem)
    rows, load = [], [os.getloadavg()[0]]
    for c in chosen:
        found = _simulated(args, c, args.disturbance).summary()
        load.append(os.getloadavg()[0])
        rows.append(_row(c, found))
        print(f"{c.name}: {found['satisfied']} of {found['runs']} satisfied", flush=True)
    price = price_of_robustness(args)
    out = Path(args.out)
    _write_csv(out / "simulation.csv", rows)
    (out / "simulation.md").write_text(table(rows, price, args, max(load)), encoding="utf-8")
    if args.curves:
        curves(args)
    return rows


def _row(c: Configuration, found: dict[str, Any]) -> dict[str, Any]:
    """A row of the table from a simulation's overall figures."""
    median, most = found["replan_median_s"], found["replan_max_s"]
    return {
        "configuration": c.name, "runs": found["runs"], "satisfied": found["satisfied"],
        "fraction": round(found["satisfied_fraction"] or 0.0, 3), "replans": found["replans"],
        "smaller_margins": found["reduced_margins"],
        "replan_median_s": None if median is None else round(median, 3),
        "replan_max_s": None if most is None else round(most, 3),
        "came_back": ", ".join(f"{n} {kind}" for kind, n in found["came_back"].items()),
        "target": c.target(), "met": c.met(found),
    }  # fmt: skip


def price_of_robustness(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The objective and ``rho_s`` of the plan robust to ``W`` and of the nominal plan."""
    found = []
    for label, margin in (("nominal", 0.0), (f"robust to {args.disturbance:g}", args.disturbance)):
        overrides = Overrides(time_limit=args.time_limit, threads=args.threads, robust_to=margin)
        result = plan(args.mission, overrides)[1]
        rho = None if result.report is None else result.report.rho_s
        found.append(
            {"plan": label, "status": result.status.value, "objective": result.objective,
             "rho_s": rho, "gap": result.gap}
        )  # fmt: skip
    return found


def _write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(rows)


def table(
    rows: Sequence[dict[str, Any]],
    price: Sequence[dict[str, Any]],
    args: argparse.Namespace,
    load: float | None = None,
) -> str:
    """The table of configurations, then the price of robustness; ``load``: the machine's
    highest one-minute load average seen between configurations (replan times depend on it)."""
    lines = [
        f"{args.mission}, {args.runs} runs per row, W = {args.disturbance:g}, seed {args.seed}, "
        f"{args.workers or 1} worker(s), {args.threads} HiGHS thread(s)"
        + ("" if load is None else f", load average up to {load:.1f}"),
        "",
        "| configuration | satisfied | replans (with smaller margins) | replan median s "
        "| replan max s | by the deadline | target | met |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        met = {True: "yes", False: "**no**", None: "-"}[r["met"]]
        lines.append(
            f"| {r['configuration']} | {r['satisfied']} of {r['runs']} ({r['fraction']:.0%}) "
            f"| {r['replans']} ({r['smaller_margins']}) | {_s(r['replan_median_s'])} | {_s(r['replan_max_s'])} "
            f"| {r['came_back'] or '-'} | {r['target'] or '-'} | {met} |"
        )
    lines += ["", "| plan | status | objective | rho_s | gap |", "|---|---|---|---|---|"]
    for p in price:
        lines.append(
            f"| {p['plan']} | {p['status']} | {_s(p['objective'], 4)} | {_s(p['rho_s'], 4)} "
            f"| {_s(p['gap'], 6)} |"
        )
    return "\n".join(lines) + "\n"


def _s(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


CURVE_POLICIES: tuple[Policy, ...] = ("every", "on-deviation", "never")


def curves(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The three policies on nominal plans, and replanning every step a plan robust to the
    benchmark's ``W``, for each ``W`` of ``--curve-w`` (``--curve-runs`` runs each), and
    ``robustness.png`` drawn from them."""
    many = argparse.Namespace(**{**vars(args), "runs": args.curve_runs})
    chosen = [Configuration(f"{p}, nominal", p, False) for p in CURVE_POLICIES]
    chosen.append(Configuration("every, robust", "every", True))
    for w in args.curve_w:
        for c in chosen:
            found = _simulated(many, c, w, "curves").summary()
            print(f"{c.name}, W = {w:g}: {found['satisfied']} of {found['runs']} satisfied")
    return robustness(args.mission, Path(args.out) / "curves")


def main(argv: Sequence[str] | None = None) -> None:
    """Command line of the benchmark."""
    parser = argparse.ArgumentParser(
        prog="python -m stlplan.sim_bench", description=__doc__.split("\n")[0]
    )
    parser.add_argument("--mission", default="missions/farm.yaml")
    parser.add_argument("--runs", type=int, default=20)
    parser.add_argument("--disturbance", type=float, default=0.02, metavar="W")
    parser.add_argument("--lose", nargs="*", default=["vis1@4"], metavar="AGENT@K")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--time-limit", type=float, default=300.0)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", default="bench-results/simulation")
    parser.add_argument("--resume", action="store_true", help="keep the runs on record")
    parser.add_argument("--curves", action="store_true", help="also draw robustness.png")
    parser.add_argument("--curve-w", type=float, nargs="+", default=[0, 0.01, 0.02, 0.05, 0.1])
    parser.add_argument("--curve-runs", type=int, default=5)
    run(parser.parse_args(argv))


if __name__ == "__main__":
    main()
