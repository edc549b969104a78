"""The `kartci` command: thin typer commands over the library. Errors: one line, exit 2."""

from __future__ import annotations

import csv
import json
import os
import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from kartci.errors import KartciError, SpecError
from kartci.report.tables import MARK, RUN, Wording, delta, num, tolerance
from kartci.results import ScenarioResult, exit_code
from kartci.runner.executors import ExecutorKind

app = typer.Typer(add_completion=False, pretty_exceptions_enable=False, no_args_is_help=True,
                  help="Run robot scenarios headless, record them, score them against baselines.")
baseline_app = typer.Typer(help="Inspect and update stored baselines.", no_args_is_help=True)
app.add_typer(baseline_app, name="baseline")
# In CI logs (no terminal) rich would wrap at 80 columns and cut metric names: use 160.
out_console = Console(width=None if sys.stdout.isatty() else 160)
err_console = Console(stderr=True, width=None if sys.stderr.isatty() else 160)

SetOpt = Annotated[list[str] | None, typer.Option(
    "--set", help="Override a scenario value: dotted.key=value (repeatable).")]
OutOpt = Annotated[Path, typer.Option("--out", "-o", help="Output folder.")]
BaselinesOpt = Annotated[Path | None, typer.Option(
    help="Folder of baseline files (default: the project's baselines/).")]


def _baselines(path: Path | None, must_exist: bool = True) -> Path:
    from kartci.runner import default_baselines

    if path is not None and must_exist and not path.is_dir():
        raise SpecError(f"--baselines {path}: no such folder")
    return path or default_baselines()


@app.command("list")
def list_cmd() -> None:
    """List the scenarios with a one-line description."""
    from kartci.spec import load_scenario, scenario_names

    table = Table("scenario", "description", box=None)
    for name in scenario_names():
        table.add_row(name, load_scenario(name).description)
    out_console.print(table)


@app.command()
def show(name: str, set_: SetOpt = None) -> None:
    """Print a scenario fully resolved (world and model files included, overrides applied)."""
    from kartci.spec import load_scenario

    spec = load_scenario(name, set_ or [])
    typer.echo(json.dumps(spec.model_dump(mode="json"), indent=2))


@app.command()
def schema(out: Annotated[Path | None, typer.Option(help="Write to this file.")] = None) -> None:
    """JSON Schema of scenario files, for editor completion and validation."""
    from kartci.spec import json_schema

    text = json.dumps(json_schema(), indent=2)
    if out is None:
        typer.echo(text)
    else:
        out.write_text(text + "\n", encoding="utf-8")


def _print_verdicts(results: list[ScenarioResult], words: Wording) -> None:
    for r in results:
        if r.error:
            out_console.print(f"[bold]{r.name}[/]: {MARK[r.status]} error: {r.error}",
                              markup=True, highlight=False)
            continue
        table = Table("metric", "value", words.base, "delta", "tolerance", "verdict",
                      title=f"{r.name}: {MARK[r.status]} {r.status.value}", title_justify="left")
        for v in r.verdicts:
            table.add_row(v.name, num(v.value, v.unit), num(v.baseline, v.unit), delta(v),
                          tolerance(v), f"{MARK[v.status]} {v.status.value}")
        for c in r.criteria:
            table.add_row(f"criterion {c.name}", num(c.value), c.bound, "", "",
                          "✅ pass" if c.ok else "❌ failed")
        out_console.print(table)


def _finish(results: list[ScenarioResult], out: Path, words: Wording = RUN,
            ci: bool = True) -> None:
    """Write every report, print the verdicts and (unless `ci` is off, as for a shard, whose
    merge reports for it) the CI outputs; exit with the gating code."""
    from kartci.report import write_all
    from kartci.report.ci import annotation_lines, append_step_summary, in_github_actions

    paths = write_all(results, out, words)
    _print_verdicts(results, words)
    if ci:
        append_step_summary(paths["markdown"].read_text(encoding="utf-8"))
    if ci and in_github_actions():
        for line in annotation_lines(results):
            typer.echo(line)
    code = exit_code(results)
    out_console.print(f"report: {paths['html']}  (exit {code})", highlight=False)
    raise typer.Exit(code)


