"""The source document's study (Sec. 7.1-7.2) read back from a grid's runs: one response curve per
sweep point, grouped as the source document's figures group them. Data only; `figures` draws it."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kartci.core import RunFolder
from kartci.errors import LogError
from kartci.logs import tables
from kartci.metrics import recorded_scenario
from kartci.robots.line_tracker.metrics import sensor_track
from kartci.robots.line_tracker.params import line_parts
from kartci.worlds.line_lab import CircleCourse

KP, TS, V1 = "agents.lt0.controller.kp", "agents.lt0.controller.period_s", (
    "agents.lt0.controller.v1_mps")
RADIUS = "world.course.radius_m"


@dataclass(frozen=True)
class Curve:
    """One run's sensor offset over time (and, on a circle, over the angle travelled)."""

    label: str
    point: dict[str, float]  # kp, period, v1 (and radius) as run, by dotted key
    t_s: np.ndarray
    offset_m: np.ndarray
    angle_deg: np.ndarray  # angle travelled round a circle's centre; empty on a straight


@dataclass(frozen=True)
class Panel:
    """One figure's worth of curves: the source document's figure it mirrors and what varies in
    it."""

    figure: str  # e.g. "Fig. 7.1.3"
    title: str
    varies: str  # the dotted key the curves differ in
    curves: tuple[Curve, ...]


def point_of(label: str) -> dict[str, float]:
    """`name@a.b=1,c=0.5` -> {"a.b": 1.0, "c": 0.5}."""
    _, _, rest = label.partition("@")
    out = {}
    for part in rest.split(","):
        key, sep, value = part.partition("=")
        if sep:
            out[key] = float(value)
    return out


def curve(folder: Path) -> Curve:
    """The curve of one run folder (its `run.mcap`); a LogError when the log is missing."""
    log = RunFolder(folder).log
    if not log.is_file():
        raise LogError(f"{folder}: no {log.name}; run the grid first")
    tabs = tables(log)
    scenario = recorded_scenario(tabs, log)
    agent = next(iter(scenario.agents))
    odom = tabs.get(f"/{agent}/odom")
    if odom is None or odom.empty:
        raise LogError(f"{log}: no /{agent}/odom messages")
    tr = sensor_track(scenario, agent, odom)
    course = line_parts(scenario, agent)[0].course
    angle = np.zeros(0)
    if isinstance(course, CircleCourse):
        a = np.unwrap(np.arctan2(tr["y"] - course.center_m[1], tr["x"] - course.center_m[0]))
        angle = np.degrees(a - a[0])
    ctrl = scenario.agents[agent].controller
    point = {key: float(getattr(ctrl, name)) for key, name in
             ((KP, "kp"), (TS, "period_s"), (V1, "v1_mps")) if hasattr(ctrl, name)}
    if isinstance(course, CircleCourse):
        point[RADIUS] = course.radius_m
    return Curve(folder.name, {**point, **point_of(folder.name)}, tr["t"].to_numpy(),
                 tr["offset"].to_numpy(), angle)


def grid(out: Path, scenario: str) -> list[Curve]:
    """Every point of a grid run into `out` (`<scenario>@...` folders), in name order."""
    folders = sorted(p for p in out.glob(f"{scenario}@*") if p.is_dir())
    if not folders:
        raise LogError(f"{out}: no {scenario}@... runs; run `kartci run {scenario} --out {out}`")
    return [curve(f) for f in folders]


def select(curves: list[Curve], **fixed: float) -> list[Curve]:
    """The curves whose point has these values (keys: kp, ts, v1, radius)."""
    keys = {"kp": KP, "ts": TS, "v1": V1, "radius": RADIUS}
    return [c for c in curves
            if all(abs(c.point.get(keys[k], np.nan) - v) < 1e-9 for k, v in fixed.items())]


def straight_panels(curves: list[Curve]) -> list[Panel]:
    """Figs. 7.1.2-7.1.4 of the seed: one parameter varies, the other two as in its example."""
    return [
        Panel("Fig. 7.1.2", "Kp 100, v1 0.1 m/s: step times", TS,
              tuple(select(curves, kp=100, v1=0.1))),
        Panel("Fig. 7.1.3", "Kp 100, ts 0.06 s: speeds", V1,
              tuple(select(curves, kp=100, ts=0.06))),
        Panel("Fig. 7.1.4", "ts 0.06 s, v1 0.1 m/s: gains", KP,
              tuple(select(curves, ts=0.06, v1=0.1))),
    ]


def circle_panels(curves: list[Curve]) -> list[Panel]:
    """Sec. 7.2's figures: distance from the line over the angle, one panel per radius."""
    radii = sorted({c.point[RADIUS] for c in curves if RADIUS in c.point})
    return [Panel("Sec. 7.2", f"circle r = {r:g} m: step times", TS,
                  tuple(select(curves, radius=r))) for r in radii]
