"""Find what breaks a scenario: the workflow behind `kartci search` and `kartci.search`.

The `--over` axes are checked against the scenario before anything runs (an unknown key, a
range the key refuses, a budget over the run cap: bad input). The search itself is
`kartci.runner.search`; its runs go through the runner's executors (`-j`, Ray) into
OUT/<scenario>@<key>=<value>,... as a sweep's points do, and each batch is journaled in
OUT/search.json, so a search interrupted and started again with the same `--out` replays what
was run (the same seed asks the same points) and runs only the rest. It ends with
OUT/found.yaml (the failure as a scenario file, runnable as is) and OUT/search.html.
"""

from __future__ import annotations

import contextlib
import functools
import math
import os
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from kartci import metrics
from kartci.atomic import write_text_atomic
from kartci.core import Direction
from kartci.errors import SpecError, did_you_mean
from kartci.project import Project
from kartci.runner.events import Listener
from kartci.runner.executors import Warm
from kartci.runner.jobs import MAX_RUNS, Job, point_label
from kartci.runner.kinds import ExecutorKind
from kartci.runner.outdir import check_inside, locked, write_manifest
from kartci.runner.search import (
    Axis,
    AxisKind,
    Evaluate,
    Evaluation,
    Found,
    Phase,
    Plan,
    Point,
    Progress,
    RunStatus,
    search,
)
from kartci.runner.suite import run_jobs
from kartci.scenario.load import apply_override, scenario_loader, scenario_path
from kartci.scenario.models import Scenario
from kartci.scenario.yamlio import clip
from kartci.verdict import read_json, write_json_atomic
from kartci.verdict.result import ScenarioResult

JOURNAL = "search.json"
FOUND = "found.yaml"
PAGE = "search.html"
CRITERIA = "criteria"  # --objective: fail the scenario's criteria (the default)
_RANGE = re.compile(
    r"^\s*(?P<low>[^.:][^:]*?)\s*\.\.\s*(?P<high>[^:]+?)\s*(?::\s*(?P<step>.+?))?\s*$")
# probes of a range that refuses arbitrary values (a period that must be a whole number of
# physics steps): the finest step of 1, 2 or 5 x 10^k whose multiples from the low end validate
_PROBES = (1, 2, 3, 7)
_STEP_DIGITS = 7  # steps tried down to span x 10^-7


@dataclass(frozen=True)
class Request:
    """One search as asked: the scenario, its axes (`KEY=LOW..HIGH[:STEP]` or `KEY=a,b,c`),
    fixed overrides, the run budget, what counts as worst, the seed."""

    scenario: str
    over: tuple[str, ...]
    overrides: tuple[str, ...] = ()
    budget: int = 100  # runs at most
    objective: str = CRITERIA
    seed: int = 0
    allow_outside_paths: bool = False

    def settings(self) -> dict[str, Any]:
        """What must match for OUT/search.json to be resumed (the budget may grow)."""
        return {"scenario": self.scenario, "over": list(self.over), "set": list(self.overrides),
                "objective": self.objective, "seed": self.seed}


@dataclass(frozen=True)
class Options:
    """How the runs are made: workers, executor, wall-clock limit per run, baselines, and the
    project the scenario is found and judged in."""

    baselines: Path
    project: Project
    workers: int = 1
    executor: ExecutorKind = ExecutorKind.LOCAL
    ray_address: str | None = None
    timeout_s: float | None = None  # per run, s
    on_event: Listener | None = None


@dataclass(frozen=True)
class SearchResult:
    """A finished search: what it found and the files it wrote."""

    found: Found
    out: Path
    found_yaml: Path | None  # OUT/found.yaml: the failure (or worst run) as a scenario file
    page: Path  # OUT/search.html
    resumed: int = 0  # runs replayed from an earlier, interrupted search in OUT

    @property
    def failed(self) -> bool:
        """A failing run was found (exit 1)."""
        return any(e.status.failing for e in self.found.counted)

    @property
    def exit_code(self) -> int:
        """1 when a run failed its criteria (or broke), else 0."""
        return 1 if self.failed else 0


