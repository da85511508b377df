"""The pacing and search rules, driven by visitor reports and times (no clock)."""

from __future__ import annotations

import math

import pytest

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.errors import GuidingError
from gidabot_navigation.guiding.pacing import Pace, Pacer, PacingConfig, Say
from gidabot_navigation.interface import Sight
from gidabot_navigation.perception.people import LastSeen, VisitorReport

ROBOT = Pose2D(10.0, 0.0, 0.0)      # heading +x: "behind" is -x


def seen(dist: float, t: float, speed: float = 0.6, sight: Sight = Sight.SEEN) -> VisitorReport:
    x = ROBOT.x - dist
    return VisitorReport(sight, track_id=1, x=x, y=0.0, vx=speed, vy=0.0, distance=dist, behind=dist,
                         bearing=math.pi, unseen=0.0 if sight == Sight.SEEN else 1.0,
                         last_seen=LastSeen(Pose2D(x, 0.0, 0.0), t), confidence=0.9)


def lost(t: float, at: float = 5.0) -> VisitorReport:
    return VisitorReport(Sight.LOST, last_seen=LastSeen(Pose2D(at, 0.0, 0.0), t - 3.0))


def pacer(**cfg) -> Pacer:
    p = Pacer(PacingConfig(**cfg))
    p.start(0.0)
    p.on_robot(ROBOT)
    return p


def test_config_is_checked_and_lists_every_problem():
    with pytest.raises(GuidingError, match="near: -1.*far: nan"):
        PacingConfig(near=-1.0, far=float("nan"))
    with pytest.raises(GuidingError, match="near <= resume <= far"):
        PacingConfig(near=3.0, resume=2.0, far=4.0)


def test_never_seen_visitor_leaves_the_robot_at_its_own_pace():
    p = pacer()
    for t in range(120):
        assert p.on_visitor(VisitorReport(Sight.ACQUIRING), float(t)) is None
        assert p.step(t + 0.5) is None
    assert p.on_visitor(VisitorReport(Sight.LOST), 121.0) is None
    assert p.pace is Pace.OFF and p.stats.waits == 0 and p.stats.searches == 0


def test_close_visitor_normal_then_slow_then_normal_again():
    p = pacer(near=2.0)
    assert p.on_visitor(seen(1.2, 1.0), 1.0) is None and p.pace is Pace.NORMAL
    d = p.on_visitor(seen(2.8, 2.0), 2.0)
    assert d.pace is Pace.SLOW and d.speed_cap == pytest.approx(0.3) and d.drive
    assert p.on_visitor(seen(3.0, 2.1), 2.1) is None          # still slow: nothing new
    assert p.on_visitor(seen(1.8, 2.5), 2.5) is None          # within near, not by the hysteresis: still slow
    d = p.on_visitor(seen(1.5, 3.0), 3.0)
    assert d.pace is Pace.NORMAL and d.speed_cap is None
    p.on_visitor(seen(2.5, 4.0), 4.0)
    assert p.stats.slowdowns == 2 and p.stats.waits == 0
    assert p.stats.worst_behind == pytest.approx(3.0)


def test_stopped_visitor_is_waited_for_facing_them_then_followed():
    p = pacer(near=2.0, still_for=4.0)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    assert p.on_visitor(seen(2.5, 1.0, speed=0.0), 1.0).pace is Pace.SLOW
    assert p.on_visitor(seen(2.6, 4.0, speed=0.0), 4.0) is None      # still for 3 s: not yet
    d = p.on_visitor(seen(2.6, 5.0, speed=0.0), 5.0)
    assert d.pace is Pace.WAIT and not d.drive and d.say is Say.WAITING
    assert d.why == "the visitor has stood still 2.6 m away for 4 s"
    assert d.face == pytest.approx((ROBOT.x - 2.6, 0.0))
    for t in range(6, 60):                                           # a minute reading a sign
        assert p.on_visitor(seen(2.6, float(t), speed=0.0), float(t)) is None
    d = p.on_visitor(seen(2.5, 61.0, speed=0.7), 61.0)
    assert d.pace is Pace.NORMAL and d.drive and d.say is Say.FOLLOW and not d.found_again
    assert p.stats.waits == 1 and p.stats.waiting == pytest.approx(56.0)


def test_far_visitor_is_waited_for_at_once():
    p = pacer()
    p.on_visitor(seen(1.5, 0.0), 0.0)
    d = p.on_visitor(seen(4.5, 1.0), 1.0)
    assert d.pace is Pace.WAIT and d.why == "the visitor is 4.5 m away, farther than 4 m"


def test_front_laser_out_of_view_turns_to_look_after_a_bound():
    p = pacer(look_after=8.0)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    for t in range(1, 9):
        assert p.on_visitor(seen(1.5, float(t), sight=Sight.OUT_OF_VIEW), float(t)) is None
    d = p.on_visitor(seen(1.5, 9.0, sight=Sight.OUT_OF_VIEW), 9.0)
    assert d.pace is Pace.WAIT and d.face is not None
    assert d.why == "the visitor has been out of the laser's view for 8 s"
    assert p.on_visitor(seen(1.4, 10.0), 10.0).say is Say.FOLLOW


