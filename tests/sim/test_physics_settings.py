"""Physics settings chosen for speed, held to what they may change: pyramid instead of cone
contact friction in track worlds (the karts' wheels carry no friction, so only a body sliding
along another feels it)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim.session import Session
from kartci.worlds.track.world import TrackWorld


def _drive(name: str, sets: list[str]) -> tuple[np.ndarray, list[Any]]:
    """Ground-truth (t, x, y, yaw, v) every 10 ms, and the collision messages, of a run."""
    states, collisions = [], []
    with Session(load_scenario(name, sets, project=active_project())) as s:
        r = s.reset()
        body = s.world.robots[0].body  # type: ignore[attr-defined]  # a kart
        while not r.done:
            r = s.step()
            collisions += [m for topic, m in r.messages if topic.endswith("/collision")]
            if s.k % 5 == 0:
                st = body.state()
                states.append((r.t_s, st.xyz[0], st.xyz[1], st.yaw, st.v_body[0]))
    return np.array(states), collisions


def test_track_worlds_use_pyramid_friction() -> None:
    assert TrackWorld.CONE_FRICTION is False


def test_pyramid_friction_leaves_a_lap_on_frictionless_wheels_unchanged(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The tyre forces are applied by tyres.py, so the contact model does not touch the drive:
    the same 4 s of kart_manual bit for bit."""
    fast, _ = _drive("kart_manual", ["duration_s=4"])
    monkeypatch.setattr(TrackWorld, "CONE_FRICTION", True)
    cone, _ = _drive("kart_manual", ["duration_s=4"])
    assert fast[-1, 4] > 2.0  # the kart is under way
    np.testing.assert_array_equal(fast, cone)


def test_pyramid_friction_keeps_a_wall_crash_within_tolerance(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """kart_wall slides along the south wall: the same one collision, starting within 10 ms,
    impulse within 10 %, and the kart ends within 5 cm and 1 degree of the cone-friction run."""
    fast, hit = _drive("kart_wall", [])
    monkeypatch.setattr(TrackWorld, "CONE_FRICTION", True)
    cone, ref = _drive("kart_wall", [])
    assert [c.other for c in hit] == [c.other for c in ref] == ["wall_south"]
    start = [c.header.stamp.sec + c.header.stamp.nanosec * 1e-9 for c in (hit[0], ref[0])]
    assert start[0] == pytest.approx(start[1], abs=0.01)
    assert hit[0].impulse_ns == pytest.approx(ref[0].impulse_ns, rel=0.1)
    assert np.hypot(*(fast[-1, 1:3] - cone[-1, 1:3])) < 0.05
    assert abs(fast[-1, 3] - cone[-1, 3]) < np.radians(1.0)
