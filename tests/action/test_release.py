"""The release: .github/workflows/release.yml and .ci/run run the same check
(tools/check_release.sh, measured at about 3-4 min: it builds, installs into an empty venv and
runs a scenario, so it runs there, not here); the publish job takes the files the check
uploaded; a tag publishes only the version it names."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest
import yaml

from kartci import __version__

ROOT = Path(__file__).resolve().parents[2]
RELEASE: dict[str, Any] = yaml.safe_load((ROOT / ".github" / "workflows" / "release.yml")
                                         .read_text())
SCRIPT = "tools/check_release.sh"


def test_ci_and_the_release_workflow_run_the_same_check() -> None:
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert any(line.startswith(f"PYTHON=.venv/bin/python {SCRIPT} ") for line in ci)
    steps = RELEASE["jobs"]["check"]["steps"]
    runs = [s["run"] for s in steps if "run" in s]
    assert runs[:2] == ["python -m pip install -q -c constraints.txt build twine",
                        f"PYTHON=python {SCRIPT} dist"]
    (up,) = [s for s in steps if "upload-artifact" in s.get("uses", "")]
    (down,) = [s for s in RELEASE["jobs"]["publish"]["steps"]
               if "download-artifact" in s.get("uses", "")]
    assert up["with"]["name"] == down["with"]["name"] and up["with"]["path"] == "dist/"
    assert RELEASE["jobs"]["publish"]["needs"] == "check"
    assert RELEASE["jobs"]["publish"]["environment"]["name"] == "pypi"
    dev = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["dev"]
    assert {"build", "twine"} <= {d.split(">")[0] for d in dev}


@pytest.mark.parametrize(("tag", "ok"), [(f"v{__version__}", True), ("v9.9.9", False)])
def test_a_tag_publishes_only_the_version_it_names(tag: str, ok: bool, tmp_path: Path) -> None:
    (step,) = [s for s in RELEASE["jobs"]["check"]["steps"]
               if s.get("name") == "The tag names the built version"]
    (tmp_path / "dist").mkdir()
    for name in (f"kartci-{__version__}-py3-none-any.whl", f"kartci-{__version__}.tar.gz"):
        (tmp_path / "dist" / name).touch()
    p = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", step["run"]], cwd=tmp_path,
                       env={**os.environ, "TAG": tag}, timeout=60)
    assert (p.returncode == 0) is ok


def test_the_check_script_passes_shellcheck() -> None:
    exe = shutil.which("shellcheck", path=os.pathsep.join([str(Path(sys.executable).parent),
                                                           os.environ.get("PATH", "")]))
    if exe is None:
        pytest.skip('shellcheck not installed: pip install -e ".[dev]"')
    p = subprocess.run([exe, str(ROOT / SCRIPT), str(ROOT / ".ci" / "run")],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stdout
