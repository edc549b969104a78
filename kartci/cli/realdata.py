"""`kartci score`, `simreal` and `calibrate`: logs from real robots (or other simulators)
scored, compared with the simulation, and used to fit the simulation's parameters."""

from __future__ import annotations

import json
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from kartci import project
from kartci.atomic import write_text_atomic
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    SetOpt,
    StrictOpt,
    app,
    baselines_dir,
    finish,
    out_console,
    out_dir,
    strict_mode,
)
from kartci.core import CONTROLLERS
from kartci.errors import SpecError
from kartci.runner.gate import require_baselines
from kartci.runner.outdir import clear_reports, locked, write_manifest

LogArg = Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap file.")]
ProfileOpt = Annotated[Path | None, typer.Option(
    "--profile", "-p", help="Import profile (YAML: which topic is the pose, the commands, ...); "
    "default: the log's only odometry/pose topic and its only command topic.")]


class AlignChoice(StrEnum):
    """`--align`'s choices (kartci.metrics.alignment.Alignment's values)."""

    NONE = "none"
    SE3 = "se3"
    SIM3 = "sim3"
    ORIGIN = "origin"


class DetectAtChoice(StrEnum):
    """`--detect-at`'s choices (kartci.realdata.lidardetect.DetectAt's values)."""

    REFERENCE = "reference"
    ESTIMATE = "estimate"


@app.command("score")
def score_cmd(log: LogArg, profile: ProfileOpt = None, out: OutOpt = None,
              baselines: BaselinesOpt = None, strict: StrictOpt = None,
              allow_outside_paths: AllowOutsideOpt = False,
              align: Annotated[AlignChoice | None, typer.Option(
                  help="Move the estimate onto the reference before APE / RPE: se3 / sim3 "
                  "(Umeyama least squares, as evo -a / -as), origin (first poses equal, "
                  "evo --align_origin) or none; default: the profile's (none).")] = None,
              align_first: Annotated[int | None, typer.Option(
                  "--align-first", min=2, help="Fit se3 / sim3 on the first N pose pairs "
                  "only (evo --n_to_align).")] = None,
              t_max_diff: Annotated[float | None, typer.Option(
                  "--t-max-diff", min=1e-9, max=3600.0, help="The largest stamp difference, "
                  "s, of an estimate / reference pose pair (evo --t_max_diff); default: the "
                  "profile's, else 0.01 s as evo's.")] = None,
              html: Annotated[bool, typer.Option(
                  help="Write report.html (interactive figures; no report-static.html, whose "
                  "matplotlib would double the command's start-up); --no-html: the metrics, "
                  "summary.md/json and junit.xml only.")] = True) -> None:
    """Score a recorded log with the same metric code as a run (duration, distance, speeds;
    laps, lap times and cross-track error with a track; localization error with an estimate),
    write the same reports and judge it against baselines/<profile name>.json."""
    from kartci.metrics.alignment import Alignment  # CLI start-up: numpy, scipy
    from kartci.realdata.score import score_log  # CLI start-up: PyBullet, pandas (+0.7 s)

    out = out_dir(out, "score")
    with locked(out):
        clear_reports(out)
        base = baselines_dir(baselines)
        result = score_log(log, profile, out, base, project.current(), allow_outside_paths,
                           None if align is None else Alignment(align.value), align_first,
                           with_plots=html, t_max_diff_s=t_max_diff)
        if strict_mode(strict):
            result = require_baselines(result, out, base)
        write_manifest(out, "score", [result.name])
        finish([result], out, html=html, static=False)


