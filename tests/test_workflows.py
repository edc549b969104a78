"""The GitHub workflows: actionlint passes, least privilege, and the gate's steps run here.

GitHub itself cannot run in a test; what can: every `kartci` step of the shard and merge
jobs, in workflow order, with the matrix values substituted, on a small project (two quick
line scenarios). The artifact hand-over is checked to be a plain copy of `shards/` (same
path uploaded and downloaded, merge-multiple), which running in one folder reproduces.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from test_parallel import PAIR

ROOT = Path(__file__).resolve().parents[1]
WORKFLOWS = sorted((ROOT / ".github" / "workflows").glob("*.yml"))
BIN = str(Path(sys.executable).parent)


def _load(path: Path) -> dict[Any, Any]:
    doc = yaml.safe_load(path.read_text())
    assert isinstance(doc, dict)
    return doc


def test_actionlint_passes_on_every_workflow() -> None:
    exe = shutil.which("actionlint", path=os.pathsep.join([BIN, os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip('actionlint not installed: pip install -e ".[dev]"')
    assert len(WORKFLOWS) >= 2
    env = {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")])}
    p = subprocess.run([exe, *map(str, WORKFLOWS)], cwd=ROOT, capture_output=True, text=True,
                       env=env, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr


@pytest.mark.parametrize("path", WORKFLOWS, ids=lambda p: p.name)
def test_least_privilege_and_pinned_actions(path: Path) -> None:
    doc = _load(path)
    triggers = doc["on"] if "on" in doc else doc[True]  # YAML 1.1 reads a bare `on` as true
    assert "pull_request" in triggers and "pull_request_target" not in triggers
    assert doc["permissions"] == {"contents": "read"}
    uses = [s["uses"] for job in doc["jobs"].values() for s in job["steps"] if "uses" in s]
    assert uses and all(re.fullmatch(r"actions/[\w-]+@v\d+", u) for u in uses), uses


def _kartci_steps(job: dict[str, Any], values: dict[str, str]) -> Iterator[str]:
    """The job's `kartci` commands with `${{ ... }}` filled in; only installs are skipped."""
    for step in job["steps"]:
        if "run" not in step:
            continue
        cmd = re.sub(r"\$\{\{\s*([\w.-]+)\s*\}\}", lambda m: values[m.group(1)], step["run"])
        assert "${{" not in cmd, cmd
        if cmd.startswith("kartci "):
            yield cmd
        else:
            assert re.match(r"(python3? -m )?pip install ", cmd), f"step not run here: {cmd}"


def _project(tmp_path: Path) -> Path:
    """KARTCI_ROOT with two 3 s scenarios and no baselines; worlds and models are built in."""
    proj = tmp_path / "project"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "baselines").mkdir()
    for name in PAIR:
        spec = yaml.safe_load((ROOT / "kartci" / "data" / "scenarios" / f"{name}.yaml")
                              .read_text())
        spec.update(duration_s=3.0, criteria={}, metrics={"line_tracking": {"transient_s": 1.0}})
        (proj / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    return proj


def test_the_gate_workflow_runs_locally_in_order(tmp_path: Path) -> None:
    jobs = _load(ROOT / ".github" / "workflows" / "kartci.yml")["jobs"]
    shards = jobs["shards"]["strategy"]["matrix"]["shard"]
    assert jobs["merge"]["needs"] == "shards"
    up = next(s for s in jobs["shards"]["steps"] if "upload-artifact" in s.get("uses", ""))
    down = next(s for s in jobs["merge"]["steps"] if "download-artifact" in s.get("uses", ""))
    assert down["with"]["merge-multiple"] is True
    assert up["with"]["path"] == down["with"]["path"] == "shards/"
    names = [up["with"]["name"].replace("${{ matrix.shard }}", str(i)) for i in shards]
    assert len(set(names)) == len(shards)  # artifacts are immutable: one name per leg
    assert all(fnmatch.fnmatch(n, down["with"]["pattern"]) for n in names)

    work = tmp_path / "work"
    work.mkdir()
    summary = tmp_path / "step_summary.md"
    env = {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")]),
           "KARTCI_ROOT": str(_project(tmp_path)), "CI": "true", "GITHUB_ACTIONS": "true",
           "GITHUB_STEP_SUMMARY": str(summary)}
    ran = []
    legs = [(jobs["shards"], {"matrix.shard": str(i), "strategy.job-total": str(len(shards))})
            for i in shards] + [(jobs["merge"], {})]
    for job, values in legs:
        for cmd in _kartci_steps(job, values):
            p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", cmd], cwd=work, env=env,
                               capture_output=True, text=True, timeout=300)
            assert p.returncode == 0, (cmd, p.stdout[-2000:], p.stderr[-2000:])
            ran.append(cmd.split()[:2])
    assert ran == [["kartci", "run"]] * len(shards) + [["kartci", "merge"]]
    merged = json.loads((work / "reports" / "merged" / "summary.json").read_text())
    assert sorted(merged["scenarios"]) == sorted(PAIR) and merged["exit_code"] == 0
    assert (work / "reports" / "merged" / "report.html").exists()
    assert summary.read_text().count("## kartci: all scenarios pass") == 1  # by merge only
