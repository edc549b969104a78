"""The ROS 2 Python for the DDS tests: $KARTCI_ROS2_PYTHON or kartci's venv (`kartci ros2 env`),
made here when missing; skipped, saying why, where it cannot be made (no network, no CPython
3.11, not Linux x86-64)."""

from __future__ import annotations

import os
import platform
from functools import cache
from pathlib import Path

import pytest

from kartci.bridge.dds import env as ros_env
from kartci.errors import KartciError


@cache
def _find_or_make() -> Path | str:
    """The Python, or why there is none (made at most once per test session)."""
    if platform.system() != "Linux" or platform.machine() != "x86_64":
        return (f"the ros-rclpy wheels are Linux x86-64 only, not {platform.system()} "
                f"{platform.machine()}")
    try:
        python = ros_env.find_python()
        if python is not None and ros_env.probe(python) is None:
            return python
        if python is not None and ros_env.PYTHON_ENV in os.environ:
            return f"${ros_env.PYTHON_ENV} does not import rclpy: {ros_env.probe(python)}"
        return ros_env.make(ros_env.default_path())
    except KartciError as err:
        return f"no ROS 2 Python for the DDS tests: {err}"


def ros_python_or_skip() -> Path:
    """A Python that imports rclpy on Fast DDS and the standard messages, or a skip saying
    why there is none."""
    found = _find_or_make()
    if isinstance(found, str):
        pytest.skip(found)
    return found
