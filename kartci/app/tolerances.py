"""Tolerances that earn their width (`kartci baseline tolerances`, issue 42): from the runs of
a `kartci faults` folder and each scenario's baseline, the width each metric needs.

A metric's tolerance has a floor and a use. The floor is the larger of 3 x its conditioning
spread (narrower, its verdict follows nanometre perturbations: ill-conditioned) and its
resolution (a tenth of its default tolerance, `MetricDef.resolution`: narrower, the gate judges
float digits and fails every harmless change). The use is to fail the gate on the faults it can
see. A fault *moves* a metric when the faulted run differs from the nominal run, in the
metric's bad direction, by more than the floor. The proposal is

- the floor, where today's tolerance is below it (widened: to earn trust, or to mean something);
- half the smallest move among the faults that move it, where today's tolerance lets one of
  them pass (tightened, with a factor of 2 to spare for a fault a little milder than the
  catalogue's), never below the floor;
- today's tolerance otherwise (it catches every fault that moves it, or none moves it: no
  evidence to tighten).

So a proposal only tightens to catch a fault or widens to the floor. The same judging as
`kartci compare` (kartci.verdict.runs.compare_runs) decides what is caught before and after.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

from kartci.app.faults import read_summary
from kartci.core import Direction, RunFolder
from kartci.errors import SpecError
from kartci.runner.compare import samples
from kartci.verdict import load, write_json_atomic
from kartci.verdict.baseline import SPREAD_MULTIPLE, definition
from kartci.verdict.runs import compare_runs

MARGIN = 2.0  # a tightened tolerance is the smallest move it must catch over this
JUDGED = ("caught", "missed")  # cells of the matrix with both runs finished


class Why(StrEnum):
    """What a proposal does to a metric's tolerance."""

    WIDENED = "widened to 3 x spread"  # it was ill-conditioned
    RESOLVED = "widened to its resolution"  # it judged float digits
    TIGHTENED = "tightened"  # it let a fault it can see pass
    KEPT = "kept"  # it catches every fault that moves it, or none moves it


@dataclass(frozen=True)
class Proposal:
    """One metric of one scenario: its tolerance today and proposed, in its unit."""

    scenario: str
    metric: str
    unit: str
    tolerance: float
    floor: float  # the larger of 3 x spread and the metric's resolution
    proposed: float
    why: Why
    moved_by: tuple[tuple[str, float], ...]  # (fault, move beyond the floor), smallest first


@dataclass(frozen=True)
class Cell:
    """A judged fault on a scenario, caught (by which metrics) at today's and the proposed
    tolerances."""

    fault: str
    scenario: str
    caught_now: tuple[str, ...]
    caught_proposed: tuple[str, ...]


@dataclass(frozen=True)
class Tolerances:
    """The proposals and the matrix they give."""

    proposals: list[Proposal]
    cells: list[Cell]

    def changed(self) -> list[Proposal]:
        """The proposals that change a tolerance."""
        return [p for p in self.proposals if p.why is not Why.KEPT]

    def score(self, proposed: bool) -> tuple[int, int]:
        """(caught, judged) of the matrix at today's or the proposed tolerances."""
        caught = sum(bool(c.caught_proposed if proposed else c.caught_now) for c in self.cells)
        return caught, len(self.cells)

    def unseen(self) -> list[str]:
        """Faults that no scenario catches even at the proposed tolerances: no metric of any
        scenario they apply to moves beyond its floor."""
        faults = sorted({c.fault for c in self.cells})
        return [f for f in faults if not any(c.caught_proposed for c in self.cells
                                             if c.fault == f)]


def _bad_move(direction: str, delta: float) -> float:
    """How far a change goes in the metric's bad direction (negative: it improved)."""
    if direction == Direction.LOWER.value:
        return delta
    if direction == Direction.HIGHER.value:
        return -delta
    return abs(delta)


def _runs(out: Path) -> list[dict[str, Any]]:
    """The judged cells of a `kartci faults` folder's matrix."""
    return [c for c in read_summary(out).get("cells", [])
            if c.get("result") in JUDGED and c.get("run")]


