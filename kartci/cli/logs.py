"""`kartci replay`, `extract` and `diff`: recorded logs in, as inputs, as copies or compared."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from kartci import project
from kartci.atomic import check_target
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    SetOpt,
    StrictOpt,
    app,
    baselines_dir,
    err_console,
    finish,
    out_console,
    out_dir,
    strict_mode,
)
from kartci.core import ROBOTS, RunFolder
from kartci.errors import LogError, SpecError
from kartci.runner.outdir import check_inside, clear_reports, locked, write_manifest
from kartci.scenario import load_scenario

if TYPE_CHECKING:
    from kartci.logs.diff import FieldDiff, LogDiff, MessageDiff, TopicDiff
    from kartci.logs.reader import TopicInfo


@app.command()
def replay(
    log: Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap file.")],
    scenario: Annotated[str, typer.Option(help="Scenario whose world and kart replay the log.")]
    = "kart_replay",
    topic: Annotated[str | None, typer.Option(
        help="Input topic (default: the log's only Joy or command topic).")] = None,
    mapping: Annotated[str, typer.Option(help="Joystick mapping for Joy logs: a name "
                                              "(models/<robot kind>/joy/<name>.yaml; the "
                                              "kart's: ps4, xbox, g29) or a path to a mapping "
                                              "YAML file.")] = "ps4",
    agent: Annotated[str | None, typer.Option(help="Agent to drive (default: the first).")]
    = None,
    set_: SetOpt = None,
    allow_outside_paths: AllowOutsideOpt = False,
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    strict: StrictOpt = None,
    open_loop: Annotated[bool, typer.Option(
        "--open-loop", help="Feed the log's recorded inputs to the registered agent named by "
        "--agent (no simulation), record its outputs in OUT/openloop.mcap and compare them with "
        "--reference (default: the outputs recorded in LOG); exit 1 when they differ.")] = False,
    ns: Annotated[str | None, typer.Option(
        "--ns", help="Open loop: the robot's namespace in the log (default: a run log's first "
        "agent).")] = None,
    reference: Annotated[Path | None, typer.Option(
        help="Open loop: the log whose outputs are the reference.")] = None,
    tolerance: Annotated[list[str] | None, typer.Option(
        help="Open loop: FIELD=TOL or TOPIC:FIELD=TOL, a dotted message field compared within "
        "TOL instead of exactly (repeat).")] = None,
) -> None:
    """Run a scenario with a recorded input stream driving one kart: sensor_msgs/Joy through a
    joystick mapping (the manual agent), or AckermannDriveStamped / Twist / TwistStamped
    commands. Log time is re-based so the first message is at sim time 0. With --open-loop,
    feed a log's sensor topics to a registered agent instead and gate on its outputs."""
    if open_loop:
        _open_loop(log, agent, ns, reference, tolerance or [], out_dir(out, "openloop"))
        return
    # CLI start-up: the runner and the report's figures load PyBullet, matplotlib (+0.9 s)
    from kartci.report.static import scenario_svgs
    from kartci.runner import Job, run_jobs

    out = out_dir(out, "replay")
    proj = project.current()
    spec = load_scenario(scenario, set_ or [], project=proj,
                         allow_outside_paths=allow_outside_paths)
    name = agent or next(iter(spec.agents))
    if name not in spec.agents:
        raise SpecError(f"scenario {spec.name} has no agent '{name}' "
                        f"(agents: {', '.join(spec.agents)})")
    chosen = _input_topic(log, topic)
    kind = spec.agents[name].model.kind
    make = ROBOTS.get(kind).replay
    if make is None:
        raise SpecError(f"scenario {spec.name}: agent {name} is a {kind} robot, which cannot be "
                        "driven from a recorded input")
    controller = make(log, chosen.topic, chosen.msgtype, mapping, proj.model_path)
    agents = dict(spec.agents)
    agents[name] = agents[name].model_copy(update={"controller": controller})
    spec = spec.model_copy(update={"agents": agents})
    err_console.print(f"replaying {chosen.topic} ({chosen.msgtype}, {chosen.count} messages) "
                      f"into {spec.name}/{name}", highlight=False, markup=False)
    with locked(out):
        check_inside(out, [spec.name])
        clear_reports(out)
        write_manifest(out, "replay", [spec.name])
        finish(run_jobs([Job(spec, spec.name)], out, baselines_dir(baselines), proj,
                        strict=strict_mode(strict), draw=scenario_svgs), out)


