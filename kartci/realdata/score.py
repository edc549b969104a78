"""`kartci score`: a foreign log imported as a run log (see importer), then scored, judged
against its baseline and reported exactly as a simulated run is."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from kartci.realdata.importer import import_log
from kartci.realdata.profile import resolve_profile
from kartci.results import ScenarioResult
from kartci.runner.run import (
    ERROR_NAME,
    LOG_NAME,
    STAGE_PREFIX,
    UNFINISHED,
    evaluate,
    failure_text,
    mark_failed,
    score,
)
from kartci.verdict import write_json_atomic


def score_log(log: Path, profile_path: Path | None, out: Path, baselines: Path) -> ScenarioResult:
    """Import `log` into OUT/<profile name>/run.mcap, compute metrics.json from it and judge it
    against `baselines/<profile name>.json`. Bad input (profile, missing topics) raises before
    anything is written; a failure later marks the folder, keeping what an earlier score left."""
    profile, info = resolve_profile(log, profile_path)
    types = {role: i.msgtype for role, i in info.items()}
    folder = out / profile.name
    folder.mkdir(parents=True, exist_ok=True)
    mark_failed(folder, profile.name, UNFINISHED)
    stage = Path(tempfile.mkdtemp(prefix=STAGE_PREFIX, dir=folder))
    try:
        import_log(log, profile, types, stage / LOG_NAME)
        score(stage)
        write_json_atomic(stage / "run.json", {"imported_from": str(log.resolve()),
                                               "profile": profile.name,
                                               "log": str(folder / LOG_NAME)})
        for name in (LOG_NAME, "metrics.json", "run.json"):
            os.replace(stage / name, folder / name)
        (folder / ERROR_NAME).unlink(missing_ok=True)
    except BaseException as err:
        mark_failed(folder, profile.name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return evaluate(folder, baselines)
