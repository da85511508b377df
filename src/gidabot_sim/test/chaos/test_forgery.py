"""The forgeries about real trips a chaos run publishes, and their accounting node by node."""

from __future__ import annotations

from gidabot_navigation.interface import Phase, Topic, is_relay_end
from gidabot_navigation.senders import Senders, uid_robot
from gidabot_sim.chaos.forgery import (
    NEXT_UIDS,
    account,
    forgeries,
    grown,
    impostor_relay,
    next_uids,
    reaching,
    refusals,
    status_node,
)

UID = "Tartalo/v1/gm.00000000000000ff"


def test_next_uids_count_on_the_token_as_if_it_were_a_counter() -> None:
    assert next_uids(UID) == ["Tartalo/v1/gm.0000000000000100", "Tartalo/v1/gm.0000000000000101"]
    assert next_uids("Tartalo/v1/gm.ffffffffffffffff", 1) == ["Tartalo/v1/gm.0000000000000000"]
    assert next_uids("not a uid", 2) == ["not a uid1", "not a uid2"]


def test_forgeries_speak_for_the_trips_origin_about_its_uid_and_the_next_ones() -> None:
    forged = forgeries(UID, "Tartalo", serial=5)
    targets = {f.msg.get("goal_uid", f.msg["uid"]) if f.topic != Topic.GOALS else f.msg["uid"] for f in forged}
    assert targets == {UID, *next_uids(UID)}
    assert len(forged) == 4 + 3 * NEXT_UIDS
    assert all(f.msg.get("origin_robot", f.msg.get("robot")) == "Tartalo" for f in forged)
    # their own uids are of the origin's namespace (a sender rule cannot tell them by format), all different
    own = [f.msg["uid"] for f in forged if f.topic != Topic.GOALS]
    assert all(uid_robot(u) == "Tartalo" for u in own) and len(set(own)) == len(own)
    assert {f.msg["phase"] for f in forged if f.topic == Topic.NAV_EVENTS} == {Phase.GOAL_REACHED, Phase.REJECTED}
    assert [f.msg["uid"] for f in forged if f.topic == Topic.GOALS][0] == UID


def test_the_impostor_relay_is_named_like_a_relay_end_but_is_none_of_the_robots() -> None:
    name = impostor_relay("Kbot")
    assert is_relay_end(name)
    senders = Senders("Kbot", {"/gidabot_relay_Tartalo_Kbot": "Tartalo"})
    assert senders.attribute(name).kind == "impostor"


def test_accounting_node_by_node() -> None:
    sent = {Topic.GOALS: 3, Topic.CANCELS: 3, Topic.NAV_EVENTS: 4}
    assert reaching(sent) == {"guiding: goal_manager": 10, "guiding: navigation": 7, "sim: visitor": 4}
    relay = "relay Tartalo_Kbot (Kbot end)"
    counters = {"guiding: goal_manager Kbot": {"refused": 12, "received": 3},
                "guiding: navigation Kbot": {"refused": 6}, relay: {"rejected": 14, "rejected_impostor": 10},
                "sim: visitor Kbot": {"refused": 4, "refused_impostor": 4},
                "relay_supervisor: Kbot": {"restarts": 0}}
    assert refusals(counters, "Kbot") == {"guiding: goal_manager": 12, "guiding: navigation": 6, "sim: visitor": 4}
    rows = account("Kbot", sent, refusals(counters, "Kbot"))
    assert [(a.node, a.sent, a.refused, a.accounted) for a in rows] == [
        ("guiding: goal_manager", 10, 12, True), ("guiding: navigation", 7, 6, False), ("sim: visitor", 4, 4, True)]
    assert status_node("tour_store: Kbot", "Kbot") == "tour_store:"
    # a node that restarted between two readings counts from 0
    assert grown({"a": 5, "b": 9}, {"a": 8, "b": 2, "c": 1}) == {"a": 3, "b": 2, "c": 1}