def parse_over(text: str) -> tuple[str, str]:
    """`KEY=SPEC` as (key, spec), both stripped."""
    key, sep, spec = text.partition("=")
    if not sep or not key.strip() or not spec.strip():
        raise SpecError(f"--over {clip(repr(text), 80)}: expected KEY=LOW..HIGH, "
                        "KEY=LOW..HIGH:STEP or KEY=a,b,c")
    return key.strip(), spec.strip()


def _number(text: str, what: str) -> float:
    try:
        x = float(yaml.safe_load(text))
    except (ValueError, TypeError, yaml.YAMLError):
        raise SpecError(f"{what}: {clip(repr(text), 40)} is not a number") from None
    if not math.isfinite(x):
        raise SpecError(f"{what}: {clip(repr(text), 40)} is not a finite number")
    return x


def _nominal(spec: Scenario, key: str) -> Any:
    """The scenario's own value at a dotted key (None where it is not set)."""
    node: Any = spec.model_dump(mode="json")
    for part in key.split("."):
        if isinstance(node, dict):
            node = node.get(part)
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return None
    return node


Loader = Callable[[Sequence[str]], Scenario]  # overrides -> the scenario validated


def make_axes(request: Request, load: Loader) -> tuple[Axis, ...]:
    """Each `--over` as an axis, checked against the scenario: the key exists, both ends (each
    choice) validate, and a range whose values the scenario only takes on a grid gets the
    grid's step (found by probing when none is given)."""
    base = load(list(request.overrides))
    axes: list[Axis] = []
    for text in request.over:
        key, spec = parse_over(text)
        if key in (a.key for a in axes):
            raise SpecError(f"--over {clip(key, 80)}: given twice")
        axes.append(_axis(key, spec, _nominal(base, key), f"--over {clip(text, 80)}",
                          functools.partial(_valid, load, request.overrides, key)))
    return tuple(axes)


def _axis(key: str, spec: str, nominal: Any, what: str, why: Callable[[str], str | None]
          ) -> Axis:
    """One axis from its `--over` text; `why(value)` says why the scenario refuses a value."""
    def check(value: str) -> None:
        refusal = why(value)
        if refusal is not None:
            raise SpecError(f"{what}: {value} is refused: {refusal}")

    m = _RANGE.match(spec)
    if m is None or "," in spec:
        choices = tuple(dict.fromkeys(v.strip() for v in spec.split(",") if v.strip()))
        if len(choices) < 2:
            raise SpecError(f"{what}: expected LOW..HIGH, LOW..HIGH:STEP or at least two "
                            "values a,b,...")
        for c in choices:
            check(c)
        mine = next((c for c in choices if yaml.safe_load(c) == nominal), choices[0])
        return Axis(key, AxisKind.CHOICE, mine, choices=choices)
    low, high = _number(m["low"], what), _number(m["high"], what)
    if not low < high:
        raise SpecError(f"{what}: the low end must be below the high end")
    integer = all(re.fullmatch(r"[+-]?\d+", m[g].strip()) for g in ("low", "high")) and (
        m["step"] is None or re.fullmatch(r"\d+", m["step"].strip()) is not None)
    step = _number(m["step"], what) if m["step"] else (1.0 if integer else 0.0)
    if m["step"] and not 0 < step <= high - low:
        raise SpecError(f"{what}: the step must be above 0 and at most the range")
    axis = Axis(key, AxisKind.GRID if step else AxisKind.FLOAT, "0", low, high, step, integer)
    check(axis.text(low))
    check(axis.at(axis.size - 1) if step else axis.text(high))
    if step:  # a step the key does not take would leave most points refused
        for k in (k for k in _PROBES if k < axis.size):
            check(axis.at(k))
    else:
        step = _discover_step(axis, why, what)
        axis = Axis(key, AxisKind.GRID if step else AxisKind.FLOAT, "0", low, high, step,
                    integer)
    own = float(nominal) if isinstance(nominal, int | float) and not isinstance(
        nominal, bool) else low
    own = min(max(own, low), high)  # a nominal outside the range: its nearer end
    at = axis.text(own) if axis.kind is AxisKind.FLOAT else axis.at(
        axis.position(axis.text(own)))
    return Axis(key, axis.kind, at, low, high, step, integer)


