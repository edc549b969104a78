"""Does the gate catch a regression? The workflow behind `kartci faults` (issue 42).

Each scenario runs as written (its *nominal* run, OUT/<scenario>/) and once under each fault of
a catalogue that acts on it (OUT/<scenario>@fault=<fault>/, a sweep point's layout). Every
faulted run is judged against the nominal run exactly as `kartci compare NOMINAL FAULTED`
judges it, with the tolerances of the scenario's baseline: the fault is *caught* when a
metric regresses or goes missing (the gate would fail), *missed* when every metric stays
within its tolerance, and *not applicable* when the scenario has nothing the fault acts on
(a kart fault on a line tracker, a gain its controller has at 0, a sensor that is off). The
faults are declared by the kinds that own their keys (`RobotKind.faults`, `Controller.faults`,
`Node.faults`, `WorldKind.faults`: kartci.core.faults) and injected as `--set` assignments,
validated with the scenario. The detection matrix goes to OUT/summary.json and
OUT/faults.html.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kartci import core
from kartci.atomic import write_text_atomic
from kartci.core import Acts, Fault, RunFolder, unknown_keys
from kartci.errors import SpecError, did_you_mean
from kartci.project import Project
from kartci.runner.compare import samples
from kartci.runner.jobs import Job, check_count, default_suite, point_label, shard_labels
from kartci.runner.kinds import ExecutorKind
from kartci.runner.outdir import check_inside, locked, write_manifest
from kartci.runner.suite import run_jobs
from kartci.scenario.load import scenario_loader
from kartci.scenario.models import Scenario
from kartci.verdict import load, write_json_atomic
from kartci.verdict.baseline import definition
from kartci.verdict.runs import compare_runs

if TYPE_CHECKING:
    from kartci.runner.events import Listener
    from kartci.verdict.baseline import MetricVerdict
    from kartci.verdict.result import ScenarioResult

STANDARD = "standard"
SUMMARY = "summary.json"
PAGE = "faults.html"
FAULT_KEY = "fault"  # a faulted run's label: <scenario>@fault=<fault>


class Scope(StrEnum):
    """What declares a fault, and so where its keys start in a scenario."""

    ROBOT = "robot kind"  # agents.<a>.model..., agents.<a>.sensors...
    CONTROLLER = "controller"  # agents.<a>.controller...
    NODE = "node"  # agents.<a>.nodes.<node>...
    WORLD = "world kind"  # world...


@dataclass(frozen=True)
class Entry:
    """One fault of the catalogue, named `<owner>.<fault>`."""

    owner: str  # the robot kind, controller, node or world kind that declares it
    scope: Scope
    fault: Fault

    @property
    def name(self) -> str:
        """`<owner>.<fault>`: unique in the catalogue."""
        return f"{self.owner}.{self.fault.name}"


def _roots(reg: core.Registries, scope: Scope, owner: str) -> dict[str, Any]:
    """The parameter models a fault's keys start in."""
    if scope is Scope.ROBOT:
        kind = reg.robots.items[owner]
        return {"model": kind.params, "sensors": kind.sensors}
    if scope is Scope.CONTROLLER:
        return {"": reg.controllers.items[owner].params}
    if scope is Scope.NODE:
        return {"": reg.nodes.items[owner].params}
    return {"": reg.worlds.items[owner].params}


def catalogue(name: str = STANDARD, registries: core.Registries = core.DEFAULT_REGISTRIES
              ) -> list[Entry]:
    """Every registered fault listed in catalogue `name`, its keys checked against its owner's
    parameter models (a key the owner lacks is a SpecError naming the fault: a plugin's typo
    must not turn into a fault that is never applicable)."""
    found: list[Entry] = []
    known: set[str] = set()
    for scope, reg in ((Scope.ROBOT, registries.robots), (Scope.CONTROLLER,
                                                          registries.controllers),
                       (Scope.NODE, registries.nodes), (Scope.WORLD, registries.worlds)):
        for item in reg.all():
            for fault in item.faults:
                known.update(fault.catalogues)
                if name not in fault.catalogues:
                    continue
                entry = Entry(item.name, scope, fault)
                bad = unknown_keys(fault, _roots(registries, scope, item.name))
                if bad:
                    raise SpecError(f"fault {entry.name} ({scope.value} {item.name}): "
                                    f"{', '.join(bad)}: no such parameter")
                if entry.name in (e.name for e in found):
                    raise SpecError(f"fault {entry.name}: declared twice")
                found.append(entry)
    if not found:
        raise SpecError(f"--catalogue {name}: no such fault catalogue"
                        f"{did_you_mean(name, known)}")
    return found


