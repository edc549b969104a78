"""Issue 40, item 4: a file the user names as output is written atomically, and an existing
path there that is not a regular file (a device, a FIFO, a socket, a folder, a symlink) is
refused with one line and left as it was; nothing is written through a symlink."""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

import pytest
from helpers import kartci

from kartci.atomic import write_text_atomic
from kartci.errors import SpecError
from kartci.logs import McapLogWriter
from kartci.logs.types import msg
from kartci.scaffold import init_project
from kartci.scenario.schema import write_schema

REFUSED = "exists and is not a regular file"


def _log(path: Path) -> Path:
    with McapLogWriter(path) as out:
        for k in range(3):
            out.write("/chatter", msg("std_msgs/msg/String", data=f"m{k}"), 1000 * (k + 1))
    return path


def _fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


def test_recover_refuses_a_fifo_as_its_output_and_leaves_it_a_fifo(tmp_path: Path) -> None:
    """`kartci recover run.mcap -o /dev/full` as root replaced the device by a file and said
    "wrote /dev/full"; a FIFO stands in for the device here (same path through the code)."""
    target = _fifo(tmp_path / "full")
    p = kartci("recover", _log(tmp_path / "run.mcap"), "-o", target)
    assert p.returncode == 2, p.stderr
    assert p.stderr == (f"kartci: error: {target}: {REFUSED} (a FIFO); kartci replaces only "
                        "regular files: remove it or choose another path\n")
    assert stat.S_ISFIFO(target.lstat().st_mode)
    assert sorted(x.name for x in tmp_path.iterdir()) == ["full", "run.mcap"]  # no temp left


def test_schema_refuses_a_symlink_and_writes_nothing_through_it(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere.json"
    elsewhere.write_text("precious\n")
    link = tmp_path / "schema.json"
    link.symlink_to(elsewhere)
    p = kartci("schema", "--out", link)
    assert p.returncode == 2
    assert p.stderr == (f"kartci: error: {link}: {REFUSED} (a symlink); kartci replaces only "
                        "regular files: remove it or choose another path\n")
    assert link.is_symlink() and elsewhere.read_text() == "precious\n"


def _mcap(path: Path) -> None:
    _log(path)


def _text(path: Path) -> None:
    write_text_atomic(path, "x\n")


WRITERS: dict[str, Callable[[Path], None]] = {
    "write_text_atomic": _text, "McapLogWriter": _mcap, "write_schema": write_schema}


@pytest.mark.parametrize("writer", WRITERS)
@pytest.mark.parametrize("kind", ["fifo", "symlink", "folder"])
def test_every_writer_refuses_what_is_not_a_regular_file_and_leaves_it(
        tmp_path: Path, writer: str, kind: str) -> None:
    target = tmp_path / "out.file"
    outside = tmp_path / "outside.txt"
    outside.write_text("keep\n")
    if kind == "fifo":
        os.mkfifo(target)
    elif kind == "symlink":
        target.symlink_to(outside)
    else:
        target.mkdir()
    before = target.lstat().st_mode
    with pytest.raises(SpecError, match=REFUSED):
        WRITERS[writer](target)
    assert target.lstat().st_mode == before
    assert outside.read_text() == "keep\n"
    assert sorted(x.name for x in tmp_path.iterdir()) == ["out.file", "outside.txt"]


def test_a_regular_file_is_replaced_whole(tmp_path: Path) -> None:
    target = tmp_path / "a.txt"
    target.write_text("old\n")
    write_text_atomic(target, "new\n")
    assert target.read_text() == "new\n"
    assert [x.name for x in tmp_path.iterdir()] == ["a.txt"]


def test_init_force_refuses_a_fifo_where_it_writes_and_one_it_would_read(tmp_path: Path) -> None:
    """`kartci init --force` over a FIFO named kartci.toml replaced it; a FIFO named
    .gitignore (which init reads to append to) hung it."""
    folder = tmp_path / "proj"
    folder.mkdir()
    _fifo(folder / ".gitignore")
    with pytest.raises(SpecError, match=r"\.gitignore: cannot read \(not a regular file "
                                        r"\(a FIFO\)\); nothing written"):
        init_project(folder, force=True)
    (folder / ".gitignore").unlink()
    _fifo(folder / "kartci.toml")
    with pytest.raises(SpecError, match=f"kartci.toml: {REFUSED} \\(a FIFO\\)"):
        init_project(folder, force=True)
    assert stat.S_ISFIFO((folder / "kartci.toml").lstat().st_mode)
    assert sorted(x.name for x in folder.iterdir()) == ["kartci.toml"]