def _valid(load: Loader, overrides: Sequence[str], key: str, value: str) -> str | None:
    """None when the scenario takes `key=value`, else why not."""
    try:
        load([*overrides, f"{key}={value}"])
    except SpecError as err:
        return str(err)
    return None


def _discover_step(axis: Axis, why: Callable[[str], str | None], what: str) -> float:
    """0 when any value of the range validates; else the finest step (1, 2 or 5 x 10^k) whose
    multiples from the low end do; none: bad input, asking for a step."""
    interior = [axis.low + axis.span * f for f in (0.381966, 0.723607)]
    refusal = next((r for r in (why(axis.text(x)) for x in interior) if r), None)
    if refusal is None:
        return 0.0
    top = math.floor(math.log10(axis.span))
    for exp in range(top - _STEP_DIGITS, top + 1):
        for mantissa in (1, 2, 5):
            step = mantissa * 10.0 ** exp
            n = math.floor(axis.span / step + 1e-9)
            grid = Axis(axis.key, AxisKind.GRID, "0", axis.low, axis.high, step, axis.integer)
            if n >= 2 and all(why(grid.at(k)) is None for k in (*_PROBES, n) if k <= n):
                return step
    raise SpecError(f"{what}: the scenario refuses values inside the range ({one(refusal)}); "
                    "give a step it takes: KEY=LOW..HIGH:STEP")


def one(text: str) -> str:
    """A loader's message without its file prefix."""
    return clip(text.split(": ", 1)[-1] if text.startswith("/") else text, 200)


def make_plan(request: Request, axes: tuple[Axis, ...]) -> Plan:
    """The search plan: the axes, a checked budget and objective."""
    if request.budget < 1:
        raise SpecError(f"--budget {request.budget}: expected 1 or more runs")
    if request.budget > MAX_RUNS:  # the run cap of --sweep and --conditioning
        raise SpecError(f"--budget {request.budget:,}: more than the {MAX_RUNS:,} runs "
                        "allowed in one command; search a smaller space or split it")
    if request.objective == CRITERIA:
        return Plan(axes, request.budget, request.seed)
    defs = metrics.definitions()
    d = defs.get(request.objective.rpartition(".")[2])
    if d is None:
        raise SpecError(f"--objective {clip(request.objective, 80)}: not '{CRITERIA}' nor a "
                        f"known metric{did_you_mean(request.objective, [CRITERIA, *defs])}")
    if d.direction is Direction.EQUAL:
        raise SpecError(f"--objective {request.objective}: the metric has no worse direction "
                        "(it must equal its baseline); search its criteria instead")
    return Plan(axes, request.budget, request.seed, request.objective,
                higher_is_worse=d.direction is Direction.LOWER)


def judged(point: Point, label: str, r: ScenarioResult, phase: Phase,
           objective: str | None) -> Evaluation:
    """A run's result as the search sees it: the criteria (their smallest margin) and the
    objective's value."""
    value = None
    if objective is not None and objective in r.metrics:
        v = r.metrics[objective].value
        value = float(v) if math.isfinite(v) else None
    if r.error is not None:
        return Evaluation(point, label, RunStatus.ERROR, -math.inf, value, (r.error,), phase)
    failing = [c for c in r.criteria if not c.ok]
    margin = min((c.margin for c in r.criteria), default=math.inf)
    why = tuple(f"{c.name} {'-' if c.value is None else f'{c.value:.4g}'} (must be {c.bound})"
                for c in failing)
    return Evaluation(point, label, RunStatus.FAIL if failing else RunStatus.PASS, margin,
                      value, why, phase)


def _float_json(x: float) -> float | str:
    return x if math.isfinite(x) else str(x)  # 'inf', '-inf', 'nan'


