"""A stack of two unmodified processes over Zenoh (examples/zenoh_stack: `odom_relay.py` relays
the odometry, `kart_driver.py --odom-topic odom_relay` drives from the relay and answers each
/clock): the lockstep waits for the relay's message before each /clock, so identical runs give
identical metrics, with kartci as a Zenoh peer and as a router. The default tier runs each twice
for 1 s; the full tier ten times for 10 s each (the issue's check)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import ROOT, kartci

EXAMPLE = ROOT / "examples" / "zenoh_stack"
SCENARIO = ROOT / "scenarios" / "external_pure_pursuit.yaml"


def two_nodes(duration_s: float, mode: str) -> dict[str, Any]:
    """The shipped external scenario with the two-process stack, as a launch file starts it."""
    spec: dict[str, Any] = yaml.safe_load(SCENARIO.read_text())
    spec["duration_s"] = duration_s
    spec["criteria"] = {}
    controller = spec["agents"]["kart0"]["controller"]
    controller["command"] = [
        "sh", "-c", f"{{python}} {EXAMPLE / 'odom_relay.py'} & exec {{python}} "
        f"{EXAMPLE / 'kart_driver.py'} --odom-topic odom_relay --speed-mps 5.0 "
        "--lookahead-m 3.5"]
    if mode == "router":
        controller["zenoh_mode"] = "router"
    return spec


def repeated(tmp_path: Path, duration_s: float, runs: int) -> tuple[Path, Any, list[str]]:
    """`runs` copies of the two-node scenario per Zenoh mode, run in one `kartci run -j 2`."""
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    names = []
    for mode in ("peer", "router"):
        for k in range(runs):
            names.append(f"{mode}_{k}")
            (proj / "scenarios" / f"{names[-1]}.yaml").write_text(
                yaml.safe_dump(two_nodes(duration_s, mode)))
    out = tmp_path / "out"
    p = kartci("run", "-j", "2", "--out", out, "--no-strict", cwd=proj)
    return out, p, names


def deterministic(out: Path, names: list[str]) -> dict[str, dict[str, Any]]:
    """Each run's metrics (timing aside) and late ticks."""
    found = {}
    for name in names:
        doc = json.loads((out / name / "metrics.json").read_text())
        found[name] = {"metrics": doc["metrics"],
                       "late": doc["timing"]["late_commands"]["value"]}
    return found


def check(tmp_path: Path, duration_s: float, runs: int) -> None:
    out, p, names = repeated(tmp_path, duration_s, runs)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "lockstep waits for /kart0/ackermann_cmd after clock, /kart0/odom_relay after " \
           "sensors" in p.stderr
    found = deterministic(out, names)
    assert {n: f["late"] for n, f in found.items()} == dict.fromkeys(names, 0)
    first = found[names[0]]["metrics"]
    assert first["progress_m"]["value"] > 0.2 * duration_s  # it drives, from the relay's data
    spread = {n: sorted(k for k in first if f["metrics"][k] != first[k])
              for n, f in found.items()}
    assert spread == {n: [] for n in names}


def test_a_two_process_stack_gives_the_same_metrics_every_run(tmp_path: Path) -> None:
    check(tmp_path, 1.0, 2)


@pytest.mark.long(reason="twenty 10 s runs of a two-process Zenoh stack")
def test_a_two_process_stack_gives_the_same_metrics_ten_runs_in_each_mode(
        tmp_path: Path) -> None:
    check(tmp_path, 10.0, 10)


def test_repeats_of_a_stack_run_it_unchanged_and_name_what_differs(tmp_path: Path) -> None:
    """`--conditioning K` on an external stack repeats the run as it is (no nudge: the stack's
    timing is the noise); a stack whose answers follow the wall clock is flagged, with the
    first difference between two repeats."""
    def short(command: list[str]) -> dict[str, Any]:
        spec: dict[str, Any] = yaml.safe_load(SCENARIO.read_text())
        spec.update(duration_s=0.3, criteria={})
        spec["agents"]["kart0"]["controller"]["command"] = command
        return spec

    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    specs = {"steady": short(["{python}", str(EXAMPLE / "kart_driver.py")]),
             "coin": short(["{python}", str(Path(__file__).with_name("zenoh_coin.py")),
                            "{namespace}"])}
    for name, spec in specs.items():
        (proj / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    out = tmp_path / "out"
    p = kartci("run", "--conditioning", "3", "-j", "2", "--out", out, "--no-strict", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    for name in specs:
        for k in (1, 2):
            run = json.loads((out / name / f"repeat_{k}" / "run.json").read_text())
            assert run["variation"] == {"vary": "start", "k": k, "step": 0.0}
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert not [w for w in summary["steady"]["warnings"] if "repeats" in w]
    assert {m["conditioning"] for m in summary["steady"]["metrics"].values()} == {"well"}
    [warning] = [w for w in summary["coin"]["warnings"] if "repeats" in w]
    assert "mean_speed_mps" in warning and "differ between repeats of the same run" in warning
    assert "first difference against repeat_" in warning and "/kart0/ackermann_cmd" in warning
    assert summary["coin"]["metrics"]["mean_speed_mps"]["conditioning"] == "ill"
