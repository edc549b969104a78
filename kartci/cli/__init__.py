"""The `kartci` command: one module per command group, each a thin function over the library.
Errors: one line on stderr, exit 2."""

from __future__ import annotations

import os
import sys
import warnings

from kartci.cli import (  # noqa: F401  (importing a command module registers its commands)
    baseline,
    bench,
    init,
    logs,
    results,
    run,
    scenarios,
)
from kartci.cli import line as line_commands  # noqa: F401
from kartci.cli.common import app
from kartci.errors import KartciError

__all__ = ["app", "main"]


def _warning_line(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                  line: str | None = None) -> str:
    """A warning (a salvaged log, say) as one line a user reads, not a Python location."""
    return f"kartci: warning: {message}\n"


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
        print("kartci: interrupted", file=sys.stderr)
        sys.exit(130)
    except Exception as err:  # a bug: still one line, and exit 2, never CI's "regression" 1
        if os.environ.get("KARTCI_TRACEBACK"):
            raise
        text = " ".join(str(err).split())[:300]
        print(f"kartci: internal error: {type(err).__name__}: {text} (set KARTCI_TRACEBACK=1 "
              "for the traceback)", file=sys.stderr)
        sys.exit(2)