def _to_json(e: Evaluation) -> dict[str, Any]:
    return {"point": [list(kv) for kv in e.point], "label": e.label, "status": e.status.value,
            "margin": _float_json(e.margin), "value": e.value, "why": list(e.why),
            "phase": e.phase.value}


def _from_json(doc: dict[str, Any]) -> Evaluation:
    return Evaluation(tuple((str(k), str(v)) for k, v in doc["point"]), str(doc["label"]),
                      RunStatus(doc["status"]), float(doc["margin"]),
                      None if doc.get("value") is None else float(doc["value"]),
                      tuple(str(w) for w in doc.get("why", [])), Phase(doc["phase"]))


class Journal:
    """OUT/search.json: the settings and every run so far, rewritten after each batch."""

    def __init__(self, out: Path, request: Request) -> None:
        self.path, self.settings = out / JOURNAL, request.settings()
        self.runs: dict[Point, Evaluation] = {}
        if not self.path.is_file():
            return
        try:
            doc = read_json(self.path)
            old = doc["settings"]
            runs = [_from_json(r) for r in doc["runs"]]
        except (KeyError, TypeError, ValueError) as err:
            raise SpecError(f"{self.path}: not a search journal kartci can resume ({err}); "
                            "choose another --out or delete it") from err
        if old != self.settings:
            diff = sorted(k for k in self.settings if old.get(k) != self.settings[k])
            raise SpecError(f"{out} holds a search with other settings ({', '.join(diff)}); "
                            "give the same ones to resume it, or choose another --out")
        self.runs = {e.point: e for e in runs}

    def save(self, runs: Sequence[Evaluation]) -> None:
        """Write the journal (atomically: an interrupt leaves the last whole one)."""
        write_json_atomic(self.path, {"kartci_search": 1, "settings": self.settings,
                                      "runs": [_to_json(e) for e in runs]})


def _runner(request: Request, plan: Plan, out: Path, opts: Options, load: Loader,
            warm: Warm) -> Evaluate:
    """Points run through the runner's executors, into OUT/<label> as a sweep's points; the
    worker processes of -j N are kept from one batch to the next (`warm`)."""
    def evaluate(points: list[Point], phase: Phase) -> list[Evaluation]:
        got: dict[Point, Evaluation] = {}
        jobs: list[tuple[Point, Job]] = []
        for p in points:
            try:
                spec = load([*request.overrides, *(f"{k}={v}" for k, v in p)])
            except SpecError as err:
                got[p] = Evaluation(p, "", RunStatus.INVALID, math.nan, None, (one(str(err)),),
                                    phase)
                continue
            jobs.append((p, Job(spec, point_label(spec.name, list(request.overrides),
                                                  list(p)))))
        if jobs:
            check_inside(out, [j.label for _, j in jobs])
            results = run_jobs([j for _, j in jobs], out, opts.baselines, opts.project,
                               workers=opts.workers,
                               executor=opts.executor, ray_address=opts.ray_address,
                               timeout_s=opts.timeout_s, strict=False, on_event=opts.on_event,
                               warm=warm)
            for (p, job), r in zip(jobs, results, strict=True):
                got[p] = judged(p, job.label, r, phase, plan.objective)
        return [got[p] for p in points]

    return evaluate


def _journaled(evaluate: Evaluate, journal: Journal, replayed: list[int]) -> Evaluate:
    """`evaluate` for the points the journal lacks; every batch journaled when it ends."""
    done: list[Evaluation] = []

    def journaled(points: list[Point], phase: Phase) -> list[Evaluation]:
        todo = [p for p in points if p not in journal.runs]
        got = dict(zip(todo, evaluate(todo, phase) if todo else [], strict=True))
        replayed[0] += len(points) - len(todo)
        batch = [got.get(p) or journal.runs[p] for p in points]
        done.extend(batch)
        seen = {e.point for e in done}  # a resumed search that stops sooner keeps the rest
        journal.save([*done, *(e for p, e in journal.runs.items() if p not in seen)])
        return batch

    return journaled


