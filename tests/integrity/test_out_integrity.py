"""Issue 24, OUT's integrity: an interrupted command leaves no older result that passes for its
own (defect 5), and no command reads or writes through a symlink out of OUT (defect 6)."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from helpers import kartci

from kartci.errors import SpecError
from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.report import FILES, write_all
from kartci.runner import expand, run_jobs
from kartci.runner.outdir import clear_reports, write_manifest
from kartci.runner.run import check_finished
from kartci.verdict import Status

SCENARIOS = BUILTIN_SCENARIOS
QUICK_S = 1.0  # s of sim: the short runs q and q2
SLOW_S = 900.0  # s of sim: the run that is interrupted (it never gets near its end)


def _project(root: Path) -> Path:
    """A project with `slow` (a circle, long) and `q`, `q2` (the straight line, short)."""
    (root / "scenarios").mkdir(parents=True)
    (root / "kartci.toml").write_text("")
    for name, base, duration_s in (("slow", "line_circle", SLOW_S), ("q", "line_straight", QUICK_S),
                                   ("q2", "line_straight", QUICK_S + 0.5)):
        spec = yaml.safe_load((SCENARIOS / f"{base}.yaml").read_text())
        spec.update(duration_s=duration_s, criteria={})
        spec["metrics"]["line_tracking"]["transient_s"] = 0.5
        (root / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    return root


def _run_here(proj: Path, out: Path, baselines: Path, *names: str) -> None:
    """A complete run of `names` with its reports, as `kartci run` leaves it (in this process:
    no start-up cost)."""
    paths = [str(proj / "scenarios" / f"{n}.yaml") for n in names]
    results = run_jobs(expand(paths, [], active_project()), out, baselines, active_project())
    assert [r.status for r in results] == [Status.NEW] * len(names)
    write_manifest(out, "run", list(names))
    write_all(results, out)


def _sigint_as_a_terminal_has_it() -> None:
    """In the child before exec: Ctrl-C's default action. A test run started in the background
    of a shell script (`.ci/run &`) inherits SIGINT ignored, Python then keeps ignoring it, and
    the run this test interrupts would finish (exit 0), as a backgrounded kartci rightly does."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt_while(busy: Path, args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run the CLI in its own session and Ctrl-C it (SIGINT to its process group) as soon as a
    run is under way in the folder `busy` (its staging folder exists)."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("GITHUB_ACTIONS", "GITHUB_STEP_SUMMARY")}
    p = subprocess.Popen([sys.executable, "-m", "kartci.cli", *args], cwd=cwd, env=env,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True, preexec_fn=_sigint_as_a_terminal_has_it)
    try:
        deadline = time.monotonic() + 120  # only a guard against a hang, never asserted
        while not any(busy.glob(".new-*")):
            if p.poll() is not None or time.monotonic() > deadline:
                pytest.fail(f"no run started in {busy} (exit {p.poll()})")
            time.sleep(0.05)
        os.killpg(p.pid, signal.SIGINT)
        stdout, stderr = p.communicate(timeout=120)
    finally:
        if p.poll() is None:  # only if the test failed: it is ours
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    return subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr)


@pytest.mark.long(reason="several kartci runs end to end")
def test_an_interrupted_run_leaves_no_older_result_to_promote(tmp_path: Path,
                                                              baselines: Path) -> None:
    """Issue 24 defect 5: OUT holds an earlier run of q and q2; `kartci run slow q q2` is
    interrupted while `slow` runs; `kartci baseline update OUT q q2` must refuse both, and the
    earlier all-pass reports must not stand beside the interrupted run."""
    proj = _project(tmp_path / "proj")
    out = tmp_path / "out"
    _run_here(proj, out, baselines, "q", "q2")
    assert all((out / name).is_file() for name in FILES.values())

    stopped = _interrupt_while(out / "slow", ["run", "slow", "q", "q2", "--out", str(out),
                                              "--baselines", str(baselines)], proj)
    assert stopped.returncode == -signal.SIGINT, stopped.stderr  # a shell sees 130
    assert "Traceback" not in stopped.stdout + stopped.stderr
    assert stopped.stderr.splitlines()[-1] == "kartci: interrupted"  # typer would exit silently
    assert not [name for name in FILES.values() if (out / name).exists()]
    assert (out / "q" / "run.mcap").is_file()  # the older outputs stay, marked

    update = kartci("baseline", "update", out, "q", "q2", "--baselines", baselines,
                    "--replicas", "0", cwd=proj)
    assert update.returncode == 2
    assert update.stderr == (f"kartci: error: q, q2: not finished in {out} (the command that "
                             "selected them was interrupted); run them again\n")
    assert not list(baselines.iterdir())

    _run_here(proj, out, baselines, "q")  # only a completed run of a label clears its mark
    check_finished(out, ["q"])
    with pytest.raises(SpecError, match=r"^q2, slow: not finished in"):
        check_finished(out, ["q2", "slow"])


