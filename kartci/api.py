"""kartci's Python API: load a scenario, run it, judge it, read the result.

```python
import kartci

result = kartci.run("line_straight", overrides=["duration_s=10",
                                                "metrics.line_tracking.transient_s=2"])
assert result.value("cross_track_max_m") < 0.002
print(result.table())
```

`kartci.run` does what `kartci run NAME` does for one scenario (simulate, record the log, score
it, judge it against the baseline and the scenario's criteria) and returns a `RunResult`
instead of writing reports and an exit code. Agents may be handed in as objects
(`agents={"kart0": MyController()}`) for a test of your own controller; see `kartci.Agent`.
`kartci.compare(base, head)` judges one run against another, `kartci.accept_baselines(result)`
stores a run as its scenario's baseline (`kartci baseline update`). `kartci.run_suite` runs
many scenarios into one output folder with its reports, as `kartci run` does, one shard of them
if asked (`shard=(i, n)`), and `kartci.merge` joins the shards' folders, as `kartci merge`. For a
run you step yourself, see `kartci.Session`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from kartci import project
from kartci.errors import SpecError
from kartci.scenario.load import load_scenario as _load
from kartci.scenario.models import Scenario
from kartci.verdict import RunResult

if TYPE_CHECKING:
    from kartci.app.accept import Accepted
    from kartci.app.search import SearchResult
    from kartci.app.suite import Suite


def load_scenario(scenario: str | Path, overrides: Sequence[str] = (), *,
                  allow_outside_paths: bool = False) -> Scenario:
    """Load and validate a scenario file.

    Args:
        scenario: A name on the project's scenario path (`"line_straight"`), or the path of a
            YAML file (a `Path`, or a string ending in `.yaml` or holding a `/`).
        overrides: `dotted.key=value` assignments, as `kartci run --set` takes them
            (`"duration_s=3"`, `"agents.lt0.controller.kp=80"`); values are parsed as YAML.
        allow_outside_paths: Let track, world and model files lie outside the project and
            kartci's data (absolute paths, `..`, symlinks), as `--allow-outside-paths`.

    Returns:
        The validated, frozen scenario, with world and robot files resolved.

    Raises:
        SpecError: The file is missing or malformed, or a value is bad; the message names the
            file, the key and what was expected.
    """
    return _load(scenario, list(overrides), project=project.current(),
                 allow_outside_paths=allow_outside_paths)


def run(scenario: str | Path | Scenario, *, overrides: Sequence[str] = (),
        out: str | Path | None = None, agents: Mapping[str, object] | None = None,
        baselines: str | Path | None = None, allow_outside_paths: bool = False) -> RunResult:
    """Run one scenario, record its log, score it and judge it against its baseline.

    Args:
        scenario: A scenario name or YAML path (see `load_scenario`), or a `Scenario`.
        overrides: `dotted.key=value` assignments applied before the run (`--set`).
        out: Output folder; the run goes into `OUT/<scenario>/` as with `kartci run --out`
            (an earlier run there is replaced). Default: a new temporary folder, kept (its
            path is in the result).
        agents: Objects replacing the scenario's controllers, by agent name; each must
            satisfy `kartci.Agent` (period_s, inputs, on_message, step). The log records the
            scenario as written plus which agents were replaced, and by what.
        baselines: Folder of baseline files. Default: the project's (`[tool.kartci]
            baselines`).
        allow_outside_paths: As for `load_scenario`.

    Returns:
        The run's metrics, verdicts and criteria (`result.passed`, `result.table()`). A
        baseline accepted from another scenario than this run's (other overrides, an agent
        object: the scenario hash it records differs) is not compared: every verdict is `new`,
        `result.baseline` is None and `result.warnings` says "no comparable baseline".

    Raises:
        SpecError: Bad input (the scenario, an override, an agent object, criteria on
            unknown metrics, a run shorter than its metrics' transient).
        RunError: The simulation broke (a non-finite state).
        KartciError: Any other problem kartci reports; an exception raised by an agent object
            (your controller) propagates unchanged.
    """
    # late: the runner loads PyBullet and pandas, which `kartci.RunResult` and
    # `kartci.load_scenario` (this module) do not need
    from kartci.app.run import run_scenario

    return run_scenario(scenario, overrides, out=None if out is None else Path(out),
                        agents=agents, project=project.current(),
                        baselines=None if baselines is None else Path(baselines),
                        allow_outside_paths=allow_outside_paths)


def compare(base: RunResult, head: RunResult, *,
            baselines: str | Path | None = None) -> RunResult:
    """Judge one run against another, metric by metric: what to do when a run has no comparable
    baseline (other overrides, an agent object), as `kartci compare BASE_OUT HEAD_OUT` does.

    ```python
    base = kartci.run("line_straight", overrides=QUICK)
    head = kartci.run("line_straight", overrides=[*QUICK, "agents.lt0.controller.kp=80"])
    print(kartci.compare(base, head).table())
    ```

    Args:
        base: The run judged against (its metrics play the baseline).
        head: The run judged.
        baselines: Folder of baseline files whose hand-set tolerances and directions apply
            (head's scenario's file, where it has the metric; else the metric's default).
            Default: the project's.

    Returns:
        `head` with one verdict per metric (value: head's, baseline: base's), no criteria and
        no warnings; `result.baseline` is base's metrics file.
    """
    # late, as in `run`: comparing loads the runner, which `import kartci.api` does not need
    from kartci.app.compare import compare_results

    return compare_results(base, head,
                           project.current().baselines if baselines is None else Path(baselines))


def accept_baselines(run: RunResult | str | Path, names: Sequence[str] = (), *,
                     baselines: str | Path | None = None, replicas: int = 4,
                     jobs: int = 1) -> list[Accepted]:
    """Store runs as their scenarios' baselines: what `kartci baseline update` does (the same
    function), from Python.

    ```python
    result = kartci.run("line_straight", out="reports/latest")
    for accepted in kartci.accept_baselines(result):
        print("\\n".join(accepted.lines()))
    ```

    Args:
        run: A result of `run` (its scenario is accepted), or an output folder of
            `kartci run` / `run(out=...)`.
        names: With a folder: the scenarios to accept (default: those of the last
            `kartci run` there).
        baselines: Folder the baseline files are written to. Default: the project's.
        replicas: Conditioning replicas per scenario (the run itself and K-1 with every
            robot's start moved k nm sideways; those missing are run now): each metric's
            spread over them goes into the baseline. 0: record no spread (required for a run
            driven by agent objects, which replicas cannot re-create).
        jobs: Replicas run at once.

    Returns:
        Per scenario, what was written (`Accepted`: `changes`, `scenario_changes`, `lines()`,
        `warnings` for ill-conditioned metrics).

    Raises:
        SpecError: A run that failed, did not finish, ran with unpinned kernels, or is not
            there; nothing is written then, and no baseline is replaced.
        BaselineError: An existing baseline file is malformed.
    """
    # late, as in `run`: accepting loads the runner, which `import kartci.api` does not need
    from kartci.app.accept import accept

    if isinstance(run, RunResult):
        if names:
            raise SpecError("accept_baselines: names go with an output folder, not a result")
        out, names = run.folder.parent, (run.folder.name,)
    else:
        out = Path(run)
    return accept(out, project.current(), names,
                  baselines=None if baselines is None else Path(baselines), replicas=replicas,
                  jobs=jobs)


def run_suite(names: Sequence[str | Path] = (), *, overrides: Sequence[str] = (),
              out: str | Path | None = None, baselines: str | Path | None = None,
              shard: tuple[int, int] | None = None, jobs: int = 1, sweep: Sequence[str] = (),
              repeat: int = 1, timeout_s: float | None = None, strict: bool = False,
              allow_outside_paths: bool = False) -> Suite:
    """Run scenarios into one output folder, score and judge them and write the reports: what
    `kartci run` does (the same function), from Python; with `shard`, one share of them, for
    `merge` to join.

    ```python
    for i in (1, 2):  # on two CI machines, say
        kartci.run_suite(shard=(i, 2), out=f"reports/shard{i}")
    suite = kartci.merge(["reports/shard1", "reports/shard2"], out="reports/latest")
    assert suite.passed, suite.reports["markdown"].read_text()
    ```

    Args:
        names: Scenario names or YAML paths. Default: the project's suite (as `kartci run`).
        overrides: `dotted.key=value` assignments for every scenario (`--set`).
        out: Output folder: `OUT/<scenario>/` per run, the reports at the top. Default: the
            project's `reports/latest`.
        baselines: Folder of baseline files. Default: the project's.
        shard: `(i, n)`: run only share i of n (labels sorted, dealt round-robin); OUT then
            holds a partial result (`shard.json`) and its reports cover that share only.
        jobs: Runs at once (this process and jobs-1 worker processes).
        sweep: `key=v1,v2,...` each: one run per value (every combination), as `--sweep`.
        repeat: Seeds per scenario (seed, seed+1, ...), into `OUT/<scenario>/repeat_<k>/`.
        timeout_s: Wall-clock limit per run, s.
        strict: Fail a scenario without a baseline or with a stale one (as under CI).
        allow_outside_paths: As for `load_scenario`.

    Returns:
        The `Suite`: `results` (one `RunResult` per scenario), `reports` (their paths by kind:
        `"html"`, `"markdown"`, `"json"`, `"junit"`), `exit_code` and `passed` as the CLI's.

    Raises:
        SpecError: Bad input (a scenario, an override, a count, a shard), found before anything
            runs; OUT busy with another kartci command.
    """
    # late, as in `run`: the runner loads PyBullet and pandas
    from kartci.app.suite import SuiteRequest
    from kartci.app.suite import run_suite as run_requested

    proj = project.current()
    target = Path(out) if out is not None else proj.default_output("latest")
    request = SuiteRequest(target, names=tuple(str(n) for n in names), overrides=tuple(overrides),
                           baselines=None if baselines is None else Path(baselines), jobs=jobs,
                           shard=shard, sweep=tuple(sweep), repeat=repeat, timeout_s=timeout_s,
                           strict=strict, allow_outside_paths=allow_outside_paths)
    return run_requested(request, proj)


def merge(parts: Sequence[str | Path], *, out: str | Path, baselines: str | Path | None = None,
          strict: bool = False) -> Suite:
    """Join the output folders of `run_suite(shard=...)` (or `kartci run --shard`) into one run
    in `out`, judged and reported as an unsharded run would be: what `kartci merge` does.

    Args:
        parts: The shards' output folders (every share of one split).
        out: Output folder of the joined run.
        baselines: Folder of baseline files. Default: the project's.
        strict: As for `run_suite`.

    Returns:
        The joined `Suite` (as `run_suite`'s).

    Raises:
        SpecError: A shard is missing or given twice, shards of different splits, a scenario
            in more than one part, or a part that is not a shard's output.
    """
    # late, as in `run`: judging loads the runner
    from kartci.app.suite import merge_shards

    proj = project.current()
    return merge_shards([Path(p) for p in parts], Path(out),
                        None if baselines is None else Path(baselines), proj, strict=strict)


def search(scenario: str | Path, over: Sequence[str], *, overrides: Sequence[str] = (),
           budget: int = 100, objective: str = "criteria", seed: int = 0,
           out: str | Path | None = None, jobs: int = 1, baselines: str | Path | None = None,
           allow_outside_paths: bool = False) -> SearchResult:
    """Search a scenario's space for a run that fails its criteria and shrink it toward the
    scenario's own values: what `kartci search` does, from Python.

    ```python
    found = kartci.search("line_circle", ["agents.lt0.controller.period_s=0.01..0.1"],
                          budget=40, out="reports/search")
    if found.failed:
        print(found.found.failure.point, found.found.brackets, found.found_yaml)
    ```

    Args:
        scenario: A scenario name or YAML path (see `load_scenario`).
        over: The axes: `KEY=LOW..HIGH`, `KEY=LOW..HIGH:STEP` or `KEY=a,b,c` each.
        overrides: `dotted.key=value` assignments fixed for every run (`--set`).
        budget: Runs at most, search and shrinking together (at most 10,000).
        objective: `"criteria"` (find a failing run), or a metric name (find where it is
            worst).
        seed: The sampler's seed: the same seed gives the same search, at any `jobs`.
        out: Output folder (default: the project's reports/search); a search interrupted
            there resumes from its journal.
        jobs: Runs at once.
        baselines: Folder of baseline files (default: the project's).
        allow_outside_paths: As for `load_scenario`.

    Returns:
        The search (`found.failure`, `found.brackets`, `found.runs`, `found.coverage`), the
        files written (`found_yaml`, `page`) and `failed` / `exit_code` as the CLI's.

    Raises:
        SpecError: Bad input (an unknown key, a range the key refuses, a budget over the cap,
            an unknown objective, an OUT holding a search of other settings).
    """
    # late: searching loads the runner and the sampler, which `import kartci.api` does not need
    from kartci.app.search import Options, Request, run_search

    request = Request(str(scenario), tuple(over), tuple(overrides), budget, objective, seed,
                      allow_outside_paths)
    proj = project.current()
    target = Path(out) if out is not None else proj.reports / "search"
    base_dir = Path(baselines) if baselines is not None else proj.baselines
    if jobs < 1:
        raise SpecError(f"jobs {jobs}: expected 1 or more")
    return run_search(request, target, Options(base_dir, proj, jobs))


__all__ = ["RunResult", "accept_baselines", "compare", "load_scenario", "merge", "run",
           "run_suite", "search"]