def select(entries: list[Entry], only: Sequence[str]) -> list[Entry]:
    """The entries named by `--only` (all of them without); an unknown name is bad input."""
    if not only:
        return entries
    names = {e.name: e for e in entries}
    for n in only:
        if n not in names:
            raise SpecError(f"--only {n}: no such fault in the catalogue{did_you_mean(n, names)}")
    return [e for e in entries if e.name in set(only)]


def _reader(spec: Scenario) -> Callable[[str], Any]:
    data = spec.model_dump(mode="json")

    def read(key: str) -> Any:
        node: Any = data
        for part in key.split("."):
            if not isinstance(node, dict) or part not in node:
                return None
            node = node[part]
        return node

    return read


def injection(spec: Scenario, entry: Entry) -> Acts:
    """The `--set` assignments that inject `entry` into the scenario, on every agent (or the
    world) it acts on; empty, with why, when it acts on none."""
    read, owner = _reader(spec), entry.owner
    if entry.scope is Scope.WORLD:
        if spec.world.kind != owner:
            return Acts(why_not=f"the world is a {spec.world.kind}, not a {owner}")
        return entry.fault.acts(read, "world.")
    prefixes = []
    for name, agent in sorted(spec.agents.items()):
        if entry.scope is Scope.ROBOT and agent.model.kind == owner:
            prefixes.append(f"agents.{name}.")
        elif entry.scope is Scope.CONTROLLER and agent.controller.type == owner:
            prefixes.append(f"agents.{name}.controller.")
        elif entry.scope is Scope.NODE and owner in agent.nodes:
            prefixes.append(f"agents.{name}.nodes.{owner}.")
    if not prefixes:
        return Acts(why_not=f"no agent has the {entry.scope.value} {owner}")
    acts = [entry.fault.acts(read, p) for p in prefixes]
    overrides = tuple(o for a in acts for o in a.overrides)
    return Acts(overrides) if overrides else Acts(why_not="; ".join(a.why_not for a in acts))


class Cell(StrEnum):
    """A fault on a scenario."""

    CAUGHT = "caught"  # the gate would fail: a metric regressed or went missing
    MISSED = "missed"  # a metric moved beyond its resolution, every one within its tolerance
    # every metric moved less than its resolution: the fault changed nothing any metric sees
    # (mutation testing's equivalent mutant); not scored, and listed as such
    NO_EFFECT = "no effect"
    NOT_APPLICABLE = "not applicable"  # nothing in the scenario the fault acts on
    ERROR = "error"  # the nominal or the faulted run failed: not judged


@dataclass(frozen=True)
class Judgement:
    """One cell of the matrix."""

    fault: str
    scenario: str
    cell: Cell
    caught_by: tuple[str, ...] = ()  # the metrics that fail the gate, each with its change
    why: str = ""  # not applicable or error: why; missed: the metric nearest its tolerance;
    # no effect: the largest move against its resolution
    label: str = ""  # the faulted run's folder in OUT
    overrides: tuple[str, ...] = ()


@dataclass(frozen=True)
class Score:
    """Caught of the faults judged (applicable, and both runs finished)."""

    caught: int
    judged: int  # caught + missed
    no_effect: int = 0  # cells whose fault moved no metric beyond its resolution

    @property
    def value(self) -> float:
        """caught / judged (NaN when nothing was judged)."""
        return self.caught / self.judged if self.judged else math.nan

    def text(self) -> str:
        """`7/9 (78 %)`."""
        return f"{self.caught}/{self.judged}" + (
            f" ({self.value:.0%})" if self.judged else "")


