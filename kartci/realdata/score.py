"""`kartci score` and `kartci simreal`: a foreign log imported as a run log (see importer), with
the sim's runs beside it for simreal, then scored, judged against its baseline and reported
exactly as a simulated run is."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path

from kartci.core import RunFolder
from kartci.logs import open_log
from kartci.metrics.alignment import Alignment
from kartci.project import Project
from kartci.realdata.importer import import_log
from kartci.realdata.profile import Profile, resolve_profile
from kartci.realdata.runlog import write_result
from kartci.runner.run import evaluate
from kartci.verdict.result import ScenarioResult


def score_log(log: Path, profile_path: Path | None, out: Path, baselines: Path, proj: Project,
              allow_outside_paths: bool = False, align: Alignment | None = None,
              align_first: int | None = None, with_plots: bool = True,
              t_max_diff_s: float | None = None) -> ScenarioResult:
    """Import `log` into OUT/<profile name>/run.mcap, compute metrics.json from it and judge it
    against `baselines/<profile name>.json`. `align` / `align_first` / `t_max_diff_s` replace
    the profile's (the estimate's alignment onto the reference, the pose pairs' largest stamp
    difference); `with_plots`: the report's time series and
    paths too (only an HTML report draws them). Bad input (profile, missing topics, a
    profile's track outside the project without `allow_outside_paths`) raises before anything
    is written. The project is looked up once (every registry lookup would read its file)."""
    with open_log(log) as reader:  # opened once: checked, then imported
        profile, info = resolve_profile(log, profile_path, proj, allow_outside_paths, reader)
        update = {k: v for k, v in (("align", align), ("align_first", align_first),
                                    ("t_max_diff_s", t_max_diff_s)) if v is not None}
        profile = Profile.model_validate({**profile.model_dump(), **update})
        types = {role: i.msgtype for role, i in info.items()}
        folder = RunFolder(out / profile.name)
        write_result(folder, profile.name,
                     lambda dst: import_log(log, profile, types, dst, reader).warnings,
                     {"imported_from": str(log.resolve()), "profile": profile.name})
        return evaluate(folder, baselines, proj, with_plots)


def simreal_log(log: Path, profile_path: Path | None, scenario: str | None,
                overrides: Sequence[str], window_s: float, out: Path,
                baselines: Path, proj: Project, allow_outside_paths: bool = False,
                say: Callable[[str], None] = print) -> ScenarioResult:
    """The log's commands replayed into the sim (whole and windowed) into
    OUT/<profile name>_simreal/, scored for divergence and judged like a run. A scenario
    guessed from the log (none named) is told through `say`, with why, in one line."""
    from kartci.realdata import simreal  # start-up: the simulator and its scipy, not for score

    profile, info = resolve_profile(log, profile_path, proj, allow_outside_paths)
    types = {role: i.msgtype for role, i in info.items()}
    setup = simreal.sim_setup(profile, scenario, overrides, proj, types)
    if setup.picked:
        say(setup.picked)
    simreal.check_commands(setup, profile, types)
    name = f"{profile.name}_simreal"
    t0 = time.perf_counter()

    def make(dst: Path) -> tuple[str, ...]:
        simreal.simreal_log(log, profile, types, setup, window_s, dst)
        return ()

    folder = RunFolder(out / name)
    write_result(folder, name, make,
                 {"imported_from": str(log.resolve()), "profile": profile.name,
                  "scenario": setup.scenario.name, "overrides": list(setup.overrides),
                  "window_s": window_s})
    result = evaluate(folder, baselines, proj)
    result.run["wall_s"] = round(time.perf_counter() - t0, 3)
    return result
