"""The gate holds: stale or failed results never pass as current, one writer per OUT, merge
artifacts are untrusted, reports survive any user text, strict baselines in CI, time limits."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import typer
import yaml
from helpers import kartci
from mcap.writer import Writer

from kartci import metrics
from kartci.cli.common import finish
from kartci.core import Outbox
from kartci.errors import BaselineError, RunError
from kartci.logs import McapLogWriter, messages, msg
from kartci.plotting import Plots
from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.report import write_all
from kartci.robots.line_tracker.line_pid import LinePid
from kartci.runner import expand, run_jobs
from kartci.verdict import Status, load
from kartci.verdict.result import ScenarioResult

QUICK = ["--set", "duration_s=2", "--set", "criteria={}",
         "--set", "metrics.line_tracking.transient_s=0.5"]
OVERRIDES = ["duration_s=2", "criteria={}", "metrics.line_tracking.transient_s=0.5"]


def _one_line(p: subprocess.CompletedProcess[str]) -> str:
    assert p.returncode == 2, p.stdout + p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1, p.stderr
    return lines[0]


def _run(out: Path, baselines: Path, *names: str, extra: tuple[str, ...] = (),
         env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return kartci("run", *names, *QUICK, *extra, "--out", out, "--baselines", baselines,
                  env=env)


# 1. Stale results never become baselines ------------------------------------------------------

def test_a_scoring_failure_marks_the_folder_and_keeps_the_good_log(
        tmp_path: Path, baselines: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    jobs = expand(["line_straight"], OVERRIDES, active_project())
    assert run_jobs(jobs, tmp_path, baselines, active_project())[0].status is Status.NEW
    folder = tmp_path / "line_straight"
    good = (folder / "run.mcap").read_bytes()

    def broken(path: Path) -> object:
        raise KeyError("cross_track")  # a scoring bug after a complete simulation

    monkeypatch.setattr(metrics, "compute", broken)
    slower = expand(["line_straight"], [*OVERRIDES, "agents.lt0.controller.kp=20"],
                    active_project())
    result = run_jobs(slower, tmp_path, baselines, active_project())[0]
    assert result.status is Status.ERROR
    assert (folder / "error.json").exists()
    assert (folder / "run.mcap").read_bytes() == good  # not replaced by the unscored run
    assert not list(folder.glob(".new-*"))
    p = kartci("baseline", "update", tmp_path, "line_straight", "--baselines", baselines)
    assert "last run of this scenario failed" in _one_line(p)
    assert not (baselines / "line_straight.json").exists()


def test_a_crashed_controller_leaves_its_traceback_beside_a_one_line_error(
        tmp_path: Path, baselines: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def step(self: LinePid, t_ns: int) -> Outbox:
        raise ZeroDivisionError("controller bug\nsecond line")

    monkeypatch.setattr(LinePid, "step", step)
    result = run_jobs(expand(["line_straight"], OVERRIDES,
                             active_project()), tmp_path, baselines, active_project())[0]
    assert result.error is not None and "\n" not in result.error
    assert "ZeroDivisionError: controller bug" in result.error
    trace = (tmp_path / "line_straight" / "traceback.txt").read_text()
    assert trace.startswith("Traceback") and "in step" in trace


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_damaged_or_deleted_log_is_an_error_of_report_and_is_marked(
        tmp_path: Path, baselines: Path) -> None:
    out = tmp_path / "out"
    assert _run(out, baselines, "line_straight", "line_circle").returncode == 0
    (out / "line_straight" / "run.mcap").write_bytes(b"\x89MCAP0\r\n not a log")
    (out / "line_circle" / "run.mcap").unlink()
    p = kartci("report", out, "--baselines", baselines)
    assert p.returncode == 2, p.stdout + p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert summary["line_straight"]["status"] == "error"
    assert "missing" in summary["line_circle"]["error"]  # not silently dropped
    for name in ("line_straight", "line_circle"):
        assert (out / name / "error.json").exists()
        p = kartci("baseline", "update", out, name, "--baselines", baselines)
        assert "last run of this scenario failed" in _one_line(p)


@pytest.mark.long(reason="several kartci runs end to end")
def test_baseline_update_takes_only_the_last_run_of_a_reused_out(tmp_path: Path,
                                                                  baselines: Path) -> None:
    out = tmp_path / "out"
    assert _run(out, baselines, "line_straight").returncode == 0
    assert _run(out, baselines, "line_circle").returncode == 0
    p = kartci("baseline", "update", out, "--baselines", baselines)
    assert p.returncode == 0, p.stderr
    assert sorted(x.name for x in baselines.glob("*.json")) == ["line_circle.json"]
    assert sorted(x.name for x in (baselines / "traces").iterdir()) == ["line_circle.json"]


@pytest.mark.long(reason="kartci runs end to end")
def test_a_dangling_baseline_symlink_is_an_error_not_a_pass(tmp_path: Path,
                                                            baselines: Path) -> None:
    link = baselines / "line_straight.json"
    link.symlink_to(tmp_path / "gone.json")
    with pytest.raises(BaselineError, match="symlink"):
        load(link)
    p = _run(tmp_path / "out", baselines, "line_straight")
    assert p.returncode == 2, p.stdout
    assert "symlink" in json.loads((tmp_path / "out" / "summary.json").read_text())[
        "scenarios"]["line_straight"]["error"]


@pytest.mark.long(reason="several kartci runs end to end")
def test_baseline_update_prints_values_that_show_the_change(tmp_path: Path,
                                                            baselines: Path) -> None:
    out = tmp_path / "out"
    assert _run(out, baselines, "line_straight").returncode == 0
    assert kartci("baseline", "update", out, "--baselines", baselines).returncode == 0
    path = baselines / "line_straight.json"
    doc = json.loads(path.read_text())
    value = doc["metrics"]["cross_track_rms_m"]["value"]
    doc["metrics"]["cross_track_rms_m"]["value"] = value * (1 + 1e-7)
    path.write_text(json.dumps(doc))
    p = kartci("baseline", "update", out, "--baselines", baselines)
    assert p.returncode == 0, p.stderr
    assert f"cross_track_rms_m: {value * (1 + 1e-7)!r} -> {value!r}" in p.stdout


DOOMED_PLUGIN = '''
import multiprocessing, os, signal
from kartci.robots.line_tracker.line_pid import LinePid

_real = LinePid.step


def step(self, t_ns):
    if self.spec.kp == 77.0 and multiprocessing.parent_process() is not None and t_ns > 5e8:
        os.kill(os.getpid(), signal.SIGKILL)  # a segfault in native code, as far as we know
    return _real(self, t_ns)


LinePid.step = step
'''


def _doomed_project(root: Path) -> Path:
    """A project whose plugin kills the worker process running `doomed` (kp 77)."""
    (root / "scenarios").mkdir(parents=True)
    (root / "kartci.toml").write_text('scenarios = ["scenarios"]\nplugins = ["doomed_plugin"]\n')
    (root / "doomed_plugin.py").write_text(DOOMED_PLUGIN)
    for name, src, changes in (("long", "line_circle", {"duration_s": 3.0}),
                               ("doomed", "line_straight", {"duration_s": 2.0})):
        spec = yaml.safe_load((BUILTIN_SCENARIOS / f"{src}.yaml").read_text())
        spec.update(changes, criteria={})
        spec["metrics"]["line_tracking"]["transient_s"] = 0.5
        if name == "doomed":
            spec["agents"]["lt0"]["controller"]["kp"] = 77.0
        (root / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    (root / "baselines").mkdir()
    return root


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_dead_worker_marks_its_folder(tmp_path: Path) -> None:
    root = _doomed_project(tmp_path / "proj")
    out = root / "out"
    first = kartci("run", "long", "doomed", "--out", out, cwd=root)  # all in this process
    assert first.returncode == 0, first.stdout + first.stderr
    good = (out / "doomed" / "run.mcap").read_bytes()
    p = kartci("run", "long", "doomed", "-j", "2", "--out", out, cwd=root)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "worker process failed" in json.loads((out / "doomed" / "error.json").read_text())[
        "error"]
    assert (out / "doomed" / "run.mcap").read_bytes() == good
    assert not list((out / "doomed").glob(".new-*"))  # the dead worker's half run is gone
    p = kartci("baseline", "update", out, "doomed", cwd=root)
    assert "last run of this scenario failed" in _one_line(p)


# 2. Reports render any user text --------------------------------------------------------------

def _plots(agent: str) -> Plots:
    t = np.linspace(0.0, 1.0, 20)
    track = pd.DataFrame({"t": t, "x": t, "y": 0 * t, "offset": 0 * t, "speed": 0 * t + 1})
    wheels = pd.DataFrame({"t": t, "left": t, "right": t})
    return Plots("line", np.column_stack([t, 0 * t]), [], {agent: track}, {agent: wheels},
                 {agent: wheels}, {}, 0.2)


def test_user_text_with_mathtext_and_rich_markup_is_reported_as_written(tmp_path: Path) -> None:
    weird = "a$\\foo{$b [/oops] [bold]"
    results = [ScenarioResult("one", weird, plots=_plots(weird)),
               ScenarioResult("two", weird, error=f"controller said {weird}\x00")]
    with pytest.raises(typer.Exit) as exit_info:
        finish(results, tmp_path, ci=False)
    assert exit_info.value.exit_code == 2  # the error scenario, not a crash
    assert "[/oops]" in (tmp_path / "report.html").read_text()
    junit = (tmp_path / "junit.xml").read_text()
    assert "\x00" not in junit and "[/oops]" in junit


def test_a_report_that_cannot_be_written_is_exit_2_and_leaves_no_old_report(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ok = [ScenarioResult("one", "")]
    write_all(ok, tmp_path)  # an earlier all-pass report

    def boom(*args: object) -> str:
        raise ValueError("cannot draw")

    monkeypatch.setattr("kartci.report.html.report_html", boom)
    with pytest.raises(RunError, match="writing the reports"):
        finish(ok, tmp_path, ci=False)
    for name in ("report.html", "report-static.html", "summary.md", "summary.json",
                 "junit.xml"):
        assert not (tmp_path / name).exists()


# 3. Gate holes and strict baselines -----------------------------------------------------------

@pytest.fixture(scope="module")
def one_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("one_run")
    (root / "empty_baselines").mkdir()
    p = _run(root / "out", root / "empty_baselines", "line_straight")
    assert p.returncode == 0, p.stderr
    return root


@pytest.mark.long(reason="several kartci runs end to end")
def test_compare_with_an_empty_or_unscored_base_is_bad_input(one_run: Path,
                                                             tmp_path: Path) -> None:
    (tmp_path / "empty").mkdir()
    line = _one_line(kartci("compare", tmp_path / "empty", one_run / "out",
                            "--out", tmp_path / "c1"))
    assert "base" in line and "no scored scenario" in line
    unscored = tmp_path / "unscored" / "line_straight"
    unscored.mkdir(parents=True)
    (unscored / "run.mcap").write_bytes((one_run / "out" / "line_straight" / "run.mcap")
                                        .read_bytes())
    line = _one_line(kartci("compare", tmp_path / "unscored", one_run / "out",
                            "--out", tmp_path / "c2"))
    assert "kartci report" in line


@pytest.mark.long(reason="several kartci runs end to end")
def test_strict_fails_a_missing_baseline_and_says_how_to_accept_it(one_run: Path,
                                                                   tmp_path: Path) -> None:
    out = one_run / "out"
    bl = tmp_path / "bl"
    bl.mkdir()
    p = kartci("report", out, "--baselines", bl, env={"CI": "true"})  # strict by default in CI
    assert p.returncode == 1, p.stdout + p.stderr
    assert f"kartci baseline update {out} line_straight" in p.stdout
    assert kartci("report", out, "--baselines", bl, "--no-strict",
                  env={"CI": "true"}).returncode == 0
    assert kartci("baseline", "update", out, "--baselines", bl).returncode == 0
    doc = json.loads((bl / "line_straight.json").read_text())
    del doc["metrics"]["completion"]
    (bl / "line_straight.json").write_text(json.dumps(doc))
    p = kartci("report", out, "--baselines", bl, "--strict")
    assert p.returncode == 1, p.stdout + p.stderr
    problems = json.loads((out / "summary.json").read_text())["scenarios"]["line_straight"][
        "problems"]
    assert "not in the baseline (strict mode): completion" in problems[0]
    assert kartci("report", out, "--baselines", bl).returncode == 0  # not strict outside CI


# 4. One writer per OUT ------------------------------------------------------------------------

def test_a_second_writer_of_one_out_gets_one_line(tmp_path: Path, baselines: Path) -> None:
    tmp_path.joinpath(".kartci.lock").touch()
    with tmp_path.joinpath(".kartci.lock").open("r+") as f:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        line = _one_line(_run(tmp_path, baselines, "line_straight"))
    assert "in use by another kartci command" in line
    assert not (tmp_path / "line_straight").exists()


def test_two_log_writers_of_one_path_do_not_share_a_partial_file(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    a, b = McapLogWriter(path), McapLogWriter(path)
    for w, text in ((a, "a"), (b, "b")):
        for k in range(50):
            w.write("/x", msg("std_msgs/msg/String", data=text * 100), k)
    a.close()
    b.close()
    assert next(messages(path))[2].data == "b" * 100
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]


def test_a_full_disk_leaves_no_partial_files_and_the_others_still_run(
        tmp_path: Path, baselines: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The disk fills while line_straight's log is written: every write to it fails, the final
    flush included."""
    real_init, real_add, real_finish = McapLogWriter.__init__, Writer.add_message, Writer.finish
    on_full_disk: set[int] = set()

    def init(self: McapLogWriter, path: Path) -> None:
        real_init(self, path)
        if "line_straight" in str(path):
            on_full_disk.add(id(self._writer))

    def full(self: Writer) -> bool:
        return id(self) in on_full_disk

    def add_message(self: Writer, *args: object, **kw: object) -> None:
        if full(self):
            raise OSError(errno.ENOSPC, "No space left on device")
        real_add(self, *args, **kw)  # type: ignore[arg-type]

    def finish_(self: Writer) -> None:
        if full(self):
            raise OSError(errno.ENOSPC, "No space left on device")
        real_finish(self)  # type: ignore[no-untyped-call]

    monkeypatch.setattr(McapLogWriter, "__init__", init)
    monkeypatch.setattr(Writer, "add_message", add_message)
    monkeypatch.setattr(Writer, "finish", finish_)
    results = {r.name: r for r in run_jobs(expand(["line_straight", "line_circle"], OVERRIDES,
                                                  active_project()),
                                           tmp_path, baselines, active_project())}
    assert "No space left" in (results["line_straight"].error or "")
    assert results["line_circle"].status is Status.NEW
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".partial")
                or p.name.startswith(".new-")]
    assert (tmp_path / "line_straight" / "error.json").exists()


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.long(reason="kartci runs end to end")
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_workers_die_with_their_parent(tmp_path: Path, baselines: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != "CI"}
    out = tmp_path / "out"
    parent = subprocess.Popen(
        [sys.executable, "-m", "kartci.cli", "run", "line_circle", "--sweep", "seed=1,2",
         "--set", "duration_s=900", "--set", "criteria={}", "-j", "2", "--out", str(out),
         "--baselines", str(baselines)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, start_new_session=True)
    workers: list[int] = []
    try:
        deadline = time.monotonic() + 90
        while time.monotonic() < deadline:  # until the worker has its run under way
            if (out / "line_circle@seed=2").is_dir() and (out / "line_circle@seed=1").is_dir():
                break
            time.sleep(0.2)
        else:
            pytest.fail("the runs did not start")
        time.sleep(2.0)
        workers = _children(parent.pid)
        assert workers
        parent.send_signal(signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 15  # a 900 s run would go on for minutes
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.2)
        alive = [w for w in workers if _alive(w)]
        assert not alive
    finally:
        parent.kill()
        parent.wait()
        for w in workers:  # only if the test failed: they are ours
            with contextlib.suppress(OSError):
                os.kill(w, signal.SIGKILL)


# 5. Merge treats shard artifacts as untrusted -------------------------------------------------

def test_merge_refuses_a_label_that_leaves_out(tmp_path: Path, baselines: Path) -> None:
    out = tmp_path / "a" / "out"
    precious = tmp_path / "a" / "victim"
    precious.mkdir(parents=True)
    (precious / "keep.txt").write_text("mine")
    shard = tmp_path / "s1"
    (tmp_path / "victim").mkdir()
    (tmp_path / "victim" / "metrics.json").write_text("{}")
    shard.mkdir()
    (shard / "shard.json").write_text(json.dumps({"index": 1, "total": 1,
                                                  "scenarios": ["../victim"]}))
    line = _one_line(kartci("merge", shard, "--out", out, "--baselines", baselines))
    assert "shard.json" in line
    assert (precious / "keep.txt").read_text() == "mine"
    assert not (tmp_path / "a" / "victim" / "metrics.json").exists()


def test_merge_errors_do_not_echo_file_contents(tmp_path: Path, baselines: Path) -> None:
    shard = tmp_path / "s1"
    shard.mkdir()
    (shard / "shard.json").write_text(json.dumps({"index": "SECRET-TOKEN", "total": 1,
                                                  "scenarios": []}))
    line = _one_line(kartci("merge", shard, "--out", tmp_path / "out",
                            "--baselines", baselines))
    assert "SECRET" not in line and "malformed shard marker" in line


# 6. Time limits hold inside a slow controller step --------------------------------------------

def test_a_time_limit_names_the_sim_time_it_stopped_at(
        tmp_path: Path, baselines: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The limit's alarm, raised inside the controller step after 0.2 s of sim time (no wall
    clock involved), names the sim time reached there, not the last progress report's (0.0 s)."""
    real = LinePid.step

    def step(self: LinePid, t_ns: int) -> Outbox:
        if t_ns > 200_000_000:
            signal.raise_signal(signal.SIGALRM)  # as if the wall-clock limit expired here
        return real(self, t_ns)

    monkeypatch.setattr(LinePid, "step", step)
    result = run_jobs(expand(["line_straight"], OVERRIDES,
                             active_project()), tmp_path, baselines, active_project(),
                      timeout_s=600.0)[0]
    # line_pid steps every 0.06 s: at 0.24 s, one physics step (2 ms) after the 0.238 s reached
    assert result.error == "time limit: over 600 s wall clock (at sim time 0.238 s)"


def test_a_sleeping_controller_step_is_stopped_by_the_time_limit(
        tmp_path: Path, baselines: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    real = LinePid.step
    hung: list[int] = []

    def step(self: LinePid, t_ns: int) -> Outbox:
        if t_ns > 200_000_000 and not hung:
            hung.append(t_ns)
            time.sleep(120)  # one step that hangs
        return real(self, t_ns)

    monkeypatch.setattr(LinePid, "step", step)
    start = time.monotonic()
    result = run_jobs(expand(["line_straight"], OVERRIDES,
                             active_project()), tmp_path, baselines, active_project(),
                      timeout_s=1.0)[0]
    assert result.status is Status.ERROR
    assert "time limit: over 1 s wall clock" in (result.error or "")
    assert time.monotonic() - start < 60  # well before the sleep would have ended
    assert (tmp_path / "line_straight" / "error.json").exists()


def test_a_strict_run_ended_by_system_exit_0_is_an_error_not_a_green_exit() -> None:
    """Whatever cuts a strict (CI) run short with a green code, a plugin's `sys.exit()` among
    them, it never passes having judged fewer scenarios than it selected."""
    from kartci.runner.gate import judging_all

    with pytest.raises(RunError, match=r"SystemExit\(0\) inside it.* never passes"), \
            judging_all(["line_straight", "line_circle"], strict=True):
        sys.exit(0)
    with pytest.raises(SystemExit), judging_all(["line_straight"], strict=False):
        sys.exit(0)  # outside strict mode: unchanged


def test_a_strict_run_that_judged_fewer_scenarios_than_selected_fails_each_missing_one() -> None:
    from kartci.runner.gate import NOT_JUDGED, judging_all
    from kartci.verdict.result import ScenarioResult, exit_code

    judged = [ScenarioResult("line_straight", "")]
    with judging_all(["line_straight", "line_circle"], strict=True) as complete:
        results = complete(judged)
    assert [(r.name, r.error) for r in results] == [("line_straight", None),
                                                    ("line_circle", NOT_JUDGED)]
    assert exit_code(results) == 2
    with judging_all(["line_straight", "line_circle"], strict=False) as complete:
        assert complete(judged) == judged


QUITTER = """
import sys
from kartci.core import Controller, register
from kartci.scenario.models import ControllerParams
from typing import Literal


class Params(ControllerParams):
    type: Literal["quitter"] = "quitter"


def build(params, ctx):
    sys.exit(0)


register(Controller("quitter", Params, build, ("line_tracker",)))
"""


def test_a_controller_that_calls_sys_exit_fails_its_own_run_not_the_whole_command(
        tmp_path: Path) -> None:
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('plugins = ["quitter"]\n')
    (proj / "quitter.py").write_text(QUITTER)
    spec = yaml.safe_load((BUILTIN_SCENARIOS / "line_straight.yaml").read_text())
    spec["agents"]["lt0"]["controller"] = {"type": "quitter"}
    (proj / "scenarios" / "quits.yaml").write_text(yaml.safe_dump(spec))
    out = tmp_path / "out"
    p = kartci("run", "quits", "--out", out, cwd=proj)
    assert p.returncode == 2, p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert summary["quits"] == {**summary["quits"], "status": "error",
                                "error": "run crashed: SystemExit: 0"}
