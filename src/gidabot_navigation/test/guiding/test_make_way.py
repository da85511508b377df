"""Making way (guiding/make_way.py), driven by calls with explicit times: the robot that needs the way asks the
idle robots standing on it in a corridor too narrow to pass with room (not in a hall); the robot asked drives
to the nearest spot off that way (the doorway niche), goes back once the asker has passed, the ask ended or
timed out, and a trip of its own takes over. Asks are validated: they speak for their sender's floor only."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from guiding_support import GM, NAV, ListLog, from_robot

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.reachability import crowding_warnings
from gidabot_navigation.errors import GoalRejected
from gidabot_navigation.guiding.make_way import MakeWay, MakeWayConfig, Mate, distance_along
from gidabot_navigation.guiding.messages import MoveTo, SendAsk, Trip, WayAsk, validate_ask
from gidabot_navigation.guiding.navigation import SUCCEEDED, NavigationConfig, NavigationCore
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, RobotState

NARROW = Path(__file__).resolve().parents[4] / "tests" / "corridors" / "narrow_corridor"
PARKER = Mate("Parker", 16.0, 5.0, 0.33, True)


@pytest.fixture(scope="module")
def narrow():
    return load_building(NARROW)


def ask_of(building, log=None) -> WayAsk:
    guide = MakeWay(building, "Guide", log or ListLog())
    ask = guide.asks_for((3.0, 6.0), (28.5, 5.0), [PARKER], 10.0)
    assert ask is not None
    return ask


def test_the_idle_robot_in_the_corridor_is_asked_and_a_busy_one_or_one_aside_is_not(narrow) -> None:
    ask = ask_of(narrow)
    assert ask.robot == "Guide" and ask.robots == ("Parker",) and len(ask.way) >= 2
    guide = MakeWay(narrow, "Guide", ListLog())
    busy = Mate("Parker", 16.0, 5.0, 0.33, False)
    assert guide.asks_for((3.0, 6.0), (28.5, 5.0), [busy], 10.0) is None
    at_the_side = Mate("Parker", 18.75, 3.2, 0.33, True)                 # in the doorway niche
    assert guide.asks_for((3.0, 6.0), (28.5, 5.0), [at_the_side], 10.0) is None
    in_the_hall = Mate("Parker", 28.5, 5.0 + 1.5, 0.33, True)            # the hall is wide: driven round
    assert guide.asks_for((3.0, 6.0), (28.5, 5.0), [in_the_hall], 10.0) is None
    assert guide.end_ask(11.0).robots == () and guide.end_ask(11.0).way == ()


def test_the_robot_asked_steps_aside_off_the_way_and_goes_back_once_the_asker_passed(narrow) -> None:
    ask = ask_of(narrow)
    log = ListLog()
    parker = MakeWay(narrow, "Parker", log)
    parker.on_ask(ask, 10.0)
    home = Pose2D(16.0, 5.0, 0.0)
    spot = parker.step(home, True, 10.5)
    assert spot is not None and math.hypot(spot.x - 16.0, spot.y - 5.0) < 4.0       # the niche at x 18..19.5
    _, off = distance_along(ask.way, spot.x, spot.y)
    assert off >= 0.35 + 0.33 + MakeWayConfig().margin - 0.05
    assert parker.step(spot, True, 11.0) is None                          # waits there
    parker.on_asker_pose("Guide", 17.0, 5.0)                              # passing
    assert parker.asks and parker.step(spot, True, 20.0) is None
    parker.on_asker_pose("Guide", spot.x + 3.5, 5.0)                      # passed (its visitor behind it too)
    assert not parker.asks
    assert parker.step(spot, True, 30.0) == home
    parker.arrived(True)
    assert parker.aside is None and parker.made_way == 1
    assert any("moving aside" in m for _, m in log.lines) and any("going back" in m for _, m in log.lines)


def test_the_end_of_the_ask_or_its_timeout_sends_it_back_and_a_trip_of_its_own_takes_over(narrow) -> None:
    ask = ask_of(narrow)
    parker = MakeWay(narrow, "Parker", ListLog(), MakeWayConfig(timeout=100.0))
    home = Pose2D(16.0, 5.0, 0.0)
    parker.on_ask(ask, 0.0)
    spot = parker.step(home, True, 0.0)
    parker.on_ask(MakeWay(narrow, "Guide", ListLog()).end_ask(5.0), 5.0)    # the asker's move ended
    assert parker.step(spot, True, 6.0) == home
    parker.arrived(True)
    parker.on_ask(ask, 10.0)
    spot = parker.step(home, True, 10.0)
    assert spot is not None and parker.step(spot, True, 109.0) is None
    assert parker.step(spot, True, 110.0) == home                          # 100 s: back, whoever asked
    parker.arrived(False)
    parker.on_ask(ask, 200.0)
    assert parker.step(home, True, 200.0) is not None
    parker.drop()                                                         # a trip of its own: from where it is
    assert parker.aside is None and parker.step(home, True, 201.0) is None


def test_asks_of_itself_or_of_another_floor_are_ignored(narrow) -> None:
    ask = ask_of(narrow)
    guide = MakeWay(narrow, "Guide", ListLog())
    guide.on_ask(ask, 0.0)
    assert not guide.asks
    parker = MakeWay(narrow, "Parker", ListLog())
    parker.on_ask(WayAsk("Guide", 0.0, ("Guide",), ask.way), 0.0)         # not naming it
    assert not parker.asks


@pytest.mark.parametrize("bad, reason", [
    (dict(robot="Nobody"), "robot"),
    (dict(floor=1.0), "floor"),
    (dict(robots=("Guide",)), "robot"),                                     # itself
    (dict(robots=("Stranger",)), "robot"),
    (dict(way=((3.0, 6.0),)), "way"),                                       # one point
    (dict(way=((3.0, 6.0), (math.nan, 5.0))), "finite"),
    (dict(way=((3.0, 6.0), (300.0, 5.0))), "way"),                          # off the map
    (dict(way=tuple((3.0, 6.0) for _ in range(201))), "way"),
])
def test_a_bad_ask_is_refused(narrow, bad: dict, reason: str) -> None:
    ask = ask_of(narrow)
    with pytest.raises(GoalRejected):
        validate_ask(narrow, WayAsk(**{**ask.__dict__, **bad}))
    assert validate_ask(narrow, ask) == ask
    assert validate_ask(narrow, WayAsk("Guide", 0.0, (), ())).robots == ()   # the end of an ask


def test_check_warns_of_a_home_that_leaves_the_corridor_too_narrow(narrow, faculty6) -> None:
    [warning] = crowding_warnings(narrow)
    assert warning.where == "home of robot Parker"
    assert "leaves the way too narrow for Guide (radius 0.35 m) to pass" in warning.message
    assert "location east" in warning.message and "location west" not in warning.message
    assert crowding_warnings(faculty6) == []          # a 3 m corridor: room to pass beside a parked robot


def test_the_navigation_cores_ask_make_way_and_go_back(narrow) -> None:
    """Two navigation cores of the narrow building: Guide's leg past Parker sends an ask (for itself), Parker
    idle steps aside with a move_base goal of its own; the ask stands while Guide drives on, though Parker, aside,
    is no longer in its way (released, Parker would go back into it before Guide passed); Guide's arrival ends
    the ask and Parker goes back; a local ask naming another robot is refused."""
    cores = {}
    for name in ("Guide", "Parker"):
        core = NavigationCore(narrow, NavigationConfig(robot=name), ListLog(), now_wall=0.0)
        core.on_move_base_available(True, 0.0)
        home = narrow.robot(name).home
        core.on_pose(home.x, home.y, home.yaw)
        cores[name] = core
    guide, parker = cores["Guide"], cores["Parker"]

    def statuses(now: float) -> None:
        for a, b in ((guide, parker), (parker, guide)):
            b.on_mate(a.status(now))

    statuses(0.0)
    east = narrow.location("east")
    t = Trip(uid="Guide/v/1", origin_robot="Guide", visitor_id="v", initial_floor=0.0, initial_x=3.0, initial_y=6.0,
             goal_floor=0.0, goal_x=east.pose.x, goal_y=east.pose.y, goal_yaw=east.pose.yaw, way="stairs",
             connector="", start_id="robot", goal_id="east", language="en", start_robot="Guide",
             start_state=LEG_COMMITTED, goal_robot="", goal_state=LEG_NONE, attempt=2)
    acts = guide.on_pending([t], 30.0, 1.0, 0.0, robot="Guide", sender=GM) + guide.tick(1.0, 0.0)
    [ask] = [a.ask for a in acts if isinstance(a, SendAsk)]
    [leg_move] = [a for a in acts if isinstance(a, MoveTo)]
    assert ask.robot == "Guide" and ask.robots == ("Parker",)
    parker.on_make_way(ask, 1.5, sender=NAV)                       # Parker's own node speaking for Guide: refused
    assert sum(parker.refusals().values()) == 1 and parker.tick(1.5, 0.0) == []
    parker.on_make_way(ask, 2.0, sender=from_robot(parker, "Guide"))
    [aside] = [a for a in parker.tick(2.0, 0.0) if isinstance(a, MoveTo)]
    assert math.hypot(aside.x - 16.0, aside.y - 5.0) > 0.5 and parker.status(2.0).state == RobotState.IDLE
    assert parker.on_move_base_result(aside.token, SUCCEEDED, "", 8.0, 0.0) == []
    parker.on_pose(aside.x, aside.y, 0.0)
    statuses(8.5)                                                  # Guide sees Parker aside, out of its way
    guide.on_pose(10.0, 5.0, 0.0)
    for now in (9.0, 11.5, 14.0):                                  # Guide's looks at who is in its way
        assert not [a for a in guide.tick(now, 0.0) if isinstance(a, SendAsk)]     # the ask stands
    guide.on_move_base_result(leg_move.token, SUCCEEDED, "", 40.0, 0.0)
    [end] = [a.ask for a in guide.tick(40.5, 0.0) if isinstance(a, SendAsk)]
    assert end.robots == ()
    parker.on_make_way(end, 41.0, sender=from_robot(parker, "Guide"))
    [back] = [a for a in parker.tick(41.0, 0.0) if isinstance(a, MoveTo)]
    assert (back.x, back.y) == (16.0, 5.0)
    parker.on_move_base_result(back.token, SUCCEEDED, "", 50.0, 0.0)
    assert parker.way.aside is None and parker.tick(51.0, 0.0) == []
