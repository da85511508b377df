"""A robot's links read from its own relay ends' diagnostics (text values; anything unreadable is unknown)."""

from __future__ import annotations

from gidabot_navigation.relay.links import DiagnosticData, link_of, own_ends


def test_own_ends_name_every_other_robot(faculty) -> None:
    assert own_ends(faculty, "Kbot") == {"/gidabot_relay_Tartalo_Kbot": "Tartalo",
                                         "/gidabot_relay_Kbot_Galtxagorri": "Galtxagorri",
                                         "/gidabot_relay_Kbot_MariSorgin": "MariSorgin"}


def test_a_relay_ends_status_read_as_a_link(faculty) -> None:
    ends = own_ends(faculty, "Kbot")
    values = {"connected": "True", "link_down_s": "", "rtt_ms": "0.84", "queue_depth": "12", "resent": "3",
              "dropped": "1", "duplicates_suppressed": "4", "link_losses": "2", "peer_master_up": "True"}
    link = link_of(DiagnosticData("relay Tartalo-Kbot: Kbot", 0, "", "/gidabot_relay_Tartalo_Kbot", values), ends, 0.4)
    assert (link.peer, link.known, link.connected, link.down_s, link.heard_s, link.rtt_ms, link.queued, link.resent,
            link.dropped, link.duplicates_suppressed, link.link_losses, link.peer_master_up) == (
        "Tartalo", True, True, 0.0, 0.4, 0.84, 12, 3, 1, 4, 2, True)
    down = link_of(DiagnosticData("relay Kbot-MariSorgin: Kbot", 2, "", "/gidabot_relay_Kbot_MariSorgin",
                                  {"connected": "False", "link_down_s": "7.5", "rtt_ms": "", "queue_depth": "x",
                                   "peer_master_up": ""}), ends)
    assert (down.connected, down.down_s, down.rtt_ms, down.queued, down.peer_master_up) == (False, 7.5, -1.0, 0, True)
    master_down = link_of(DiagnosticData("relay Kbot-MariSorgin: Kbot", 1, "", "/gidabot_relay_Kbot_MariSorgin",
                                         {"connected": "True", "peer_master_up": "False", "rtt_ms": "nan",
                                          "resent": "-4", "dropped": "1e99"}), ends)
    assert (master_down.peer_master_up, master_down.rtt_ms, master_down.resent, master_down.dropped) == (
        False, -1.0, 0, 0)


def test_statuses_of_other_nodes_and_other_robots_ends_are_not_links(faculty) -> None:
    ends = own_ends(faculty, "Kbot")
    for name, hw in (("relay Tartalo-Galtxagorri: Tartalo", "/gidabot_relay_Tartalo_Galtxagorri"),
                     ("tour_store: Kbot", "Kbot"), ("relay Tartalo-Kbot: Kbot", "/gidabot_relay_Kbot_Tartalo"),
                     ("relay_supervisor: Kbot", "/gidabot_relay_Tartalo_Kbot")):
        assert link_of(DiagnosticData(name, 0, "", hw, {}), ends) is None
