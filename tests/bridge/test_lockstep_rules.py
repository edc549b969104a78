"""The lockstep's rules without a stack: what a tick waits for from the graph, how messages are
counted into ticks (a late answer never answers a later tick), the tick-0 learning of phases,
and QoS pairs that can never match."""

from __future__ import annotations

import pytest

from kartci.bridge import ros2
from kartci.bridge.lockstep import (
    Durability,
    Endpoint,
    Expect,
    Kind,
    Ledger,
    Phase,
    Qos,
    Reliability,
    mismatches,
    offer_for,
    plan,
    unpublished,
)

BEST_EFFORT = Qos(Reliability.BEST_EFFORT, Durability.VOLATILE, 5)
LATCHED = Qos(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1)
PUB, SUB = Kind.PUBLISHER, Kind.SUBSCRIPTION


def relay_and_driver() -> list[Endpoint]:
    """Node A relays /k/odom to /k/odom_relay; node B drives from it and a planner's /k/plan
    (the planner reads only /clock), answering on /k/cmd; everyone logs to /rosout."""
    return [Endpoint("/k/a", SUB, "/k/odom", "nav_msgs/msg/Odometry"),
            Endpoint("/k/a", PUB, "/k/odom_relay", "nav_msgs/msg/Odometry"),
            Endpoint("/k/a", PUB, "/rosout", "rcl_interfaces/msg/Log"),
            Endpoint("/k/b", SUB, "/k/odom_relay", "nav_msgs/msg/Odometry"),
            Endpoint("/k/b", SUB, "/k/plan", "nav_msgs/msg/Path"),
            Endpoint("/k/b", SUB, "/rosout", "rcl_interfaces/msg/Log"),
            Endpoint("/k/b", PUB, "/k/cmd", "geometry_msgs/msg/Twist"),
            Endpoint("/k/p", SUB, "/clock", "rosgraph_msgs/msg/Clock"),
            Endpoint("/k/p", PUB, "/k/plan", "nav_msgs/msg/Path")]


def test_a_tick_waits_for_the_stacks_own_links_and_the_commands() -> None:
    wanted, data = plan(relay_and_driver(), {"/k/odom"}, {"/k/cmd"}, {})
    assert sorted(wanted) == ["/k/cmd", "/k/odom_relay", "/k/plan"]  # /rosout is no link
    assert data == {"/k/odom_relay", "/k/cmd"}  # /k/plan's node reads no data


def test_waits_for_adds_overrides_and_count_zero_removes() -> None:
    wanted, _ = plan(relay_and_driver(), {"/k/odom"}, {"/k/cmd"},
                     {"/k/plan": Expect(1, 5, Phase.CLOCK), "/k/odom_relay": Expect(0),
                      "/k/diag": Expect(2)})
    assert wanted == {"/k/cmd": Expect(), "/k/plan": Expect(1, 5, Phase.CLOCK),
                      "/k/diag": Expect(2)}


def ledger() -> Ledger:
    wanted, data = plan(relay_and_driver(), {"/k/odom"}, {"/k/cmd"}, {})
    return Ledger(wanted, data, {"/k/cmd"})


def test_tick_zero_learns_which_topics_answer_data_and_which_time() -> None:
    book = ledger()
    assert book.learning()
    assert book.missing(Phase.SENSORS) == ["/k/odom_relay"]
    book.belongs("/k/odom_relay", book.count("/k/odom_relay"))
    assert book.missing(Phase.SENSORS) == []
    book.learn(Phase.SENSORS)
    assert book.missing(Phase.CLOCK) == ["/k/cmd", "/k/plan"]
    for topic in ("/k/plan", "/k/cmd"):
        book.count(topic)
    book.learn(Phase.CLOCK)
    assert not book.learning()
    assert book.waits_for() == [
        {"topic": "/k/cmd", "after": "clock", "count": 1},
        {"topic": "/k/odom_relay", "after": "sensors", "count": 1},
        {"topic": "/k/plan", "after": "clock", "count": 1}]


def test_a_topic_that_never_published_in_tick_zero_is_not_awaited() -> None:
    book = ledger()
    book.count("/k/odom_relay")
    book.learn(Phase.SENSORS)
    book.count("/k/cmd")  # the planner never published: a slower node, or none at all
    assert book.missing(Phase.CLOCK, learnt_only=True) == []  # the quiet time passed
    book.learn(Phase.CLOCK)
    assert sorted(book.expect) == ["/k/cmd", "/k/odom_relay"]


