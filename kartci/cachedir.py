"""Where kartci keeps what it can rebuild (compiled solvers, learned run times): one folder."""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """KARTCI_CACHE_DIR, else ~/.cache/kartci (XDG_CACHE_HOME respected)."""
    env = os.environ.get("KARTCI_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "kartci"
