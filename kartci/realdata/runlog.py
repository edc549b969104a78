"""Writing a result folder the way a run does: staged, then moved into place, the folder
marked failed on any error (an earlier good result is never destroyed)."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from kartci.core import UNFINISHED, RunFolder
from kartci.runner.outdir import check_inside
from kartci.runner.run import failure_text, mark_failed, score
from kartci.verdict import write_json_atomic


def write_result(folder: Path, name: str, make_log: Callable[[Path], Sequence[str]],
                 facts: dict[str, Any]) -> None:
    """`make_log(path)` writes the run log and returns its warnings; it is scored into
    metrics.json and, with `facts` and the warnings as run.json, moved into `folder` (never
    through a symlink leading out of OUT)."""
    check_inside(folder.parent, [folder.name])
    folder.mkdir(parents=True, exist_ok=True)
    mark_failed(folder, name, UNFINISHED)
    run = RunFolder(folder)
    stage = run.new_stage()
    try:
        warnings = list(make_log(stage.log))
        score(stage.path)
        write_json_atomic(stage.run_record, {**facts, "log": str(run.log),
                                             **({"warnings": warnings} if warnings else {})})
        run.adopt(stage)
        run.error.unlink(missing_ok=True)
    except BaseException as err:
        mark_failed(folder, name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage.path, ignore_errors=True)
