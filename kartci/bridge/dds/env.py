"""The ROS 2 Python the DDS bridge runs under: the team's own (`$KARTCI_ROS2_PYTHON`) or a venv
kartci makes from the `ros-rclpy` wheels (ROS 2 Kilted, cp311 manylinux, a community build).

Never kartci's own environment: the wheels install a `.pth` file that re-executes every Python
interpreter of their environment (to set LD_LIBRARY_PATH), so they live in a venv of their own.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

from kartci.cachedir import cache_dir
from kartci.errors import RunError, SpecError

PYTHON_ENV = "KARTCI_ROS2_PYTHON"  # a team's ROS 2 Python (its rclpy, its messages)
DISTRO = "kilted"
# rclpy with Fast DDS and the message packages the bridge and the example node use; pinned so
# that every venv made from them has the same definitions (their RIHS01 hashes are tested)
REQUIREMENTS = ("ros-rclpy[fastrtps]==9.1.2", "ros-std-msgs==5.5.1", "ros-sensor-msgs==5.5.1",
                "ros-nav-msgs==5.5.1", "ros-geometry-msgs==5.5.1", "ros-rosgraph-msgs==2.3.0")
PROFILE = "fastdds_shm_only.xml"  # shipped beside this module
PROBE = "import rclpy, rmw_fastrtps_cpp, nav_msgs.msg, geometry_msgs.msg, rosgraph_msgs.msg"


def default_path() -> Path:
    """Where `kartci ros2 env` makes the venv unless told otherwise."""
    return cache_dir() / f"ros2-{DISTRO}"


def venv_python(path: Path) -> Path:
    """The interpreter of the venv at `path`."""
    return path / "bin" / "python"


def find_python() -> Path | None:
    """$KARTCI_ROS2_PYTHON (it must exist), else the default venv's Python if made, else None."""
    named = os.environ.get(PYTHON_ENV)
    if named:
        path = Path(named)
        if not path.exists():
            raise SpecError(f"{PYTHON_ENV}={named}: no such file")
        return path
    python = venv_python(default_path())
    return python if python.exists() else None


def require_python() -> Path:
    """The ROS 2 Python, or an error saying how to get one."""
    python = find_python()
    if python is None:
        raise SpecError(f"middleware dds needs a ROS 2 Python with rclpy: run `kartci ros2 env` "
                        f"(a venv in {default_path()}) or set {PYTHON_ENV}")
    return python


def probe(python: Path, timeout_s: float = 60.0) -> str | None:
    """None when `python` imports rclpy, Fast DDS's RMW and the bridge's messages, else why not
    (its last line of stderr)."""
    try:
        done = subprocess.run([str(python), "-c", PROBE], capture_output=True, text=True,
                              timeout=timeout_s, check=False)
    except (OSError, subprocess.TimeoutExpired) as err:
        return f"{python}: {err}"
    if done.returncode == 0:
        return None
    lines = done.stderr.strip().splitlines()
    return f"{python}: {lines[-1] if lines else f'exit code {done.returncode}'}"


def base_python() -> str:
    """A Python 3.11 to make the venv with (the wheels are cp311 only)."""
    if sys.version_info[:2] == (3, 11):
        return sys.executable
    found = shutil.which("python3.11")
    if found is None:
        raise SpecError("the ros-rclpy wheels are built for CPython 3.11 only and no "
                        "python3.11 is on PATH; install one or set "
                        f"{PYTHON_ENV} to a ROS 2 installation's Python")
    return found


def make(path: Path) -> Path:
    """A venv at `path` with `REQUIREMENTS` (pip, from the configured index); its Python. One
    process at a time per path (test workers may ask at once): the others wait, then find it."""
    python = venv_python(path)
    path.mkdir(parents=True, exist_ok=True)
    with (path / ".kartci-make.lock").open("a") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not python.exists():
            _run([base_python(), "-m", "venv", str(path)], "make the venv")
        _run([str(python), "-m", "pip", "install", "--quiet", *REQUIREMENTS],
             "install the wheels")  # a few seconds when all are there at their pins
    why = probe(python)
    if why is not None:
        raise RunError(f"the ROS 2 venv at {path} does not import rclpy: {why}")
    return python


def _run(argv: list[str], what: str) -> None:
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        lines = (done.stderr or done.stdout).strip().splitlines()
        raise RunError(f"cannot {what} ({' '.join(argv[:3])} ...): "
                       f"{lines[-1] if lines else f'exit code {done.returncode}'}")


def profile_path() -> Path:
    """kartci's copy of the shared-memory-only Fast DDS profile (shipped in the package)."""
    return Path(str(resources.files("kartci.bridge.dds").joinpath(PROFILE)))


def dds_env(domain_id: int, namespace: str) -> dict[str, str]:
    """What every DDS process of the run is told, before rclpy starts: Fast DDS (3.x and 2.x
    variable names) with kartci's SHM-only profile, the run's domain, the agent's namespace."""
    profile = str(profile_path())
    return {"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
            "FASTDDS_DEFAULT_PROFILES_FILE": profile, "FASTRTPS_DEFAULT_PROFILES_FILE": profile,
            "ROS_DOMAIN_ID": str(domain_id), "KARTCI_NAMESPACE": namespace,
            # the wheels' .pth re-executes Python once to set LD_LIBRARY_PATH; a marker
            # inherited from a ROS 2 process that started kartci would skip that
            "_ROS_WHEELS_BOOTSTRAP_COMPLETE": ""}
