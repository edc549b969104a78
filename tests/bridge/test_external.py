"""`controller: {type: external}` end to end: a separate program drives closed loop over Zenoh;
an independent subscriber sees rmw_zenoh's keys, attachments and tokens; two runs at once do
not hear each other; the program crashing, hanging or answering late is an error for its
scenario only; the example stack's runs are byte-identical."""

from __future__ import annotations

import json
import os
import shutil
import signal
import struct
import sys
from pathlib import Path
from typing import Any

import pytest
import xxhash
import yaml
from helpers import ROOT, kartci

from kartci.bridge.agent import child_env

SCENARIOS = ROOT / "scenarios"
LISTENER = Path(__file__).with_name("zenoh_listener.py")
TWO_STAGE = Path(__file__).with_name("zenoh_two_stage.py")
DRIVER = ROOT / "examples" / "zenoh_stack" / "kart_driver.py"


def external(duration_s: float, command: list[str], **controller: Any) -> dict[str, Any]:
    """The shipped external scenario, shortened, with another program and settings."""
    spec: dict[str, Any] = yaml.safe_load((SCENARIOS / "external_pure_pursuit.yaml").read_text())
    spec["duration_s"] = duration_s
    spec["criteria"] = {}
    spec["agents"]["kart0"]["controller"].update(command=command, **controller)
    return spec


def project(tmp_path: Path, specs: dict[str, dict[str, Any]]) -> Path:
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    for name, spec in specs.items():
        (proj / "scenarios" / f"{name}.yaml").write_text(yaml.safe_dump(spec))
    return proj


def listener(out: Path, *distro: str) -> list[str]:
    return ["{python}", str(LISTENER), str(out), "{namespace}", *distro]


@pytest.fixture(scope="module")
def two_at_once(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Any]:
    """Two external runs with -j 2, both domain 0 and the same topic names, each with its own
    independent listener; durations differ so each knows which ticks are its own."""
    tmp = tmp_path_factory.mktemp("j2")
    seen = tmp / "seen"
    seen.mkdir()
    proj = project(tmp, {"ext_a": external(1.0, listener(seen / "a.json")),
                         "ext_b": external(1.5, listener(seen / "b.json"))})
    out = tmp / "out"
    p = kartci("run", "-j", "2", "--out", out, "--no-strict", cwd=proj)
    return out, seen, p


@pytest.mark.long(reason="a Zenoh stack driving full runs")
def test_independent_subscriber_sees_clock_odometry_and_tokens(two_at_once: Any) -> None:
    out, seen, p = two_at_once
    assert p.returncode == 0, p.stdout + p.stderr
    s = json.loads((seen / "a.json").read_text())
    clock_key = ("0/clock/rosgraph_msgs::msg::dds_::Clock_/"
                 "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564")
    odom_key = ("0/kart0/odom/nav_msgs::msg::dds_::Odometry_/"
                "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0")
    # /clock once per control tick (0.02 s) from t = 0 to 1 s, in order, with attachments
    assert [c["stamp"] for c in s["clock"]] == [k * 20_000_000 for k in range(51)]
    assert {c["key"] for c in s["clock"]} == {clock_key}
    assert [c["seq"] for c in s["clock"]] == list(range(1, 52))
    assert {(c["len"], c["gid_len"]) for c in s["clock"]} == {(33, 16)}
    assert {o["key"] for o in s["odom"]} == {odom_key}
    assert s["odom"][0]["stamp"] == 0 and s["odom"][-1]["stamp"] == 1_000_000_000
    tokens = s["tokens"]
    bridge = [t for t in tokens if t.endswith("/NN/%/%/kartci")]
    assert len(bridge) == 1
    zid = bridge[0].split("/")[2]
    clock_token = (f"@ros2_lv/0/{zid}/0/11/MP/%/%/kartci/%clock/rosgraph_msgs::msg::dds_::"
                   f"Clock_/{clock_key.rsplit('/', 1)[1]}/::,10:,:,:,,")
    assert clock_token in tokens
    # the GID as rmw_zenoh's: XXH3-128 of the publisher's token, low then high 64 bits, LE
    h = xxhash.xxh3_128_intdigest(clock_token.encode())
    assert {c["gid"] for c in s["clock"]} == {
        struct.pack("<QQ", h & (2**64 - 1), h >> 64).hex()}
    assert any(t.startswith(f"@ros2_lv/0/{zid}/0/") and "/MP/%/%/kartci/%kart0%odom/"
               "nav_msgs::msg::dds_::Odometry_/" + odom_key.rsplit("/", 1)[1] in t
               for t in tokens)
    assert any("/MS/%/%/kartci/%kart0%ackermann_cmd/" in t for t in tokens)
    # what crossed the bridge is in the log: one command per tick, stamped with the tick
    run = json.loads((out / "ext_a" / "run.json").read_text())
    assert run["sim_time_s"] == 1.0
    assert (out / "ext_a" / "kart0.external.stdout.log").exists()


