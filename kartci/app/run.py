"""One scenario run, scored and judged, returned as a result: the workflow behind `kartci.run`
and the pytest plugin (its scenario items and the `kartci_run` fixture)."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path

from kartci.core import RunFolder
from kartci.project import Project
from kartci.runner.run import check_criteria_names, run_pinned
from kartci.scenario.load import load_scenario, with_overrides
from kartci.scenario.models import Scenario
from kartci.verdict import read_baseline
from kartci.verdict.judging import Stale, judge_folder
from kartci.verdict.result import ScenarioResult


def run_scenario(scenario: str | Path | Scenario, overrides: Sequence[str] = (), *,
                 out: Path | None = None, agents: Mapping[str, object] | None = None,
                 project: Project, baselines: Path | None = None,
                 allow_outside_paths: bool = False, stale: Stale = Stale.SKIP) -> ScenarioResult:
    """Run `scenario` (a name, a YAML path or a `Scenario`, with `overrides`) into
    OUT/<scenario>/ (OUT default: a new temporary folder) and judge it against its baseline in
    `baselines` (default: `project`'s), by `project`'s tolerance policy. `stale`: SKIP for
    `kartci.run` and the fixture, whose overrides and agent objects make another scenario on
    purpose; WARN for a scenario file run as written (a pytest scenario item), judged as
    `kartci run` judges it."""
    if isinstance(scenario, Scenario):
        spec = with_overrides(scenario, list(overrides), project=project,
                              allow_outside_paths=allow_outside_paths)
    else:
        spec = load_scenario(scenario, list(overrides), project=project,
                             allow_outside_paths=allow_outside_paths)
    check_criteria_names([spec], project)
    root = out if out is not None else Path(tempfile.mkdtemp(prefix=f"kartci-{spec.name}-"))
    folder = RunFolder(root / spec.name)
    run_pinned(spec, root, folder, agents)
    base_dir = baselines if baselines is not None else project.baselines
    baseline = read_baseline(base_dir / f"{spec.name}.json")
    return judge_folder(folder, spec, baseline, project, stale)
