"""Where jobs run: a module of its own, so the CLI can offer the choice without loading the
runner (the simulator, pandas, the log readers)."""

from __future__ import annotations

from enum import StrEnum


class ExecutorKind(StrEnum):
    """Where jobs run (`--executor`)."""

    LOCAL = "local"  # this process with -j 1, a process pool with -j N
    RAY = "ray"  # one Ray task per job, local Ray or a cluster