def _input_topic(log: Path, topic: str | None) -> TopicInfo:
    """The log's input topic: the one named (which must be a Joy or drive-command topic with
    messages), else its only such topic."""
    # CLI start-up: the log readers load mcap, rosbags, pandas (+0.3 s), as below
    from kartci.logs import topics
    from kartci.logs.recorded import COMMANDS, JOY

    info = topics(log)
    usable = (*JOY, *COMMANDS)
    listed = ", ".join(f"{i.topic} ({i.msgtype}, {i.count})" for i in info) or "none"
    if topic is not None:
        named = [i for i in info if i.topic == topic]
        if not named:
            raise SpecError(f"{log}: no topic {topic}; it has: {listed}")
        if named[0].msgtype not in usable:
            raise SpecError(f"{log}: topic {topic} is {named[0].msgtype}, which cannot drive a "
                            f"kart; expected one of {', '.join(usable)}")
        if named[0].count == 0:
            raise SpecError(f"{log}: topic {topic} has no messages")
        return named[0]
    candidates = [i for i in info if i.msgtype in usable and i.count > 0]
    if len(candidates) != 1:
        raise SpecError(f"{log}: needs exactly one Joy or drive-command topic with messages; "
                        f"it has: {listed}; choose one with --topic")
    return candidates[0]


@app.command()
def extract(
    log: Annotated[Path, typer.Argument(help="Any log: .bag, rosbag2 folder or .mcap.")],
    topic: Annotated[list[str], typer.Option("--topic", "-t", help="Topic to keep (repeat).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The new .mcap file.")],
) -> None:
    """Copy some topics of a log into a new MCAP file (ROS 2 types), e.g. a joystick stream."""
    from kartci.logs import extract as copy_topics  # CLI start-up: the log readers

    check_target(out)
    n = copy_topics(log, topic, out)
    out_console.print(f"wrote {out}: {n} messages", highlight=False)


@app.command()
def recover(
    log: Annotated[Path, typer.Argument(help="A damaged or truncated log: .mcap, .bag or "
                                            "rosbag2 folder.")],
    out: Annotated[Path, typer.Option("--out", "-o", help="The new .mcap file.")],
) -> None:
    """Write every message that can still be read from a damaged log into a new MCAP file
    (as `mcap recover` does): a cut chunk is stream-decompressed up to the cut; what was lost
    is said in a warning."""
    from kartci.logs import recover as salvage_log  # CLI start-up: the log readers

    check_target(out)
    n = salvage_log(log, out)
    out_console.print(f"wrote {out}: {n} messages", highlight=False)


def _open_loop(log: Path, agent: str | None, ns: str | None, reference: Path | None,
               tolerance: list[str], out: Path) -> None:
    from kartci.realdata.openloop import open_loop  # CLI start-up: PyBullet, scipy (+0.7 s)

    if agent is None:
        raise SpecError("--open-loop needs --agent NAME: a registered controller or node")
    tols: dict[str, float] = {}
    for item in tolerance:
        key, _, value = item.rpartition("=")
        try:
            tols[key] = float(value)
        except ValueError as err:
            raise SpecError(f"--tolerance {item}: expected FIELD=TOL with a number") from err
    results = open_loop(log, agent, ns, reference, tols, out)
    bad = 0
    for r in results:
        worst = ", ".join(f"{k} by {v:.3g}" for k, v in sorted(r.worst.items()))
        ok = r.differing == 0 and not r.note
        bad += not ok
        text = (f"{'same' if ok else 'DIFFERS'} {r.topic}: {r.compared} messages compared, "
                f"{r.differing} differ" + (f" ({worst})" if worst else "")
                + (f"; {r.note}" if r.note else ""))
        out_console.print(text, highlight=False, markup=False)
    out_console.print(f"outputs: {out / 'openloop.mcap'}  (exit {1 if bad else 0})",
                      highlight=False)
    raise typer.Exit(1 if bad else 0)