@app.command()
def run(
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenario names or YAML paths (default: every scenario in scenarios/).")] = None,
    set_: SetOpt = None,
    out: OutOpt = Path("reports/latest"),
    baselines: BaselinesOpt = None,
    jobs: Annotated[int | None, typer.Option(
        "--jobs", "-j", help="Runs at once: this process and N-1 worker processes (local), "
                             "or Ray CPUs [default: 1 local, all cores on Ray].")] = None,
    shard: Annotated[str | None, typer.Option(
        help="I/N: run share I of N (labels sorted, dealt round-robin); OUT holds a partial "
             "result for `kartci merge`.")] = None,
    executor: Annotated[ExecutorKind, typer.Option(
        help="local: this process, or a process pool with -j N; ray: one Ray task per run "
             '(pip install "kartci[ray]").')] = ExecutorKind.LOCAL,
    ray_address: Annotated[str | None, typer.Option(
        help="Ray cluster to use (default: start a local Ray instance).")] = None,
    sweep: Annotated[list[str] | None, typer.Option(
        help="key=v1,v2,...: one run per value, into OUT/<scenario>@<key>=<value> "
             "(repeatable: every combination).")] = None,
    repeat: Annotated[int, typer.Option(
        help="Run K seeds (seed, seed+1, ...): extra runs in OUT/<scenario>/repeat_<k>/, for "
             "`kartci compare`.")] = 1,
    timeout_s: Annotated[float | None, typer.Option(
        "--timeout-s", help="Wall-clock limit per run, s: a slower run is an error.")] = None,
) -> None:
    """Run scenarios, record each as OUT/<scenario>/run.mcap, score and judge them.

    Exit 0 when everything passes, 1 on a regression or failed criterion, 2 on bad input or a
    run error. Reports: OUT/report.html, summary.md, summary.json, junit.xml.
    """
    from kartci.report.progress import ProgressView
    from kartci.runner import expand, parse_shard, run_jobs
    from kartci.runner import shard as share
    from kartci.runner.merge import write_marker
    from kartci.spec import load_scenario, scenario_names

    if jobs is not None and jobs < 1:
        raise SpecError(f"--jobs {jobs}: expected 1 or more")
    if timeout_s is not None and not timeout_s > 0:
        raise SpecError(f"--timeout-s {timeout_s:g}: expected a positive number of seconds")
    if ray_address and executor is not ExecutorKind.RAY:
        raise SpecError("--ray-address needs --executor ray")
    part = parse_shard(shard) if shard else None
    selected = names or [n for n in scenario_names() if "tool" not in
                         load_scenario(n).tags]
    if not selected:
        raise SpecError("no scenarios to run: scenarios/ is empty (set KARTCI_ROOT to the "
                        "project folder)")
    todo = expand(selected, set_ or [], sweep, repeat)
    if part is not None:
        todo = share(todo, *part)
    out.mkdir(parents=True, exist_ok=True)  # an unusable --out fails here, before any run
    index, total = part or (None, None)
    write_marker(out, index, total, [j.label for j in todo if j.repeat == 0])
    workers = jobs or (os.cpu_count() or 1 if executor is ExecutorKind.RAY else 1)
    live = err_console.is_terminal and not os.environ.get("CI")
    with ProgressView(todo, err_console, live) as view:
        results = run_jobs(todo, out, _baselines(baselines), workers=workers,
                           executor=executor, ray_address=ray_address, timeout_s=timeout_s,
                           on_event=view)
    _finish(results, out, ci=part is None)


