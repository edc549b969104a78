"""What several test modules share: running the CLI as a user does, and short runs."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

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

