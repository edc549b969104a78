"""What several test modules share: running the CLI as a user does, and short runs."""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import stat
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from kartci.core import Direction
from kartci.verdict import MetricVerdict, Status
from kartci.verdict.result import ScenarioResult

ROOT = Path(__file__).resolve().parents[1]  # the checkout
# Two short line-tracker runs, for tests of running many scenarios rather than one
PAIR = ["line_straight", "line_circle"]
QUICK = ["--set", "duration_s=3", "--set", "criteria={}",
         "--set", "metrics.line_tracking.transient_s=1"]


def kartci(*args: str | Path, cwd: Path | None = None,
           env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    """Run the CLI in a fresh process, outside any GitHub job unless `env` says otherwise."""
    base = {k: v for k, v in os.environ.items()
            if k not in ("GITHUB_ACTIONS", "GITHUB_STEP_SUMMARY")}
    return subprocess.run([sys.executable, "-m", "kartci.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, timeout=300,
                          env={**base, **(env or {})})


BIN = Path(sys.executable).parent
# evo (GPL) is never a dependency of kartci: its command line is run from its own environment,
# named by KARTCI_EVO (its bin folder) or found at .venv-evo (made by .ci/run) or /tmp/venv-evo
EVO_DIRS = [Path(p) for p in (os.environ.get("KARTCI_EVO", ""),) if p] + [
    ROOT / ".venv-evo" / "bin", Path("/tmp/venv-evo/bin"), BIN]


def evo_exe(tool: str) -> str:
    """The path of evo's `tool` (evo_ape, evo_rpe), or the test skips saying how to get it."""
    for folder in EVO_DIRS:
        if (folder / tool).is_file():
            return str(folder / tool)
    found = shutil.which(tool)
    if found is None:
        pytest.skip(f"{tool} not found (KARTCI_EVO, .venv-evo, /tmp/venv-evo, PATH): "
                    "python3 -m venv .venv-evo && .venv-evo/bin/python -m pip install evo")
    return found


def evo(tmp: Path, tool: str, *args: str) -> dict[str, float]:
    """Run evo_ape / evo_rpe on tmp/ref.txt and tmp/est.txt; its saved statistics."""
    exe = evo_exe(tool)
    out = tmp / "res.zip"
    out.unlink(missing_ok=True)
    env = {**os.environ, "HOME": str(tmp), "MPLBACKEND": "Agg"}  # evo keeps settings in ~/.evo
    proc = subprocess.run([exe, "tum", "ref.txt", "est.txt", *args,
                           "--save_results", str(out), "--no_warnings"],
                          cwd=tmp, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    with zipfile.ZipFile(out) as z:
        stats: dict[str, float] = json.loads(z.read("stats.json"))
    return stats


@dataclass(frozen=True)
class KartLap:
    """One kart lap run through the CLI and `baseline update` (fixture `kart_lap`): the run
    folder, its baselines (with the reference trace), the update's output and the result judged
    again so that its report overlays the trace."""

    out: Path
    baselines: Path
    update: subprocess.CompletedProcess[str]
    result: ScenarioResult



# the synthetic "real" kart logs of tests/realdata (its conftest's `kart_logs`)
KART = "agents.kart0.model"
# the truth of the perturbed log, relative to the nominal model: gain +20 %, steering rate
# -15 %, speed scale (the motor controller's wheel radius) +4.7 %
TRUTH = {"speed_gain_per_s": 2.4, "steering_rate_radps": 3.4, "rear_wheel_radius_m": 0.133}
NOMINAL = {"speed_gain_per_s": 2.0, "steering_rate_radps": 4.0, "rear_wheel_radius_m": 0.127}
DURATION_S = 5.0


def changed(fraction: float) -> list[str]:
    """Overrides that move every TRUTH parameter `fraction` of the way from nominal."""
    return [f"{KART}.{k}={NOMINAL[k] + fraction * (TRUTH[k] - NOMINAL[k])}" for k in TRUTH]


# an emoji (pictographs, dingbats, arrows and shapes, the emoji presentation selector)
EMOJI = re.compile("[\U0001F000-\U0001FAFF\u2600-\u27BF\u2B00-\u2BFF\uFE0F]")


def glance_results() -> list[ScenarioResult]:
    """Thirteen scenarios, alphabetically the failures in the middle: eleven pass, one
    regressed, one errored."""
    def verdict(status: Status, value: float) -> MetricVerdict:
        return MetricVerdict("lap_time_s", value, "s", 12.0, 0.1, Direction.LOWER, status)

    results = [ScenarioResult(f"scenario_{i:02d}", "passes", [verdict(Status.PASS, 12.0)])
               for i in range(13)]
    results[6] = ScenarioResult("scenario_06", "slower", [verdict(Status.REGRESSED, 12.5)])
    results[9] = ScenarioResult("scenario_09", "crashed", error="run crashed: boom")
    return results


def bullet_gaps_m(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """PyBullet's closest distance between two default karts' collision shapes (chassis box,
    wheel spheres; 0 when they touch) with base_link at each pair of poses (x, y, yaw), m: an
    outline-free reference for the clearance metric."""
    from kartci._bullet import pb  # start-up cost: only the tests that need PyBullet load it
    from kartci.robots.gokart import GokartModel
    from kartci.sim.urdf import physics_urdf, urdf_path

    client = pb.connect(pb.DIRECT)
    try:
        path = str(physics_urdf(urdf_path(GokartModel())))
        bodies = [pb.loadURDF(path, physicsClientId=client) for _ in range(2)]
        com = pb.getDynamicsInfo(bodies[0], -1, physicsClientId=client)[3]  # in base_link
        out = []
        for pa, pb_pose in zip(a, b, strict=True):
            for body, (x, y, yaw) in zip(bodies, (pa, pb_pose), strict=True):
                c, s = np.cos(yaw), np.sin(yaw)
                pb.resetBasePositionAndOrientation(
                    body, (x + c * com[0] - s * com[1], y + s * com[0] + c * com[1], com[2]),
                    pb.getQuaternionFromEuler((0, 0, yaw)), physicsClientId=client)
            points = pb.getClosestPoints(*bodies, 10.0, physicsClientId=client)
            out.append(max(0.0, min((p[8] for p in points), default=10.0)))
        return np.array(out)
    finally:
        pb.disconnect(physicsClientId=client)


def kartci_shell_env(tmp_path: Path, *then: str) -> dict[str, str]:
    """The environment of a page's or tutorial's shell commands: a `kartci` command from this
    checkout first on PATH (a shim in tmp_path/bin), then the folders `then`, and nothing that
    points kartci elsewhere."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    shim = bin_dir / "kartci"
    shim.write_text(f'#!/bin/sh\nexec {shlex.quote(sys.executable)} -m kartci.cli "$@"\n',
                    encoding="utf-8")
    shim.chmod(shim.stat().st_mode | stat.S_IXUSR)
    drop = ("KARTCI_ROOT", "CI", "GITHUB_ACTIONS", "GITHUB_STEP_SUMMARY")
    env = {k: v for k, v in os.environ.items() if k not in drop}
    env["PATH"] = os.pathsep.join([str(bin_dir), *then, env.get("PATH", "")])
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(ROOT), env.get("PYTHONPATH")) if p)
    return env
