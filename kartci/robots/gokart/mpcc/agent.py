"""The MPCC agent: reads its state from an odometry topic (ground truth by default, so a
localisation estimate can replace it by configuration), sees static obstacles from the
scenario and other karts from their odometry, and publishes kart commands in the source document's
format, its predicted horizon (nav_msgs/Path) and solver statistics every step."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from kartci.core import AgentContext, Outbox
from kartci.logs.types import WORLD_FRAME, base_link, header, msg, yaw_of
from kartci.robots.gokart import KartInput, column_for_wheel_angle, wheel_angles
from kartci.robots.gokart.joy import kart_command
from kartci.robots.gokart.mpcc.controller import Mpcc, Plan
from kartci.robots.gokart.mpcc.params import MpccController
from kartci.robots.gokart.mpcc.recovery import Measured, MpccStatus, Watchdog
from kartci.robots.gokart.mpcc.reference import FrictionMap, Obstacle, obstacle_from_xy
from kartci.robots.gokart.outline import footprint_m
from kartci.robots.gokart.params import GokartModel, axle_distance_m, cog_x_m
from kartci.worlds.track import OBSTACLES_TOPIC, TRACK_TOPIC, Track, track_from_text


class MpccAgent:
    """Built on the track it is sent (`/kartci/track`, at t = 0); static obstacles come as
    boxes on `/kartci/obstacles`, other karts from their odometry."""

    def __init__(self, spec: MpccController, ctx: AgentContext) -> None:
        assert isinstance(ctx.model, GokartModel)  # Controller.build checked the robot kind
        self.spec, self.model, self.period_s = spec, ctx.model, spec.period_s
        self.frame = base_link(ctx.name)
        # the world's floor and zones, as the real kart's map would hold them
        self.friction = FrictionMap.of(ctx.world, ctx.model.tire_friction)
        _, self.kart_length_m, self.kart_width_m = footprint_m(ctx.model)  # other karts': alike
        self.watchdog = Watchdog(spec.recovery, spec.period_s, axle_distance_m(ctx.model))
        self.track: Track | None = None
        self.mpcc: Mpcc | None = None
        self.static: list[Obstacle] = []
        self._boxes: list[tuple[float, float, float]] = []  # centre x, y and radius, m
        perceive = spec.obstacles_from == "perception"
        self.others = {} if perceive else {f"/{name}/odom": name for name in ctx.others}
        seen = (spec.detections_topic,) if perceive else (OBSTACLES_TOPIC, *self.others)
        self.inputs = (TRACK_TOPIC, spec.state_topic, "joint_states", *seen)
        self._state: np.ndarray | None = None  # [X, Y, psi, vx, vy, r] of the CoG
        self._delta = 0.0
        self._accel = 0.0
        self._s: float | None = None
        self._karts: dict[str, tuple[float, float, float, float]] = {}
        self._tracks: dict[str, tuple[float, float, float]] = {}  # detection id -> t, x, y

    def on_message(self, topic: str, message: Any) -> None:
        """Build the solver on the track, place static obstacles (boxes as circles), follow the
        steering from joint states, and take this and other karts' states from odometry (moved from
        base_link to the CoG)."""
        if topic == TRACK_TOPIC:
            self.track = track_from_text(message.data, TRACK_TOPIC)
            self.mpcc = Mpcc(self.spec, self.model, self.track, self.friction)
            self._place_obstacles()
            return
        if topic == OBSTACLES_TOPIC:
            self._boxes = [(float(m.pose.position.x), float(m.pose.position.y),
                            0.5 * math.hypot(float(m.scale.x), float(m.scale.y)))
                           for m in message.markers]
            self._place_obstacles()
            return
        if topic == self.spec.detections_topic:  # perception: static boxes, moving karts
            self._perceived(message)
            return
        if topic == "joint_states":
            names = list(message.name)
            if "steering_column" in names:
                col = float(message.position[names.index("steering_column")])
                self._delta = sum(wheel_angles(self.model, col)) / 2
            return
        p, tw = message.pose.pose.position, message.twist.twist
        yaw, c = yaw_of(message.pose.pose.orientation), cog_x_m(self.model)
        x, y = p.x + c * math.cos(yaw), p.y + c * math.sin(yaw)
        vx, vy, r = float(tw.linear.x), float(tw.linear.y) + c * float(tw.angular.z), float(
            tw.angular.z)
        if topic == self.spec.state_topic:
            self._state = np.array([x, y, yaw, vx, vy, r])
        elif topic in self.others:
            self._karts[topic] = (x, y, yaw, vx)

    def _perceived(self, message: Any) -> None:
        """Detections: static ones as boxes; dynamic ones as other karts (their footprint, and
        their speed from the track's displacement since its last detection)."""
        t = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
        boxes, karts, seen = [], {}, {}
        for d in message.detections:
            c, size = d.bbox.center, d.bbox.size
            x, y = float(c.position.x), float(c.position.y)
            if d.results and d.results[0].hypothesis.class_id == "dynamic":
                last = self._tracks.get(d.id)
                v, yaw = 0.0, yaw_of(d.results[0].pose.pose.orientation)
                if last is not None and t > last[0]:
                    v = math.hypot(x - last[1], y - last[2]) / (t - last[0])
                seen[d.id] = (t, x, y)
                karts[d.id] = (x, y, yaw, v)
            else:
                boxes.append((x, y, 0.5 * math.hypot(float(size.x), float(size.y))))
        self._tracks, self._karts, self._boxes = seen, karts, boxes
        self._place_obstacles()

    def _place_obstacles(self) -> None:
        if self.track is not None:
            self.static = [obstacle_from_xy(self.track, x, y, r) for x, y, r in self._boxes]

    def _obstacles(self) -> list[Obstacle]:
        assert self.track is not None
        out = list(self.static)
        radius = 0.5 * self.kart_width_m
        for x, y, yaw, v in self._karts.values():
            s, _, _, _ = self.track.project(np.array([[x, y]]))
            heading = self.track.pose_at(float(s[0]))[2]
            speed = v * math.cos(yaw - heading)
            out.append(obstacle_from_xy(self.track, x, y, radius, speed,
                                        follow_gap_m=self.kart_length_m + 1.0))
        return out

    def step(self, t_ns: int) -> Outbox:
        """Solve from the measured state and the progress of the last tick (unwrapped across the
        start line); publish the command, the horizon and solver statistics. Nothing until the track
        and a state have arrived."""
        if self._state is None or self.mpcc is None or self.track is None:
            return []
        st = self._state
        proj = float(self.track.project(st[None, :2])[0][0])
        ref = self._s if self._s is not None else (proj if proj < self.track.length_m / 2
                                                   else proj - self.track.length_m)
        s0 = proj + self.track.length_m * round((ref - proj) / self.track.length_m)
        x0 = np.array([*st, s0, self._delta, self._accel])
        plan = self._plan(x0)
        self._s = s0
        # after a failed solve the brake is an emergency action, not part of a plan: the next
        # solve starts from a neutral pedal so that it is not born infeasible at standstill
        self._accel = plan.accel_mps2 if plan.success else 0.0
        cmd = KartInput(column_for_wheel_angle(self.model, plan.wheel_angle_rad),
                        max(plan.accel_mps2, 0.0), max(-plan.accel_mps2, 0.0))
        return [("cmd", kart_command(cmd, t_ns, self.frame)),
                ("mpcc/horizon", self._path(plan, t_ns)),
                ("mpcc/stats", self._stats(plan, t_ns))]

    def _plan(self, x0: np.ndarray) -> Plan:
        """The watchdog first: a sliding kart brakes straight (no solve), a stalled one
        re-plans from scratch and says so; else the MPCC's plan."""
        assert self.mpcc is not None
        status = self.watchdog.judge(Measured(float(x0[3]), float(x0[4]), float(x0[5]),
                                              self._delta, float(x0[6])))
        if status in (MpccStatus.LOSS_OF_CONTROL, MpccStatus.RECOVERING):
            return self.mpcc.brake_straight(x0, status)
        if status is MpccStatus.STALLED:
            self.mpcc.reset()
            plan = self.mpcc.solve(x0, self._obstacles())
            # a failed solve keeps its own status: it says why the kart stands
            return (dataclasses.replace(plan, success=False, status=MpccStatus.STALLED)
                    if plan.success else plan)
        return self.mpcc.solve(x0, self._obstacles())

    def _path(self, plan: Plan, t_ns: int) -> Any:
        poses = []
        for row in plan.states:
            half = row[2] / 2
            poses.append(msg("geometry_msgs/msg/PoseStamped", header=header(t_ns, WORLD_FRAME),
                             pose=msg("geometry_msgs/msg/Pose",
                                      position=msg("geometry_msgs/msg/Point", x=float(row[0]),
                                                   y=float(row[1]), z=0.0),
                                      orientation=msg("geometry_msgs/msg/Quaternion", x=0.0,
                                                      y=0.0, z=math.sin(half),
                                                      w=math.cos(half)))))
        return msg("nav_msgs/msg/Path", header=header(t_ns, WORLD_FRAME), poses=poses)

    def _stats(self, plan: Plan, t_ns: int) -> Any:
        return msg("kartci_msgs/msg/SolverStats", header=header(t_ns, WORLD_FRAME),
                   success=plan.success, status=plan.status, solve_ms=plan.solve_ms,
                   iterations=plan.iterations, cost=plan.cost,
                   failures=self.mpcc.failures if self.mpcc else 0,
                   max_slack_m=plan.slack_m)