def score(cells: Sequence[Judgement]) -> Score:
    """The score of some cells: errors, not-applicable and no-effect ones are not counted."""
    return Score(sum(c.cell is Cell.CAUGHT for c in cells),
                 sum(c.cell in (Cell.CAUGHT, Cell.MISSED) for c in cells),
                 sum(c.cell is Cell.NO_EFFECT for c in cells))


@dataclass(frozen=True)
class Matrix:
    """Faults x scenarios."""

    faults: list[Entry]
    scenarios: list[str]
    cells: list[Judgement]
    nominal: dict[str, str] = field(default_factory=dict)  # scenario -> its run vs baseline

    def cell(self, fault: str, scenario: str) -> Judgement:
        """The cell of a fault on a scenario."""
        return next(c for c in self.cells if c.fault == fault and c.scenario == scenario)

    def scenario_score(self, scenario: str) -> Score:
        """What the scenario catches of the faults that apply to it."""
        return score([c for c in self.cells if c.scenario == scenario])

    def fault_score(self, fault: str) -> Score:
        """How many of the scenarios it applies to catch the fault."""
        return score([c for c in self.cells if c.fault == fault])

    @property
    def score(self) -> Score:
        """The suite's: caught of every judged cell."""
        return score(self.cells)


@dataclass(frozen=True)
class Request:
    """What `kartci faults` was asked."""

    out: Path
    names: tuple[str, ...] = ()  # scenarios; () the project's default suite
    catalogue: str = STANDARD
    only: tuple[str, ...] = ()
    baselines: Path | None = None
    jobs: int = 1
    shard: tuple[int, int] | None = None
    executor: ExecutorKind = ExecutorKind.LOCAL
    ray_address: str | None = None
    timeout_s: float | None = None
    min_score: float | None = None  # 0..1: exit 1 below it
    allow_outside_paths: bool = False


def _no_events(jobs: list[Job]) -> AbstractContextManager[Listener]:
    @contextmanager
    def ignored() -> Any:
        yield lambda event: None
    return ignored()


Running = Callable[[list[Job]], AbstractContextManager["Listener"]]


@dataclass(frozen=True)
class FaultsResult:
    """A finished `kartci faults`: the matrix and the files written."""

    matrix: Matrix
    out: Path
    summary: Path
    page: Path
    min_score: float | None = None

    @property
    def exit_code(self) -> int:
        """0: the matrix was computed; 1: the suite's score is below `--min-score` (a suite
        with nothing judged is below any)."""
        s = self.matrix.score.value
        if self.min_score is not None and (math.isnan(s) or s < self.min_score):
            return 1
        return 0


def _describe(r: Request) -> str:
    parts = ["kartci faults", *r.names, "--catalogue", r.catalogue,
             *(f"--only {o}" for o in r.only)]
    if r.shard:
        parts.append(f"--shard {r.shard[0]}/{r.shard[1]}")
    return " ".join(parts)


Plan = tuple[str, list[Job], list[Judgement]]  # a scenario, its runs, its cells (unjudged)


def _check(r: Request) -> None:
    if r.jobs < 1:
        raise SpecError(f"--jobs {r.jobs}: expected 1 or more")
    check_count("--jobs", r.jobs)
    if r.timeout_s is not None and not r.timeout_s > 0:
        raise SpecError(f"--timeout-s {r.timeout_s:g}: expected a positive number of seconds")
    if r.ray_address and r.executor is not ExecutorKind.RAY:
        raise SpecError("--ray-address needs --executor ray")
    if r.min_score is not None and not 0 <= r.min_score <= 1:
        raise SpecError(f"--min-score {r.min_score:g}: expected a fraction from 0 to 1")
    if r.baselines is not None and not r.baselines.is_dir():
        raise SpecError(f"--baselines {r.baselines}: no such folder")


