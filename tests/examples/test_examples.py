"""examples/ run as a user would run them: the example package installed into a fresh virtual
environment next to kartci's wheel, then driven through the CLI, `-j 2`, Ray and pytest, with
no change to kartci."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest
from venvs import ROOT, offline_env

EXAMPLE = ROOT / "examples" / "pure_pursuit"


def _metrics(out: Path) -> bytes:
    return (out / "pure_pursuit_lap" / "metrics.json").read_bytes()


@pytest.mark.long(reason="a fresh venv from the wheel")
def test_the_pure_pursuit_package_runs_everywhere(tmp_path: Path, fresh_venv: Path) -> None:
    work = tmp_path / "pure_pursuit"
    shutil.copytree(EXAMPLE, work, ignore=shutil.ignore_patterns("reports", "build",
                                                                 "*.egg-info"))
    env = offline_env(fresh_venv)

    def sh(*args: str, timeout: float = 600) -> subprocess.CompletedProcess[str]:
        return subprocess.run(list(args), cwd=work, env=env, capture_output=True, text=True,
                              timeout=timeout)

    p = sh(str(fresh_venv / "pip"), "install", "-q", "--no-deps", "--no-index",
           "--no-build-isolation", ".")
    assert p.returncode == 0, p.stdout + p.stderr
    p = sh(str(fresh_venv / "kartci"), "plugins")
    assert p.returncode == 0 and "pure_pursuit" in p.stdout and "cornering" in p.stdout

    # the CLI, judged against the example's own committed baseline, strictly
    p = sh(str(fresh_venv / "kartci"), "run", "--strict", "--out", "reports/serial")
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-2000:]
    summary = json.loads((work / "reports/serial/summary.json").read_text())["scenarios"]
    metrics = summary["pure_pursuit_lap"]["metrics"]
    assert metrics["laps_completed"]["value"] >= 2
    assert metrics["lateral_accel_max_mps2"]["status"] == "pass"  # the team's own metric

    # a process pool and Ray: the same bytes
    p = sh(str(fresh_venv / "kartci"), "run", "-j", "2", "--out", "reports/pool")
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-2000:]
    assert _metrics(work / "reports/pool") == _metrics(work / "reports/serial")
    pytest.importorskip("ray")
    p = sh(str(fresh_venv / "kartci"), "run", "--executor", "ray", "-j", "2", "--out",
           "reports/ray")
    assert p.returncode == 0, p.stdout[-3000:] + p.stderr[-2000:]
    assert _metrics(work / "reports/ray") == _metrics(work / "reports/serial")

    # kartci's pytest plugin collects the scenario file as a test item
    p = sh(str(fresh_venv / "python"), "-m", "pytest", "-q", "-p", "no:cacheprovider",
           "scenarios/")
    assert p.returncode == 0 and "1 passed" in p.stdout, p.stdout[-3000:] + p.stderr[-2000:]

    # the example's own tests: its plugins pass kartci.testing.check_kind
    p = sh(str(fresh_venv / "python"), "-m", "pytest", "-q", "-p", "no:cacheprovider",
           "tests/")
    assert p.returncode == 0 and "1 passed" in p.stdout, p.stdout[-3000:] + p.stderr[-2000:]
