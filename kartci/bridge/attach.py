"""How a person attaches ROS 2 tools (`ros2 topic echo`, rviz) to a running external stack: the
run's middleware facts (DDS domain and Fast DDS profile, or Zenoh endpoint) and one ready
command. An agent calls `announce()` once its endpoint is up: the facts go into the run folder
(the runner puts them in run.json under `attach`) and, on a terminal outside CI, one line on
stderr, so nobody guesses the domain of a run.
"""

from __future__ import annotations

import json
import os
import shlex
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kartci.atomic import write_text_atomic
from kartci.core import RunFolder

# what a ROS 2 tool needs of the stack's environment to see the run's graph
_ZENOH_KEYS = ("ROS_DOMAIN_ID", "ZENOH_CONFIG_OVERRIDE", "ZENOH_ROUTER_CHECK_ATTEMPTS")
_DDS_KEYS = ("ROS_DOMAIN_ID", "FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")


@dataclass(frozen=True)
class Attach:
    """One agent's attach facts: its middleware, what to set, a topic worth echoing."""

    middleware: str  # "dds" or "zenoh"
    rmw: str  # RMW_IMPLEMENTATION for the tool
    env: tuple[tuple[str, str], ...]  # the variables to set, in order (empty ones left out)
    topic: str  # a fully qualified topic of the stack (its first command topic)
    facts: tuple[tuple[str, Any], ...] = ()  # domain_id, profile, endpoint: for run.json

    @property
    def command(self) -> str:
        """A shell command that echoes `topic` of the running stack."""
        assigns = [f"{k}={shlex.quote(v)}" for k, v in (*self.env,
                                                         ("RMW_IMPLEMENTATION", self.rmw))]
        return " ".join([*assigns, "ros2", "topic", "echo", shlex.quote(self.topic)])

    def record(self) -> dict[str, Any]:
        """The facts as run.json holds them."""
        return {"middleware": self.middleware, "rmw": self.rmw, **dict(self.facts),
                "command": self.command}


def for_dds(env: Mapping[str, str], topic: str) -> Attach:
    """Attach facts of a DDS run from the environment its processes get (`dds_env`)."""
    chosen = tuple((k, env[k]) for k in _DDS_KEYS if env.get(k))
    profile = next((v for k, v in chosen if k.endswith("_PROFILES_FILE")), "")
    return Attach("dds", env.get("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp"), chosen, topic,
                  (("domain_id", int(env["ROS_DOMAIN_ID"])), ("profile", profile),
                   ("profile_variables", [k for k, _ in chosen if k != "ROS_DOMAIN_ID"])))


def for_zenoh(env: Mapping[str, str], endpoint: str, topic: str) -> Attach:
    """Attach facts of a Zenoh run from the environment its stack gets (`child_env`)."""
    chosen = tuple((k, env[k]) for k in _ZENOH_KEYS if env.get(k))
    return Attach("zenoh", "rmw_zenoh_cpp", chosen, topic,
                  (("domain_id", int(env["ROS_DOMAIN_ID"])), ("endpoint", endpoint)))


def quiet() -> bool:
    """No line on stderr: not a terminal, or in CI (run.json still has the facts)."""
    return not sys.stderr.isatty() or os.environ.get("CI", "").strip().lower() not in (
        "", "0", "false", "no")


def announce(run_dir: Path | None, agent: str, attach: Attach) -> None:
    """Record `attach` for run.json (when the run has a folder) and print its command."""
    if run_dir is not None:
        write_text_atomic(RunFolder(run_dir).attach(agent),
                          json.dumps(attach.record(), sort_keys=True) + "\n")
    if not quiet():
        print(f"kartci: {agent} on {attach.middleware}; attach ROS 2 tools with: "
              f"{attach.command}", file=sys.stderr, flush=True)
