"""What makes a sweep one sweep: its missions, seed and settings, kept beside its records
(``sweep.json``; a simulation's, :mod:`stlplan.simulation`, in ``simulation.json``).

``--resume`` continues the sweep recorded in a folder; it is refused when the command asks for
something else (other missions, another seed, another time limit or setting), since the records
would then mix two experiments. The number of runs may grow: resuming with more runs extends it.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from stlplan.errors import UsageError


def identity(specs: Sequence[Any]) -> dict[str, Any]:
    """Missions (name to a digest of the text), seed and the settings that change results.

    ``specs`` are :class:`stlplan.sweep.runner.Spec`, whose ``settings()`` leave out the threads
    (they change the time a run takes, not its answer).
    """
    if not specs:
        return {}
    missions = {
        s.mission_key: hashlib.sha256(s.mission_text.encode("utf-8")).hexdigest()[:16]
        for s in specs
    }
    settings = specs[0].settings()
    return {"missions": missions, "seed": specs[0].seed, "settings": _plain(settings)}


def _plain(value: Any) -> Any:
    """``value`` as JSON would give it back (tuples as lists)."""
    return json.loads(json.dumps(value, default=str))


def claim(out: Path, specs: Sequence[Any], resume: bool, what: str = "sweep") -> None:
    """Record the identity of the ``what`` (sweep, simulation) in ``out/WHAT.json``; with
    ``resume``, first refuse a different one."""
    check_claim(out, specs, resume, what)
    text = json.dumps(identity(specs), indent=2, sort_keys=True) + "\n"
    (out / f"{what}.json").write_text(text, encoding="utf-8")


def check_claim(out: Path, specs: Sequence[Any], resume: bool, what: str = "sweep") -> None:
    """With ``resume``, refuse a ``what`` that differs from the one recorded in ``out``."""
    path = out / f"{what}.json"
    if resume and path.exists():
        recorded = json.loads(path.read_text(encoding="utf-8"))
        changes = differences(recorded, identity(specs))
        if changes:
            raise UsageError(
                f"--resume continues the {what} recorded in {out}, and this one differs: "
                + "; ".join(changes)
                + ". Run it with the recorded settings, or choose another --out"
            )


def differences(recorded: dict[str, Any], wanted: dict[str, Any]) -> list[str]:
    """What ``wanted`` changes of ``recorded``, in words."""
    out = []
    old_missions, new_missions = recorded.get("missions", {}), wanted.get("missions", {})
    if set(old_missions) != set(new_missions):
        out.append(f"missions {sorted(old_missions)} recorded, {sorted(new_missions)} now")
    changed = [m for m in old_missions if m in new_missions and old_missions[m] != new_missions[m]]
    if changed:
        out.append(f"the text of {', '.join(changed)} changed since")
    if recorded.get("seed") != wanted.get("seed"):
        out.append(f"seed {recorded.get('seed')} recorded, {wanted.get('seed')} now")
    old_settings, new_settings = recorded.get("settings", {}), wanted.get("settings", {})
    for name in sorted(set(old_settings) | set(new_settings)):
        if old_settings.get(name) != new_settings.get(name):
            before, now = old_settings.get(name, "unset"), new_settings.get(name, "unset")
            out.append(f"{name} {before} recorded, {now} now")
    return out
