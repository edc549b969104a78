"""One error base class; the CLI turns any of these into one line on stderr and exit code 2."""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def one_line(text: str, limit: int = 500) -> str:
    """User text for a one-line message: control characters and newlines become spaces."""
    flat = " ".join("".join(c if c.isprintable() else " " for c in text).split())
    return flat if len(flat) <= limit else flat[:limit - 1] + "…"


class KartciError(Exception):
    """Base of every error kartci reports to a user (bad input or a failed run)."""


class SpecError(KartciError):
    """A scenario, world or model file is missing, malformed or has a bad value."""


class LogError(KartciError):
    """A log (ROS 1 bag, rosbag2 directory, MCAP file) cannot be read or lacks what is needed."""


class RunError(KartciError):
    """A simulation run failed (a NaN state, a controller exception, a time limit)."""


class BaselineError(KartciError):
    """A baseline file is malformed or cannot be written."""


class PluginError(SpecError):
    """A plugin a scenario needs failed to load (an installed entry point or a project plugin
    module): the scenarios that need it fail with this, the others run. `trace`: the plugin's
    own traceback, for the failed scenario's folder (never a user's terminal)."""

    def __init__(self, message: str, trace: str = "") -> None:
        super().__init__(message)
        self.trace = trace


def did_you_mean(name: str, known: Iterable[object]) -> str:
    """' (did you mean 'x'?)' for a near miss, else the list of known names: the end of an
    error message about an unknown name."""
    names = sorted(str(k) for k in known)
    close = difflib.get_close_matches(name, names, n=1)
    if close:
        return f" (did you mean '{close[0]}'?)"
    listed = ", ".join(names[:20]) + (", ..." if len(names) > 20 else "")
    return f" (known: {listed or 'none'})"