def test_every_report_file_the_writers_make_is_cleared(tmp_path: Path) -> None:
    """The names cleared at a command's start are the report writers' own (report-static.html
    was missing from a second hand-kept list)."""
    written = write_all([], tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in written.values())
    clear_reports(tmp_path)
    assert not list(tmp_path.iterdir())


@pytest.fixture
def one_run(tmp_path: Path, baselines: Path) -> Path:
    """OUT with one complete run of q."""
    out = tmp_path / "out"
    _run_here(_project(tmp_path / "proj"), out, baselines, "q")
    return out


def _tree(root: Path) -> dict[str, bytes | None]:
    """Every path under `root` with its bytes (None: a folder)."""
    return {str(p.relative_to(root)): p.read_bytes() if p.is_file() else None
            for p in sorted(root.rglob("*"))}


def _one_line(p: subprocess.CompletedProcess[str], where: Path) -> str:
    assert p.returncode == 2, p.stdout + p.stderr
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stdout, p.stdout + p.stderr
    assert str(where) in lines[0]
    return lines[0]


def test_report_does_not_write_through_a_symlinked_scenario_folder(
        one_run: Path, tmp_path: Path, baselines: Path) -> None:
    """Issue 24 defect 6: `kartci report OUT` with OUT/q a symlink to a folder outside OUT
    wrote that folder's metrics.json; now it refuses, and the folder stays byte-identical."""
    outside = tmp_path / "outside"
    outside.mkdir()
    shutil.move(one_run / "q", outside / "q")
    (outside / "q" / "metrics.json").write_text("{}")  # any rewrite of it would show
    (one_run / "q").symlink_to(outside / "q")
    before = _tree(outside)
    line = _one_line(kartci("report", one_run, "--baselines", baselines), one_run / "q")
    assert "a symlink" in line
    assert _tree(outside) == before


@pytest.mark.parametrize("command", ["run", "report", "baseline update", "compare", "merge"])
def test_no_command_follows_a_symlink_out_of_out(command: str, one_run: Path, tmp_path: Path,
                                                  baselines: Path) -> None:
    """A file in a scenario folder that is a symlink leading outside OUT is refused with one
    line by every command that uses the folder (each would read or replace through it);
    nothing outside OUT changes."""
    outside = tmp_path / "outside"
    outside.mkdir()
    os.replace(one_run / "q" / "run.mcap", outside / "run.mcap")
    (one_run / "q" / "run.mcap").symlink_to(outside / "run.mcap")
    before = _tree(outside)
    proj = tmp_path / "proj"
    shard = tmp_path / "shard"  # a clean copy of q to merge into OUT
    shutil.copytree(one_run / "q", shard / "q", symlinks=False)
    args: dict[str, list[str | Path]] = {
        "run": ["run", "q", "--out", one_run],
        "report": ["report", one_run],
        "baseline update": ["baseline", "update", one_run, "--replicas", "0"],
        "compare": ["compare", one_run, one_run, "--out", tmp_path / "cmp"],
        "merge": ["merge", shard, "--out", one_run]}
    line = _one_line(kartci(*args[command], "--baselines", baselines, cwd=proj),
                     one_run / "q" / "run.mcap")
    assert "a symlink leading outside" in line
    assert _tree(outside) == before


@pytest.mark.long(reason="several kartci runs end to end")
def test_score_does_not_write_through_a_symlinked_folder(one_run: Path, tmp_path: Path,
                                                          baselines: Path) -> None:
    """`kartci score LOG --out OUT` writes OUT/<profile>: a symlink there is refused, as for
    every command that writes label folders; the folder it points to stays as it was."""
    out = tmp_path / "scored"
    log = one_run / "q" / "run.mcap"
    p = kartci("score", log, "--out", out, "--baselines", baselines)
    assert p.returncode == 0, p.stdout + p.stderr
    (folder,) = [f for f in out.iterdir() if f.is_dir()]
    outside = tmp_path / "outside"
    os.replace(folder, outside)
    folder.symlink_to(outside, target_is_directory=True)
    before = _tree(outside)
    line = _one_line(kartci("score", log, "--out", out, "--baselines", baselines), folder)
    assert "a symlink" in line
    assert _tree(outside) == before
