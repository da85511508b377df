"""The navigation core guiding at the visitor's pace, and asking who arrives at a meeting point to press Continue."""

from __future__ import annotations

import math

import pytest
from guiding_support import GM, GUI, PEOPLE, Bus, evs, moves, nav, phases, trip

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.guiding.messages import StopMoving
from gidabot_navigation.guiding.navigation import ABORTED, SUCCEEDED
from gidabot_navigation.guiding.pacing import PacingConfig
from gidabot_navigation.interface import REASON_VISITOR_LOST, Phase, RobotState, Sight
from gidabot_navigation.perception.people import LastSeen, Track, VisitorReport


def behind(n, dist: float, t: float, speed: float = 0.6, sight: Sight = Sight.SEEN) -> VisitorReport:
    p = n.pose
    x, y = p.x - dist * math.cos(p.yaw), p.y - dist * math.sin(p.yaw)
    return VisitorReport(sight, track_id=7, x=x, y=y, vx=speed, vy=0.0, distance=dist, behind=dist, bearing=math.pi,
                         unseen=0.0, last_seen=LastSeen(Pose2D(x, y, 0.0), t), confidence=0.9)


def guiding(faculty, **pacing):
    n = nav(faculty, "Kbot", pacing=PacingConfig(**pacing))
    assert not n.wants_people                     # idle: nobody needs the laser read
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    [move] = moves(n.on_pending([t], 0.0, 1.0, 0.0, robot=n.me, sender=GM))
    assert n.wants_visitor and n.wants_people and n.speed_cap is None
    return n, t, move


def test_a_visitor_never_seen_leaves_the_guiding_as_it_was(faculty) -> None:
    n, t, move = guiding(faculty)
    for k in range(200):
        sight = Sight.ACQUIRING if k < 5 else Sight.LOST
        assert n.on_visitor(VisitorReport(sight), 2.0 + k, 0.0, sender=PEOPLE) == []
        assert n.tick(2.5 + k, 0.0) == []
    assert n.speed_cap is None
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 300.0, 0.0)
    assert phases(acts) == [Phase.GOAL_REACHED] and not n.wants_visitor and not n.wants_people
    assert n.pace_done[-1][0] == t.uid and n.pace_done[-1][2]["samples"] == 0


def test_pacing_off_by_configuration(faculty) -> None:
    n = nav(faculty, "Kbot", pacing=None)
    n.on_pending([trip(faculty, "Kbot", "104", "Kbot/v/1")], 0.0, 1.0, 0.0, robot=n.me, sender=GM)
    assert not n.wants_visitor and n.on_visitor(behind(n, 6.0, 2.0), 2.0, 0.0, sender=PEOPLE) == []
    assert n.wants_people                         # a trip: the people around are watched all the same


def test_slow_wait_facing_the_visitor_then_go_on(faculty) -> None:
    n, t, move = guiding(faculty)
    assert n.on_visitor(behind(n, 1.3, 2.0), 2.0, 0.0, sender=PEOPLE) == []
    assert n.on_visitor(behind(n, 2.8, 3.0), 3.0, 0.0, sender=PEOPLE) == [] and n.speed_cap == pytest.approx(0.3)
    acts = n.on_visitor(behind(n, 4.5, 4.0), 4.0, 0.0, sender=PEOPLE)
    assert phases(acts) == [Phase.WAITING_FOR_YOU] and n.speed_cap is None
    assert [a.token for a in acts if isinstance(a, StopMoving)] == [move.token]
    [turn] = moves(acts)
    assert (turn.x, turn.y) == pytest.approx((n.pose.x, n.pose.y))
    assert math.cos(turn.yaw - n.pose.yaw) == pytest.approx(-1.0)        # facing the visitor behind it
    assert n.status(4.0).state == RobotState.GUIDING
    assert n.on_move_base_result(turn.token, SUCCEEDED, "", 6.0, 0.0) == []   # turned: waits
    for k in range(60):                                                    # a minute in sight
        assert n.on_visitor(behind(n, 4.5, 7.0 + k, speed=0.0), 7.0 + k, 0.0, sender=PEOPLE) == []
    acts = n.on_visitor(behind(n, 1.8, 70.0), 70.0, 0.0, sender=PEOPLE)
    assert phases(acts) == [Phase.FOLLOW_ME]
    [again] = moves(acts)
    assert (again.x, again.y) == (t.goal_x, t.goal_y)
    acts = n.on_move_base_result(again.token, SUCCEEDED, "", 90.0, 0.0)
    assert phases(acts) == [Phase.GOAL_REACHED]
    stats = n.pace_done[-1][2]
    assert (stats["waits"], stats["slowdowns"], stats["searches"]) == (1, 1, 0)
    assert stats["waiting"] == pytest.approx(66.0) and stats["worst_behind"] == pytest.approx(4.5)
    assert n.stats["pace_waits"] == 1


