"""Obstacle detection scored from the log: each `obstacle_detector/detections` message (a frame)
against the ground-truth boxes of that moment: the world's static boxes (/kartci/obstacles) and
every other robot (its odometry and the centre of its kind's outline; dynamic while faster than
`dynamic_mps`).

A detection matches a truth box when their centres are within `match_m` (centre distance, not
IoU: a lidar sees one or two faces of a box, so its box is smaller than the truth and IoU would
punish what is a correct detection), one-to-one, nearest first. Recall counts the truth boxes
within `range_m` of the kart (by its true pose); precision the detections within that range."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams
from kartci.core.params import Size_m
from kartci.logs.reader import messages
from kartci.logs.types import stamp_ns
from kartci.metrics import ScoreContext, outline_of
from kartci.metrics.outline import bounds
from kartci.worlds.track import OBSTACLES_TOPIC


class DetectionMetricsParams(MetricParams):
    """Which detections, which range, what counts as a match."""

    topic: str = Field("obstacle_detector/detections", description="the detections "
                       "(vision_msgs/Detection3DArray), relative to the agent or absolute")
    range_m: Size_m = Field(15.0, description="truth boxes and detections this close "
                            "to the kart count, m")
    match_m: Size_m = Field(1.0, description="largest centre distance of a match, m")
    dynamic_mps: float = Field(0.5, ge=0.0, le=100.0, description="a kart faster than this is a "
                               "dynamic truth box, m/s")


DEFS: dict[str, MetricDef] = {
    "recall_15m": MetricDef("fraction", Direction.HIGHER, 0.01, 0.0, "truth boxes within "
                            "range matched by a detection, over all frames"),
    "precision": MetricDef("fraction", Direction.HIGHER, 0.01, 0.0, "detections within range "
                           "that match a truth box"),
    "detection_error_m": MetricDef("m", Direction.LOWER, 0.01, 0.2, "mean centre distance of "
                                   "matched detections"),
    "class_accuracy": MetricDef("fraction", Direction.HIGHER, 0.01, 0.0, "matched detections "
                                "with the right class (static / dynamic)"),
    "detection_latency_s": MetricDef("s", Direction.LOWER, 0.001, 0.0, "mean sim time from a "
                                     "scan's stamp to its detections' publication"),
}


def _truth(ctx: ScoreContext, t: float, statics: list[tuple[float, float]],
           params: DetectionMetricsParams) -> list[tuple[float, float, bool]]:
    """(x, y, dynamic) of every truth box at time t."""
    out = [(x, y, False) for x, y in statics]
    for other in ctx.scenario.agents:
        if other == ctx.agent:
            continue
        odom = ctx.table(f"/{other}/odom")
        if odom is None or odom.empty:
            continue
        i = min(int(np.searchsorted(odom["t"].to_numpy(), t)), len(odom) - 1)
        row = odom.iloc[i]
        outline = outline_of(ctx, other)
        ahead, left = bounds(outline)[:2] if outline else (0.0, 0.0)
        c, s = math.cos(row["yaw"]), math.sin(row["yaw"])
        out.append((float(row["x"]) + ahead * c - left * s,
                    float(row["y"]) + ahead * s + left * c,
                    abs(float(row["vx"])) > params.dynamic_mps))
    return out


def _match(dets: list[tuple[float, float, bool]], truth: list[tuple[float, float, bool]],
           match_m: float) -> list[tuple[int, int, float]]:
    pairs = sorted((math.hypot(d[0] - g[0], d[1] - g[1]), i, j)
                   for i, d in enumerate(dets) for j, g in enumerate(truth))
    used_d: set[int] = set()
    used_g: set[int] = set()
    out = []
    for dist, i, j in pairs:
        if dist <= match_m and i not in used_d and j not in used_g:
            used_d.add(i)
            used_g.add(j)
            out.append((i, j, dist))
    return out


@dataclass
class _Tally:
    """Counts over all frames."""

    truth: int = 0
    found: int = 0
    dets: int = 0
    true_dets: int = 0
    right: int = 0
    errors: list[float] = field(default_factory=list)
    latency: list[float] = field(default_factory=list)

    def frame(self, ego: tuple[float, float], dets: list[tuple[float, float, bool]],
              truth: list[tuple[float, float, bool]], params: DetectionMetricsParams) -> None:
        """Score one frame's detections against its truth boxes."""
        def near(p: tuple[float, float, bool]) -> bool:
            return math.hypot(p[0] - ego[0], p[1] - ego[1]) <= params.range_m

        matches = _match(dets, truth, params.match_m)
        found = {j for _, j, _ in matches}
        self.truth += sum(near(g) for g in truth)
        self.found += sum(near(g) for j, g in enumerate(truth) if j in found)
        matched = {i: (j, d) for i, j, d in matches}
        for i, det in enumerate(dets):
            if not near(det):
                continue
            self.dets += 1
            if i in matched:
                j, dist = matched[i]
                self.true_dets += 1
                self.errors.append(dist)
                self.right += det[2] == truth[j][2]


def detection_metrics(ctx: ScoreContext, params: DetectionMetricsParams) -> list[Metric]:
    """Recall, precision, position error, class accuracy and latency over all frames (none
    for an agent without an obstacle_detector node)."""
    if "obstacle_detector" not in ctx.scenario.agents[ctx.agent].nodes:
        return []
    topic = params.topic if params.topic.startswith("/") else f"/{ctx.agent}/{params.topic}"
    statics: list[tuple[float, float]] = []
    frames: list[tuple[float, float, Any]] = []
    for name, t_ns, m in messages(ctx.path, [OBSTACLES_TOPIC, topic]):
        if name == OBSTACLES_TOPIC:
            statics = [(float(k.pose.position.x), float(k.pose.position.y)) for k in m.markers]
        else:
            frames.append((stamp_ns(m.header) * 1e-9, t_ns * 1e-9, m))
    odom = ctx.odom
    ts = odom["t"].to_numpy()
    tally = _Tally()
    for t, logged, m in frames:
        tally.latency.append(logged - t)
        row = odom.iloc[min(int(np.searchsorted(ts, t)), len(ts) - 1)]
        dets = [(float(d.bbox.center.position.x), float(d.bbox.center.position.y),
                 bool(d.results) and d.results[0].hypothesis.class_id == "dynamic")
                for d in m.detections]
        tally.frame((float(row["x"]), float(row["y"])), dets,
                    _truth(ctx, t, statics, params), params)
    n_truth, n_found, n_dets, n_true_dets, n_right, errors, latency = (
        tally.truth, tally.found, tally.dets, tally.true_dets, tally.right, tally.errors,
        tally.latency)
    nan = float("nan")
    return [Metric("recall_15m", n_found / n_truth if n_truth else nan, "fraction",
                   {"truth_boxes": n_truth, "frames": len(frames)}),
            Metric("precision", n_true_dets / n_dets if n_dets else nan, "fraction",
                   {"detections": n_dets}),
            Metric("detection_error_m", float(np.mean(errors)) if errors else nan, "m"),
            Metric("class_accuracy", n_right / n_true_dets if n_true_dets else nan, "fraction"),
            Metric("detection_latency_s", float(np.mean(latency)) if latency else nan, "s")]
