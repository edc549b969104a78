"""The `kartci` command: one module per command group, each a thin function over the library.
Errors: one line on stderr, exit 2."""

from __future__ import annotations

import os
import sys
import warnings
from types import TracebackType
from typing import NoReturn

from kartci.cli import (  # noqa: F401  (importing a command module registers its commands)
    baseline,
    bench,
    faults,
    init,
    logs,
    maps,
    realdata,
    results,
    ros2,
    run,
    scenarios,
    search,
)
from kartci.cli.common import app
from kartci.errors import KartciError

__all__ = ["app", "main"]


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  line: str | None = None) -> str:
    """A warning (a salvaged log, say) as one line a user reads, not a Python location."""
    return f"kartci: warning: {message}\n"


def _interrupted(err: BaseException) -> bool:
    """True when a KeyboardInterrupt is among the causes of `err`."""
    seen: BaseException | None = err
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return True
        seen = seen.__cause__ or seen.__context__
    return False


def _quiet_hook(kind: type[BaseException], err: BaseException,
                tb: TracebackType | None) -> None:
    """sys.excepthook once the interrupt has been reported: nothing more to print."""


def _die_interrupted() -> NoReturn:
    """Ctrl-C: one line, then die by SIGINT after the normal clean-up, as Python does for an
    uncaught KeyboardInterrupt, so a calling shell sees 130 and stops its script too. A plain
    exit 130 is not reliable: an interrupt landing inside exec() (a dataclass built by a lazy
    import) makes CPython kill itself with SIGINT at exit anyway."""
    print("kartci: interrupted", file=sys.stderr)
    sys.excepthook = _quiet_hook
    raise KeyboardInterrupt


def main() -> None:
    """Entry point: every KartciError becomes one line on stderr and exit code 2."""
    warnings.formatwarning = _warning_line
    try:
        app(prog_name="kartci")
    except KartciError as err:
        print(f"kartci: error: {err}", file=sys.stderr)
        sys.exit(2)
    except OSError as err:
        where = f"{err.filename}: " if err.filename else ""
        print(f"kartci: error: {where}{err.strerror or err}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        _die_interrupted()
    except SystemExit as exit_:
        if _interrupted(exit_):  # typer turns Ctrl-C into a silent exit 130
            _die_interrupted()
        raise
    except Exception as err:  # a bug: still one line, and exit 2, never CI's "regression" 1
        if os.environ.get("KARTCI_TRACEBACK"):
            raise
        text = " ".join(str(err).split())[:300]
        print(f"kartci: internal error: {type(err).__name__}: {text} (set KARTCI_TRACEBACK=1 "
              "for the traceback)", file=sys.stderr)
        sys.exit(2)