def test_only_the_robot_s_own_people_node_is_heard(faculty) -> None:
    """A visitor track or people tracks from another node (a relay end, rostopic pub, the GUI) are refused and
    counted: they can neither stop the robot nor prompt at the meeting point."""
    n, t, move = guiding(faculty)
    far = behind(n, 6.0, 2.0)
    for sender in (GUI, GM, "/rostopic_1", n.gate.senders.relay_of("Tartalo")):
        assert n.on_visitor(far, 2.0, 0.0, sender=sender) == []
        assert n.on_people([person(1, n.pose.x + 1.0, n.pose.y)], 2.0, sender=sender) == []
    assert n.refusals()["impostor"] == 8 and n.speed_cap is None and n.leg.moving
    assert phases(n.on_visitor(far, 3.0, 0.0, sender=PEOPLE)) == [Phase.WAITING_FOR_YOU]


def test_a_failed_turn_never_fails_the_trip(faculty) -> None:
    n, t, move = guiding(faculty)
    n.on_visitor(behind(n, 1.3, 2.0), 2.0, 0.0, sender=PEOPLE)
    [turn] = moves(n.on_visitor(behind(n, 5.0, 3.0), 3.0, 0.0, sender=PEOPLE))
    assert n.on_move_base_result(turn.token, ABORTED, "no", 4.0, 0.0) == [] and n.leg is not None


def test_search_found_again(faculty) -> None:
    n, t, move = guiding(faculty)
    n.on_visitor(behind(n, 1.3, 2.0), 2.0, 0.0, sender=PEOPLE)
    last = behind(n, 2.0, 3.0)
    n.on_visitor(last, 3.0, 0.0, sender=PEOPLE)
    acts = n.on_visitor(VisitorReport(Sight.LOST, last_seen=last.last_seen), 6.0, 0.0, sender=PEOPLE)
    assert phases(acts) == [Phase.WAITING_FOR_YOU] and n.relocks == 1
    acts = n.tick(27.0, 0.0)
    assert phases(acts) == [Phase.SEARCHING_VISITOR] and n.relocks == 2
    ev = evs(acts)[0]
    assert (ev.x, ev.y) == pytest.approx((last.x, last.y))
    [go_back] = moves(acts)
    assert (go_back.x, go_back.y) == pytest.approx((last.x, last.y))
    n.on_pose(go_back.x, go_back.y, go_back.yaw)
    [look] = moves(n.on_move_base_result(go_back.token, SUCCEEDED, "", 30.0, 0.0))
    assert (look.x, look.y) == pytest.approx((go_back.x, go_back.y)) and look.yaw != pytest.approx(go_back.yaw)
    acts = n.on_visitor(behind(n, 1.0, 32.0), 32.0, 0.0, sender=PEOPLE)
    assert phases(acts) == [Phase.FOLLOW_ME] and "found again" in evs(acts)[0].detail
    assert moves(acts)[0].x == t.goal_x