@app.command()
def merge(
    dirs: Annotated[list[Path], typer.Argument(help="Partial results (`run --shard` OUTs).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    baselines: BaselinesOpt = None,
) -> None:
    """Join partial results into one run: copy the scenario folders into OUT, then judge and
    report them exactly as an unsharded run would (same summary, verdicts, exit code)."""
    from kartci.runner.merge import merge as join

    _finish(join(dirs, out, _baselines(baselines)), out)


@app.command("compare")
def compare_cmd(
    base: Annotated[Path, typer.Argument(help="The base run's OUT (e.g. the target branch).")],
    head: Annotated[Path, typer.Argument(help="The head run's OUT (e.g. the pull request).")],
    out: OutOpt = Path("reports/compare"),
    baselines: BaselinesOpt = None,
    alpha: Annotated[float, typer.Option(
        help="Significance level across --repeat samples (Mann-Whitney U).")] = 0.05,
) -> None:
    """Compare head with base, scenario by scenario and metric by metric: base, head, delta,
    verdict (tolerances and directions as for baselines; with repeats, a change must also be
    significant). Reports both runs' paths and time series overlaid. Exit 1 when head
    regressed, 0 when not, 2 when a run failed."""
    from kartci.report import COMPARE
    from kartci.runner.compare import compare_outs

    if not 0 < alpha < 1:
        raise SpecError(f"--alpha {alpha:g}: expected 0 < alpha < 1")
    _finish(compare_outs(base, head, _baselines(baselines), alpha), out, COMPARE)


@app.command()
def replay(
    log: Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap file.")],
    scenario: Annotated[str, typer.Option(help="Scenario whose world and kart replay the log.")]
    = "kart_replay",
    topic: Annotated[str | None, typer.Option(
        help="Input topic (default: the log's only Joy or command topic).")] = None,
    mapping: Annotated[str, typer.Option(help="Joystick mapping for Joy logs: "
                                              "models/gokart/joy/<name>.yaml.")] = "ps4",
    agent: Annotated[str | None, typer.Option(help="Agent to drive (default: the first).")]
    = None,
    set_: SetOpt = None,
    out: OutOpt = Path("reports/replay"),
    baselines: BaselinesOpt = None,
) -> None:
    """Run a scenario with a recorded input stream driving one kart: sensor_msgs/Joy through a
    joystick mapping (the manual agent), or AckermannDriveStamped / Twist / TwistStamped
    commands. Log time is re-based so the first message is at sim time 0."""
    from kartci.agents.kart import COMMANDS, JOY
    from kartci.logs import topics
    from kartci.runner import Job, run_jobs
    from kartci.spec import load_scenario
    from kartci.spec.models import CommandsController, LogSource, ManualController

    spec = load_scenario(scenario, set_ or [])
    name = agent or next(iter(spec.agents))
    if name not in spec.agents:
        raise SpecError(f"scenario {spec.name} has no agent '{name}' "
                        f"(agents: {', '.join(spec.agents)})")
    info = topics(log)
    candidates = [i for i in info if (topic is None or i.topic == topic)
                  and i.msgtype in (*JOY, *COMMANDS) and i.count > 0]
    if len(candidates) != 1:
        listed = ", ".join(f"{i.topic} ({i.msgtype}, {i.count})" for i in info) or "none"
        what = f"topic {topic}" if topic else "exactly one Joy or drive-command topic"
        raise SpecError(f"{log}: needs {what} with messages; it has: {listed}"
                        + ("" if topic else "; choose one with --topic"))
    chosen = candidates[0]
    source = LogSource(log=str(log.resolve()), topic=chosen.topic)
    controller: ManualController | CommandsController
    if chosen.msgtype in JOY:
        controller = ManualController(mapping=mapping, source=source)
    else:
        controller = CommandsController(source=source)
    agents = dict(spec.agents)
    agents[name] = agents[name].model_copy(update={"controller": controller})
    spec = spec.model_copy(update={"agents": agents})
    out.mkdir(parents=True, exist_ok=True)
    err_console.print(f"replaying {chosen.topic} ({chosen.msgtype}, {chosen.count} messages) "
                      f"into {spec.name}/{name}", highlight=False)
    _finish(run_jobs([Job(spec, spec.name)], out, _baselines(baselines)), out)


@app.command()
def extract(
    log: Annotated[Path, typer.Argument(help="Any log: .bag, rosbag2 folder or .mcap.")],
    topic: Annotated[list[str], typer.Option("--topic", "-t", help="Topic to keep (repeat).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The new .mcap file.")],
) -> None:
    """Copy some topics of a log into a new MCAP file (ROS 2 types), e.g. a joystick stream."""
    from kartci.logs import extract as copy_topics

    n = copy_topics(log, topic, out)
    out_console.print(f"wrote {out}: {n} messages", highlight=False)


@app.command()
def report(out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
           baselines: BaselinesOpt = None) -> None:
    """Rebuild metrics and all reports of a run folder from its logs alone."""
    from kartci.runner import rescore

    _finish(rescore(out, _baselines(baselines)), out)


@baseline_app.command("update")
def baseline_update(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
    names: Annotated[list[str] | None, typer.Argument(help="Scenarios (default: all in OUT).")]
    = None,
    baselines: BaselinesOpt = None,
) -> None:
    """Store a run's metrics as the baselines; the only command that writes baselines."""
    from kartci.runner import ERROR_NAME
    from kartci.verdict import load, read_metrics, update

    folders = [out / n for n in names] if names else sorted(
        p.parent for p in out.glob("*/metrics.json"))
    if not folders:
        raise SpecError(f"{out}: no <scenario>/metrics.json found; run `kartci run` first")
    target = _baselines(baselines, must_exist=False)
    checked = []
    for folder in folders:  # check everything before writing anything
        if (folder / ERROR_NAME).exists():
            raise SpecError(f"{folder}: the last run of this scenario failed; its metrics are "
                            "stale and will not become a baseline")
        load(target / f"{folder.name}.json")
        checked.append((folder, read_metrics(folder / "metrics.json")))
    for folder, values in checked:
        changes = update(target / f"{folder.name}.json", folder.name, values)
        moved = [c for c in changes if c.kind != "unchanged"]
        out_console.print(f"{folder.name}: {len(moved)} of {len(changes)} metrics changed",
                          highlight=False)
        for c in moved:
            out_console.print(f"  {c.kind:8s} {c.metric}: {num(c.old)} -> {num(c.new)}",
                              highlight=False)


@app.command()
def characterise(
    out: OutOpt = Path("reports/characterisation"),
    scenario: Annotated[str, typer.Option(help="Scenario whose robot and world are used.")]
    = "line_straight",
    fovs: Annotated[str, typer.Option(help="Fields of view to compare, rad, comma-separated.")]
    = "0.5,0.75,1.0,1.2,1.4,1.5,2.0",
    step_m: Annotated[float, typer.Option(help="Offset step of the sweep, m.")] = 0.0005,
    set_: SetOpt = None,
) -> None:
    """Sweep the line tracker across the line and characterise its sensor (seed Fig. 5.2.2.2,
    6.3.1, 5.2.2.3): sweep.csv, fov_sweep.csv, characterisation.html, fitted slope."""
    from kartci.report.plots import sensor_sweep
    from kartci.sim.characterise import sweep
    from kartci.spec import load_scenario

    spec = load_scenario(scenario, set_ or [])
    agent = next(iter(spec.agents))
    try:
        fov_list = [float(f) for f in fovs.split(",") if f.strip()]
    except ValueError:
        raise SpecError(f"--fovs {fovs!r}: expected comma-separated numbers") from None
    if not fov_list or not all(0.05 < f < 3.0 for f in fov_list):
        raise SpecError(f"--fovs {fovs!r}: each field of view must be in (0.05, 3.0) rad")
    if not 0 < step_m <= 0.005:
        raise SpecError(f"--step-m {step_m}: expected 0 < step <= 0.005")
    offsets = np.round(np.arange(-0.03, 0.03 + step_m / 2, step_m), 9)
    out.mkdir(parents=True, exist_ok=True)
    geo = sweep(spec, agent, offsets, mode="geometric")
    ren = sweep(spec, agent, offsets, mode="rendered")
    with (out / "sweep.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["offset_m", "left", "right", "difference", "left_rendered",
                    "right_rendered", "difference_rendered"])
        for i, d in enumerate(offsets):
            w.writerow([f"{d:.6f}", f"{geo.left[i]:.6f}", f"{geo.right[i]:.6f}",
                        f"{geo.difference[i]:.6f}", f"{ren.left[i]:.6f}", f"{ren.right[i]:.6f}",
                        f"{ren.difference[i]:.6f}"])
    fov_curves = {f: sweep(spec, agent, offsets, fov_rad=f, mode="geometric") for f in fov_list}
    with (out / "fov_sweep.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["offset_m", *[f"difference_fov_{x:g}" for x in fov_list]])
        for i, d in enumerate(offsets):
            w.writerow([f"{d:.6f}", *[f"{fov_curves[x].difference[i]:.6f}" for x in fov_list]])
    slope, intercept, r2 = geo.fit()
    rslope, rintercept, rr2 = ren.fit()
    lines = [f"geometric: y = {slope:.2f} d + {intercept:.4f}  (R^2 {r2:.4f} over |d| <= 8 mm)",
             f"rendered:  y = {rslope:.2f} d + {rintercept:.4f}  (R^2 {rr2:.4f})",
             "seed (Eq. 6.12): y = 39.4022 d + 0.0036"]
    for x in fov_list:
        s, _, r = fov_curves[x].fit()
        lines.append(f"fov {x:g} rad: slope {s:.2f} /m, R^2 {r:.3f}")
    figs = [sensor_sweep(list(offsets), {"left": list(geo.left), "right": list(geo.right),
                                         "left - right": list(geo.difference),
                                         "left - right (rendered)": list(ren.difference)},
                         "camera outputs across the line (fov 1.2 rad)"),
            sensor_sweep(list(offsets), {f"fov {x:g} rad": list(c.difference)
                                         for x, c in fov_curves.items()},
                         "left - right for several fields of view")]
    html_text = ("<!doctype html><html><head><meta charset='utf-8'><title>line sensor "
                 "characterisation</title></head><body><h1>Line-sensor characterisation</h1><pre>"
                 + "\n".join(lines) + "</pre>" + "".join(figs) + "</body></html>\n")
    (out / "characterisation.html").write_text(html_text, encoding="utf-8")
    for line in lines:
        out_console.print(line, highlight=False)
    out_console.print(f"wrote {out}/sweep.csv, fov_sweep.csv, characterisation.html",
                      highlight=False)


def main() -> None:
    """Entry point: every KartciError becomes one line on stderr and exit code 2."""
    try:
        app()
    except KartciError as err:
        print(f"kartci: error: {err}", file=sys.stderr)
        sys.exit(2)
    except OSError as err:
        where = f"{err.filename}: " if err.filename else ""
        print(f"kartci: error: {where}{err.strerror or err}", file=sys.stderr)
        sys.exit(2)
    except KeyboardInterrupt:
        print("kartci: interrupted", file=sys.stderr)
        sys.exit(130)


if __name__ == "__main__":
    main()