@app.command("diff")
def diff_cmd(
    a: Annotated[Path, typer.Argument(
        help="Run A: a log (.mcap) or a run folder (OUT/<scenario>, holding run.mcap).",
        show_default=False)],
    b: Annotated[Path, typer.Argument(help="Run B, the same.", show_default=False)],
    ignore: Annotated[list[str] | None, typer.Option(
        "--ignore", metavar="TOPIC[:FIELD]",
        help="Leave a topic, or one dotted field of it, out of the comparison (repeat). TOPIC "
        "may hold * wildcards; FIELD is written without array indices, e.g. "
        "'/kart0/mpcc/horizon:poses.pose.position.x'.")] = None,
    wall_clock: Annotated[bool, typer.Option(
        "--wall-clock", help="Also compare the fields measured on the wall clock (the MPCC's "
        "solve_ms; declared by the robot kinds, see kartci/logs/wallclock.py), which differ "
        "between any two runs.")]
    = False,
    tolerance: Annotated[float, typer.Option(
        help="Absolute tolerance of float fields, in each field's own unit [default: 0: "
        "bitwise equal, NaN equal to NaN].", show_default=False)] = 0.0,
    fields: Annotated[int, typer.Option(
        "--fields", help="Differing fields printed at most.")] = 10,
) -> None:
    """Find where two run logs diverge: the first message, in log-time order, that differs
    between A and B (its topic, sim time, index on the topic and differing fields with both
    values in full precision), e.g. a run on a laptop against the same run in CI. Topics found
    in one log only, of another type or with another message count are listed first. Exit 0
    when identical, 1 when they differ, 2 for bad input. (`kartci compare` compares metrics.)"""
    # CLI start-up: the log readers
    from kartci.logs.damage import count_of
    from kartci.logs.diff import DiffOptions, Ignore, diff_logs

    options = DiffOptions(tolerance, wall_clock, tuple(Ignore.parse(i) for i in ignore or []),
                          fields)
    log_a, log_b = _run_log(a, "A"), _run_log(b, "B")
    result = diff_logs(log_a, log_b, options)
    for unused in result.unused_ignores:
        err_console.print(f"kartci: warning: --ignore {unused} matches no topic of either log",
                          highlight=False, markup=False)
    if result.identical:
        _say(f"identical: {count_of(result.compared, 'message')} compared on "
             f"{count_of(result.topics, 'topic')}"
             + "".join(f"; {s}" for s in _skipped_lines(result)))
        raise typer.Exit(0)
    _say(f"A: {log_a}\nB: {log_b}")
    for line in _diff_lines(result):
        _say(line)
    _say(f"logs differ ({count_of(result.compared, 'message')} compared; exit 1)")
    raise typer.Exit(1)


def _say(text: str) -> None:
    out_console.print(text, highlight=False, markup=False, soft_wrap=True)


def _run_log(path: Path, which: str) -> Path:
    """The log a path names: a log file, a rosbag2 folder, a run folder's run.mcap, or the one
    run's log in an OUT folder."""
    name = RunFolder.LOG_NAME
    what = f"give a run log (.mcap) or a run folder (OUT/<scenario>, holding {name})"
    if not path.exists():
        raise LogError(f"{which}: {path}: no such file or folder; {what}")
    if not path.is_dir() or (path / "metadata.yaml").is_file():
        return path
    folder = RunFolder(path)
    if folder.log.is_file():
        return folder.log
    runs = sorted(path.glob(f"*/{name}"))
    if len(runs) == 1:
        return runs[0]
    if runs:
        names = ", ".join(r.parent.name for r in runs)
        raise LogError(f"{which}: {path} holds {len(runs)} runs ({names}); give one of them, "
                       f"e.g. {runs[0].parent}")
    raise LogError(f"{which}: {path}: no {name} in this folder; {what}")


