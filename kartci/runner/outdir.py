"""OUT as a whole: one writer at a time (a lock), and the manifest of the last run's labels.

Two commands writing one OUT would share scenario folders and mix their results, so every
command that writes OUT holds an exclusive `flock` on `OUT/.kartci.lock` for as long as it runs;
a second one stops at once with one line. The lock dies with its process (the kernel drops it),
so a killed run never leaves OUT locked.

`OUT/manifest.json` lists the labels of the last command that wrote scenario folders (run,
replay, merge, report). OUT is reused (`reports/latest` by default), so it may also hold folders
of older runs; `kartci baseline update OUT` with no names takes only the manifest's labels.

No command reads or writes through a symlink that leaves OUT (`check_inside`): OUT may be an
artifact someone else made, and a symlinked `OUT/<label>` would have kartci write elsewhere.
"""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from kartci.errors import RunError, SpecError
from kartci.verdict import read_json, write_json_atomic

LOCK_NAME = ".kartci.lock"
MANIFEST_NAME = "manifest.json"
# every file the report writers (kartci.report.write_all) put in OUT, by key: the one list, kept
# with OUT's layout (OUT clears these at a command's start)
FILES = {"html": "report.html", "static": "report-static.html", "markdown": "summary.md",
         "json": "summary.json", "junit": "junit.xml"}
REPORT_NAMES = tuple(FILES.values())
_LABEL = re.compile(r"^[A-Za-z0-9_=@+,-][A-Za-z0-9_.=@+,-]*$")  # as jobs._safe makes them


def valid_label(label: object) -> bool:
    """A label names one folder directly in OUT: no separator, no `..`, no hidden name."""
    return isinstance(label, str) and bool(_LABEL.match(label)) and ".." not in label


@contextmanager
def locked(out: Path) -> Iterator[None]:
    """Hold OUT's writer lock (creating OUT); a second writer gets a RunError at once."""
    try:
        import fcntl  # optional: POSIX only
    except ImportError:  # not POSIX: no lock, as before
        out.mkdir(parents=True, exist_ok=True)
        yield
        return
    out.mkdir(parents=True, exist_ok=True)
    try:  # O_NOFOLLOW: a symlinked lock file would have the pid written over its target
        fd = os.open(out / LOCK_NAME, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0),
                     0o644)
    except OSError as err:
        if err.errno != errno.ELOOP:
            raise
        raise SpecError(f"{out / LOCK_NAME}: a symlink; remove it") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
            raise RunError(f"{out}: in use by another kartci command"
                           f"{f' (pid {holder})' if holder.isdigit() else ''}; wait for it to "
                           "end or choose another --out") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield
    finally:
        os.close(fd)  # releases the lock


def clear_reports(out: Path) -> None:
    """Remove the suite reports before anything else changes OUT, so an interrupted or failed
    command can never leave an earlier all-pass report beside its own results."""
    for name in REPORT_NAMES:
        (out / name).unlink(missing_ok=True)


def check_inside(out: Path, labels: Iterable[str]) -> None:
    """Refuse (SpecError) a label folder that is a symlink, or that holds a symlink resolving
    outside OUT: reading or writing through it would touch files elsewhere. Every command that
    uses label folders checks them before it changes anything."""
    root = out.resolve()
    for label in labels:
        folder = out / label
        if folder.is_symlink():
            raise SpecError(f"{folder}: a symlink; kartci uses only folders inside {out} "
                            "(replace it with the folder itself)")
        for where, dirs, files in os.walk(folder):  # does not descend into symlinked folders
            for name in (*dirs, *files):
                path = Path(where, name)
                if path.is_symlink() and not path.resolve().is_relative_to(root):
                    raise SpecError(f"{path}: a symlink leading outside {out}; remove it")


def write_manifest(out: Path, command: str, labels: list[str]) -> None:
    """manifest.json in OUT: the command that wrote it and its scenarios' labels, which later
    commands use when given no names."""
    write_json_atomic(out / MANIFEST_NAME, {"command": command, "scenarios": sorted(labels)})


def read_manifest(out: Path) -> list[str]:
    """The labels of the last run in OUT (SpecError when OUT has no usable manifest)."""
    path = out / MANIFEST_NAME
    if path.is_symlink():
        raise SpecError(f"{path}: a symlink; remove it, or name the scenarios to use")
    if not path.is_file():
        raise SpecError(f"{out}: no {MANIFEST_NAME} (not written by `kartci run`, `replay`, "
                        "`merge` or `report`); name the scenarios to use")
    try:
        labels = read_json(path)["scenarios"]
    except (OSError, ValueError, KeyError, TypeError):
        labels = None
    if not isinstance(labels, list) or not all(valid_label(x) for x in labels):
        raise SpecError(f"{path}: malformed manifest; name the scenarios to use")
    return [str(x) for x in labels]


def manifest_labels(out: Path) -> list[str] | None:
    """The manifest's labels, or None when OUT has no manifest (a folder of an older kartci)."""
    if not (out / MANIFEST_NAME).is_file() and not (out / MANIFEST_NAME).is_symlink():
        return None
    return read_manifest(out)
