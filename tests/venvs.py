"""kartci as a user gets it: its wheel, installed into a fresh virtual environment.

No network: the wheel is built from this checkout without build isolation (hatchling from the
test environment), and the fresh venv sees the test environment's packages
(numpy, pybullet, ...) through a `.pth` file instead of installing them again. kartci itself
comes from the wheel only: a `.pth` line adds a folder to sys.path but runs none of the `.pth`
files in it, so the test environment's editable kartci is never imported (and pip leaves
distributions outside the venv alone: "Not uninstalling ..., outside environment").
"""

from __future__ import annotations

import os
import shutil
import site
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
WHEEL = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["hatch"]["build"]["targets"][
    "wheel"]  # what the wheel is built from: kartci/ and the built-in folders (only-include)
# What must not leak from the test process into a user's shell.
SCRUBBED = ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "KARTCI_ROOT", "CI", "GITHUB_ACTIONS",
            "GITHUB_STEP_SUMMARY", "__PYVENV_LAUNCHER__")


def offline_env(bin_dir: Path | None = None) -> dict[str, str]:
    """The environment of a user's shell: this process's minus test and CI variables, pip
    kept off the network, `bin_dir` first on PATH."""
    env = {k: v for k, v in os.environ.items() if k not in SCRUBBED}
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PIP_NO_INPUT="1")
    if bin_dir is not None:
        env["PATH"] = os.pathsep.join([str(bin_dir), env.get("PATH", "")])
        env["VIRTUAL_ENV"] = str(bin_dir.parent)
    return env


def build_wheel(out: Path) -> Path:
    """kartci's wheel from a copy of this checkout (the source tree stays free of build/)."""
    try:
        metadata.version("hatchling")
    except metadata.PackageNotFoundError as err:
        pytest.skip(f'{err} not installed: pip install -e ".[dev]"')
    src = out / "src"
    src.mkdir(parents=True)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(ROOT / name, src / name)
    for name in WHEEL["only-include"]:
        shutil.copytree(ROOT / name, src / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    dist = out / "dist"
    p = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps",
                        "--no-build-isolation", "-w", str(dist), str(src)],
                       capture_output=True, text=True, env=offline_env(), timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    (wheel_file,) = dist.glob("kartci-*.whl")
    return wheel_file


def make_venv(where: Path, wheel: Path) -> Path:
    """A fresh venv with kartci installed from `wheel` (no dependencies, no index); returns
    its bin folder."""
    subprocess.run([sys.executable, "-m", "venv", str(where)], check=True, timeout=300,
                   env=offline_env())
    bin_dir = where / "bin"
    purelib = subprocess.run(
        [str(bin_dir / "python"), "-c",
         "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True, text=True, check=True, env=offline_env()).stdout.strip()
    shared = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (Path(purelib) / "_kartci_tests_shared_site.pth").write_text("\n".join(shared) + "\n")
    p = subprocess.run([str(bin_dir / "pip"), "install", "-q", "--no-deps", "--no-index",
                        str(wheel)], capture_output=True, text=True, env=offline_env(bin_dir),
                       timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    return bin_dir
