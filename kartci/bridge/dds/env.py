"""The ROS 2 Python the DDS bridge runs under: the team's own (`$KARTCI_ROS2_PYTHON`) or a venv
kartci makes from the `ros-rclpy` wheels (ROS 2 Kilted, cp311 manylinux, a community build).

Never kartci's own environment: the wheels install a `.pth` file that re-executes every Python
interpreter of their environment (to set LD_LIBRARY_PATH), so they live in a venv of their own.

The profile's variable depends on Fast DDS's major version, probed once per Python: Fast DDS 3
(Kilted and later) reads FASTDDS_DEFAULT_PROFILES_FILE, and its RMW warns on every start that
FASTRTPS_DEFAULT_PROFILES_FILE is deprecated when that one is set (the warning then was the last
line of every DDS error); Fast DDS 2.x (Humble, Jazzy) reads only FASTRTPS_DEFAULT_PROFILES_FILE
and, without a profile, would use its default UDP transport with multicast discovery. So the
variable the installed Fast DDS reads gets the profile and the other one is set empty (an
inherited value would be read, or warned about); when the version cannot be told, both get it.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import subprocess
import sys
from functools import cache
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
PROFILE_VARIABLES = {3: "FASTDDS_DEFAULT_PROFILES_FILE", 2: "FASTRTPS_DEFAULT_PROFILES_FILE"}
# loads Fast DDS's RMW (and so Fast DDS) without starting a participant, then names the
# Fast DDS library the process mapped: libfastdds.so.<major>.<minor> (3.x), libfastrtps (2.x)
VERSION_PROBE = ("import ctypes, os\nctypes.CDLL('librmw_fastrtps_cpp.so')\n"
                 "print(*sorted({os.path.basename(os.path.realpath(line.split()[-1])) for line "
                 "in open('/proc/self/maps') if '/libfastdds.so' in line or '/libfastrtps.so' "
                 "in line}))")
_LIBRARY = re.compile(r"lib(fastdds|fastrtps)\.so\.(\d+)(?:\.(\d+))?")


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


@cache
def fastdds_version(python: Path, timeout_s: float = 60.0) -> tuple[int, int] | None:
    """(major, minor) of the Fast DDS that `python`'s rmw_fastrtps_cpp loads, or None when it
    cannot be told (probed once per Python and process: about 0.4 s)."""
    try:
        done = subprocess.run([str(python), "-c", VERSION_PROBE], capture_output=True,
                              text=True, timeout=timeout_s, check=False,
                              env={**os.environ, "_ROS_WHEELS_BOOTSTRAP_COMPLETE": ""})
    except (OSError, subprocess.TimeoutExpired):
        return None
    m = _LIBRARY.search(done.stdout) if done.returncode == 0 else None
    if m is None:
        return None
    major = int(m.group(2)) if m.group(1) == "fastdds" else min(int(m.group(2)), 2)
    return major, int(m.group(3) or 0)


def profile_env(python: Path | None) -> dict[str, str]:
    """The profile variables for the Fast DDS of `python`: the one it reads set to kartci's
    profile, the other empty; both set when the version is unknown (or `python` is None)."""
    profile = str(profile_path())
    version = fastdds_version(python) if python is not None else None
    if version is None:
        return dict.fromkeys(PROFILE_VARIABLES.values(), profile)
    reads = PROFILE_VARIABLES[3 if version[0] >= 3 else 2]
    return {v: profile if v == reads else "" for v in PROFILE_VARIABLES.values()}


def dds_env(domain_id: int, namespace: str, python: Path | None = None) -> dict[str, str]:
    """What every DDS process of the run is told, before rclpy starts: Fast DDS with kartci's
    SHM-only profile (in the variable `python`'s Fast DDS reads, see `profile_env`), the run's
    domain, the agent's namespace."""
    return {"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp", **profile_env(python),
            "ROS_DOMAIN_ID": str(domain_id), "KARTCI_NAMESPACE": namespace,
            # the wheels' .pth re-executes Python once to set LD_LIBRARY_PATH; a marker
            # inherited from a ROS 2 process that started kartci would skip that
            "_ROS_WHEELS_BOOTSTRAP_COMPLETE": ""}
