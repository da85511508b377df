"""Who may speak for whom (senders.py): attribution, the speaks-for table, uids, handled uids, the gate."""

from __future__ import annotations

import struct
from types import SimpleNamespace

import pytest

from gidabot_navigation.guiding.messages import CancelData, NavEventData, Trip
from gidabot_navigation.interface import SHARED_TOPICS, Node, Phase, Topic, global_name
from gidabot_navigation.senders import (
    CONFLICT,
    DUPLICATE,
    FOREIGN,
    IMPOSTOR,
    NEW,
    OWN,
    PUBLISHERS,
    RELAY,
    SCOPE_STAFF,
    SPEAKS_FOR,
    WRONG_NAMESPACE,
    Claim,
    Gate,
    HandledUids,
    Senders,
    claim_of,
    fingerprint,
    make_uid,
    uid_robot,
)
from gidabot_navigation.tours.tour_store import TourMessage


class Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, msg: str) -> None:
        self.lines.append(msg)

    warning = error = info


@pytest.fixture(scope="module")
def tartalo(faculty) -> Senders:
    return Senders.of_building(faculty, "Tartalo")


def test_own_nodes_speak_for_this_robot_relay_ends_for_their_peer(tartalo) -> None:
    for node in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.TOUR_STORE, Node.GUI):
        s = tartalo.attribute(global_name(node))
        assert (s.kind, s.robot) == (OWN, "Tartalo") and s.own
    for peer in ("Kbot", "Galtxagorri", "MariSorgin"):      # Tartalo is first: it is robot_a of all its links
        s = tartalo.attribute(f"/gidabot_relay_Tartalo_{peer}")
        assert (s.kind, s.robot) == (RELAY, peer) and tartalo.relay_of(peer) == s.node
    with pytest.raises(KeyError):
        tartalo.relay_of("Ghost")


@pytest.mark.parametrize("callerid", [
    "/chaos_probe", "/rostopic_4242_1700000000", "/goal_manager_2", "goal_manager", "/robot/goal_manager", "",
    "/visitor",                                    # the simulated visitor: a node of this robot only in simulation
    "/relay_supervisor",                           # starts the ends; publishes no message of another robot
    "/gidabot_relay_Kbot_Tartalo",                 # the pair in the wrong order
    "/gidabot_relay_Kbot_Galtxagorri",             # a real link, not one of Tartalo's
    "/gidabot_relay_Tartalo_Ghost",                # a link to a robot not in the building
    "/gidabot_relay_Tartalo_Tartalo", "/gidabot_relay_Tartalo_Kbot/x", 42, None])
def test_anything_else_is_an_impostor(tartalo, callerid) -> None:
    s = tartalo.attribute(callerid)
    assert (s.kind, s.robot) == (IMPOSTOR, "")
    assert Senders.refusal(s, Claim("Tartalo")) == IMPOSTOR


def test_the_simulated_visitor_is_an_own_node_in_simulation_only(faculty) -> None:
    assert Senders.of_building(faculty, "Kbot", simulated=True).attribute("/visitor").kind == OWN
    assert Senders.of_building(faculty, "Kbot").attribute("/visitor").kind == IMPOSTOR
    kbot = Senders.of_building(faculty, "Kbot")                # Kbot is robot_b of its link with Tartalo
    assert kbot.attribute("/gidabot_relay_Tartalo_Kbot").robot == "Tartalo"
    assert kbot.attribute("/gidabot_relay_Kbot_MariSorgin").robot == "MariSorgin"


