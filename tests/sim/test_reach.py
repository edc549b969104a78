"""The kart asks PyBullet for contacts only where its bounding sphere meets a static body's box
(kartci/sim/reach.py): never clear where a contact exists, clear in open floor."""

from __future__ import annotations

from kartci._bullet import pb
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim.session import Session


def _touching(client: int, body: int, floor: int) -> bool:
    return any(c[2] not in (floor, body)
               for c in pb.getContactPoints(bodyA=body, physicsClientId=client))


def test_reach_is_never_clear_where_the_kart_touches_a_wall() -> None:
    with Session(load_scenario("kart_wall", ["duration_s=4"], project=active_project())) as s:
        r = s.reset()
        w = s.world
        kart = w.robots[0]
        body = kart.body  # type: ignore[attr-defined]  # a KartRobot
        touching = clear = 0
        while not r.done:
            r = s.step()
            is_clear = kart.reach.clear(body.reading())  # type: ignore[attr-defined]
            hit = _touching(w.client, body.body, w.floor)
            assert not (hit and is_clear), f"clear while touching at step {r.step}"
            touching += hit
            clear += is_clear
    assert touching > 0  # the kart did hit the wall
    assert clear > 500  # and drove in open floor first: most steps skip the query


def test_reach_always_asks_when_a_body_that_moves_is_in_the_world() -> None:
    with Session(load_scenario("kart_manual", ["duration_s=1"], project=active_project())) as s:
        s.reset()
        w = s.world
        kart = w.robots[0]
        rd = kart.body.reading()  # type: ignore[attr-defined]
        assert kart.reach.clear(rd)  # type: ignore[attr-defined]  # the start: open floor
        box = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=[0.1] * 3,
                                      physicsClientId=w.client)
        pb.createMultiBody(1.0, box, -1, [25.0, 15.0, 0.1], physicsClientId=w.client)
        assert not kart.reach.clear(rd)  # type: ignore[attr-defined]