def plan(names: Sequence[str], entries: list[Entry], proj: Project,
         allow_outside_paths: bool = False) -> list[Plan]:
    """Each scenario's runs (its nominal run first; none when no fault acts on it) and its
    cells, every faulted scenario validated before anything runs."""
    plans: list[Plan] = []
    for name in dict.fromkeys(names):
        load = scenario_loader(name, project=proj, allow_outside_paths=allow_outside_paths)
        spec = load([])
        if spec.sweep:
            raise SpecError(f"scenario {spec.name}: a grid (its own sweep); faults judge one "
                            "scenario against its own nominal run: name one without a sweep")
        if spec.name in (p[0] for p in plans):
            raise SpecError(f"scenario selected twice: {spec.name}")
        jobs, cells = [], []
        for e in entries:
            acts = injection(spec, e)
            if not acts.overrides:
                cells.append(Judgement(e.name, spec.name, Cell.NOT_APPLICABLE,
                                       why=acts.why_not))
                continue
            try:
                faulted = load(list(acts.overrides))
            except SpecError as err:
                raise SpecError(f"fault {e.name} on {spec.name}: {err}") from err
            label = point_label(spec.name, [], [(FAULT_KEY, e.name)])
            jobs.append(Job(faulted, label))
            cells.append(Judgement(e.name, spec.name, Cell.MISSED, label=label,
                                   overrides=acts.overrides))
        if jobs:
            jobs.insert(0, Job(spec, point_label(spec.name, [], [])))
        plans.append((spec.name, jobs, cells))
    return plans


def run_faults(request: Request, proj: Project, running: Running | None = None
               ) -> FaultsResult:
    """Check the request, run every scenario nominal and under each fault that acts on it,
    judge, and write OUT/summary.json and OUT/faults.html. Bad input (an unknown scenario,
    fault or catalogue) is a SpecError before anything runs or is written."""
    r = request
    _check(r)
    baselines = r.baselines if r.baselines is not None else proj.baselines
    entries = select(catalogue(r.catalogue), r.only)
    names = list(r.names) or default_suite(proj.own_scenarios(), proj, r.allow_outside_paths)
    if not names:
        raise SpecError("no scenarios: name one (`kartci list` shows the built-in ones)")
    plans = plan(names, entries, proj, r.allow_outside_paths)
    if r.shard is not None:  # a scenario with all its faults stays on one shard
        mine = shard_labels({p[0] for p in plans}, *r.shard)
        plans = [p for p in plans if p[0] in mine]
    todo = [j for _, jobs, _ in plans for j in jobs]
    out = r.out
    with locked(out):
        check_inside(out, [j.label for j in todo])
        for stale in (SUMMARY, PAGE):  # an earlier matrix must not pass for this one
            (out / stale).unlink(missing_ok=True)
        write_manifest(out, "faults", [j.label for j in todo])
        with (running or _no_events)(todo) as on_event:
            results = run_jobs(todo, out, baselines, proj, workers=r.jobs, executor=r.executor,
                               ray_address=r.ray_address, timeout_s=r.timeout_s,
                               on_event=on_event) if todo else []
        by_label = {x.name: x for x in results}
        nominal = {name: "error" if by_label[name].error else by_label[name].status.value
                   for name, _, _ in plans if name in by_label}
        cells = [judge(c, by_label.get(name), by_label.get(c.label), out, baselines)
                 for name, _, mine in plans for c in mine]
        matrix = Matrix(entries, [p[0] for p in plans], cells, nominal)
        doc = to_json(matrix, _describe(r), r.catalogue, r.shard)
        summary = out / SUMMARY
        write_json_atomic(summary, doc)
        from kartci.report.faults import faults_page  # late: matplotlib, for the page only

        page = out / PAGE
        write_text_atomic(page, faults_page(doc))
    return FaultsResult(matrix, out, summary, page, r.min_score)


