"""The core of a relay end: handshake, HMAC, seq/ack, dedup, journal replay, bounded queues, coalescing, liveness.

Two cores joined by an in-memory wire (relay_support.Wire); no sockets, no master.
"""

from __future__ import annotations

import pytest
from relay_support import MD5, SECRET, TYPES, Clock, Log, make_core, pair

from gidabot_navigation.errors import RelayConfigError
from gidabot_navigation.interface import EVENT, Node, Topic, TopicSpec, global_name, is_relay_end, relay_end_name
from gidabot_navigation.relay.end import Close, RelayEndConfig, Send, parse_shared_topics, read_secret
from gidabot_navigation.relay.journal import Journal
from gidabot_navigation.relay.protocol import FrameType, Hello, encode_frame, hello_key
from gidabot_navigation.senders import SCOPE_STAFF, make_uid

G = Topic.GOALS
S = Topic.STATUS


# -- handshake and authentication ------------------------------------------------------------
def test_events_cross_in_order_exactly_once(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    assert w.a.active is not None and w.b.active is not None
    for i in range(5):
        w.local("a", G, b"goal%d" % i)
    w.local("b", G, b"from-b")
    assert w.payloads("b") == [b"goal%d" % i for i in range(5)]
    assert w.payloads("a") == [b"from-b"]
    assert len(w.a.state.outq) == 0 and len(w.b.state.outq) == 0      # everything acknowledged
    assert w.a.snapshot()["forwarded_events"] == 5 and w.b.snapshot()["delivered_events"] == 5


@pytest.mark.parametrize(("sa", "sb"), [(SECRET, b"another secret of 16+ bytes"), (SECRET, None), (None, SECRET)])
def test_mismatched_secrets_never_connect(tmp_path, sa, sb) -> None:
    w, _, _, _ = pair(tmp_path, secret_a=sa, secret_b=sb)
    w.connect()
    w.local("a", G, b"secret goal")
    assert w.a.active is None and w.b.active is None
    assert w.payloads("b") == []
    rejected = w.a.stats.rejected["auth"] + w.b.stats.rejected["auth"]
    assert rejected >= 1


def test_no_secret_on_both_sides_works(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path, secret_a=None, secret_b=None)
    w.connect()
    w.local("a", G, b"open")
    assert w.payloads("b") == [b"open"]


def test_wrong_link_name_is_refused(tmp_path) -> None:
    clock, log = Clock(), Log()
    b = make_core("b", Journal(None), clock, log)
    b.connection_opened(1, initiator=False)
    hello = Hello("Tartalo_Galtxagorri", "a", b"n" * 16, b"", 1, 0, 0)
    acts = b.data_received(1, encode_frame(FrameType.HELLO, hello.encode(), hello_key(SECRET)))
    assert any(isinstance(x, Close) for x in acts)
    assert b.stats.rejected["auth"] == 1 and log.has("expects side")


def test_spoofed_and_replayed_frames_are_rejected_and_counted(tmp_path) -> None:
    w, _, lb, _ = pair(tmp_path)
    w.connect()
    w.local("a", G, b"real")
    # an attacker on another connection replays a's HELLO, then a captured EVENT frame
    hello = next(data for side, data in w.tap if side == "a")
    event = [data for side, data in w.tap if side == "a"][2]          # HELLO, READY, EVENT
    acts = w.b.connection_opened(99, initiator=False)
    acts += w.b.data_received(99, hello)
    assert any(isinstance(x, Send) for x in acts)                    # b answers the HELLO ...
    acts = w.b.data_received(99, event)                               # ... but the replayed EVENT is not READY
    assert any(isinstance(x, Close) and x.conn == 99 for x in acts)
    assert w.b.active is not None and w.b.active.id == w.conn        # the real link is untouched
    # frames without MAC, with a bad MAC, and a forged MAC on the live link are all refused
    before = w.b.stats.rejected["auth"]
    for conn, data in ((100, encode_frame(FrameType.HELLO, b"x")),
                       (101, encode_frame(FrameType.HELLO, b"x", hello_key(b"wrong secret 1234567")))):
        w.b.connection_opened(conn, initiator=False)
        assert any(isinstance(x, Close) for x in w.b.data_received(conn, data))
    assert w.b.stats.rejected["auth"] == before + 2
    assert w.payloads("b") == [b"real"]
    assert lb.has("rejected (auth)")


def test_an_authenticated_peer_cannot_be_hijacked_by_a_half_open_handshake(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path, handshake_timeout=3.0)
    w.connect()
    w.b.connection_opened(50, initiator=False)
    for _ in range(14):
        clock.t += 0.25
        w.tick()                                     # heartbeats flow on the real link
    assert 50 not in w.b.conns and w.b.active is not None


def test_too_many_unauthenticated_connections_are_refused(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path, max_pending_connections=2)
    assert w.b.connection_opened(1, False) == []
    assert w.b.connection_opened(2, False) == []
    assert isinstance(w.b.connection_opened(3, False)[0], Close)


# -- oversize, malformed, types, loops -----------------------------------------------------------
def test_local_messages_that_must_not_cross(tmp_path) -> None:
    w, la, _, _ = pair(tmp_path, max_message_bytes=100)
    w.connect()
    w.run("a", w.a.local_message(G, relay_end_name("Kbot", "Galtxagorri"), TYPES[G], MD5[G], b"relayed"))
    own = global_name(Node.GOAL_MANAGER)
    w.run("a", w.a.local_message(G, own, "std_msgs/String", "f" * 32, b"wrong type"))
    w.run("a", w.a.local_message(G, own, TYPES[G], "f" * 32, b"wrong md5"))
    w.run("a", w.a.local_message(G, own, TYPES[G], MD5[G], b"x" * 101))
    w.run("a", w.a.local_message(G, own, TYPES[G], MD5[G], b"BAD bytes"))
    w.run("a", w.a.local_message("/not/shared", own, "std_msgs/String", "0" * 32, b"x"))
    assert w.payloads("b") == []
    s = w.a.snapshot()
    assert s["ignored_relay"] == 1 and s["rejected_type"] == 3 and s["rejected_oversize"] == 1
    assert s["rejected_malformed"] == 1 and s["queue_depth"] == 0 and s["forwarded"] == 0
    assert la.has("only gidabot_msgs/Goal")


def test_a_node_named_like_a_relay_end_that_is_none_of_this_robots_is_an_impostor(tmp_path) -> None:
    """Tartalo's ends know Tartalo's links (the supervisor passes them): another link's end is ignored (it published
    what its robot sent), a relay-looking name of a link Tartalo does not have is refused and counted."""
    ends = frozenset(relay_end_name("Tartalo", r) for r in ("Kbot", "Galtxagorri", "MariSorgin"))
    w, la, _, _ = pair(tmp_path, robot_ends=ends)
    w.connect()
    w.run("a", w.a.local_message(G, relay_end_name("Tartalo", "Galtxagorri"), TYPES[G], MD5[G], b"relayed"))
    for impostor in (relay_end_name("Tartalo", "Ghost"), relay_end_name("Kbot", "Galtxagorri"),
                     relay_end_name("Galtxagorri", "Tartalo")):
        w.run("a", w.a.local_message(G, impostor, TYPES[G], MD5[G], b"forged"))
    assert w.payloads("b") == []
    s = w.a.snapshot()
    assert s["ignored_relay"] == 1 and s["rejected_impostor"] == 3 and s["forwarded"] == 0
    assert la.has("named like a relay end but is none of Tartalo's")


def test_a_state_crosses_only_from_the_robot_it_speaks_for(tmp_path) -> None:
    """A status / pose / pending list published on Tartalo's master that speaks for another robot (a spoofed or
    hostile one: the chaos run's NavPose of 'Ghost' with an infinite pose) never leaves Tartalo; it is counted."""
    w, la, _, _ = pair(tmp_path)
    w.connect()
    nav = global_name(Node.MULTIROBOT_NAVIGATION)
    w.local("a", S, b"robot=Tartalo;ok", callerid=nav)
    w.local("a", S, b"robot=Ghost;x=inf", callerid=nav)
    w.local("a", S, b"robot=Kbot;spoofed", callerid=nav)
    assert w.payloads("b", S) == [b"robot=Tartalo;ok"]
    assert w.a.snapshot()["rejected_foreign"] == 2 and la.has("may speak for Tartalo, not for 'Ghost'")
    # and a peer's state that does not speak for the peer is not published here (the link stays)
    from gidabot_navigation.relay.protocol import Message, encode_message

    for payload in (b"robot=MariSorgin;relayed", b"robot=Tartalo;ok again"):
        w.run("a", [w.a._frame(w.a.active, FrameType.STATE, encode_message(Message(S, "/x", MD5[S], payload), False))])
    assert w.payloads("b", S) == [b"robot=Tartalo;ok", b"robot=Tartalo;ok again"]
    assert w.b.snapshot()["rejected_foreign"] == 1 and w.b.active is not None


def test_a_goal_published_by_a_node_that_is_not_this_robots_is_never_forwarded(tmp_path) -> None:
    """A goal on Tartalo's master from a node that is neither one of Tartalo's nodes nor a relay end (rostopic pub,
    a probe, the fault injection; a name that merely looks like ours) never leaves Tartalo, whatever it says."""
    w, la, _, _ = pair(tmp_path)
    w.connect()
    goal = f"robot=Tartalo;uid={make_uid('Tartalo', 'v', 'gm')}".encode()
    for callerid in ("/chaos_probe", "/rostopic_4242_1700000000", "/goal_manager_2", "goal_manager", ""):
        w.local("a", G, goal, callerid=callerid)
    snap = w.a.snapshot()
    assert w.payloads("b") == [] and snap["rejected_impostor"] == 5 and snap["forwarded"] == 0
    assert la.has("is not one of Tartalo's nodes")
    w.local("a", G, goal, callerid=global_name(Node.GOAL_MANAGER))
    assert w.payloads("b") == [goal]


def test_an_own_event_that_does_not_speak_for_this_robot_is_not_forwarded(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    for payload in (f"robot=Kbot;uid={make_uid('Kbot', 'event', 'nav')}",             # another robot's
                    f"robot=Ghost;uid={make_uid('Ghost', 'event', 'nav')}",           # not in the building
                    f"robot=Tartalo;uid={make_uid('Kbot', 'event', 'nav')}",          # a uid of Kbot's
                    "robot=Tartalo;uid=Tartalo/event/nav.1"):                         # no random part
        w.local("a", G, payload.encode(), callerid=global_name(Node.MULTIROBOT_NAVIGATION))
    snap = w.a.snapshot()
    assert w.payloads("b") == [] and snap["rejected_foreign"] == 2 and snap["rejected_wrong_namespace"] == 2
    assert snap["queue_depth"] == 0 and w.a.refusals()["foreign"] == 2


def test_a_staff_command_crosses_only_from_this_robots_dashboard(tmp_path) -> None:
    """A staff command speaks for the robot whose dashboard sent it: another node of Tartalo's (its goal manager,
    its GUI) may not publish one (senders.PUBLISHERS); it never leaves Tartalo."""
    w, la, _, _ = pair(tmp_path)
    w.connect()
    cmd = f"robot=Tartalo;uid={make_uid('Tartalo', SCOPE_STAFF, 'dash')}".encode()
    for node in (Node.GOAL_MANAGER, Node.GUI):
        w.local("a", Topic.STAFF, cmd, callerid=global_name(node))
    assert w.payloads("b", Topic.STAFF) == [] and w.a.snapshot()["rejected_impostor"] == 2
    assert la.has("is a node of this robot that may not publish this")
    w.local("a", Topic.STAFF, cmd, callerid=global_name(Node.DASHBOARD))
    assert w.payloads("b", Topic.STAFF) == [cmd]


def test_an_event_the_peer_sends_for_another_robot_is_acknowledged_never_published(tmp_path) -> None:
    """Over the link from Tartalo, only what speaks for Tartalo is published on Kbot's master: an event for Kbot
    itself, for a third robot, or with a uid of another robot's is dropped and counted (and acknowledged: the
    link goes on)."""
    from gidabot_navigation.relay.protocol import Message, encode_message

    w, _, lb, _ = pair(tmp_path)
    w.connect()
    real = f"robot=Tartalo;uid={make_uid('Tartalo', 'event', 'gm')}".encode()
    forged = [f"robot=Kbot;uid={make_uid('Kbot', 'event', 'gm')}",
              f"robot=MariSorgin;uid={make_uid('MariSorgin', 'cancel', 'nav')}",
              f"robot=Tartalo;uid={make_uid('Galtxagorri', 'v', 'gm')}"]
    first = w.a.state.next_seq
    w.a.state.next_seq += 4
    for i, payload in enumerate([p.encode() for p in forged] + [real]):
        m = Message(G, global_name(Node.GOAL_MANAGER), MD5[G], payload, first + i)
        w.run("a", [w.a._frame(w.a.active, FrameType.EVENT, encode_message(m, True))])
    assert w.payloads("b") == [real]
    snap = w.b.snapshot()
    assert snap["rejected_foreign"] == 2 and snap["rejected_wrong_namespace"] == 1 and w.b.active is not None
    assert w.b.state.in_last == first + 3 and lb.has("may speak for Tartalo, not for 'Kbot'")


def test_oversized_frame_from_the_peer_closes_only_that_connection(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path, max_message_bytes=100)
    w.connect()
    huge = encode_frame(FrameType.EVENT, b"x" * 5000)
    w.b.connection_opened(7, initiator=False)
    acts = w.b.data_received(7, huge[:20])
    assert any(isinstance(x, Close) and x.conn == 7 for x in acts)
    assert w.b.stats.rejected["oversize"] == 1 and w.b.active is not None


def test_peer_event_of_wrong_md5_or_malformed_is_acknowledged_not_published(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    # end a's adapter is bypassed: put a bad message straight into its outbound stream
    from gidabot_navigation.relay.protocol import Message, encode_message

    conn = w.a.active
    first = w.a.state.next_seq
    w.a.state.next_seq += 3
    for m in (Message(G, "/x", "0" * 32, b"ok", first),
              Message(G, "/x", MD5[G], b"BAD", first + 1),
              Message(S, "/x", MD5[S], b"state as event", first + 2)):
        w.run("a", [w.a._frame(conn, FrameType.EVENT, encode_message(m, True))])
    assert w.payloads("b") == []
    assert w.b.stats.rejected["type"] == 2 and w.b.stats.rejected["malformed"] == 1
    assert w.b.state.in_last == 3 and w.b.active is not None


def test_relay_names() -> None:
    assert relay_end_name("Tartalo", "Kbot") == "/gidabot_relay_Tartalo_Kbot"
    assert is_relay_end("/gidabot_relay_Tartalo_Kbot") and not is_relay_end(global_name(Node.RELAY_SUPERVISOR))


# -- sequence numbers, acknowledgements, de-duplication -------------------------------------------
def test_queued_while_down_then_retransmitted_without_duplicates(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    w.local("a", G, b"1")
    w.cut()
    w.local("a", G, b"2")
    w.local("a", G, b"3")
    assert w.a.snapshot()["queue_depth"] == 2
    w.connect()
    assert w.payloads("b") == [b"1", b"2", b"3"]
    assert w.a.snapshot()["queue_depth"] == 0


def test_lost_acks_cause_retransmission_that_is_suppressed(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    # a sends two events, b receives them but the ACKs never reach a
    w.open = True
    gm = global_name(Node.GOAL_MANAGER)
    frames = w.a.local_message(G, gm, TYPES[G], MD5[G], b"x1") + w.a.local_message(G, gm, TYPES[G], MD5[G], b"x2")
    for f in frames:
        w.b.data_received(w.conn, f.data)                             # replies dropped
    w.deliver()
    assert w.payloads("b") == [b"x1", b"x2"] and len(w.a.state.outq) == 2
    w.cut()
    w.connect()                                                       # b's HELLO says in_last = 2
    assert w.payloads("b") == [b"x1", b"x2"] and len(w.a.state.outq) == 0
    assert w.a.snapshot()["acked_on_reconnect"] == 2 and w.a.stats.resent == 0
    # even without the HELLO shortcut, a retransmitted duplicate is suppressed
    from gidabot_navigation.relay.protocol import Message, encode_message

    dup = Message(G, "/gm", MD5[G], b"x2", 2)
    w.run("a", [w.a._frame(w.a.active, FrameType.EVENT, encode_message(dup, True))])
    assert w.payloads("b") == [b"x1", b"x2"]
    assert w.b.stats.duplicates_suppressed == 1


# -- journal: crash and replay ------------------------------------------------------------------
def test_sender_killed_with_unacknowledged_events_delivers_them_after_restart(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path)
    w.connect()
    w.local("a", G, b"before")
    w.cut()
    w.local("a", G, b"queued1")
    w.local("a", G, b"queued2")
    w.a.journal.close()                                 # SIGKILL: no shutdown, nothing flushed but write(2)s
    a2 = make_core("a", Journal(tmp_path / "a.journal"), clock, Log())
    assert [m.payload for m in a2.state.outq] == [b"queued1", b"queued2"]
    w.a = a2
    w.connect()
    assert w.payloads("b") == [b"before", b"queued1", b"queued2"]
    w.local("a", G, b"after")
    assert w.payloads("b")[-1] == b"after" and w.b.stats.duplicates_suppressed == 0


def test_receiver_killed_after_acknowledging_publishes_after_restart_exactly_once(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path)
    w.connect()
    w.b.set_delivery_open(False)                        # e.g. its master is restarting
    w.local("a", G, b"held1")
    w.local("a", G, b"held2")
    assert len(w.a.state.outq) == 0                     # acknowledged by b
    assert w.payloads("b") == []
    w.cut()
    w.b.journal.close()                                 # b is killed
    b2 = make_core("b", Journal(tmp_path / "b.journal"), clock, Log())
    w.b = b2
    w.deliver()
    assert w.payloads("b") == [b"held1", b"held2"]
    w.connect()                                         # a does not resend; b would suppress anyway
    w.local("a", G, b"next")
    assert w.payloads("b") == [b"held1", b"held2", b"next"]
    b2.journal.close()
    b3 = make_core("b", Journal(tmp_path / "b.journal"), clock, Log())
    assert len(b3.state.pending_in) == 0 and b3.state.in_last == 3


def test_torn_journal_tail_is_cut_off(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path)
    w.local("a", G, b"one")
    w.local("a", G, b"two")
    w.a.journal.close()
    path = tmp_path / "a.journal"
    data = path.read_bytes()
    digest_record = 4 + 4 + 1 + 4 + 16                  # each event's write ends with its digest ('H')
    path.write_bytes(data[:-(digest_record + 5)])       # killed in the middle of the last write
    log = Log()
    a2 = make_core("a", Journal(path), clock, log)
    assert [m.payload for m in a2.state.outq] == [b"one"]
    assert a2.state.next_seq == 2 and log.has("torn tail")


def test_journal_is_locked_against_a_second_process(tmp_path) -> None:
    from gidabot_navigation.errors import JournalError

    j = Journal(tmp_path / "x.journal")
    j.open()
    with pytest.raises(JournalError, match="in use"):
        Journal(tmp_path / "x.journal").open()
    j.close()


def test_compaction_keeps_the_live_state(tmp_path) -> None:
    clock = Clock()
    w, _, _, _ = pair(tmp_path, clock=clock)
    w.a.journal.compact_min_bytes = 2000
    w.connect()
    for i in range(100):
        w.local("a", G, b"%03d" % i + b"." * 50)
    w.cut()
    w.local("a", G, b"pending")
    w.tick()
    assert w.a.journal.compactions >= 1
    size = (tmp_path / "a.journal").stat().st_size
    assert size < 2000
    w.a.journal.close()
    a2 = make_core("a", Journal(tmp_path / "a.journal"), clock, Log())
    assert [m.payload for m in a2.state.outq] == [b"pending"] and a2.state.next_seq == 102


def test_new_sender_epoch_is_not_mistaken_for_duplicates(tmp_path) -> None:
    w, _, lb, clock = pair(tmp_path)
    w.connect()
    w.local("a", G, b"old1")
    w.local("a", G, b"old2")
    w.cut()
    w.a.journal.close()
    (tmp_path / "a.journal").unlink()                   # a's state directory was wiped
    w.a = make_core("a", Journal(tmp_path / "a.journal"), clock, Log())
    w.connect()
    w.local("a", G, b"new1")                            # seq 1 again, but a new epoch
    assert w.payloads("b") == [b"old1", b"old2", b"new1"]
    assert lb.has("changed epoch")


# -- bounded queues ---------------------------------------------------------------------------
def test_outbound_bound_drops_the_oldest_with_a_clear_log(tmp_path) -> None:
    w, la, _, _ = pair(tmp_path, max_queue=3)
    for i in range(5):
        w.local("a", G, b"%d" % i)
    assert [m.payload for m in w.a.state.outq] == [b"2", b"3", b"4"]
    assert w.a.stats.dropped == 2 and la.has("outbound queue full (3 events")
    w.connect()
    assert w.payloads("b") == [b"2", b"3", b"4"]


def test_inbound_bound_drops_the_oldest_held_event(tmp_path) -> None:
    w, _, lb, _ = pair(tmp_path, max_inbound=2)
    w.connect()
    w.b.set_delivery_open(False)
    for i in range(4):
        w.local("a", G, b"%d" % i)
    w.b.set_delivery_open(True)
    w.deliver()
    assert w.payloads("b") == [b"2", b"3"]
    assert w.b.stats.dropped == 2 and lb.has("inbound queue full")


def test_queue_bounds_in_bytes_too(tmp_path) -> None:
    w, la, _, _ = pair(tmp_path, max_queue_bytes=250)
    for i in range(5):
        w.local("a", G, b"%d" % i + b"." * 99)
    assert len(w.a.state.outq) == 2 and w.a.snapshot()["queue_bytes"] == 200
    assert la.has("250 bytes")
    w.connect()
    assert [p[:1] for p in w.payloads("b")] == [b"3", b"4"]
    assert w.a.snapshot()["queue_bytes"] == 0


def test_state_keys_are_bounded(tmp_path) -> None:
    w, la, _, _ = pair(tmp_path, max_state_keys=2)
    w.connect()
    for node in (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION, Node.TOUR_STORE):
        w.local("a", S, b"x", callerid=global_name(node))
    assert len(w.b.latest_states(S)) == 2 and w.a.stats.dropped == 1 and la.has("already 2")


# -- states: latest value, coalescing, re-sent on reconnect --------------------------------------
def test_states_are_coalesced_per_publisher_and_resent_on_reconnect(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path, state_rate=10.0)
    w.connect()
    for i in range(20):                                  # 20 updates within 50 ms
        w.local("a", S, b"s%d" % i, callerid=global_name(Node.MULTIROBOT_NAVIGATION))
        clock.t += 0.0025
    w.local("a", S, b"other", callerid=global_name(Node.GOAL_MANAGER))
    got = w.payloads("b", S)
    assert got[0] == b"s0" and len(got) <= 3
    clock.t += 0.2
    w.tick()
    got = w.payloads("b", S)
    assert got[-2:] in ([b"s19", b"other"], [b"other", b"s19"]) or got[-1] == b"s19"
    assert sorted(m.payload for m in w.b.latest_states(S)) == [b"other", b"s19"]
    n = len(got)
    w.cut()
    w.connect()                                          # both latest values again at once
    assert sorted(w.payloads("b", S)[n:]) == [b"other", b"s19"]


def test_a_due_coalesced_state_is_sent_by_the_next_tick_so_the_loop_never_spins(tmp_path) -> None:
    """The node's loop waits ``next_tick_in()`` and then ticks when it is 0: that tick must send the
    state that made it 0, or the loop would wake at once, again and again (it once did, for up to
    half a heartbeat after every coalesced state)."""
    w, _, _, clock = pair(tmp_path, state_rate=10.0, heartbeat=0.5)
    w.connect()
    nav = global_name(Node.MULTIROBOT_NAVIGATION)
    w.local("a", S, b"first", callerid=nav)              # sent at once
    clock.t += 0.01
    w.local("a", S, b"second", callerid=nav)             # within 0.1 s: coalesced
    assert w.payloads("b", S) == [b"first"]
    assert w.a.next_tick_in() == pytest.approx(0.09)
    clock.t += 0.09
    assert w.a.next_tick_in() == 0.0
    w.tick()
    assert w.payloads("b", S) == [b"first", b"second"]
    assert w.a.next_tick_in() == pytest.approx(0.25)      # nothing due before the next heartbeat check


def test_states_published_while_down_arrive_as_latest_only(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path)
    for i in range(5):
        w.local("a", S, b"v%d" % i, callerid=global_name(Node.MULTIROBOT_NAVIGATION))
    w.connect()
    assert w.payloads("b", S) == [b"v4"]


# -- liveness ---------------------------------------------------------------------------------
def test_heartbeats_keep_the_link_and_silence_kills_it(tmp_path) -> None:
    w, _, _, clock = pair(tmp_path, heartbeat=0.5, link_timeout=2.0)
    w.connect()
    for _ in range(20):                                  # 5 s of normal heartbeats
        clock.t += 0.25
        w.tick()
    assert w.a.active is not None and w.a.rtt is not None
    # the network silently drops everything: nothing reaches either side
    w.open = False
    lost_at = None
    for step in range(1, 20):
        clock.t += 0.25
        w.a.tick()
        w.b.tick()
        if w.a.active is None and w.b.active is None:
            lost_at = step * 0.25
            break
    assert lost_at is not None and lost_at <= 2.5
    assert w.a.stats.link_losses == 1


def test_diagnostics_snapshot_has_the_required_keys(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    snap = w.a.snapshot()
    for key in ("connected", "rtt_ms", "queue_depth", "forwarded", "dropped", "duplicates_suppressed",
                "rejected_auth", "rejected_oversize", "rejected_malformed"):
        assert key in snap


# -- configuration ----------------------------------------------------------------------------
@pytest.mark.parametrize(("doc", "text"), [
    ({}, "non-empty list"),
    ({"topics": [{"name": "rel", "type": "a/B", "class": "event"}]}, "global topic name"),
    ({"topics": [{"name": "/t", "type": "AB", "class": "event"}]}, "package/Type"),
    ({"topics": [{"name": "/t", "type": "a/B", "class": "sometimes"}]}, "event or state"),
    ({"topics": [{"name": "/t", "type": "a/B", "class": "event", "extra": 1}]}, "exactly the keys"),
    ({"topics": [{"name": "/t", "type": "a/B", "class": "event"}] * 2}, "twice"),
])
def test_bad_shared_topics_are_explained(doc, text) -> None:
    with pytest.raises(RelayConfigError, match=text):
        parse_shared_topics(doc)


def test_secret_file_rules(tmp_path) -> None:
    good = tmp_path / "secret"
    good.write_text("a-long-enough-secret\n")
    assert read_secret(good) == b"a-long-enough-secret"
    short = tmp_path / "short"
    short.write_text("tiny")
    with pytest.raises(RelayConfigError, match="at least 16"):
        read_secret(short)
    with pytest.raises(RelayConfigError, match="cannot read"):
        read_secret(tmp_path / "missing")


def test_link_config_validation() -> None:
    topics = (TopicSpec(G, TYPES[G], EVENT),)
    with pytest.raises(RelayConfigError, match="side"):
        RelayEndConfig("A", "B", "c", topics, MD5)
    with pytest.raises(RelayConfigError, match="shorter than link_timeout"):
        RelayEndConfig("A", "B", "a", topics, MD5, heartbeat=3.0)
    with pytest.raises(RelayConfigError, match="no md5"):
        RelayEndConfig("A", "B", "a", topics, {})


def test_a_local_event_published_again_is_forwarded_once_even_after_a_restart(tmp_path) -> None:
    """A restarted node publishes its unsent outbox again, and replays its recent events to a relay end
    that (re)connects: the end forwards only what it has not forwarded before (digests in its journal)."""
    clock = Clock()
    w, _, _, _ = pair(tmp_path, clock=clock, header_topics=frozenset({G}))
    w.connect()
    w.local("a", G, b"\x01\x00\x00\x00goal-1")
    w.local("a", G, b"\x02\x00\x00\x00goal-1")          # the same message again: only header.seq differs
    w.local("a", G, b"\x03\x00\x00\x00goal-2")
    assert w.payloads("b") == [b"\x01\x00\x00\x00goal-1", b"\x03\x00\x00\x00goal-2"]
    assert w.a.stats.replays_ignored == 1
    w.a.journal.compact_min_bytes = 1                   # compaction keeps the digests
    w.a.journal.compact(w.a.state)
    w.a.journal.close()
    a2 = make_core("a", Journal(tmp_path / "a.journal"), clock, Log(), header_topics=frozenset({G}))
    assert a2.local_message(G, global_name(Node.GOAL_MANAGER), TYPES[G], MD5[G], b"\x09\x00\x00\x00goal-2") == []
    assert a2.stats.replays_ignored == 1
    a2.local_message(G, global_name(Node.GOAL_MANAGER), TYPES[G], MD5[G], b"\x09\x00\x00\x00goal-3")
    assert a2.stats.forwarded_events == 1


def test_without_a_header_every_byte_counts(tmp_path) -> None:
    w, _, _, _ = pair(tmp_path)
    w.connect()
    w.local("a", G, b"\x01\x00\x00\x00same")
    w.local("a", G, b"\x02\x00\x00\x00same")
    assert len(w.payloads("b")) == 2 and w.a.stats.replays_ignored == 0
