"""Writing a result folder the way a run does: staged, then moved into place, the folder
marked failed on any error (an earlier good result is never destroyed)."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from kartci.core import UNFINISHED, RunFolder
from kartci.runner.outdir import check_inside
from kartci.runner.run import failure_text, score
from kartci.verdict import write_json_atomic


def write_result(folder: RunFolder, name: str, make_log: Callable[[Path], Sequence[str]],
                 facts: dict[str, Any]) -> None:
    """`make_log(path)` writes the run log and returns its warnings; it is scored into
    metrics.json and, with `facts` and the warnings as run.json, moved into `folder` (never
    through a symlink leading out of OUT)."""
    check_inside(folder.path.parent, [folder.name])
    folder.path.mkdir(parents=True, exist_ok=True)
    folder.mark_failed(name, UNFINISHED)
    stage = folder.new_stage()
    try:
        warnings = list(make_log(stage.log))
        score(stage)
        write_json_atomic(stage.run_record, {**facts, "log": str(folder.log),
                                             **({"warnings": warnings} if warnings else {})})
        folder.adopt(stage)
        folder.error.unlink(missing_ok=True)
    except BaseException as err:
        folder.mark_failed(name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage.path, ignore_errors=True)