def test_two_runs_at_once_do_not_hear_each_other(two_at_once: Any) -> None:
    _, seen, p = two_at_once
    assert p.returncode == 0, p.stdout + p.stderr
    for name, ticks in (("a", 51), ("b", 76)):
        s = json.loads((seen / f"{name}.json").read_text())
        assert [c["stamp"] for c in s["clock"]] == [k * 20_000_000 for k in range(ticks)]
        nodes = {t.split("/")[2] for t in s["tokens"] if t.endswith("/NN/%/%/kartci")}
        assert len(nodes) == 1, f"{name} heard {len(nodes)} kartci sessions"
    a, b = (json.loads((seen / f"{n}.json").read_text()) for n in "ab")
    assert {t.split("/")[2] for t in a["tokens"]}.isdisjoint(
        {t.split("/")[2] for t in b["tokens"]})


def test_run_json_says_how_to_attach_ros2_tools_to_each_run(two_at_once: Any) -> None:
    """Each run's Zenoh endpoint (its own free port) and a ready `ros2 topic echo` command
    connecting an rmw_zenoh tool to it, in run.json (no terminal here: nothing printed)."""
    out, _, p = two_at_once
    assert p.returncode == 0, p.stdout + p.stderr
    assert "attach ROS 2 tools" not in p.stderr
    seen = {}
    for name in ("ext_a", "ext_b"):
        facts = json.loads((out / name / "run.json").read_text())["attach"]["kart0"]
        endpoint = facts["endpoint"]
        assert endpoint.startswith("tcp/127.0.0.1:")
        override = child_env(endpoint, 0, "kart0")["ZENOH_CONFIG_OVERRIDE"]
        assert f'connect/endpoints=["{endpoint}"]' in override
        assert facts == {
            "middleware": "zenoh", "rmw": "rmw_zenoh_cpp", "domain_id": 0,
            "endpoint": endpoint, "command": (
                f"ROS_DOMAIN_ID=0 ZENOH_CONFIG_OVERRIDE='{override}' "
                "ZENOH_ROUTER_CHECK_ATTEMPTS=-1 RMW_IMPLEMENTATION=rmw_zenoh_cpp "
                "ros2 topic echo /kart0/ackermann_cmd")}
        seen[name] = endpoint
    assert seen["ext_a"] != seen["ext_b"]


