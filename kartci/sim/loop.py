"""The fixed-step loop: `simulate()` runs a scenario to its end as one client of `Session`.

The loop knows the `Robot` and `SimWorld` contracts only; the registries say which controller,
robot and world classes a scenario names (see `kartci.sim.session`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from pathlib import Path

from kartci.scenario import Scenario
from kartci.sim.session import Bus, RunInfo, Session, build_world, make_world


def simulate(scenario: Scenario, log_path: Path,
             on_progress: Callable[[float], None] | None = None,
             agents: Mapping[str, object] | None = None) -> RunInfo:
    """Run a scenario to its end and write its log; raises KartciError on bad input or a
    broken state (a failed run leaves no log behind).

    Args:
        scenario: The validated scenario.
        log_path: Where the MCAP log goes.
        on_progress: Called with the sim time reached, s, after every physics step (an
            exception it raises, say a wall-clock limit, ends the run as failed); cheap to
            call, so a time limit can name the sim time it stopped at.
        agents: Agent objects by agent name, replacing those agents' controllers.
    """
    with Session(scenario, log_path, agents) as session:
        session.reset()
        session.run_to_end(on_progress)  # step() without a result a step: nothing here reads one
        return session.info()


__all__ = ["Bus", "RunInfo", "build_world", "make_world", "simulate"]
