"""`kartci replay` and `extract`: recorded logs in, as inputs or as copies."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import (
    BaselinesOpt,
    OutOpt,
    SetOpt,
    app,
    baselines_dir,
    err_console,
    finish,
    out_console,
    out_dir,
)
from kartci.errors import SpecError


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
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
) -> None:
    """Run a scenario with a recorded input stream driving one kart: sensor_msgs/Joy through a
    joystick mapping (the manual agent), or AckermannDriveStamped / Twist / TwistStamped
    commands. Log time is re-based so the first message is at sim time 0."""
    from kartci.agents.kart import COMMANDS, JOY
    from kartci.agents.params import CommandsController, ManualController
    from kartci.logs import topics
    from kartci.runner import Job, run_jobs
    from kartci.spec import load_scenario
    from kartci.spec.models import LogSource

    out = out_dir(out, "replay")
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
    finish(run_jobs([Job(spec, spec.name)], out, baselines_dir(baselines)), out)


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