@pytest.mark.long(reason="a Zenoh stack driving full runs")
def test_crash_hang_and_late_are_errors_for_their_scenario_only(tmp_path: Path) -> None:
    copy = tmp_path / "kart_driver.py"  # a path of this test's own, to look for leftovers by
    shutil.copy(DRIVER, copy)
    driver = ["{python}", str(copy), "--connect", "{endpoint}"]
    quick = {"tick_timeout_s": 0.2, "max_late_in_row": 3}
    ok = external(1.0, driver)
    proj = project(tmp_path, {
        "crash": external(2.0, [*driver, "--crash-at-s", "0.5"]),
        "hang": external(2.0, [*driver, "--hang-at-s", "0.3"], **quick),
        "late": external(2.0, [*driver, "--delay-s", "0.3"], **quick),
        "dead": external(2.0, ["{python}", "-c", "import sys; print('no such stack', "
                                                 "file=sys.stderr); sys.exit(4)"]),
        "missing": external(2.0, ["/nonexistent/stack"]),
        "silent": external(2.0, ["{python}", "-c", "import time; time.sleep(60)"],
                           startup_timeout_s=0.5),
        "slow": external(0.2, [*driver, "--delay-s", "0.3"], tick_timeout_s=0.2,
                         max_late_in_row=100),
        "ok": ok})
    out = tmp_path / "out"
    p = kartci("run", "-j", "2", "--out", out, "--no-strict", cwd=proj)
    assert p.returncode == 2, p.stdout + p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert summary["ok"]["status"] == "new"
    # late but within max_late_in_row: every tick (0 to 0.2 s) counted late, the run finishes
    assert summary["slow"]["status"] == "new"
    assert [m.data for m in messages(out / "slow" / "run.mcap",
                                     "/kart0/bridge/late_commands")] == list(range(1, 12))
    timing = json.loads((out / "slow" / "metrics.json").read_text())["timing"]
    assert timing["late_commands"]["value"] == 11
    errors = {n: summary[n]["error"] for n in ("crash", "hang", "late", "dead", "silent")}
    assert all(summary[n]["status"] == "error" for n in errors)
    assert "exited with code 3 at t=0.500 s" in errors["crash"]
    assert "crashing on purpose at t=0.50 s" in errors["crash"]
    assert "no answer within 0.2 s for 3 ticks in a row" in errors["hang"]
    assert "hanging on purpose" in errors["hang"]
    assert "no answer within 0.2 s for 3 ticks in a row" in errors["late"]
    assert "no such stack" in errors["dead"] and "exited with code 4" in errors["dead"]
    assert "within 0.5 s the stack declared no subscription to /clock" in errors["silent"]
    assert summary["missing"]["status"] == "error"
    assert "cannot start '/nonexistent/stack'" in summary["missing"]["error"]
    for name in errors:  # the program's output is kept beside the error
        assert (out / name / "kart0.external.stderr.log").exists()
    assert "no such stack" in (out / "report.html").read_text()
    # every program was stopped with its run: no process with our driver's path is left
    left = [p for p in Path("/proc").iterdir() if p.name.isdigit() and str(copy).encode()
            in _cmdline(p)] if sys.platform == "linux" else []
    assert left == []


def messages(log: Path, topic: str) -> list[Any]:
    """The decoded messages of one topic of a run log."""
    from mcap.reader import make_reader

    from kartci.logs.types import typestore

    with log.open("rb") as f:
        return [typestore().deserialize_cdr(m.data, s.name if s else "")
                for s, _, m in make_reader(f).iter_messages(topics=[topic])]