def test_a_late_answer_is_stale_in_the_next_tick_not_its_answer() -> None:
    """A node that takes longer than the deadline: tick 0's answer arrives during tick 1 and
    is tick 0's (stale), so tick 1 is late too (it used to alternate late and on time)."""
    book = Ledger({"/k/cmd": Expect(phase=Phase.CLOCK)}, set(), {"/k/cmd"})
    book.next_tick()  # tick 0 timed out: no answer counted
    assert book.belongs("/k/cmd", book.count("/k/cmd")) == -1  # tick 0's, arriving late
    assert book.missing(Phase.CLOCK) == ["/k/cmd"]  # tick 1 still waits
    assert book.belongs("/k/cmd", book.count("/k/cmd")) == 0


def test_more_messages_than_due_are_seen() -> None:
    book = Ledger({"/k/cmd": Expect(phase=Phase.CLOCK)}, set(), {"/k/cmd"})
    assert book.belongs("/k/cmd", book.count("/k/cmd")) == 0
    assert book.belongs("/k/cmd", book.count("/k/cmd")) == 1


def test_a_slower_node_is_due_every_n_ticks() -> None:
    e = Expect(2, 5)
    assert [e.due(t) for t in range(7)] == [2, 0, 0, 0, 0, 2, 0]
    assert [e.due_before(t) for t in range(7)] == [0, 2, 2, 2, 2, 2, 4]


def test_stamped_topics_are_forgiven_in_the_count_after_a_late_tick() -> None:
    book = Ledger({"/k/ack": Expect(phase=Phase.CLOCK)}, set(), {"/k/ack"})
    book.next_tick(stamped=["/k/ack"])  # tick 0 late: its stamp decides, not the count
    assert book.missing(Phase.CLOCK) == ["/k/ack"]
    assert book.belongs("/k/ack", book.count("/k/ack")) == 0


def test_kartci_offers_what_every_subscription_asks() -> None:
    assert offer_for([BEST_EFFORT, LATCHED]) == Qos(Reliability.RELIABLE,
                                                    Durability.TRANSIENT_LOCAL, 5)
    assert offer_for([]) == Qos()


def test_a_pair_that_never_matches_names_both_qos() -> None:
    eps = [Endpoint("/a", PUB, "/t", "std_msgs/msg/String", BEST_EFFORT),
           Endpoint("/b", SUB, "/t", "std_msgs/msg/String", Qos()),
           Endpoint("/c", SUB, "/t", "std_msgs/msg/String", BEST_EFFORT),
           Endpoint("/d", SUB, "/t", "std_msgs/msg/String", LATCHED)]
    assert mismatches(eps) == [
        "/t: /a's publisher offers best-effort, volatile, /b's subscription asks reliable, "
        "volatile; they never match (reliability)",
        "/t: /a's publisher offers best-effort, volatile, /d's subscription asks reliable, "
        "transient-local; they never match (reliability and durability)"]


@pytest.mark.parametrize("qos", [Qos(), BEST_EFFORT, LATCHED])
def test_token_qos_round_trips_as_rmw_zenoh_writes_it(qos: Qos) -> None:
    assert ros2.parse_qos(ros2.qos_text(qos)) == qos


def test_rmw_zenohs_default_qos_is_reliable_volatile_depth_ten() -> None:
    assert ros2.qos_text(Qos()) == ros2.DEFAULT_QOS == "::,10:,:,:,,"
    assert ros2.parse_qos("2:1:,5:,:,:,,") == Qos(Reliability.BEST_EFFORT,
                                                  Durability.TRANSIENT_LOCAL, 5)


def test_t0_waits_for_a_publisher_of_everything_the_stack_subscribes_to() -> None:
    """The driver is up before the relay: /k/odom_relay has no publisher yet, so the stack is
    not all there; kartci's own topics, /rosout and topics waits_for says not to wait for
    (count 0) need none."""
    eps = [e for e in relay_and_driver() if e.node != "/k/a"]
    assert unpublished(eps, {"/k/odom", "/clock"}, ()) == [
        "publisher of /k/odom_relay (which /k/b subscribes to)"]
    assert unpublished(eps, {"/k/odom", "/clock"}, {"/k/odom_relay"}) == []
    assert unpublished(relay_and_driver(), {"/k/odom", "/clock"}, ()) == []
