"""Writing a result folder the way a run does: staged, then moved into place, the folder
marked failed on any error (an earlier good result is never destroyed)."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from kartci.runner.outdir import check_inside
from kartci.runner.run import (
    ERROR_NAME,
    LOG_NAME,
    STAGE_PREFIX,
    UNFINISHED,
    failure_text,
    mark_failed,
    score,
)
from kartci.verdict import write_json_atomic


def write_result(folder: Path, name: str, make_log: Callable[[Path], object],
                 facts: dict[str, Any]) -> None:
    """`make_log(path)` writes the run log; it is scored into metrics.json and, with `facts`
    as run.json, moved into `folder` (never through a symlink leading out of OUT)."""
    check_inside(folder.parent, [folder.name])
    folder.mkdir(parents=True, exist_ok=True)
    mark_failed(folder, name, UNFINISHED)
    stage = Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=folder))
    try:
        make_log(stage / LOG_NAME)
        score(stage)
        write_json_atomic(stage / "run.json", {**facts, "log": str(folder / LOG_NAME)})
        for item in (LOG_NAME, "metrics.json", "run.json"):
            os.replace(stage / item, folder / item)
        (folder / ERROR_NAME).unlink(missing_ok=True)
    except BaseException as err:
        mark_failed(folder, name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
