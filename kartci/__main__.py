"""`kartci` and `python -m kartci`: the command, in a pinned process (see kartci.portable)."""

from __future__ import annotations

import sys

from kartci import portable
from kartci.errors import KartciError


def main() -> None:
    """Re-execute pinned if needed (before anything that computes is imported), then run."""
    try:
        portable.reexec(["-P", "-m", "kartci", *sys.argv[1:]])
    except KartciError as err:  # a bad KARTCI_SIMD: one line, as the CLI says every error
        print(f"kartci: error: {err}", file=sys.stderr)
        sys.exit(2)
    from kartci.cli import main as cli  # CLI start-up: loaded once, after the re-exec

    cli()


if __name__ == "__main__":
    main()
