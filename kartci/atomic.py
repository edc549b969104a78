"""Atomic writes: a temporary file beside the target, then a rename, so a crash, a kill or a
full disk never leaves half a file where a whole one was (DESIGN.md: writes are atomic).

Every file kartci writes goes through `check_target` first: the rename would replace whatever
the name holds, so an existing path that is not a regular file is refused (as root, `-o
/dev/full` would otherwise turn a device into a file; a FIFO, a socket or a folder are someone
else's), and so is a symlink: replacing it loses the link, writing through it writes elsewhere.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from pathlib import Path
from typing import Any

from kartci.boundedio import RefusedFileError, check_file
from kartci.errors import SpecError


def check_target(path: Path) -> None:
    """SpecError (one line naming `path`) unless `path` is absent or a regular file; never
    follows a symlink (lstat), so a link is refused, not written through. Commands call it on a
    file the user names before any work; the writers below call it again before they write."""
    try:
        st = path.lstat()
    except FileNotFoundError:
        return
    except (OSError, ValueError) as err:  # ValueError: a NUL character in the name
        why = err.strerror if isinstance(err, OSError) and err.strerror else str(err)
        raise SpecError(f"{path}: cannot be written ({why})") from err
    if stat.S_ISLNK(st.st_mode):
        kind = "not a regular file (a symlink)"
    else:
        try:
            check_file(st, None)
            return
        except RefusedFileError as err:
            kind = str(err)
    raise SpecError(f"{path}: exists and is {kind}; kartci replaces only regular files: "
                    "remove it or choose another path")


def write_text_atomic(path: Path, text: str) -> None:
    """Write `text` (UTF-8) to `path` in one step; the temporary file goes on any failure."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` in one step (check_target first); the temporary file goes on any
    failure."""
    check_target(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)  # mkstemp makes 0600; these are shared, reviewable files
        check_target(path)  # again: the name may have changed while the data was written
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json_atomic(path: Path, data: Any) -> None:
    """JSON with sorted keys and no NaN or Infinity (diffable, parseable anywhere)."""
    write_text_atomic(path, json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n")