def _seconds(t_ns: int) -> str:
    return f"{t_ns / 1e9:.9f}".rstrip("0").rstrip(".") + " s"


def _value(v: object) -> str:
    from kartci.logs.diff import ABSENT  # CLI start-up: the log readers

    if v is ABSENT:
        return "(no such field)"
    text = repr(v)
    return text if len(text) <= 100 else f"{text[:97]}..."


def _field_line(f: FieldDiff, width: int) -> str:
    a, b = f.a, f.b
    if isinstance(a, str) and isinstance(b, str) and max(len(a), len(b)) > 60:
        at = next((i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y),
                  min(len(a), len(b)))
        start = max(at - 20, 0)
        return (f"  {f.path:<{width}}  strings differ from character {at}: "
                f"A ...{a[start:at + 40]!r}...  B ...{b[start:at + 40]!r}...")
    delta = f.delta
    return (f"  {f.path:<{width}}  A {_value(a)}  B {_value(b)}"
            + ("" if delta is None else f"  B-A {delta!r}"))


def _message_lines(d: MessageDiff) -> list[str]:
    head = (f"first difference: {d.topic} message {d.index} (counted from 0), "
            f"t = {_seconds(d.t_ns)}, {d.msgtype}")
    if d.t_a_ns is None or d.t_b_ns is None:
        has, lacks = ("B", "A") if d.t_a_ns is None else ("A", "B")
        n_a, n_b = d.counts
        return [head, f"  only in {has}: {lacks} has no message {d.index} on {d.topic} "
                      f"(A has {n_a}, B {n_b})"]
    lines = [head]
    if d.t_a_ns != d.t_b_ns:
        lines.append(f"  log time: A {_seconds(d.t_a_ns)}  B {_seconds(d.t_b_ns)}")
    width = max((len(f.path) for f in d.fields), default=0)
    lines += [_field_line(f, width) for f in d.fields]
    if d.more_fields:
        lines.append(f"  ... and {d.more_fields} more differing "
                     f"{'field' if d.more_fields == 1 else 'fields'} (--fields N shows more)")
    return lines


def _topic_line(t: TopicDiff) -> str:
    from kartci.logs.diff import TopicChange  # CLI start-up: the log readers

    a, b = t.a, t.b
    if t.change is TopicChange.ONLY_A and a is not None:
        return f"topic {t.topic}: only in A ({a.msgtype}, {a.count} messages)"
    if t.change is TopicChange.ONLY_B and b is not None:
        return f"topic {t.topic}: only in B ({b.msgtype}, {b.count} messages)"
    if t.change is TopicChange.TYPE and a is not None and b is not None:
        return f"topic {t.topic}: type {a.msgtype} in A, {b.msgtype} in B (not compared)"
    return (f"topic {t.topic}: {t.change.value}, A {a.count if a else 0}, "
            f"B {b.count if b else 0}")


def _skipped_lines(result: LogDiff) -> list[str]:
    # CLI start-up: the log readers
    from kartci.logs.damage import count_of
    from kartci.logs.diff import SkipReason

    out = []
    for s in (s for s in result.skipped if s.messages):
        hint = " (--wall-clock compares it)" if s.reason is SkipReason.WALL_CLOCK else ""
        out.append(f"not compared ({s.reason.value}): {s.field} on {s.topic}, in "
                   f"{count_of(s.messages, 'message')}{hint}")
    if result.ignored_topics:
        out.append(f"not compared (--ignore): {', '.join(result.ignored_topics)}")
    return out


def _diff_lines(result: LogDiff, shown: int = 10) -> list[str]:
    lines = [_topic_line(t) for t in result.topic_diffs[:shown]]
    if len(result.topic_diffs) > shown:
        lines.append(f"... and {len(result.topic_diffs) - shown} more topics that differ")
    if result.first is not None:
        lines += _message_lines(result.first)
    elif result.topics:
        lines.append(f"no message differs on the {result.topics} topics both logs have")
    return lines + _skipped_lines(result)
