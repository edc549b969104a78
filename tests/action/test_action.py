"""The root action.yml (a composite action): a workflow using it from a local path passes
actionlint, its inputs reach its scripts only as data, its actions are pinned as the workflows
pin them, and its steps run here (tests/action/composite.py): one job, kartci's own CI's shard
and merge jobs (`uses: ./`), the gate's `fail-on`, the pull-request comment (with a stand-in
`gh`)."""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
import yaml
from action_project import make_project
from composite import Ran, run_action, runs, with_values
from helpers import PAIR

from kartci import __version__
from kartci.cachedir import cache_dir

ROOT = Path(__file__).resolve().parents[2]
ACTION_TEXT = (ROOT / "action.yml").read_text()
ACTION: dict[str, Any] = yaml.safe_load(ACTION_TEXT)
CI: dict[str, Any] = yaml.safe_load((ROOT / ".github" / "workflows" / "ci.yml").read_text())
BIN = str(Path(sys.executable).parent)
GITHUB = {"action_path": str(ROOT), "event_name": "push", "repository": "team/robot",
          "server_url": "https://github.com", "run_id": "7", "job": "gate", "token": "t0ken"}


def _actionlint() -> str:
    exe = shutil.which("actionlint", path=os.pathsep.join([BIN, os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip('actionlint not installed: pip install -e ".[dev]"')
    return exe


def _scratch(tmp_path: Path, with_: str) -> subprocess.CompletedProcess[str]:
    """actionlint on a scratch repository holding the action and a workflow using `./`."""
    repo = tmp_path / "repo"
    (repo / ".github" / "workflows").mkdir(parents=True)
    shutil.copy2(ROOT / "action.yml", repo / "action.yml")
    subprocess.run(["git", "init", "-q", str(repo)], check=True, timeout=60)
    (repo / ".github" / "workflows" / "kartci.yml").write_text(f"""\
name: kartci
on:
  pull_request:
permissions:
  contents: read
  pull-requests: write
jobs:
  shards:
    runs-on: ubuntu-latest
    strategy:
      matrix:
        shard: [1, 2, 3]
    steps:
      - uses: actions/checkout@08c6903cd8c0fde910a37f88322edcfb5dd907a8 # v5.0.0
        with:
          persist-credentials: false
      - uses: ./
        with:
          shard: ${{{{ matrix.shard }}}}/${{{{ strategy.job-total }}}}
  merge:
    needs: shards
    runs-on: ubuntu-latest
    steps:
      - uses: actions/checkout@08c6903cd8c0fde910a37f88322edcfb5dd907a8 # v5.0.0
        with:
          persist-credentials: false
      - uses: ./
        id: kartci
        with:
{with_}
      - run: echo "kartci exited $CODE; report in $REPORT"
        env:
          CODE: ${{{{ steps.kartci.outputs.exit-code }}}}
          REPORT: ${{{{ steps.kartci.outputs.report }}}}
""")
    env = {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")])}
    return subprocess.run([_actionlint()], cwd=repo, capture_output=True, text=True, env=env,
                          timeout=120)


EVERY_INPUT = """\
          merge: "true"
          scenarios: line_straight kart_wall
          python-version: "3.12"
          kartci: kartci==0.1.0
          constraints: constraints.txt
          plugin-packages: -e . team-metrics==1.2
          artifact-name: nightly
          baselines: baselines
          history: history/summaries
          fail-on: error
          comment: "true"
          github-token: ${{ github.token }}"""


def test_a_workflow_using_the_action_from_a_local_path_passes_actionlint(
        tmp_path: Path) -> None:
    p = _scratch(tmp_path, EVERY_INPUT)
    assert p.returncode == 0, p.stdout + p.stderr
    # actionlint reads the local action: a misspelt input is an error
    p = _scratch(tmp_path / "bad", EVERY_INPUT.replace("fail-on:", "fail_on:"))
    assert p.returncode == 1 and 'input "fail_on" is not defined in action "kartci"' in p.stdout


def test_kartcis_own_workflows_pass_actionlint_with_the_action() -> None:
    env = {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")])}
    p = subprocess.run([_actionlint()], cwd=ROOT, capture_output=True, text=True, env=env,
                       timeout=120)
    assert p.returncode == 0, p.stdout + p.stderr
    uses = [s.get("uses") for job in CI["jobs"].values() for s in job["steps"]]
    assert uses.count("./") == 2  # the shard legs and the merge


def test_inputs_reach_scripts_as_data_and_actions_are_pinned_as_the_workflows_pin_them() -> None:
    declared = set(ACTION["inputs"])
    used = set(re.findall(r"inputs\.([\w-]+)", ACTION_TEXT))
    assert used == declared
    steps = ACTION["runs"]["steps"]
    assert all(s["shell"] == "bash" and "${{" not in s["run"] for s in steps if "run" in s)
    workflows = "\n".join(p.read_text() for p in (ROOT / ".github" / "workflows").glob("*.yml"))
    pins = re.findall(r"^\s*(?:- )?uses: (.*)$", ACTION_TEXT, re.MULTILINE)
    assert len(pins) == 6 and all(re.fullmatch(r"[\w-]+/[\w-]+@[0-9a-f]{40} # v\d+\.\d+\.\d+", u)
                                  and u in workflows for u in pins), pins
    assert all(s["with"]["overwrite"] is True for s in steps
               if s.get("uses", "").startswith("actions/upload-artifact@"))


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A project with the two 3 s line scenarios and baselines accepted from a first run."""
    return make_project(tmp_path_factory.mktemp("project"))


def _env(project: Path, tmp_path: Path, **extra: str) -> dict[str, str]:
    return {**os.environ, "PATH": os.pathsep.join([BIN, os.environ.get("PATH", "")]),
            "KARTCI_ROOT": str(project), "CI": "true", "GITHUB_ACTIONS": "true",
            "GITHUB_STEP_SUMMARY": str(tmp_path / "step_summary.md"), **extra}


def _installed(name: str) -> bool:
    """The install step is what the test environment already did (offline, this checkout)."""
    return name == "Install kartci"


@pytest.mark.long(reason="the action's steps with a fresh install")
def test_one_job_runs_the_selected_scenarios_reports_and_uploads(project: Path,
                                                                 tmp_path: Path) -> None:
    ran = run_action(ACTION, {"scenarios": "line_straight"}, GITHUB, tmp_path,
                     _env(project, tmp_path), skip=_installed,
                     contexts={"runner.os": "Linux", "runner.arch": "X64"})
    assert ran.code == 0, ran.stdout[-3000:]
    assert ran.steps == ["actions/setup-python", "Check the inputs", "actions/cache",
                         "Install kartci", "Locate the solver cache", "actions/cache",
                         "Run kartci", "actions/upload-artifact", "Gate"]
    name = ran.outputs.pop("artifact")
    assert ran.outputs == {"exit-code": "0", "report": "reports/kartci"}
    assert re.fullmatch(r"kartci-report-gate-[0-9a-f]{8}", name)
    assert ran.uploads == [(name, "reports/kartci/")]
    # the solver cache: kartci's cache folder, keyed by kartci's version, the runner and the
    # constraints (kartci's own, shipped with the action, when the input is empty)
    pip, solver = [w for action, w in ran.uses if action == "actions/cache"]
    pins = hashlib.sha256((ROOT / "constraints.txt").read_bytes()).hexdigest()[:16]
    assert pip["key"] == f"kartci-pip-Linux-X64-py3.11-{pins}"
    assert solver["path"] == str(cache_dir())
    assert re.fullmatch(rf"kartci-solver-{re.escape(__version__)}-Linux-X64-{pins}-[0-9a-f]{{16}}",
                        solver["key"]), solver
    assert solver["key"].startswith(solver["restore-keys"])
    summary = json.loads((tmp_path / "reports" / "kartci" / "summary.json").read_text())
    assert sorted(summary["scenarios"]) == ["line_straight"] and summary["exit_code"] == 0
    assert (tmp_path / "reports" / "kartci" / "line_straight" / "run.mcap").is_file()
    assert (tmp_path / "step_summary.md").read_text().count("## kartci: all scenarios pass") == 1


@pytest.mark.long(reason="the action's steps with a fresh install")
def test_kartcis_own_ci_runs_its_shards_and_merge_through_the_action(project: Path,
                                                                     tmp_path: Path) -> None:
    """ci.yml's shard legs and merge job, each `uses: ./` expanded into the action's steps,
    in one folder (the artifact hand-over: every leg uploads shards/, merge downloads them)."""
    env = _env(project, tmp_path)
    shards = CI["jobs"]["shards"]["strategy"]["matrix"]["shard"]
    assert CI["jobs"]["merge"]["needs"] == "shards"
    done: list[Ran] = []
    legs = [("shards", {"matrix.shard": str(i), "strategy.job-total": str(len(shards))})
            for i in shards] + [("merge", {})]
    for job, values in legs:
        (step,) = [s for s in CI["jobs"][job]["steps"] if s.get("uses") == "./"]
        assert not any("run" in s for s in CI["jobs"][job]["steps"])
        done.append(run_action(ACTION, with_values(step, values), GITHUB, tmp_path, env,
                               skip=_installed))
        assert done[-1].code == 0, done[-1].stdout[-3000:]
    assert [r.uploads for r in done] == [[("kartci-report-shard-1", "shards/")],
                                         [("kartci-report-shard-2", "shards/")],
                                         [("kartci-report", "reports/merged/")]]
    assert [w["pattern"] for action, w in done[-1].uses
            if action == "actions/download-artifact"] == ["kartci-report-shard-*"]
    merged = json.loads((tmp_path / "reports" / "merged" / "summary.json").read_text())
    assert sorted(merged["scenarios"]) == sorted(PAIR) and merged["exit_code"] == 0
    assert (tmp_path / "step_summary.md").read_text().count("## kartci: all scenarios pass") == 1
    # the comment workflow posts the report the merge job uploads
    comment = yaml.safe_load((ROOT / ".github" / "workflows" / "kartci-comment.yml").read_text())
    (down,) = [s for s in comment["jobs"]["comment"]["steps"] if "uses" in s]
    assert down["with"]["name"] == "kartci-report"


def _step(name: str) -> dict[str, Any]:
    steps: list[dict[str, Any]] = ACTION["runs"]["steps"]
    (step,) = [s for s in steps if s.get("name") == name]
    return step


def _only(name: str, inputs: dict[str, str], outputs: dict[str, str], tmp_path: Path,
          extra_env: dict[str, str] | None = None) -> Ran:
    """One step of the action alone, with `outputs` as the run step's."""
    action = {**ACTION, "runs": {"steps": [_step(name)]}}
    ctx_github = {**GITHUB, **{f"steps.run.outputs.{k}": v for k, v in outputs.items()}}
    return run_action(action, inputs, ctx_github, tmp_path, {**os.environ, **(extra_env or {})})


@pytest.mark.parametrize(("fail_on", "code", "fails"), [
    ("regression", "0", False), ("regression", "1", True), ("regression", "2", True),
    ("error", "1", False), ("error", "2", True), ("never", "2", False)])
def test_the_gate_fails_as_fail_on_says(fail_on: str, code: str, fails: bool,
                                        tmp_path: Path) -> None:
    action = {**ACTION, "runs": {"steps": [_step("Gate")]}}
    action["runs"]["steps"][0] = {**_step("Gate"), "env": {
        "CODE": code, "FAIL_ON": "${{ inputs.fail-on }}"}}
    ran = run_action(action, {"fail-on": fail_on}, GITHUB, tmp_path, dict(os.environ))
    assert ran.code == (int(code) if fails else 0), ran.stdout


@pytest.mark.parametrize(("inputs", "message"), [
    ({"shard": "2"}, "shard must be i/N, not '2'"),
    ({"merge": "yes"}, "merge must be true or false, not 'yes'"),
    ({"shard": "1/2", "merge": "true"}, "shard and merge go in separate jobs"),
    ({"fail-on": "regressions"},
     "fail-on must be regression, error or never, not 'regressions'"),
    ({"comment": "1"}, "comment must be true or false, not '1'")])
def test_bad_inputs_are_one_line_exit_2(inputs: dict[str, str], message: str,
                                        tmp_path: Path) -> None:
    ran = _only("Check the inputs", inputs, {}, tmp_path)
    assert ran.code == 2 and ran.stdout.strip() == f"::error::kartci action: {message}"


def test_the_comment_is_posted_once_then_edited(tmp_path: Path) -> None:
    """The comment step with a stand-in `gh` that records its calls: the first run posts the
    summary under the marker, a later one edits that comment."""
    report = tmp_path / "reports" / "kartci"
    report.mkdir(parents=True)
    (report / "summary.md").write_text("## kartci: all scenarios pass\n")
    fake = tmp_path / "bin"
    fake.mkdir()
    log = tmp_path / "gh.log"
    (fake / "gh").write_text(f"""#!/usr/bin/env bash
echo "$*" >> {log}
for a in "$@"; do case "$a" in body=@*) cp "${{a#body=@}}" {tmp_path}/posted.md;; esac; done
if [[ "$*" == *--paginate* && -f {tmp_path}/posted.md ]]; then echo 4242; fi
""")
    (fake / "gh").chmod(0o755)
    env = {"PATH": os.pathsep.join([str(fake), os.environ["PATH"]])}
    step = _step("Post or update the kartci comment")
    ctx = {"github.event_name": "pull_request", "steps.run.outputs.report": str(report)}
    assert runs(step, {**ctx, "inputs.comment": "true"}, False)
    assert not runs(step, {**ctx, "inputs.comment": "false"}, False)
    assert not runs(step, {**ctx, "inputs.comment": "true", "github.event_name": "push"}, False)
    assert not runs(step, {**ctx, "inputs.comment": "true", "steps.run.outputs.leg": "1"}, False)
    action = {**ACTION, "runs": {"steps": [{**step, "if": "true", "env": {
        **step["env"], "PR": "12", "REPORT": str(report)}}]}}
    for _ in range(2):
        ran = run_action(action, {"comment": "true"}, GITHUB, tmp_path, {**os.environ, **env})
        assert ran.code == 0, ran.stdout
    calls = log.read_text().splitlines()
    assert [c.split()[:3] for c in calls if "--paginate" not in c] == [
        ["api", "-X", "POST"], ["api", "-X", "PATCH"]]
    assert "repos/team/robot/issues/12/comments" in calls[1]
    assert "repos/team/robot/issues/comments/4242" in calls[3]
    posted = (tmp_path / "posted.md").read_text()
    assert posted.startswith("<!-- kartci-report -->\n## kartci: all scenarios pass\n")
    assert "https://github.com/team/robot/actions/runs/7" in posted


def test_a_comment_that_cannot_be_posted_is_a_warning(tmp_path: Path) -> None:
    """A fork's pull request gets a read-only token: the comment fails, the step does not."""
    report = tmp_path / "report"
    report.mkdir()
    (report / "summary.md").write_text("## kartci: 1 regression\n")
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "gh").write_text("#!/usr/bin/env bash\necho 'HTTP 403: Resource not accessible' >&2\n"
                             "exit 1\n")
    (fake / "gh").chmod(0o755)
    step = _step("Post or update the kartci comment")
    action = {**ACTION, "runs": {"steps": [{**step, "if": "true", "env": {
        **step["env"], "PR": "12", "REPORT": str(report)}}]}}
    ran = run_action(action, {"comment": "true"}, GITHUB, tmp_path,
                     {**os.environ, "PATH": os.pathsep.join([str(fake), os.environ["PATH"]])})
    assert ran.code == 0
    assert "::warning::kartci: no pull-request comment (needs pull-requests: write" in ran.stdout


def _outputs(ran: Ran) -> dict[str, str]:
    return dict(line.split("=", 1) for line in ran.stdout.splitlines() if "=" in line)


def _names(tmp_path: Path, inputs: dict[str, str], contexts: dict[str, str] | None = None,
           **github: str) -> tuple[str, str]:
    """The report artifact's name and the shard prefix "Check the inputs" settles on."""
    step = _step("Check the inputs")
    action = {**ACTION, "runs": {"steps": [
        step, {"name": "show", "shell": "bash", "env": {
            "R": "${{ steps.setup.outputs.report-name }}",
            "S": "${{ steps.setup.outputs.shard-prefix }}"},
            "run": 'echo "r=$R"; echo "s=$S"'}]}}
    ran = run_action(action, inputs, {**GITHUB, **github}, tmp_path, dict(os.environ),
                     contexts=contexts)
    assert ran.code == 0, ran.stdout
    out = _outputs(ran)
    return out["r"], out["s"]


def test_artifact_names_are_unique_per_job_and_use(tmp_path: Path) -> None:
    """Two uses in one job, two jobs, two legs of a matrix: each its own report artifact;
    the same use again (a re-run) the same one; `artifact-name` names it and its shards."""
    one, prefix = _names(tmp_path, {"scenarios": "line_straight"})
    assert re.fullmatch(r"kartci-report-gate-[0-9a-f]{8}", one) and prefix == "kartci-shard"
    assert _names(tmp_path, {"scenarios": "line_straight"})[0] == one
    others = {_names(tmp_path, {"scenarios": "kart_wall"})[0],
              _names(tmp_path, {"scenarios": "line_straight"}, job="nightly")[0],
              _names(tmp_path, {"scenarios": "line_straight"}, {"strategy.job-index": "1"})[0],
              _names(tmp_path, {"scenarios": "line_straight", "merge": "true"})[0]}
    assert len(others) == 4 and one not in others
    assert _names(tmp_path, {"artifact-name": "nightly"}) == ("nightly", "nightly-shard")


def test_the_constraints_default_to_kartcis_own(tmp_path: Path) -> None:
    step = _step("Check the inputs")
    action = {**ACTION, "runs": {"steps": [step, {
        "name": "show", "shell": "bash", "env": {"C": "${{ steps.setup.outputs.constraints }}"},
        "run": 'echo "c=$C"'}]}}
    ran = run_action(action, {}, GITHUB, tmp_path, dict(os.environ))
    assert ran.code == 0 and _outputs(ran)["c"] == f"{ROOT}/constraints.txt"
    (tmp_path / "team.txt").write_text("numpy==2.0\n")
    ran = run_action(action, {"constraints": "team.txt"}, GITHUB, tmp_path, dict(os.environ))
    assert ran.code == 0 and _outputs(ran)["c"] == "team.txt"
    ran = _only("Check the inputs", {"constraints": "missing.txt"}, {}, tmp_path)
    assert ran.code == 2
    assert ran.stdout.strip() == "::error::kartci action: constraints: no file 'missing.txt'"


def test_plugin_packages_are_installed_after_kartci_as_data(tmp_path: Path) -> None:
    """A stand-in `python` records the installs: kartci, then the team's packages, both with
    the constraints; a value with shell syntax stays one argument."""
    fake = tmp_path / "bin"
    fake.mkdir()
    log = tmp_path / "python.log"
    (fake / "python").write_text(f'#!/usr/bin/env bash\nprintf "%s|" "$@" >> {log}\n'
                                 f'echo >> {log}\n')
    (fake / "python").chmod(0o755)
    env = {"PATH": os.pathsep.join([str(fake), os.environ["PATH"]])}
    step = _step("Install kartci")
    action = {**ACTION, "runs": {"steps": [{**step, "env": {
        **step["env"], "CONSTRAINTS": "pins.txt"}}]}}
    ran = run_action(action, {"plugin-packages": "-e ./metrics team-x==1.2 $(touch pwned)"},
                     GITHUB, tmp_path, {**os.environ, **env})
    assert ran.code == 0, ran.stdout
    assert log.read_text().splitlines() == [
        f"-m|pip|install|-q|-c|pins.txt|{ROOT}|",
        "-m|pip|install|-q|-c|pins.txt|-e|./metrics|team-x==1.2|$(touch|pwned)|"]
    assert not (tmp_path / "pwned").exists()
    log.unlink()
    ran = run_action(action, {}, GITHUB, tmp_path, {**os.environ, **env})
    assert ran.code == 0 and len(log.read_text().splitlines()) == 1  # no plugins: one install


def test_every_input_and_output_is_documented() -> None:
    """In action.yml (a description each) and in the GitHub Actions how-to (each by name)."""
    page = (ROOT / "docs" / "howto" / "github-actions.md").read_text()
    for kind in ("inputs", "outputs"):
        for name, spec in ACTION[kind].items():
            assert len(spec.get("description", "")) > 20, name
            assert f"`{name}`" in page, f"{kind[:-1]} {name} not in the how-to"
