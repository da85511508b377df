"""The relay end's delivery hold (delivery_hold.py): when received events are published again."""

from __future__ import annotations

from gidabot_navigation.interface import Node, Topic, global_name, relay_end_name
from gidabot_navigation.relay.delivery_hold import DeliveryHold, Release, subscribers_in_system_state

G, C = Topic.GOALS, Topic.CANCELS
GM, NAV = global_name(Node.GOAL_MANAGER), global_name(Node.MULTIROBOT_NAVIGATION)
RELAY = relay_end_name("Tartalo", "Kbot")


def test_at_start_delivery_opens_as_soon_as_nobody_registered_is_missing() -> None:
    hold = DeliveryHold([G, C], grace=1.5, now=0.0)
    assert hold.held and hold.deciding(master_up=True)
    assert hold.update(0.1, {G: {GM}}, True, {G: [GM, NAV]}) is None            # NAV registered, not connected
    release = hold.update(0.2, {G: {GM, NAV}}, True, {G: [GM, NAV]})
    assert release == Release({}) and release.why == "every subscriber is connected"
    assert not hold.held and not hold.deciding(True)


def test_after_a_master_restart_the_subscribers_seen_before_are_waited_for_then_the_grace_ends_it() -> None:
    hold = DeliveryHold([G, C], grace=1.5, now=0.0)
    assert hold.update(0.0, {G: {GM, RELAY}, C: {NAV}}, True, {}) == Release({})
    hold.update(1.0, {G: {GM, RELAY}, C: {NAV}}, True, {})                      # open: remembers who is there
    hold.master_down()
    assert hold.held and not hold.deciding(True)                               # no deadline while it is down
    assert hold.update(100.0, {}, False, {}) is None
    assert hold.update(100.0, {}, True, {}) is None                             # not back yet (no re-registration)
    hold.master_back(200.0)
    assert hold.update(200.5, {G: {GM}}, True, {}) is None                      # NAV (cancels) not back yet
    release = hold.update(201.5, {G: {GM}}, True, {})
    assert release == Release({C: [NAV]}) and release.why == f"grace period over, still missing {C}: {NAV}"


def test_relays_are_never_waited_for_and_a_master_down_holds() -> None:
    hold = DeliveryHold([G], grace=1.0, now=0.0)
    assert hold.update(0.0, {G: {RELAY}}, True, {G: [RELAY]}) == Release({})
    hold.master_down()
    assert hold.update(5.0, {G: {GM}}, False, {}) is None and hold.held
    assert hold.expected == {G: set()}                                          # the relay was not remembered


def test_the_registered_subscribers_in_a_system_state() -> None:
    state = [[[G, ["/pub"]]], [[G, [GM, RELAY]], [C, [NAV]], ["/other", ["/x"]]], []]
    assert subscribers_in_system_state(state, [G, C]) == {G: {GM, RELAY}, C: {NAV}}
    for garbage in (None, 3, [], [[]], [[], [["only-a-topic"]]]):
        assert subscribers_in_system_state(garbage, [G]) == {}