def run_search(request: Request, out: Path, opts: Options, progress: Progress | None = None,
               evaluate: Evaluate | None = None) -> SearchResult:
    """Check the request, search, write OUT/found.yaml and OUT/search.html. `evaluate`
    replaces the runner (tests inject a cheap one); either is journaled in OUT/search.json."""
    load = scenario_loader(request.scenario, project=opts.project,
                           allow_outside_paths=request.allow_outside_paths)
    axes = make_axes(request, load)
    plan = make_plan(request, axes)
    warm = Warm()
    with locked(out), contextlib.closing(warm):  # a busy --out fails here, before any run
        journal = Journal(out, request)
        replayed = [0]
        inner = evaluate or _runner(request, plan, out, opts, load, warm)
        found = search(plan, _journaled(inner, journal, replayed), progress)
        warm.close()  # before drawing the page: the workers are done
        write_manifest(out, "search", [e.label for e in found.counted if e.label])
        target = found.failure if (found.failure is not None and (
            plan.objective is not None or found.failure.status.failing)) else None
        yaml_path = (write_found(request, found, target, out, opts.project)
                     if target is not None else None)
        if yaml_path is None:
            (out / FOUND).unlink(missing_ok=True)  # an earlier search's: not this one's
        from kartci.report.search import search_page  # late: matplotlib, for the page only

        page = out / PAGE
        write_text_atomic(page, search_page(found, request.scenario, describe(request),
                                            None if yaml_path is None else yaml_path.name))
    return SearchResult(found, out, yaml_path, page, replayed[0])


def describe(request: Request) -> str:
    """The command that made a search (for found.yaml's header and the page)."""
    parts = ["kartci search", request.scenario, *(f"--over {o}" for o in request.over),
             *(f"--set {s}" for s in request.overrides), f"--budget {request.budget}"]
    if request.objective != CRITERIA:
        parts.append(f"--objective {request.objective}")
    return " ".join([*parts, f"--seed {request.seed}"])


def write_found(request: Request, found: Found, e: Evaluation, out: Path, proj: Project
                ) -> Path:
    """OUT/found.yaml: the scenario's own file with the overrides and the found values
    written in, runnable as is (`kartci run OUT/found.yaml`); its name is the file's, so a
    copy into scenarios/ under a name of its own joins the suite with a baseline of its own."""
    source = scenario_path(request.scenario, proj)
    data = yaml.safe_load(source.read_text(encoding="utf-8"))
    for agent in (data.get("agents") or {}).values():  # a recorded input's log is found from
        log = ((agent or {}).get("controller") or {}).get("source") or {}  # the file's folder
        if isinstance(log, dict) and isinstance(log.get("log"), str) and not Path(
                log["log"]).is_absolute():
            log["log"] = os.path.relpath((source.parent / log["log"]).resolve(), out.resolve())
    for assignment in [*request.overrides, *(f"{k}={v}" for k, v in e.point)]:
        apply_override(data, assignment)
    data.pop("name", None)
    data.pop("sweep", None)  # one point: the found one
    values = ", ".join(f"{k}={v}" for k, v in e.point)
    what = (f"fails {'; '.join(e.why)}" if e.status.failing else
            f"worst {found.plan.objective} {e.value:.4g}" if e.value is not None else "")
    data["description"] = f"{data.get('description', '')} [found by kartci search: {values}]"
    lines = [f"# Found by `{describe(request)}`", f"# at {values}: {what}"]
    for b in found.brackets:
        lines.append(f"# boundary of {b.key}: {b.passing} passes, {b.failing} fails")
    if found.brackets:
        lines.append("# (shrunk toward the scenario's own values: the nearest failure found)")
    lines.append("# Run it: kartci run <this file>; once it passes, copy it into scenarios/ and "
                 "accept a baseline (kartci baseline update).")
    text = "\n".join(lines) + "\n" + yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
    path = out / FOUND
    write_text_atomic(path, text)
    return path
