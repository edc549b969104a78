"""Logs that open well in Foxglove and replay with ROS 2 tools: markers for the track, obstacles
and collisions; each robot's URDF on a latched topic; QoS metadata as rosbag2 writes it; one
consistent set of frame ids; the shipped layout; the kartci_msgs ROS package agreeing with
kartci's own message definitions."""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
import yaml
from helpers import ROOT
from mcap.reader import make_reader

from kartci.logs.reader import messages
from kartci.project import current as active_project
from kartci.runner import expand, run_jobs

LAYOUT = resources.files("kartci").joinpath("data", "foxglove", "kartci-layout.json")
MSG_DIR = ROOT / "kartci" / "logs" / "msg" / "kartci_msgs"
ROS_PKG = ROOT / "ros" / "kartci_msgs"


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A kart that hits a wall (collisions) and a short MPCC run among obstacles."""
    root = tmp_path_factory.mktemp("fox")
    (root / "baselines").mkdir()
    res = run_jobs(expand(["kart_wall"], ["criteria={}"], active_project()) +
                   expand(["obstacle_avoidance"], ["duration_s=1", "criteria={}"],
                          active_project()),
                   root / "out", root / "baselines", active_project())
    assert not [r.error for r in res if r.error]
    return {name: root / "out" / name / "run.mcap" for name in ("kart_wall", "obstacle_avoidance")}


def _channels(path: Path) -> dict[str, tuple[str, dict[str, str]]]:
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    return {c.topic: (summary.schemas[c.schema_id].name, dict(c.metadata))
            for c in summary.channels.values()}


def _all(path: Path) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for topic, _, m in messages(path):
        out.setdefault(topic, []).append(m)
    return out


def test_markers_draw_the_track_obstacles_and_collisions(logs: dict[str, Path]) -> None:
    msgs = _all(logs["kart_wall"])
    [track] = msgs["/kartci/track_markers"]
    by_ns = {(m.ns, m.id): m for m in track.markers}
    assert sorted(by_ns) == [("centreline", 0), ("lap_line", 0), ("track_edges", 0),
                             ("track_edges", 1)]
    for key in [("centreline", 0), ("track_edges", 0), ("track_edges", 1)]:
        pts = by_ns[key].points
        assert by_ns[key].type == 4 and len(pts) > 50  # LINE_STRIP
        assert (pts[0].x, pts[0].y) == (pts[-1].x, pts[-1].y)  # closed
    lap = by_ns[("lap_line", 0)]
    assert lap.type == 5 and len(lap.points) == 2  # LINE_LIST: across the track at its start
    centre = by_ns[("centreline", 0)].points[0]
    mid = ((lap.points[0].x + lap.points[1].x) / 2, (lap.points[0].y + lap.points[1].y) / 2)
    assert mid == pytest.approx((centre.x, centre.y), abs=0.05)
    [obstacles] = _all(logs["obstacle_avoidance"])["/kartci/obstacles"]
    assert len(obstacles.markers) >= 1 and all(m.type == 1 for m in obstacles.markers)
    collisions = msgs["/kart0/collision"]
    marks = [m for a in msgs["/kart0/collision_markers"] for m in a.markers]
    assert len(collisions) >= 1 and len(marks) == 2 * len(collisions)  # a sphere and a label
    spheres = [m for m in marks if m.type == 2]
    assert [(s.pose.position.x, s.pose.position.y) for s in spheres] == [
        (c.position.x, c.position.y) for c in collisions]
    assert all(m.text.startswith("collision: ") for m in marks if m.type == 9)


def _qos(meta: dict[str, str]) -> dict[str, Any]:
    [profile] = yaml.safe_load(meta["offered_qos_profiles"])
    assert set(profile) == {"history", "depth", "reliability", "durability", "deadline",
                            "lifespan", "liveliness", "liveliness_lease_duration",
                            "avoid_ros_namespace_conventions"}
    return dict(profile)


def test_robot_description_is_latched_and_every_channel_has_qos(logs: dict[str, Path]) -> None:
    channels = _channels(logs["kart_wall"])
    latched = {t for t, (_, meta) in channels.items() if _qos(meta)["durability"] == 1}
    assert len(channels) > len(latched)  # every channel has a profile (_qos checks it)
    assert latched == {"/kartci/scenario", "/kartci/course", "/kartci/track",
                       "/kartci/obstacles", "/kartci/track_markers",
                       "/kart0/robot_description", "/tf_static"}
    odom = _qos(channels["/kart0/odom"][1])
    assert (odom["durability"], odom["reliability"], odom["history"], odom["depth"]) == (2, 1, 1,
                                                                                         10)
    assert _qos(channels["/tf_static"][1])["depth"] == 1
    [urdf] = _all(logs["kart_wall"])["/kart0/robot_description"]
    links = [e.get("name") for e in ET.fromstring(urdf.data).iter("link")]
    assert links and all(str(n).startswith("kart0/") for n in links)


def _frames(msgs: dict[str, list[Any]]) -> tuple[set[str], set[str]]:
    """Frames the tf tree knows, and frames message headers name."""
    tree = {"map"}
    for topic in ("/tf", "/tf_static"):
        for m in msgs.get(topic, []):
            for tr in m.transforms:
                tree |= {tr.header.frame_id, tr.child_frame_id}
    used = set()
    for topic, ms in msgs.items():
        for m in ms:
            for item in [m, *getattr(m, "markers", [])]:
                hdr = getattr(item, "header", None)
                if hdr is not None and topic not in ("/tf", "/tf_static"):
                    used.add(hdr.frame_id)
    return tree, used


def test_frame_ids_are_consistent(logs: dict[str, Path]) -> None:
    for path in logs.values():
        msgs = _all(path)
        tree, used = _frames(msgs)
        assert used <= tree, used - tree
        assert {m.header.frame_id for m in msgs["/kart0/cmd"]} == {"kart0/base_link"}
        [urdf] = msgs["/kart0/robot_description"]
        links = {str(e.get("name")) for e in ET.fromstring(urdf.data).iter("link")}
        assert links - tree <= {"kart0/cog_link"} and "kart0/base_link" in links & tree


def _panes(node: Any) -> list[str]:
    if isinstance(node, str):
        return [node]
    assert set(node) >= {"first", "second", "direction"} and node["direction"] in ("row",
                                                                                 "column")
    return _panes(node["first"]) + _panes(node["second"])


def test_the_layout_parses_and_names_only_logged_topics(logs: dict[str, Path]) -> None:
    layout = json.loads(LAYOUT.read_text(encoding="utf-8"))
    assert set(layout) >= {"configById", "layout", "globalVariables", "userNodes"}
    panes = _panes(layout["layout"])
    assert sorted(panes) == sorted(layout["configById"])
    assert all(re.fullmatch(r"[A-Za-z0-9]+![A-Za-z0-9_-]+", p) for p in panes)
    text = json.dumps(layout)
    topics = set(re.findall(r'"(/kart0/[a-z_/]+|/kartci/[a-z_]+|/tf(?:_static)?)', text))
    logged = set(_channels(logs["kart_wall"])) | set(_channels(logs["obstacle_avoidance"]))
    assert topics and topics <= logged, topics - logged
    plots = [c for k, c in layout["configById"].items() if k.startswith("Plot!")]
    fields = {p["value"].split(".", 1)[1] for c in plots for p in c["paths"]
              if p["value"].startswith("/kart0/")}
    assert {"twist.twist.linear.x", "steering_wheel_angle_rad", "max_slack_m"} <= fields


def test_kartci_msgs_package_agrees_with_kartci(tmp_path: Path) -> None:
    ours = {p.name: p.read_text(encoding="utf-8") for p in MSG_DIR.glob("*.msg")}
    package = {p.name: p.read_text(encoding="utf-8") for p in (ROS_PKG / "msg").glob("*.msg")}
    assert package == ours  # same files, same text: regenerate with cp when one changes
    cmake = (ROS_PKG / "CMakeLists.txt").read_text(encoding="utf-8")
    assert sorted(re.findall(r'"msg/(\w+\.msg)"', cmake)) == sorted(ours)
    deps = {line.split("/")[0] for text in ours.values() for line in text.splitlines()
            if re.match(r"^[a-z_]+/\w+ ", line)}
    xml = ET.parse(ROS_PKG / "package.xml").getroot()
    assert xml.findtext("name") == "kartci_msgs"
    assert deps <= {e.text for e in xml.iter("depend")}
    assert f"DEPENDENCIES {' '.join(sorted(deps, reverse=True))}" in cmake
    assert all(re.fullmatch(r"[A-Z][A-Za-z0-9]*\.msg", n) for n in ours)