def test_waiting_unseen_too_long_searches_where_last_seen_then_lost():
    p = pacer(lost_after=30.0, search_for=60.0)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    assert p.on_visitor(seen(5.0, 1.0, speed=0.0), 1.0).pace is Pace.WAIT
    assert p.on_visitor(seen(5.0, 11.0, speed=0.0, sight=Sight.HIDDEN), 11.0) is None
    assert p.step(30.0) is None                                      # last seen at 1 s
    d = p.step(31.0)
    assert d.pace is Pace.SEARCH and d.relock and d.say is Say.SEARCHING
    assert (d.search_at.x, d.search_at.y) == pytest.approx((5.0, 0.0))
    p.on_robot(Pose2D(5.0, 0.0, 0.0))
    look = p.on_search_arrived(40.0)
    assert look.look_yaw == pytest.approx(2.0) and not look.drive
    assert p.on_visitor(VisitorReport(Sight.LOST), 47.0).relock      # re-lock every 6 s while nobody is there
    assert p.step(90.0).pace is Pace.SEARCH
    d = p.step(91.0)
    assert d.pace is Pace.LOST and d.say is Say.LOST and not d.drive
    assert p.step(200.0) is None                                     # lost is final
    s = p.stats
    assert (s.waits, s.searches, s.lost, s.found_again) == (1, 1, 1, 0)
    assert s.waiting == pytest.approx(90.0)


def test_a_visitor_in_sight_who_stays_away_is_searched_for_after_the_wait_bound():
    p = pacer(wait_for=100.0)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    assert p.on_visitor(seen(5.0, 1.0, speed=0.0), 1.0).pace is Pace.WAIT
    for t in range(2, 101):
        assert p.on_visitor(seen(5.0, float(t), speed=0.0), float(t)) is None
    assert p.on_visitor(seen(5.0, 101.0, speed=0.0), 101.0).pace is Pace.SEARCH


def test_tracker_lost_is_waited_for_then_searched_and_found_again() -> None:
    p = pacer(lost_after=20.0, relock_every=6.0)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    d = p.on_visitor(lost(4.0, at=6.0), 4.0)
    assert d.pace is Pace.WAIT and d.relock and d.say is Say.WAITING and d.face == pytest.approx((6.0, 0.0))
    assert d.why == "the laser lost the visitor"
    assert p.on_visitor(VisitorReport(Sight.ACQUIRING), 5.0) is None
    assert p.on_visitor(VisitorReport(Sight.LOST), 10.0).relock        # asked anew every 6 s
    assert p.step(23.0).pace is Pace.WAIT                               # waited 19 s
    d = p.step(24.0)
    assert d.pace is Pace.SEARCH and d.search_at.x == pytest.approx(6.0)
    d = p.on_visitor(seen(1.0, 26.0), 26.0)
    assert d.pace is Pace.NORMAL and d.found_again and d.say is Say.FOLLOW
    assert p.stats.found_again == 1 and p.stats.lost == 0 and p.stats.waits == 1


def test_tracker_lost_and_back_while_waiting_goes_on_without_a_search() -> None:
    p = pacer()
    p.on_visitor(seen(1.5, 0.0), 0.0)
    assert p.on_visitor(lost(4.0), 4.0).pace is Pace.WAIT
    d = p.on_visitor(seen(1.5, 7.0), 7.0)
    assert d.say is Say.FOLLOW and not d.found_again and p.stats.searches == 0


def test_look_turns_are_bounded():
    p = pacer(look_turns=2)
    p.on_visitor(seen(1.5, 0.0), 0.0)
    p.on_visitor(lost(4.0), 4.0)
    assert p.step(30.0).pace is Pace.SEARCH
    assert p.on_search_arrived(5.0) is not None
    assert p.on_search_arrived(6.0) is not None
    assert p.on_search_arrived(7.0) is None


def test_start_resets_the_leg():
    p = pacer()
    p.on_visitor(seen(5.0, 0.0), 0.0)
    p.start(10.0)
    assert p.pace is Pace.OFF and p.stats.samples == 0


def test_a_none_report_the_unlock_of_a_relock_says_nothing_of_the_visitor() -> None:
    """A relock is an unlock then a lock: the people node reports NONE in between. Taken for "unseen", it made the
    robot stop and turn (WAIT) and the next report go on (FOLLOW) in the same instant, and asked for another
    relock, so again and again. It is ignored, while walking and while waiting."""
    p = pacer()
    p.on_visitor(seen(1.2, 0.0), 0.0)
    assert p.on_visitor(VisitorReport(Sight.NONE), 1.0) is None and p.pace is Pace.NORMAL
    assert p.on_visitor(seen(1.2, 1.0), 1.0) is None and p.stats.waits == 0
    assert p.on_visitor(lost(4.0), 4.0).pace is Pace.WAIT
    assert p.on_visitor(VisitorReport(Sight.NONE), 4.5) is None and p.pace is Pace.WAIT
    assert p.on_visitor(seen(1.0, 5.0), 5.0).say is Say.FOLLOW and p.stats.waits == 1