def read_summary(out: Path) -> dict[str, Any]:
    """OUT/summary.json of `kartci faults`; a SpecError (one line) when it is missing or not
    one."""
    path = out / SUMMARY
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        raise SpecError(f"{path}: no detection matrix to read ({type(err).__name__}); run "
                        "`kartci faults --out DIR` first") from None
    if not isinstance(doc, dict) or "kartci_faults" not in doc:
        raise SpecError(f"{path}: not written by `kartci faults`")
    return doc


def is_faults_folder(out: Path) -> bool:
    """Whether OUT holds a `kartci faults` matrix (so `kartci merge` merges matrices)."""
    try:
        read_summary(out)
    except SpecError:
        return False
    return True


def rejudge(out: Path, baselines: Path, min_score: float | None = None) -> FaultsResult:
    """Judge a `kartci faults` folder's runs again with today's baselines, running nothing:
    after `kartci baseline tolerances --write`, the matrix the new tolerances give."""
    old = read_summary(out)
    with locked(out):
        return _judge_again(out, old, baselines, min_score)


def merge_faults(dirs: Sequence[Path], out: Path, baselines: Path, proj: Project,
                 min_score: float | None = None) -> FaultsResult:
    """Join `kartci faults --shard` OUTs into one matrix in `out`: their run folders copied as
    `kartci merge` copies a sharded run's (checked, never outside OUT), their cells judged
    again together with today's baselines."""
    from kartci.runner.merge import merge  # start-up: PyBullet (+0.4 s)

    docs = [read_summary(d) for d in dirs]
    if len({d["catalogue"] for d in docs}) > 1:
        raise SpecError("the shards ran different catalogues ("
                        + ", ".join(sorted({d["catalogue"] for d in docs})) + "); merge one's")
    names = [s["name"] for d in docs for s in d["scenarios"]]
    if len(set(names)) < len(names):
        raise SpecError("a scenario is in two shards' matrices; merge the shards of one "
                        "`kartci faults --shard I/N` run")
    base = baselines
    order = {e.name: i for i, e in enumerate(catalogue(docs[0]["catalogue"]))}
    faults = {f["name"]: f for d in docs for f in d["faults"]}
    joined = {"kartci_faults": 1, "catalogue": docs[0]["catalogue"], "shard": None,
              "command": "kartci merge " + " ".join(str(d) for d in dirs),
              "faults": sorted(faults.values(), key=lambda f: order.get(f["name"], len(order))),
              "scenarios": sorted((s for d in docs for s in d["scenarios"]),
                                  key=lambda s: str(s["name"])),
              "cells": [c for d in docs for c in d["cells"]]}
    with locked(out):
        merge(list(dirs), out, base, proj)
        return _judge_again(out, joined, base, min_score)


def _judge_again(out: Path, old: dict[str, Any], base: Path, min_score: float | None
                 ) -> FaultsResult:
    from kartci.verdict import ScenarioResult  # runtime: the judged runs' stand-ins

    declared = {e.name: e for e in catalogue(old["catalogue"])}
    entries = [declared[f["name"]] for f in old["faults"] if f["name"] in declared]
    names = [s["name"] for s in old["scenarios"]]
    cells = []
    for c in old["cells"]:
        cell = Judgement(c["fault"], c["scenario"], Cell(c["result"]), why=c["why"],
                         label=c["run"] or "", overrides=tuple(c["set"]))
        if cell.cell in (Cell.CAUGHT, Cell.MISSED, Cell.NO_EFFECT):
            cell = judge(cell, ScenarioResult(cell.scenario, ""),
                         ScenarioResult(cell.label, ""), out, base)
        cells.append(cell)
    matrix = Matrix(entries, names, cells, {s["name"]: s["nominal"] for s in old["scenarios"]})
    doc = to_json(matrix, old["command"], old["catalogue"],
                  None if old["shard"] is None else (old["shard"][0], old["shard"][1]))
    write_json_atomic(out / SUMMARY, doc)
    from kartci.report.faults import faults_page  # late: matplotlib, for the page only

    write_text_atomic(out / PAGE, faults_page(doc))
    return FaultsResult(matrix, out, out / SUMMARY, out / PAGE, min_score)


