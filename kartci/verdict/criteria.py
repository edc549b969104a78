"""The pass criteria a baseline was accepted with, against the scenario's criteria now.

Criteria are not part of the scenario hash (kartci.verdict.fingerprint ignores them: they do
not change the run), so deleting one used to change nothing in a verdict: a pull request could
weaken the gate without anyone being told. `kartci baseline update` records the criteria it
accepted (`"criteria": {NAME: {"max": 0.5}}` in the baseline); judging lists every criterion
added, removed or changed since, and a strict run (CI) fails on a removed one until a baseline
update accepts the removal. A baseline accepted before criteria were recorded has no such key:
nothing is compared (its first update records them).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from kartci.boundedio import is_number
from kartci.scenario.models import Criterion

KEY = "criteria"  # the baseline document's entry
BOUNDS = ("max", "min", "equal")  # a criterion's fields, as Criterion names them


class ChangeKind(StrEnum):
    """How a criterion differs from the one its baseline was accepted with."""

    ADDED = "added"
    REMOVED = "removed"  # a strict run fails until `kartci baseline update` accepts it
    CHANGED = "changed"


@dataclass(frozen=True)
class CriterionChange:
    """One criterion added, removed or changed since the baseline; bounds as text
    (`<= 0.5 and >= 0.1`), "" where there is none."""

    name: str
    kind: ChangeKind
    before: str = ""
    after: str = ""

    def text(self) -> str:
        """The line a reader sees (terminal, report, summary.md, pull-request comment)."""
        if self.kind is ChangeKind.ADDED:
            return f"criterion {self.name} added since the baseline: {self.after}"
        if self.kind is ChangeKind.CHANGED:
            return (f"criterion {self.name} changed since the baseline: {self.before} -> "
                    f"{self.after}")
        return (f"criterion {self.name} ({self.before}) removed since the baseline: the gate no "
                "longer checks it; `kartci baseline update` accepts the removal")


def recorded(criteria: Mapping[str, Criterion]) -> dict[str, dict[str, float]]:
    """The criteria as a baseline stores them: each with its bounds that are set."""
    return {name: {k: float(v) for k in BOUNDS if (v := getattr(c, k)) is not None}
            for name, c in sorted(criteria.items())}


def bound_text(bounds: Mapping[str, float]) -> str:
    """`<= 0.5 and >= 0.1`, as a checked criterion shows its bound."""
    signs = {"max": "<=", "min": ">=", "equal": "=="}
    return " and ".join(f"{signs[k]} {bounds[k]:g}" for k in BOUNDS if k in bounds)


def check_recorded(doc: Any) -> None:
    """ValueError unless a baseline document's criteria (if any) are {NAME: {BOUND: number}}."""
    found = doc.get(KEY) if isinstance(doc, dict) else None
    if found is None:
        return
    if not isinstance(found, dict):
        raise ValueError(f"{KEY}: expected a mapping")
    for name, bounds in found.items():
        if not isinstance(bounds, dict) or not bounds or any(
                k not in BOUNDS or not is_number(v) for k, v in bounds.items()):
            raise ValueError(f"{KEY}.{str(name)[:40]}: expected bounds max, min or equal")


def changes(doc: Any, now: Mapping[str, Criterion]) -> list[CriterionChange]:
    """Each criterion added, removed or changed since the baseline `doc` was accepted, by name;
    none when `doc` recorded no criteria (accepted before baselines did)."""
    then = doc.get(KEY) if isinstance(doc, dict) else None
    if not isinstance(then, dict):
        return []
    current = recorded(now)
    out = []
    for name in sorted({*then, *current}):
        before = bound_text(then[name]) if name in then else ""
        after = bound_text(current[name]) if name in current else ""
        if name not in then:
            out.append(CriterionChange(name, ChangeKind.ADDED, after=after))
        elif name not in current:
            out.append(CriterionChange(name, ChangeKind.REMOVED, before=before))
        elif {k: float(v) for k, v in then[name].items()} != current[name]:
            out.append(CriterionChange(name, ChangeKind.CHANGED, before, after))
    return out


__all__ = ["BOUNDS", "KEY", "ChangeKind", "CriterionChange", "bound_text", "changes",
           "check_recorded", "recorded"]