@pytest.mark.long(reason="a Zenoh stack driving a run")
def test_paced_mode_runs_at_its_real_time_factor(tmp_path: Path, baselines: Path) -> None:
    """Paced: sim time is held to 2x wall clock (3 s of sim take at least 1.5 s), the stack's
    latest commands drive the kart (3 s, not 1: a stack slow to start on a loaded machine
    still answers within the run)."""
    proj = project(tmp_path, {"paced": external(
        3.0, ["{python}", str(DRIVER), "--connect", "{endpoint}"], mode="paced",
        real_time_factor=2.0)})
    out = tmp_path / "out"
    p = kartci("run", "--out", out, "--baselines", baselines, "--no-strict", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    assert json.loads((out / "paced" / "run.json").read_text())["wall_s"] >= 1.5
    cmds = messages(out / "paced" / "run.mcap", "/kart0/ackermann_cmd")
    assert len(cmds) > 10 and max(c.drive.speed for c in cmds) > 3.0


def _cmdline(proc: Path) -> bytes:
    try:
        return (proc / "cmdline").read_bytes()
    except OSError:
        return b""


@pytest.mark.long(reason="the example stack, two full runs")
def test_the_example_stack_gives_byte_identical_metrics(tmp_path: Path,
                                                       baselines: Path) -> None:
    """Two lockstep runs of the shipped scenario (shortened to one lap) with the example
    program: the same metrics, byte for byte, and the kart really drove."""
    metrics = []
    for k in range(2):
        out = tmp_path / f"o{k}"
        p = kartci("run", "external_pure_pursuit", "--set", "duration_s=16", "--set",
                   "criteria={}", "--out", out, "--baselines", baselines, "--no-strict",
                   cwd=ROOT)
        assert p.returncode == 0, p.stdout + p.stderr
        metrics.append((out / "external_pure_pursuit" / "metrics.json").read_bytes())
    assert metrics[0] == metrics[1]
    values = json.loads(metrics[0])["metrics"]
    assert values["laps_completed"]["value"] == 1
    assert values["collisions"]["value"] == 0
    assert values["mean_speed_mps"]["value"] > 3.5


@pytest.mark.long(reason="a Zenoh stack driving a run")
def test_a_stack_started_by_hand_connects_to_a_fixed_port(tmp_path: Path,
                                                          baselines: Path) -> None:
    """No `command`: the user starts the stack, told the port; kartci waits for it."""
    import subprocess

    from kartci.bridge.link import free_port

    port = free_port()
    proj = project(tmp_path, {"by_hand": external(0.5, [], port=port)})
    seen = tmp_path / "seen.json"
    stack = subprocess.Popen([sys.executable, str(LISTENER), str(seen), "kart0"],
                             env={**os.environ,
                                  "KARTCI_ZENOH_ENDPOINT": f"tcp/127.0.0.1:{port}"})
    try:
        p = kartci("run", "--out", tmp_path / "out", "--baselines", baselines, "--no-strict",
                   cwd=proj)
    finally:
        stack.terminate()
        stack.wait(10)
    assert p.returncode == 0, p.stdout + p.stderr
    stamps = [c["stamp"] for c in json.loads(seen.read_text())["clock"]]
    assert stamps == [k * 20_000_000 for k in range(26)]


@pytest.mark.long(reason="a Zenoh stack driving full runs")
def test_a_stack_of_two_processes_meets_through_kartci(tmp_path: Path, baselines: Path) -> None:
    """Planner and driver both connect to kartci only; kartci's gossip tells each where the
    other listens, so the plan reaches the driver and every tick is answered on time."""
    stack = ["{python}", str(TWO_STAGE), "{namespace}"]
    proj = project(tmp_path, {"two": external(0.5, stack, startup_timeout_s=10.0)})
    out = tmp_path / "out"
    p = kartci("run", "--out", out, "--baselines", baselines, "--no-strict", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    cmds = messages(out / "two" / "run.mcap", "/kart0/ackermann_cmd")
    stamps = [c.header.stamp.sec * 10**9 + c.header.stamp.nanosec for c in cmds]
    assert stamps == [k * 20_000_000 for k in range(26)]
    timing = json.loads((out / "two" / "metrics.json").read_text())["timing"]
    assert timing["late_commands"]["value"] == 0


@pytest.mark.long(reason="a Zenoh stack driving a run")
@pytest.mark.parametrize("kartci_is_router", [False, True])
def test_a_stack_behind_a_router_drives(tmp_path: Path, baselines: Path,
                                        kartci_is_router: bool) -> None:
    """A two-process stack (gossip on, as rmw_zenoh's nodes) connects only to a router: one the
    test starts on 127.0.0.1 that kartci joins (`connect`), or kartci itself (`zenoh_mode:
    router`). (Peers meet through gossip: a zenoh 1.10 router did not forward between two peers
    of which one had gossip off.)"""
    import subprocess

    import zenoh

    from kartci.bridge.link import free_port

    port = free_port()
    router_ep = f"tcp/127.0.0.1:{port}"
    router = None
    if kartci_is_router:
        settings: dict[str, Any] = {"zenoh_mode": "router", "port": port}
    else:
        conf = zenoh.Config()
        conf.insert_json5("mode", '"router"')
        conf.insert_json5("listen/endpoints", json.dumps([router_ep]))
        conf.insert_json5("scouting/multicast/enabled", "false")
        router = zenoh.open(conf)
        settings = {"connect": [router_ep]}
    proj = project(tmp_path, {"routed": external(0.5, [], **settings)})
    stack = subprocess.Popen([sys.executable, str(TWO_STAGE), "kart0"], start_new_session=True,
                             env={**os.environ, "KARTCI_ZENOH_ENDPOINT": router_ep})
    try:
        p = kartci("run", "--out", tmp_path / "out", "--baselines", baselines, "--no-strict",
                   cwd=proj)
    finally:
        os.killpg(stack.pid, signal.SIGTERM)
        stack.wait(10)
        if router is not None:
            router.close()  # type: ignore[no-untyped-call]
    assert p.returncode == 0, p.stdout + p.stderr
    cmds = messages(tmp_path / "out" / "routed" / "run.mcap", "/kart0/ackermann_cmd")
    stamps = [c.header.stamp.sec * 10**9 + c.header.stamp.nanosec for c in cmds]
    assert stamps == [k * 20_000_000 for k in range(26)]


def test_joining_a_remote_endpoint_is_refused_unless_allowed(tmp_path: Path) -> None:
    proj = project(tmp_path, {"far": external(0.5, [], connect=["tcp/192.0.2.1:7447"])})
    p = kartci("run", "--out", tmp_path / "out", "--no-strict", cwd=proj)
    assert p.returncode == 2
    assert "Traceback" not in p.stdout + p.stderr
    assert ("bridge: tcp/192.0.2.1:7447 reaches beyond this host; set allow_remote: true in "
            "the external controller to allow it") in p.stdout + p.stderr


@pytest.mark.long(reason="a Zenoh stack driving a run")
def test_a_humble_stack_drives_with_humbles_keys(tmp_path: Path) -> None:
    """`ros_distro: humble`: keys and tokens carry `TypeHashNotSupported` (rmw_zenoh on Humble);
    the independent stack, speaking Humble's keys, answers every tick."""
    seen = tmp_path / "seen.json"
    proj = project(tmp_path, {"humble": external(0.5, listener(seen, "humble"),
                                                 ros_distro="humble")})
    p = kartci("run", "--out", tmp_path / "out", "--no-strict", cwd=proj)
    assert p.returncode == 0, p.stdout + p.stderr
    s = json.loads(seen.read_text())
    assert {c["key"] for c in s["clock"]} == {
        "0/clock/rosgraph_msgs::msg::dds_::Clock_/TypeHashNotSupported"}
    assert {o["key"] for o in s["odom"]} == {
        "0/kart0/odom/nav_msgs::msg::dds_::Odometry_/TypeHashNotSupported"}
    assert any(t.endswith("/MP/%/%/kartci/%clock/rosgraph_msgs::msg::dds_::Clock_/"
                          "TypeHashNotSupported/::,10:,:,:,,") for t in s["tokens"])
    cmds = messages(tmp_path / "out" / "humble" / "run.mcap", "/kart0/ackermann_cmd")
    assert [c.header.stamp.sec * 10**9 + c.header.stamp.nanosec for c in cmds] == [
        k * 20_000_000 for k in range(26)]


def test_an_unknown_ros_distro_is_one_line(tmp_path: Path) -> None:
    proj = project(tmp_path, {"iron": external(0.5, [], ros_distro="iron")})
    p = kartci("run", "--out", tmp_path / "out", "--no-strict", cwd=proj)
    assert p.returncode == 2
    assert "Traceback" not in p.stdout + p.stderr
    assert p.stderr.count("\n") == 1 and p.stderr.endswith(
        "agents.kart0.controller.ros_distro: Input should be 'humble', 'jazzy', 'kilted', "
        "'lyrical' or 'rolling'\n")