def test_lost_ends_the_trip_everywhere(faculty) -> None:
    """The goal-floor robot waiting at the meeting point drops the trip as soon as the cancel arrives."""
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    bus.finish_move("MariSorgin")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-1] == Phase.WAITING_VISITOR
    tartalo = bus.robots["Tartalo"].nav
    bus.run("Tartalo", tartalo.on_visitor(behind(tartalo, 1.3, bus.now_ros), bus.now_ros, bus.now_wall,
                                          sender=PEOPLE))
    bus.run("Tartalo", tartalo.on_visitor(VisitorReport(Sight.LOST), bus.now_ros + 2, bus.now_wall, sender=PEOPLE))
    bus.pump()
    assert bus.phases("Tartalo", uid)[-1] == Phase.WAITING_FOR_YOU
    bus.tick(ros_dt=23.0)
    assert bus.phases("Tartalo", uid)[-1] == Phase.SEARCHING_VISITOR
    bus.tick(ros_dt=61.0)
    assert bus.phases("Tartalo", uid)[-1] == Phase.VISITOR_LOST
    assert bus.cancels[-1].reason == REASON_VISITOR_LOST
    assert bus.phases("MariSorgin", uid)[-1] == Phase.VISITOR_LOST        # told at once, not after its timeout
    assert bus.robots["MariSorgin"].nav.leg is None and bus.queue_of("MariSorgin") == []
    assert bus.robots["Tartalo"].nav.leg is None and not tartalo.wants_visitor


def person(tid: int, x: float, y: float) -> Track:
    return Track(tid, x, y, 0.0, 0.0, 0.9, 0.0, True, False)


def test_meeting_point_asks_who_arrives_and_asks_again(faculty) -> None:
    n = nav(faculty, "MariSorgin")
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    [move] = moves(n.on_pending([t], 0.0, 1.0, 0.0, robot=n.me, sender=GM))
    n.on_pose(move.x, move.y, move.yaw)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    bystander = person(1, move.x + 1.0, move.y)            # already standing there: not the visitor
    assert n.on_people([bystander], 11.0, sender=PEOPLE) == []
    assert n.on_people([bystander, person(2, move.x + 4.0, move.y)], 12.0, sender=PEOPLE) == []
    acts = n.on_people([bystander, person(2, move.x + 1.2, move.y)], 15.0, sender=PEOPLE)
    assert phases(acts) == [Phase.PRESS_CONTINUE]
    assert n.on_people([bystander, person(2, move.x + 1.0, move.y)], 20.0, sender=PEOPLE) == []
    assert phases(n.on_people([person(2, move.x + 1.0, move.y)], 36.0, sender=PEOPLE)) == [Phase.PRESS_CONTINUE]
    acts = n.on_continue(t.uid, 40.0, 0.0, sender=GUI)
    assert phases(acts) == [Phase.ON_THE_WAY]
    assert n.on_people([person(2, move.x + 1.0, move.y)], 80.0, sender=PEOPLE) == []



def test_driving_alone_to_the_meeting_point_the_laser_is_read_only_near_it(faculty) -> None:
    """The goal-floor robot drives alone to the meeting point: nobody to watch on the way (a simulated laser not
    read costs no rays); from ``watch_within`` m of it on, for the rest of the leg, and waiting there, it watches."""
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    n = nav(faculty, t.goal_robot, watch_within=8.0)
    [move] = moves(n.on_pending([t], 0.0, 1.0, 0.0, robot=n.me, sender=GM))
    home = faculty.robot(t.goal_robot).home
    assert math.hypot(move.x - home.x, move.y - home.y) > 8.0          # a meeting point far from home
    assert not n.wants_people and not n.wants_visitor
    n.on_pose(move.x - 9.0, move.y, 0.0)
    assert not n.wants_people
    n.on_pose(move.x - 7.0, move.y, 0.0)
    assert n.wants_people
    n.on_pose(move.x - 9.0, move.y, 0.0)                                # the path winds away: still read
    assert n.wants_people
    n.on_pose(move.x, move.y, move.yaw)
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 60.0, 0.0)
    assert phases(acts) == [Phase.WAITING_VISITOR] and n.wants_people and not n.wants_visitor


def test_a_leg_that_starts_near_its_target_is_watched_at_once(faculty) -> None:
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    n = nav(faculty, t.goal_robot, watch_within=1e6)
    n.on_pending([t], 0.0, 1.0, 0.0, robot=n.me, sender=GM)
    assert n.wants_people
