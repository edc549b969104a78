"""Issue 24, the gate: a baseline accepted from another scenario (stale) or with a tolerance
loosened by hand never lets a run pass in CI unnoticed."""

from __future__ import annotations

import json
import shutil
import tomllib
from pathlib import Path
from typing import Any

import pytest
from helpers import ROOT, kartci

from kartci.project import current as active_project
from kartci.verdict import load
from kartci.verdict.baseline import above, policy_bound

SCENARIO = """\
description: quick line tracker
world: line_lab/straight
duration_s: 2.0
seed: 1
agents:
  lt0:
    model: line_tracker
    start: {along_m: 0.1, lateral_m: 0.005}
    controller: {type: line_pid, kp: 100.0, ki: 0.0, period_s: 0.06, v1_mps: 0.1}
    sensors: {line_sensor: {mode: geometric}}
metrics:
  line_tracking: {transient_s: 0.5, settle_band_m: 0.001}
"""
CONFIG = '[tool.kartci]\nscenarios = ["scenarios"]\n'
CI = {"CI": "true"}


@pytest.fixture(scope="module")
def accepted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A project with scenario q, run once into `out` and accepted as its baseline."""
    proj = tmp_path_factory.mktemp("accepted")
    (proj / "scenarios").mkdir()
    (proj / "scenarios" / "q.yaml").write_text(SCENARIO)
    (proj / "pyproject.toml").write_text(CONFIG)
    for cmd in (("run", "q", "--out", "out"), ("baseline", "update", "out", "--replicas", "0")):
        p = kartci(*cmd, cwd=proj)
        assert p.returncode == 0, p.stdout + p.stderr
    return proj


def _copy(accepted: Path, tmp_path: Path) -> Path:
    proj = tmp_path / "proj"
    shutil.copytree(accepted, proj)
    return proj


def _scenario(out: Path) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads((out / "summary.json").read_text())["scenarios"]["q"]
    return doc


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_changed_scenario_makes_its_baseline_stale(accepted: Path, tmp_path: Path) -> None:
    proj = _copy(accepted, tmp_path)
    stale = ("baseline is stale: scenario changed since it was accepted (fields: {}); run it as "
             "accepted, or accept the change with `kartci baseline update`")
    # `--set` changes the scenario: a run with it is judged against a stale baseline
    p = kartci("run", "q", "--set", "agents.lt0.controller.kp=110", "--out", "set", cwd=proj,
               env=CI)
    assert p.returncode == 1, p.stdout + p.stderr
    assert _scenario(proj / "set")["problems"] == [stale.format("agents.lt0.controller.kp")]
    # so is a change in the scenario file: a gain and the duration
    q = proj / "scenarios" / "q.yaml"
    q.write_text(q.read_text().replace("kp: 100.0", "kp: 110.0").replace("duration_s: 2.0",
                                                                         "duration_s: 3.0"))
    stale = stale.format("agents.lt0.controller.kp, duration_s")
    p = kartci("run", "q", "--out", "second", cwd=proj, env=CI)
    assert p.returncode == 1, p.stdout + p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    result = _scenario(proj / "second")
    assert result["problems"] == [stale]
    assert result["metrics"]["completion"]["status"] == "improved"  # what the gate said before
    # outside CI a visible warning in every output, not a failure
    p = kartci("report", "second", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"kartci: warning: q: {stale}" in " ".join(p.stderr.split())
    assert _scenario(proj / "second")["warnings"] == [stale]
    assert f"warning: {stale}" in (proj / "second" / "summary.md").read_text()
    assert stale.replace("`", "") in (proj / "second" / "junit.xml").read_text().replace("`",
                                                                                          "")
    # accepting the change shows it field by field and records the new scenario
    p = kartci("baseline", "update", "second", "--replicas", "0", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    assert ("q: accepting a changed scenario (2 fields)\n"
            "  scenario agents.lt0.controller.kp: 100.0 -> 110.0\n"
            "  scenario duration_s: 2.0 -> 3.0\n") in p.stdout
    assert kartci("report", "second", cwd=proj, env=CI).returncode == 0
    # a baseline made before baselines recorded their scenario: a warning, not a CI failure
    path = proj / "baselines" / "q.json"
    doc = json.loads(path.read_text())
    del doc["scenario_hash"], doc["scenario_fields"]
    path.write_text(json.dumps(doc))
    p = kartci("report", "second", cwd=proj, env=CI)
    assert p.returncode == 0, p.stdout + p.stderr
    assert _scenario(proj / "second")["warnings"] == [
        "no scenario hash recorded in baseline q.json: a changed scenario would pass unnoticed; "
        "`kartci baseline update` records it"]


@pytest.mark.long(reason="several kartci runs end to end")
def test_a_tolerance_loosened_by_hand_fails_in_ci(accepted: Path, tmp_path: Path) -> None:
    proj = _copy(accepted, tmp_path)
    path = proj / "baselines" / "q.json"
    doc = json.loads(path.read_text())
    for name, entry in doc["metrics"].items():
        entry["tolerance"] = 1e9
        if name in ("completion", "mean_speed_mps"):
            entry["value"] *= 2  # this run: completion and speed halved
    path.write_text(json.dumps(doc))
    bounds = {n: policy_bound(n, e, 3.0) for n, e in (load(path) or {}).items()}
    loose = [f"{n}: baseline tolerance 1e+09 is loosened beyond the policy bound {b:.3g} (the "
             f"larger of 3x its default tolerance and 3x its spread); narrow it in the baseline, "
             f'or allow it in [tool.kartci.allow_loose_tolerances] as "q:{n}" = "<reason>"'
             for n, b in sorted(bounds.items())]
    p = kartci("report", "out", cwd=proj, env=CI)
    assert p.returncode == 1, p.stdout + p.stderr
    result = _scenario(proj / "out")
    assert result["problems"] == loose
    assert result["metrics"]["completion"]["status"] == "pass"  # what the gate said before
    assert f"LOOSENED: bound ±{bounds['completion']:.3g}" in p.stdout
    assert kartci("report", "out", cwd=proj).returncode == 0  # outside CI: warnings
    assert _scenario(proj / "out")["warnings"] == loose
    # allowed by name, with a reason, in the project's configuration: passes, still shown
    allow = "".join(f'"q:{n}" = "tested wide"\n' for n in bounds)
    (proj / "pyproject.toml").write_text(f"{CONFIG}\n[tool.kartci.allow_loose_tolerances]\n"
                                         f"{allow}")
    p = kartci("report", "out", cwd=proj, env=CI)
    assert p.returncode == 0, p.stdout + p.stderr
    assert f"allowed: bound ±{bounds['completion']:.3g}" in p.stdout
    # an update keeps the hand-set tolerances, never silently: a line for each
    p = kartci("baseline", "update", "out", "--replicas", "0", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    bounds = {n: policy_bound(n, e, 3.0) for n, e in (load(path) or {}).items()}  # new values
    assert [ln.strip() for ln in p.stdout.splitlines() if "kept tolerance" in ln] == [
        f"kept tolerance {n}: 1e+09 above the policy bound {b:.3g} (allowed: tested wide)"
        for n, b in sorted(bounds.items())]
    assert {e["tolerance"] for e in json.loads(path.read_text())["metrics"].values()} == {1e9}


def test_committed_baselines_keep_the_tolerance_policy() -> None:
    """Every tolerance in baselines/ is within the policy bound or allowed by name."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["kartci"]
    allowed = config.get("allow_loose_tolerances", {})
    loose = sorted(f"{path.stem}:{name}" for path in (ROOT / "baselines").glob("*.json")
                   for name, entry in (load(path) or {}).items()
                   if (b := policy_bound(name, entry, config.get("loosen_factor", 3.0)))
                   is not None and above(float(entry["tolerance"]), b))
    assert loose == sorted(allowed) == ["perception_obstacles:kart0.recall_15m"]