def test_a_message_speaks_only_for_its_sender_with_a_uid_of_that_robot(tartalo) -> None:
    own, kbot = tartalo.attribute("/goal_manager"), tartalo.attribute("/gidabot_relay_Tartalo_Kbot")
    cases = [(own, Claim("Tartalo", make_uid("Tartalo", "v", "gm")), None),
             (own, Claim("Tartalo"), None),                                     # a state: no uid
             (own, Claim("Kbot", make_uid("Kbot", "event", "nav")), FOREIGN),
             (kbot, Claim("Kbot", make_uid("Kbot", "cancel", "nav")), None),
             (kbot, Claim("Tartalo", make_uid("Tartalo", "v", "gm")), FOREIGN),   # Kbot's relay for Tartalo
             (kbot, Claim("Ghost", make_uid("Ghost", "v", "gm")), FOREIGN),        # a robot not in the building
             (kbot, Claim("Kbot", make_uid("MariSorgin", "event", "gm")), WRONG_NAMESPACE),
             (kbot, Claim("Kbot", "Kbot/event/gm.t.7"), WRONG_NAMESPACE),          # counted: guessable
             (kbot, Claim("Kbot", ""), WRONG_NAMESPACE)]
    for sender, claim, kind in cases:
        assert Senders.refusal(sender, claim) == kind, (sender, claim)
        assert tartalo.check(sender.node, claim) == (sender, kind)


def test_a_staff_command_or_link_summary_comes_only_from_the_dashboard_or_a_relay_end(tartalo) -> None:
    staff = Claim("Tartalo", make_uid("Tartalo", SCOPE_STAFF, "dash"))
    for topic, claim in ((Topic.STAFF, staff), (Topic.LINKS, Claim("Tartalo"))):
        assert set(PUBLISHERS[topic]) == {Node.DASHBOARD}
        assert tartalo.check(global_name(Node.DASHBOARD), claim, topic)[1] is None
        for node in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.TOUR_STORE, Node.GUI):
            assert tartalo.check(global_name(node), claim, topic)[1] == IMPOSTOR
            assert tartalo.check(global_name(node), claim)[1] is None             # on a topic without the rule
        kbot = Claim("Kbot", make_uid("Kbot", SCOPE_STAFF, "dash") if claim.uid else None)
        assert tartalo.check("/gidabot_relay_Tartalo_Kbot", kbot, topic)[1] is None
        assert tartalo.check("/gidabot_relay_Tartalo_Kbot", claim, topic)[1] == FOREIGN
    assert tartalo.check(global_name(Node.GOAL_MANAGER), Claim("Tartalo"), Topic.STATUS)[1] is None


def test_uids_have_a_random_token_after_their_robots_namespace() -> None:
    uids = {make_uid("Kbot", "event", "gm") for _ in range(1000)}
    assert len(uids) == 1000 and all(uid_robot(u) == "Kbot" for u in uids)
    assert all(len(u.rsplit(".", 1)[1]) == 16 for u in uids)
    assert uid_robot(make_uid("Kbot", "a.visitor@x", "nav")) == "Kbot"


def test_the_table_says_whom_every_shared_message_speaks_for() -> None:
    assert set(SPEAKS_FOR) == {t.name for t in SHARED_TOPICS}
    uid = make_uid("Kbot", "v", "gm")
    trip = Trip(uid=uid, origin_robot="Kbot", visitor_id="v", initial_floor=1.0, initial_x=0.0, initial_y=0.0,
                goal_floor=1.0, goal_x=0.0, goal_y=0.0, goal_yaw=0.0, way="", connector="", start_id="robot",
                goal_id="101", language="en")
    assert claim_of(Topic.GOALS, trip) == Claim("Kbot", uid)
    cancel = CancelData(uid=make_uid("Galtxagorri", "cancel", "nav"), goal_uid=uid, origin_robot="Galtxagorri",
                        reason="visitor")
    assert claim_of(Topic.CANCELS, cancel) == Claim("Galtxagorri", cancel.uid)
    ev = NavEventData(uid=make_uid("MariSorgin", "event", "nav"), robot="MariSorgin", floor=3.0, goal_uid=uid,
                      phase=Phase.ACCEPTED)
    assert claim_of(Topic.NAV_EVENTS, ev) == Claim("MariSorgin", ev.uid)
    tour = TourMessage(uid=make_uid("Tartalo", "tour", "ts"), origin_robot="Kbot", editor_robot="MariSorgin")
    assert claim_of(Topic.TOURS, tour) == Claim("Tartalo", tour.uid)              # the robot that sends it
    for topic in (Topic.STATUS, Topic.POSES, Topic.PENDING, Topic.TOUR_INDEX):
        assert claim_of(topic, SimpleNamespace(robot="Kbot")) == Claim("Kbot")
    assert claim_of(Topic.STATUS, SimpleNamespace(robot=7)) == Claim("")
    staff = SimpleNamespace(uid=make_uid("Kbot", SCOPE_STAFF, "dash"), robot="Kbot", target_robot="Lamia")
    assert claim_of(Topic.STAFF, staff) == Claim("Kbot", staff.uid)                 # not the robot it is about
    assert claim_of(Topic.LINKS, SimpleNamespace(robot="Kbot", links=[])) == Claim("Kbot")
    assert claim_of(Topic.VISITOR_COMMAND, ev) is None


