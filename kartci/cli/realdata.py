"""`kartci score`, `simreal` and `calibrate`: logs from real robots (or other simulators)
scored, compared with the simulation, and used to fit the simulation's parameters."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import (
    BaselinesOpt,
    OutOpt,
    StrictOpt,
    app,
    baselines_dir,
    finish,
    out_dir,
    strict_mode,
)

LogArg = Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap file.")]
ProfileOpt = Annotated[Path | None, typer.Option(
    "--profile", "-p", help="Import profile (YAML: which topic is the pose, the commands, ...); "
    "default: the log's only odometry/pose topic and its only command topic.")]


@app.command("score")
def score_cmd(log: LogArg, profile: ProfileOpt = None, out: OutOpt = None,
              baselines: BaselinesOpt = None, strict: StrictOpt = None) -> None:
    """Score a recorded log with the same metric code as a run (duration, distance, speeds;
    laps, lap times and cross-track error with a track; localization error with an estimate),
    write the same reports and judge it against baselines/<profile name>.json."""
    from kartci.realdata.score import score_log
    from kartci.runner.gate import require_baselines
    from kartci.runner.outdir import clear_reports, locked, write_manifest

    out = out_dir(out, "score")
    with locked(out):
        clear_reports(out)
        base = baselines_dir(baselines)
        result = score_log(log, profile, out, base)
        if strict_mode(strict):
            result = require_baselines(result, out, base)
        write_manifest(out, "score", [result.name])
        finish([result], out)
