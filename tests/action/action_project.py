"""The project the action runs in, for its tests (test_action, test_release)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import yaml
from helpers import PAIR

ROOT = Path(__file__).resolve().parents[2]


def make_project(proj: Path) -> Path:
    """In `proj`: a project with the two 3 s line scenarios and baselines accepted from a
    first run."""
    (proj / "scenarios").mkdir()
    (proj / "baselines").mkdir()
    for name in PAIR:
        spec = yaml.safe_load((ROOT / "scenarios" / f"{name}.yaml").read_text())
        spec.update(duration_s=3.0, criteria={}, metrics={"line_tracking": {"transient_s": 1.0}})
        (proj / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    local = {**os.environ, "KARTCI_ROOT": str(proj)}
    first = proj / "first"
    for cmd in (["run", "--no-strict", "--out", str(first)],
                ["baseline", "update", "--replicas", "0", str(first)]):
        p = subprocess.run([sys.executable, "-m", "kartci.cli", *cmd], env=local,
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stdout[-2000:] + p.stderr[-2000:]
    return proj