def judge(cell: Judgement, nominal: ScenarioResult | None, faulted: ScenarioResult | None,
          out: Path, baselines: Path) -> Judgement:
    """A faulted run against its nominal run, as `kartci compare` judges head against base."""
    if cell.cell is Cell.NOT_APPLICABLE:
        return cell
    for side, res in (("nominal", nominal), ("faulted", faulted)):
        if res is None or res.error is not None:
            why = "not run" if res is None else res.error
            return _with(cell, Cell.ERROR, why=f"{side} run: {why}")
    assert nominal is not None and faulted is not None
    verdicts = compare_runs(samples(RunFolder(out / nominal.name)),
                            samples(RunFolder(out / cell.label)),
                            load(baselines / f"{cell.scenario}.json"))
    bad = [v for v in verdicts if v.status.bad]
    if bad:
        return _with(cell, Cell.CAUGHT, caught_by=tuple(_change(v) for v in bad))
    moves = [(_over_resolution(v), v) for v in verdicts]
    if all(m <= 1.0 for m, _ in moves):
        m, v = max(moves, key=lambda mv: mv[0], default=(0.0, None))
        return _with(cell, Cell.NO_EFFECT, why="no metric moved" if v is None or m == 0 else (
            f"largest move: {_change(v)}, {m:.2g} of its resolution"))
    near = min((v for v in verdicts if v.tolerance and v.delta is not None),
               key=lambda v: -abs(v.delta or 0.0) / (v.tolerance or 1.0), default=None)
    return _with(cell, Cell.MISSED, why="" if near is None else f"nearest: {_change(near)}")


def _over_resolution(v: MetricVerdict) -> float:
    """A metric's move between the runs in units of its resolution (`MetricDef.resolution`):
    inf when one side has no value or the metric has no definition and moved."""
    if v.value is None or v.baseline is None:
        return 0.0 if v.value is None and v.baseline is None else math.inf
    move = abs(v.value - v.baseline)
    d = definition(v.name)
    resolution = 0.0 if d is None else d.resolution(v.baseline)
    if resolution > 0:
        return move / resolution
    return math.inf if move > 0 else 0.0


def _with(cell: Judgement, result: Cell, **kw: Any) -> Judgement:
    return replace(cell, cell=result, **kw)


def _change(v: MetricVerdict) -> str:
    """`settle_time_s 0.84 -> 1.08 s (tolerance 0.5, lower): regressed`."""
    def n(x: float | None) -> str:
        return "-" if x is None else f"{x:.4g}"

    unit = f" {v.unit}" if v.unit and v.unit not in ("bool", "fraction") else ""
    tol = "" if v.tolerance is None else f" (tolerance {v.tolerance:.3g}, {v.direction.value})"
    return f"{v.name} {n(v.baseline)} -> {n(v.value)}{unit}{tol}: {v.status.value}"


def to_json(m: Matrix, command: str, name: str, shard: tuple[int, int] | None
            ) -> dict[str, Any]:
    """summary.json: the catalogue, the cells, the scores."""
    def s(x: Score) -> dict[str, Any]:
        return {"caught": x.caught, "judged": x.judged, "no_effect": x.no_effect,
                "score": None if math.isnan(x.value) else round(x.value, 4)}

    return {
        "kartci_faults": 1, "command": command, "catalogue": name,
        "shard": None if shard is None else list(shard),
        "score": s(m.score),
        "faults": [{"name": e.name, "owner": e.owner, "scope": e.scope.value,
                    "description": e.fault.description, **s(m.fault_score(e.name))}
                   for e in m.faults],
        "scenarios": [{"name": n, "nominal": m.nominal.get(n), **s(m.scenario_score(n))}
                      for n in m.scenarios],
        "cells": [{"fault": c.fault, "scenario": c.scenario, "result": c.cell.value,
                   "caught_by": list(c.caught_by), "why": c.why, "run": c.label or None,
                   "set": list(c.overrides)} for c in m.cells],
    }