def test_a_data_file_edited_in_place_makes_the_fields_differ(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The track CSV is named by path in the scenario; its bytes are hashed beside it, so a
    track edited in place moves the scenario hash as an edited scenario does."""
    from kartci import project
    from kartci.scenario import load_scenario
    from kartci.verdict import fingerprint

    world = tmp_path / "worlds" / "my"
    shutil.copytree(ROOT / "sims" / "winti", world)
    hall = world / "hall.yaml"
    hall.write_text(hall.read_text().replace("track: winti/track.csv", "track: my/track.csv"))
    (tmp_path / "pyproject.toml").write_text('[tool.kartci]\nworlds = ["worlds"]\n')
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("KARTCI_ROOT", raising=False)
    project.activate(None)

    def flat() -> dict[str, Any]:
        return fingerprint.fields(load_scenario("kart_manual", ["world=my/hall"],
                                                project=active_project()), active_project())

    before = flat()
    assert before["world.track"] == "my/track.csv"  # portable: as named in its world folder
    track = world / "track.csv"
    lines = track.read_text().splitlines(keepends=True)
    track.write_text("".join([*lines[:-1], lines[-1].replace("1", "2", 1)]))
    after = flat()
    assert fingerprint.changed(before, after) == ["world.track#sha256"]
    assert fingerprint.digest(before) != fingerprint.digest(after)


def test_committed_baselines_were_accepted_from_the_scenarios_as_they_are() -> None:
    """Every baseline in baselines/ records a scenario hash, and it matches the scenario (or
    sweep point) as it loads today: a change to a shipped scenario, world, model or data file
    without re-accepting its baselines fails here, not only in CI's run."""
    from kartci.scenario import load_scenario
    from kartci.verdict import fingerprint

    stale = []
    for path in sorted((ROOT / "baselines").glob("*.json")):
        name, _, point = path.stem.partition("@")
        found, _ = fingerprint.recorded(json.loads(path.read_text()))
        flat = fingerprint.fields(load_scenario(name, point.split(",") if point else [],
                                                project=active_project()), active_project())
        if found != fingerprint.digest(flat):
            stale.append(path.stem)
    assert stale == []


def test_a_parameter_added_at_its_default_leaves_older_baselines_current() -> None:
    """kart_wall's baseline as it was before the kart gained `steering_offset_rad` and
    `command_delay_s`: current for today's scenario (both at their defaults), stale once one
    is set, and stale for a field removed or changed as before."""
    from kartci.scenario import load_scenario
    from kartci.verdict import fingerprint

    new = ("agents.kart0.model.steering_offset_rad", "agents.kart0.model.command_delay_s")
    proj = active_project()
    spec = load_scenario("kart_wall", project=proj)
    flat = fingerprint.fields(spec, proj)
    assert set(new) <= fingerprint.defaulted(spec)
    old = {k: v for k, v in flat.items() if k not in new}
    doc = {"scenario_hash": fingerprint.digest(old), "scenario_fields": old}
    fresh = fingerprint.check(doc, flat, fingerprint.defaulted(spec))
    assert fresh.freshness is fingerprint.Freshness.CURRENT
    assert fingerprint.check(doc, flat).freshness is fingerprint.Freshness.STALE  # no defaults
    offset = load_scenario("kart_wall", [f"{new[0]}=0.05"], project=proj)
    got = fingerprint.check(doc, fingerprint.fields(offset, proj), fingerprint.defaulted(offset))
    assert got.freshness is fingerprint.Freshness.STALE and got.fields == (new[0],)
    fewer = {k: v for k, v in flat.items() if k != "duration_s"}
    got = fingerprint.check(doc, fewer, fingerprint.defaulted(spec))
    assert got.fields == ("duration_s",)