def test_a_fingerprint_is_the_content_as_the_ros_message_carries_it() -> None:
    def event(**kw) -> NavEventData:
        return NavEventData(**{"uid": "u", "robot": "Kbot", "floor": 1.0, "goal_uid": "g", "phase": Phase.ACCEPTED,
                               "eta": 12.3, "detail": "x", **kw})

    ev = event(floor=1)
    through_float32 = struct.unpack("<f", struct.pack("<f", 12.3))[0]
    assert fingerprint(ev) == fingerprint(event(eta=through_float32))
    assert fingerprint(ev) != fingerprint(event(eta=12.4))
    assert fingerprint(ev, ("detail",)) == fingerprint(event(detail="y"), ("detail",))
    assert fingerprint(TourMessage(tour_goals_info=("a", "b"))) != fingerprint(TourMessage(tour_goals_info=("ab",)))
    assert fingerprint(event(robot="K", floor=float("nan"), goal_uid="\udcff", eta=1e300))


def test_handled_uids_tell_a_repeat_from_a_conflict() -> None:
    h = HandledUids(limit=3)
    assert h.check("a", "1") == NEW and h.add("a", "1") and not h.add("a", "2")
    assert (h.check("a", "1"), h.check("a", "2")) == (DUPLICATE, CONFLICT)
    h.update([["b", "2"], "c", 5, ["d"]])                      # bare uid: content not known, any repeat a duplicate
    assert h.check("c", "anything") == DUPLICATE and "a" in h and len(h) == 3
    h.add("e", "5")
    assert "a" not in h and h.recent(2) == [["c", ""], ["e", "5"]] and h.recent(0) == []
    h.discard("e")
    assert h.check("e", "5") == NEW


def test_the_gate_counts_every_refusal_and_logs_a_conflict_once(tartalo) -> None:
    log = Log()
    gate = Gate(tartalo, log, clock=lambda: 0.0)
    assert gate.admit("/gidabot_relay_Tartalo_Kbot", Claim("Kbot"), "status").robot == "Kbot"
    assert gate.admit("/chaos_probe", Claim("Tartalo"), "goal") is None
    assert gate.admit("/goal_manager", Claim("Kbot"), "goal") is None
    handled = HandledUids()
    handled.add("u", "1")
    assert not gate.conflict(handled, "u", "1", "goal") and not gate.conflict(handled, "v", "2", "goal")
    assert all(gate.conflict(handled, "u", "2", "goal") for _ in range(3))
    assert gate.refusals() == {"impostor": 1, "foreign": 1, "wrong_namespace": 0, "conflict": 3, "invalid": 0}
    assert sum("came again" in line for line in log.lines) == 1
    assert any("'/chaos_probe' is neither a node of this robot nor one of its relay ends" in line for line in log.lines)
