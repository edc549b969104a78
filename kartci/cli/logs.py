"""`kartci replay` and `extract`: recorded logs in, as inputs or as copies."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from kartci.cli.common import (
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
from kartci.errors import SpecError

if TYPE_CHECKING:
    from kartci.logs.reader import TopicInfo


@app.command()
def replay(
    log: Annotated[Path, typer.Argument(help="ROS 1 .bag, rosbag2 folder or .mcap file.")],
    scenario: Annotated[str, typer.Option(help="Scenario whose world and kart replay the log.")]
    = "kart_replay",
    topic: Annotated[str | None, typer.Option(
        help="Input topic (default: the log's only Joy or command topic).")] = None,
    mapping: Annotated[str, typer.Option(help="Joystick mapping for Joy logs: a name "
                                              "(models/gokart/joy/<name>.yaml: ps4, xbox, g29) "
                                              "or a path to a mapping YAML file.")] = "ps4",
    agent: Annotated[str | None, typer.Option(help="Agent to drive (default: the first).")]
    = None,
    set_: SetOpt = None,
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
    from kartci.agents.joy import check_pad, load_mapping
    from kartci.agents.kart import JOY
    from kartci.agents.params import CommandsController, ManualController
    from kartci.runner import Job, run_jobs
    from kartci.runner.outdir import clear_reports, locked, write_manifest
    from kartci.spec import load_scenario
    from kartci.spec.models import LogSource

    out = out_dir(out, "replay")
    spec = load_scenario(scenario, set_ or [])
    name = agent or next(iter(spec.agents))
    if name not in spec.agents:
        raise SpecError(f"scenario {spec.name} has no agent '{name}' "
                        f"(agents: {', '.join(spec.agents)})")
    chosen = _input_topic(log, topic)
    source = LogSource(log=str(log.resolve()), topic=chosen.topic)
    controller: ManualController | CommandsController
    if chosen.msgtype in JOY:
        check_pad(load_mapping(mapping), mapping, log, chosen.topic)
        controller = ManualController(mapping=mapping, source=source)
    else:
        controller = CommandsController(source=source)
    agents = dict(spec.agents)
    agents[name] = agents[name].model_copy(update={"controller": controller})
    spec = spec.model_copy(update={"agents": agents})
    err_console.print(f"replaying {chosen.topic} ({chosen.msgtype}, {chosen.count} messages) "
                      f"into {spec.name}/{name}", highlight=False, markup=False)
    with locked(out):
        clear_reports(out)
        write_manifest(out, "replay", [spec.name])
        finish(run_jobs([Job(spec, spec.name)], out, baselines_dir(baselines),
                        strict=strict_mode(strict)), out)


def _input_topic(log: Path, topic: str | None) -> TopicInfo:
    """The log's input topic: the one named (which must be a Joy or drive-command topic with
    messages), else its only such topic."""
    from kartci.agents.kart import COMMANDS, JOY
    from kartci.logs import topics

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
    from kartci.logs import extract as copy_topics

    n = copy_topics(log, topic, out)
    out_console.print(f"wrote {out}: {n} messages", highlight=False)


def _open_loop(log: Path, agent: str | None, ns: str | None, reference: Path | None,
               tolerance: list[str], out: Path) -> None:
    from kartci.realdata.openloop import open_loop

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
        text = (f"{'✅' if ok else '❌'} {r.topic}: {r.compared} messages compared, "
                f"{r.differing} differ" + (f" ({worst})" if worst else "")
                + (f"; {r.note}" if r.note else ""))
        out_console.print(text, highlight=False, markup=False)
    out_console.print(f"outputs: {out / 'openloop.mcap'}  (exit {1 if bad else 0})",
                      highlight=False)
    raise typer.Exit(1 if bad else 0)
