"""The visitor's pace per trip and robot, from the robots' events and their pace statuses."""

from __future__ import annotations

import pytest

from gidabot_navigation.interface import Phase
from gidabot_sim.report.pace import merge, pace_from_diagnostics, pace_from_events, people_at, totals, where_lost


def test_waits_searches_lost_and_found_again_from_the_events() -> None:
    events = [(10.0, "Kbot", "g1", Phase.ON_THE_WAY), (20.0, "Kbot", "g1", Phase.WAITING_FOR_YOU),
              (50.0, "Kbot", "g1", Phase.FOLLOW_ME), (60.0, "Kbot", "g1", Phase.SEARCHING_VISITOR),
              (70.0, "Kbot", "g1", Phase.FOLLOW_ME), (90.0, "Kbot", "g1", Phase.GOAL_REACHED),
              (5.0, "Tartalo", "g2", Phase.ON_THE_WAY), (8.0, "Tartalo", "g2", Phase.SEARCHING_VISITOR),
              (68.0, "Tartalo", "g2", Phase.VISITOR_LOST), (68.5, "MariSorgin", "g2", Phase.VISITOR_LOST),
              (9.0, "Kbot", "g3", Phase.GOAL_REACHED)]
    rows = pace_from_events(events)
    assert set(rows) == {("g1", "Kbot"), ("g2", "Tartalo")}      # MariSorgin only heard of it; g3 never paced
    g1, g2 = rows[("g1", "Kbot")], rows[("g2", "Tartalo")]
    assert (g1["waits"], g1["searches"], g1["found_again"], g1["lost"], g1["waiting_s"]) == (1, 1, 1, 0, 40.0)
    assert (g2["searches"], g2["lost"], g2["found_again"], g2["waiting_s"]) == (1, 1, 0, 60.0)


def test_the_robots_own_counts_win_and_are_summed() -> None:
    diags = [("guiding: pace Kbot", {"goal_uid": "g1", "leg": "start", "mean_behind": "1.4", "worst_behind": "3.2",
                                     "waiting": "30.0", "slowdowns": "2", "waits": "1", "searches": "1", "lost": "0",
                                     "found_again": "1", "samples": "300"}),
             ("guiding: navigation Kbot", {"goal_uid": "g1"}),
             ("guiding: pace Tartalo", {"goal_uid": "g2", "leg": "start", "mean_behind": "0", "worst_behind": "0",
                                        "waiting": "0", "slowdowns": "0", "waits": "0", "searches": "0", "lost": "0",
                                        "found_again": "0", "samples": "0"})]
    own = pace_from_diagnostics(diags)
    assert own[("g1", "Kbot")]["mean_behind_m"] == pytest.approx(1.4) and own[("g1", "Kbot")]["slowdowns"] == 2
    assert own[("g2", "Tartalo")]["mean_behind_m"] is None          # never seen: no distance
    rows = merge(pace_from_events([(20.0, "Kbot", "g1", Phase.WAITING_FOR_YOU)]), own)
    assert len(rows) == 2 and rows[0]["waiting_s"] == 30.0
    t = totals(rows)
    assert t == {"legs": 2, "mean_behind_m": 1.4, "worst_behind_m": 3.2, "waiting_s": 30.0, "slowdowns": 2,
                 "waits": 1, "searches": 1, "lost": 0, "found_again": 1}


def test_where_a_lost_visitor_truly_was() -> None:
    """The simulator's people_at (bad parts skipped) and the robot's track at the loss: the body 6 m away; a body
    gone from the floor; nothing recorded near the time."""
    assert people_at("person/v1 1.00 2.00; person/v2 x 3; person/b1 4 5 6; ; person/v3 nan 1") == \
        {"person/v1": (1.0, 2.0)}
    tracks = {"Kbot": [(90.0, 0.0, 0.0), (101.0, 10.0, 0.0), (500.0, 1.0, 1.0)]}
    bodies = {"Kbot": [(95.0, {"person/v1": (4.0, 0.0)}), (105.0, {"person/v1": (4.0, 0.0), "person/v1/1": (4.0, 1.0)}),
                       (300.0, {"person/bystander0": (1.0, 1.0)})]}
    rows = where_lost([(300.0, "Kbot", "Kbot/v1/gm.2"), (100.0, "Kbot", "Kbot/v1/gm.1"),
                       (900.0, "Kbot", "Kbot/v1/gm.3")], tracks, bodies)
    assert rows[0] == {"t": 100.0, "robot": "Kbot", "goal_uid": "Kbot/v1/gm.1", "robot_at": [10.0, 0.0],
                       "body_at": [4.0, 0.0], "on_floor": True, "distance_m": 6.0}
    assert (rows[1]["body_at"], rows[1]["on_floor"], rows[1]["robot_at"]) == (None, False, None)
    assert (rows[2]["body_at"], rows[2]["on_floor"], rows[2]["distance_m"]) == (None, None, None)