@app.command("simreal")
def simreal_cmd(
    log: LogArg,
    profile: ProfileOpt = None,
    scenario: Annotated[str | None, typer.Option(
        help="Scenario whose world and robot are simulated (default: the profile's, else the "
             "one its robot kind names for sim vs real, else the one the log's command type "
             "picks, said on stderr).")] = None,
    window_s: Annotated[float, typer.Option(
        "--window-s", min=0.05, help="Re-start the sim from the log's state every this many "
             "seconds.")] = 2.0,
    set_: SetOpt = None,
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    strict: StrictOpt = None,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Replay a log's commands into the simulated robot from the log's state, over the whole
    log and in windows re-started every --window-s, and report the divergence: APE / RPE (as
    evo), per-signal residuals (x, y, yaw, speed, yaw rate), both paths overlaid; judged
    against baselines/<profile>_simreal.json and the scenario's criteria like a run."""
    from kartci.realdata.score import simreal_log  # CLI start-up: PyBullet, pandas (+0.7 s)

    out = out_dir(out, "simreal")
    with locked(out):
        clear_reports(out)
        base = baselines_dir(baselines)
        result = simreal_log(log, profile, scenario, set_ or [], window_s, out, base,
                             project.current(), allow_outside_paths, say=lambda line: typer.echo(
                                 f"kartci: {line}", err=True))
        if strict_mode(strict):
            result = require_baselines(result, out, base)
        write_manifest(out, "simreal", [result.name])
        finish([result], out)


@app.command("localize")
def localize_cmd(
    log: LogArg,
    profile: ProfileOpt = None,
    out: OutOpt = None,
    detect: Annotated[bool, typer.Option(
        "--detect", help="Also run the obstacle detector over every scan at the log's pose of "
        "its stamp (lidar mount from /tf_static, else the profile's lidar.mount, else assumed "
        "at the base): the static tracks in OUT/detections.json, its detections, markers and "
        "the placed scans in OUT/detections.mcap (Foxglove).")] = False,
    detect_at: Annotated[DetectAtChoice, typer.Option(
        "--detect-at", help="The poses --detect places the scans at: the log's own "
        "(reference) or the localization's estimate.")] = DetectAtChoice.REFERENCE,
    detect_map: Annotated[str | None, typer.Option(
        "--detect-map", help="Map (PLY, the pose's frame) whose points the detector ignores; "
        "default none: every obstacle, walls included, is reported.")] = None,
) -> None:
    """Replay a real robot's lidar (LaserScan or PointCloud2), odometry and IMU (without one:
    predicted from the odometry, said on stderr) open loop through kartci's localization
    node, on a map built from the log's own scans at its recorded poses (OUT/map.ply), and
    score the estimate against the log's pose (APE, as evo_ape); writes
    OUT/localization.json."""
    from kartci.realdata.lidardetect import DetectAt  # CLI start-up: scipy
    from kartci.realdata.lidarloc import (  # CLI start-up: small_gicp, scipy
        Prediction,
        replay_localization,
    )

    out = out_dir(out, "localize")
    proj = project.current()
    if detect_map is not None and not Path(detect_map).is_absolute():  # on the world path
        detect_map = str(proj.world_file(detect_map))
    r = replay_localization(log, profile, out, proj,
                            DetectAt(detect_at.value) if detect else None, detect_map)
    doc = {"ape_rmse_m": r.ape.rmse, "ape_max_m": r.ape.max, "poses": r.ape.count,
           "scans": r.scans, "estimates": r.estimates, "log_s": r.log_s,
           "wall_s": round(r.wall_s, 3), "map_points": r.map_points,
           "prediction": r.prediction.value}
    write_text_atomic(out / "localization.json", json.dumps(doc, indent=2) + "\n")
    if r.prediction is Prediction.ODOMETRY:
        typer.echo(f"kartci: {log.name} has no IMU: the filter predicts from the odometry's yaw "
                   "rate alone (no side slip seen between scans)", err=True)
    out_console.print(f"{log.name}: {r.scans} scans over {r.log_s:.1f} s, {r.estimates} "
                      f"estimates; APE against its odometry: RMSE {r.ape.rmse:.4f} m, max "
                      f"{r.ape.max:.4f} m ({r.ape.count} poses); {r.wall_s:.1f} s wall; "
                      f"wrote {out / 'localization.json'}", highlight=False)
    if r.detections is not None:
        d = r.detections
        write_text_atomic(out / "detections.json", json.dumps(
            {**d.as_json(), "wall_s": round(r.detect_s, 3)}, indent=2) + "\n")
        m = d.mount
        out_console.print(
            f"detector at the {d.at.value} poses: {len(d.static)} static obstacles ({d.frame} "
            f"frame), {len(d.dynamic)} dynamic tracks, over {d.scans} scans; lidar mount x "
            f"{m.x_m:.3f} y {m.y_m:.3f} z {m.z_m:.3f} m yaw {m.yaw_rad:.3f} rad "
            f"({m.source.value}); {r.detect_s:.1f} s; "
            f"wrote {out / 'detections.json'}, {out / 'detections.mcap'}", highlight=False)


@app.command("calibrate")
def calibrate_cmd(
    log: LogArg,
    params: Annotated[list[str], typer.Option(
        "--params", help="A parameter to fit: model.NAME (the robot's model), a full dotted "
        "path, or profile.commands.NAME (the profile's base controller: wheel_radius_m, "
        "max_speed_mps, max_accel_mps2, ...), optionally =LO:HI bounds (default: half to twice "
        "its value). Repeat.")],
    profile: ProfileOpt = None,
    scenario: Annotated[str | None, typer.Option(
        help="Scenario whose world and robot are fitted (as for simreal).")] = None,
    window_s: Annotated[float, typer.Option("--window-s", min=0.05,
                                            help="Window of the divergence, s.")] = 2.0,
    set_: SetOpt = None,
    out: OutOpt = None,
    mpcc: Annotated[bool, typer.Option(
        "--mpcc", help="Fit the MPCC's own prediction model instead (LOG: a kartci run log of a "
        "simulated kart; --params: its single-track parameters, e.g. "
        "mass_per_yaw_inertia_per_m2, front.d_mps2); writes OUT/mpcc_fit.json.")] = False,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Fit model parameters to a log by minimising the windowed sim-vs-log divergence
    (scipy.optimize.least_squares, trust-region reflective, bounded); prints the values with 95 %
    intervals and the divergence before and after, writes OUT/calibration.json and
    OUT/overlay.yaml (the values as dotted keys for --set)."""
    if mpcc:
        _fit_mpcc(log, params, out_dir(out, "calibrate"))
        return
    from kartci.realdata.calibrate import calibrate_log  # CLI start-up: PyBullet, scipy

    out = out_dir(out, "calibrate")
    fit = calibrate_log(log, profile, scenario, set_ or [], params, window_s, out,
                        project.current(), allow_outside_paths)
    table = Table("parameter", "start", "fitted", "95 % interval", "note",
                  title=f"calibration ({fit.evaluations} evaluations, {fit.method})",
                  title_justify="left")
    for p, e in zip(fit.params, fit.estimates, strict=True):
        table.add_row(p.path, f"{p.start:.6g}", f"{e.value:.6g}", e.interval(), e.note(p))
    out_console.print(table)
    div = Table("divergence", "before", "after", title_justify="left")
    for name, before in fit.before.items():
        div.add_row(name, f"{before:.4g}", f"{fit.after[name]:.4g}")
    out_console.print(div)
    out_console.print(f"wrote {out / 'calibration.json'} and {out / 'overlay.yaml'}",
                      highlight=False)


def _fit_mpcc(log: Path, names: list[str], out: Path) -> None:
    fit = CONTROLLERS.get("mpcc").fit
    if fit is None:
        raise SpecError("--mpcc: the registered mpcc controller has no model to fit")
    for line in fit(log, names, out):
        out_console.print(line, highlight=False)