def _judge(out: Path, cells: Sequence[Mapping[str, Any]],
           baseline: dict[str, dict[str, Any]]) -> dict[str, dict[str, float]]:
    """For each fault of one scenario, each metric's move in its bad direction."""
    moves: dict[str, dict[str, float]] = {}
    for c in cells:
        nominal = samples(RunFolder(out / c["scenario"]))
        verdicts = compare_runs(nominal, samples(RunFolder(out / c["run"])), baseline)
        moves[c["fault"]] = {v.name: _bad_move(v.direction.value, v.delta)
                             for v in verdicts if v.delta is not None
                             and math.isfinite(v.delta)}
    return moves


def _caught(out: Path, cell: Mapping[str, Any], baseline: dict[str, dict[str, Any]]
            ) -> tuple[str, ...]:
    """The metrics by which `kartci compare` fails a faulted run against its nominal run."""
    verdicts = compare_runs(samples(RunFolder(out / cell["scenario"])),
                            samples(RunFolder(out / cell["run"])), baseline)
    return tuple(v.name for v in verdicts if v.status.bad)


def _round_down(x: float) -> float:
    """Four significant digits, rounded down (a tightened tolerance still catches)."""
    if x <= 0 or not math.isfinite(x):
        return max(x, 0.0)
    scale = 10 ** (math.floor(math.log10(x)) - 3)
    return float(math.floor(x / scale) * scale)


def _propose(scenario: str, name: str, entry: Mapping[str, Any],
             moves: Mapping[str, Mapping[str, float]]) -> Proposal:
    tol = float(entry["tolerance"])
    chaos = SPREAD_MULTIPLE * float(entry.get("spread") or 0.0)  # the policy's own bound
    d, value = definition(name), entry.get("value")
    resolution = 0.0 if d is None else d.resolution(math.nan if value is None else float(value))
    floor = max(chaos, resolution)
    moved = sorted(((f, m[name]) for f, m in moves.items() if m.get(name, 0.0) > floor),
                   key=lambda fm: fm[1])
    unit = str(entry.get("unit", ""))
    if tol < floor:
        why = Why.WIDENED if chaos >= resolution else Why.RESOLVED
        return Proposal(scenario, name, unit, tol, floor, floor, why, tuple(moved))
    if moved and moved[0][1] <= tol:  # a fault it can see passes today
        target = max(floor, _round_down(moved[0][1] / MARGIN))
        if target < tol:
            return Proposal(scenario, name, unit, tol, floor, target, Why.TIGHTENED,
                            tuple(moved))
    return Proposal(scenario, name, unit, tol, floor, tol, Why.KEPT, tuple(moved))


def propose(out: Path, baselines: Path) -> Tolerances:
    """The proposals for every scenario of a `kartci faults` folder with a baseline."""
    cells = _runs(out)
    proposals: list[Proposal] = []
    judged: list[Cell] = []
    for scenario in sorted({c["scenario"] for c in cells}):
        baseline = load(baselines / f"{scenario}.json")
        if baseline is None:
            raise SpecError(f"{scenario}: no baseline in {baselines}; `kartci baseline update` "
                            "it first (a tolerance is a baseline's)")
        mine = [c for c in cells if c["scenario"] == scenario]
        moves = _judge(out, mine, baseline)
        mine_props = [_propose(scenario, n, e, moves) for n, e in sorted(baseline.items())
                      if e.get("tolerance") is not None]
        proposals += mine_props
        after = {n: dict(e) for n, e in baseline.items()}
        for p in mine_props:
            after[p.metric]["tolerance"] = p.proposed
        judged += [Cell(c["fault"], scenario, _caught(out, c, baseline), _caught(out, c, after))
                   for c in mine]
    return Tolerances(proposals, judged)


def write(result: Tolerances, baselines: Path) -> list[Path]:
    """Store the changed tolerances in the baseline files (nothing else in them changes);
    returns the files written."""
    by_file: dict[str, list[Proposal]] = {}
    for p in result.changed():
        by_file.setdefault(p.scenario, []).append(p)
    written = []
    for scenario, props in sorted(by_file.items()):
        path = baselines / f"{scenario}.json"
        doc = json.loads(path.read_text(encoding="utf-8"))
        for p in props:
            doc["metrics"][p.metric]["tolerance"] = p.proposed
        write_json_atomic(path, doc)
        written.append(path)
    return written
