"""The navigation core (Algorithm 1), alone and with its partners on the bus."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest
from guiding_support import Bus, ListLog, catalog_of

from gidabot_navigation.building.model import Building
from gidabot_navigation.errors import GuidingError
from gidabot_navigation.guiding.messages import (
    CancelData,
    CommandData,
    MoveTo,
    NavEventData,
    SendCancel,
    SendEvent,
    StopMoving,
    Trip,
)
from gidabot_navigation.guiding.navigation import ABORTED, PREEMPTED, SUCCEEDED, NavigationConfig, NavigationCore
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, Cmd, Phase, RobotState

TOURS = Path(__file__).resolve().parents[4] / "tours"


def trip(faculty, origin: str, goal_id: str, uid: str, start: tuple[float, float] | None = None,
         connector: str = "stairs_west", **kw) -> Trip:
    """A trip made at ``origin`` whose legs are committed to ``origin`` and the goal floor's first robot."""
    loc = faculty.location(goal_id)
    r = faculty.robot(origin)
    sx, sy = start or (r.home.x, r.home.y)
    goal_robot = faculty.robots_on(loc.floor)[0].name if loc.floor != r.floor and faculty.has_robot(loc.floor) else ""
    legs = {"start_robot": origin, "start_state": LEG_COMMITTED, "goal_robot": goal_robot,
            "goal_state": LEG_COMMITTED if goal_robot else LEG_NONE, "attempt": 2}
    return Trip(uid=uid, origin_robot=origin, visitor_id="v", initial_floor=r.floor, initial_x=sx, initial_y=sy,
                goal_floor=loc.floor, goal_x=loc.pose.x, goal_y=loc.pose.y, goal_yaw=loc.pose.yaw, way="stairs",
                connector=connector if loc.floor != r.floor else "", start_id="robot", goal_id=goal_id,
                language="en", **{**legs, **kw})


def nav(faculty, robot: str, **cfg) -> NavigationCore:
    n = NavigationCore(faculty, NavigationConfig(robot=robot, **cfg), ListLog(), now_wall=0.0, boot="t")
    n.on_move_base_available(True, 0.0)
    home = faculty.robot(robot).home
    n.on_pose(home.x, home.y, home.yaw)
    for r in faculty.robots:
        n.on_status(r.name, 0.0)
    return n


def evs(actions):
    return [a.event for a in actions if isinstance(a, SendEvent)]


def phases(actions):
    return [e.phase for e in evs(actions)]


def moves(actions):
    return [a for a in actions if isinstance(a, MoveTo)]


def cancels(actions):
    return [a.cancel for a in actions if isinstance(a, SendCancel)]


def released(n: NavigationCore, by: str, goal_uid: str, now: float, k: int = 1) -> None:
    n.on_nav_event(NavEventData(uid=f"{by}/event/nav.t.{k}", robot=by, floor=faculty_floor(by), goal_uid=goal_uid,
                                phase=Phase.GO_TO_FLOOR), now, 0.0, from_relay=True)


def faculty_floor(name: str) -> float:
    return {"Tartalo": 0.0, "Kbot": 1.0, "Galtxagorri": 2.0, "MariSorgin": 3.0}[name]


def test_config_is_checked(faculty) -> None:
    with pytest.raises(GuidingError, match="continue_timeout"):
        NavigationConfig(robot="Kbot", continue_timeout=0)
    with pytest.raises(GuidingError, match="not in building"):
        NavigationCore(faculty, NavigationConfig(robot="Robbie"), ListLog(), 0.0)


def test_same_floor_guides_to_the_goal(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    acts = n.on_pending([t], 30.0, 1.0, 0.0)
    [move] = moves(acts)
    assert (move.x, move.y) == (t.goal_x, t.goal_y) and phases(acts) == [Phase.ON_THE_WAY]
    assert evs(acts)[0].location_id == "104"
    assert n.status(1.0).state == RobotState.GUIDING and n.status(1.0).current_goal_uid == t.uid
    assert n.status(11.0).busy_for == pytest.approx(20.0)
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 20.5, 0.0, done_ros=20.0)
    assert phases(acts) == [Phase.GOAL_REACHED] and n.leg is None
    assert evs(acts)[0].stamp == 20.0          # when move_base got there, not when its result arrived
    assert n.status(20.0).state == RobotState.IDLE
    # the pending list still holds it until the goal manager drops it: not run twice
    assert n.on_pending([t], 0.0, 21.0, 0.0) == []


def test_a_far_robot_first_picks_the_visitor_up(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1", start=(10.0, 12.0))
    acts = n.on_pending([t], 0.0, 1.0, 0.0)
    [move] = moves(acts)
    assert (move.x, move.y) == (10.0, 12.0) and phases(acts) == [Phase.GOING_TO_MEETING]
    assert n.status(1.0).state == RobotState.TO_MEETING
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 5.0, 0.0, done_ros=4.5)
    assert phases(acts) == [Phase.ON_THE_WAY] and moves(acts)[0].x == t.goal_x
    assert evs(acts)[0].stamp == 5.0           # guiding starts when the next goal is sent


def test_start_floor_guides_to_the_connector_then_sends_the_visitor_up(faculty) -> None:
    n = nav(faculty, "Tartalo")
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    acts = n.on_pending([t], 0.0, 1.0, 0.0)
    meet = faculty.find_connector("stairs_west").meeting[0.0]
    assert (moves(acts)[0].x, moves(acts)[0].y) == (meet.x, meet.y)
    assert phases(acts) == [Phase.ON_THE_WAY] and evs(acts)[0].location_id == "stairs_west"
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 5.0, 0.0)
    [ev] = evs(acts)
    assert (ev.phase, ev.target_floor, ev.way, ev.connector, ev.location_id) == (Phase.GO_TO_FLOOR, 3.0, "stairs",
                                                                               "stairs_west", "301")
    assert n.leg is None


@pytest.mark.parametrize("connector, way, name", [("stairs_west", "stairs", "West staircase"),
                                                   ("stairs_east", "stairs", "East staircase"),
                                                   ("lift", "lift", "Lift")])
def test_no_robot_on_the_goal_floor(faculty, connector: str, way: str, name: str) -> None:
    """The visitor is sent alone, told which lift or staircase to take (its English name: details are English)."""
    no_mari = Building(faculty.id, faculty.name, faculty.path, faculty.floors, faculty.locations,
                       faculty.connectors, faculty.robots[:3])
    assert faculty.find_connector(connector).name("en") == name
    n = nav(no_mari, "Tartalo")
    t = replace(trip(no_mari, "Tartalo", "301", "Tartalo/v/1", connector=connector), way=way)
    acts = n.on_pending([t], 0.0, 1.0, 0.0)
    meet = faculty.find_connector(connector).meeting[0.0]
    assert (moves(acts)[0].x, moves(acts)[0].y) == (meet.x, meet.y)
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 5.0, 0.0)
    [ev] = evs(acts)
    assert (ev.phase, ev.target_floor, ev.way, ev.connector) == (Phase.NO_ROBOT_ON_FLOOR, 3.0, way, connector)
    assert ev.detail == f"no robot serves floor 3: take the {way} ({name}) to floor 3 and find 301 yourself"


def goal_floor_leg(faculty, **cfg):
    n = nav(faculty, "MariSorgin", **cfg)
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    acts = n.on_pending([t], 0.0, 1.0, 0.0)
    meet = faculty.find_connector("stairs_west").meeting[3.0]
    assert (moves(acts)[0].x, moves(acts)[0].y) == (meet.x, meet.y)
    assert phases(acts) == [Phase.GOING_TO_MEETING] and evs(acts)[0].location_id == "stairs_west"
    assert n.status(1.0).state == RobotState.TO_MEETING
    return n, t, moves(acts)[0]


def test_goal_floor_meets_the_visitor_and_guides_on_continue(faculty) -> None:
    n, t, move = goal_floor_leg(faculty)
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    assert phases(acts) == [Phase.WAITING_VISITOR] and n.status(10.0).state == RobotState.WAITING
    assert n.on_continue("Other/v/9", 11.0, 0.0) == []          # not this trip
    acts = n.on_continue(t.uid, 12.0, 0.0)
    assert phases(acts) == [Phase.ON_THE_WAY] and moves(acts)[0].x == t.goal_x
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 30.0, 0.0)
    assert phases(acts) == [Phase.GOAL_REACHED]


def test_of_the_visitor_commands_only_a_continue_is_the_navigation_s(faculty) -> None:
    n, t, move = goal_floor_leg(faculty)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    for cmd in (Cmd.REQUEST, Cmd.CANCEL, Cmd.START_TOUR, Cmd.SKIP):
        assert n.on_command(CommandData(command=cmd, uid=f"Lamia/v/cmd/{cmd}", goal_uid=t.uid), 11.0, 0.0) == []
    press = CommandData(command=Cmd.CONTINUE, uid="Lamia/v/cmd/9", goal_uid=t.uid, stamp=11.5)
    acts = n.on_command(press, 12.0, 0.0)
    assert phases(acts) == [Phase.ON_THE_WAY]
    assert n.on_command(press, 13.0, 0.0) == [] and n.stats["duplicate_commands"] == 1     # the same press again
    assert n.durable(acts) == [a for a in acts if isinstance(a, SendEvent)]               # not the MoveTo


def test_continue_before_arrival_goes_on_at_once(faculty) -> None:
    n, t, move = goal_floor_leg(faculty)
    assert n.on_continue("", 5.0, 0.0) == []
    acts = n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    assert phases(acts) == [Phase.WAITING_VISITOR, Phase.ON_THE_WAY]


def test_continue_pressed_while_still_queued(faculty) -> None:
    n = nav(faculty, "MariSorgin")
    first = trip(faculty, "MariSorgin", "305", "MariSorgin/v/1")
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    acts = n.on_pending([first, t], 0.0, 1.0, 0.0)
    n.on_continue(t.uid, 2.0, 0.0)                 # the visitor is already upstairs
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 5.0, 0.0)
    assert phases(acts) == [Phase.GOAL_REACHED, Phase.GOING_TO_MEETING]
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 9.0, 0.0)
    assert phases(acts) == [Phase.WAITING_VISITOR, Phase.ON_THE_WAY]


def test_continue_timeout_counts_from_arrival_and_release(faculty) -> None:
    n, t, move = goal_floor_leg(faculty, continue_timeout=60.0)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    # the start robot has not released the visitor yet: no timeout however long
    assert n.tick(500.0, 0.0) == [] and n.leg is not None
    released(n, "Tartalo", t.uid, 600.0)
    assert n.tick(659.0, 0.0) == []
    acts = n.tick(660.5, 0.0)
    [ev] = evs(acts)
    assert ev.phase == Phase.TIMEOUT and ev.location_id == "stairs_west"
    [c] = cancels(acts)
    assert (c.reason, c.goal_uid, c.origin_robot) == ("timeout", t.uid, "MariSorgin")
    assert n.leg is None and n.status(661.0).state == RobotState.IDLE


def test_timeout_from_arrival_when_released_before(faculty) -> None:
    n, t, move = goal_floor_leg(faculty, continue_timeout=60.0)
    released(n, "Tartalo", t.uid, 5.0)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    assert n.tick(69.0, 0.0) == []
    assert phases(n.tick(70.0, 0.0)) == [Phase.TIMEOUT]


def test_a_release_from_the_wrong_robot_does_not_start_the_timer(faculty) -> None:
    n, t, move = goal_floor_leg(faculty, continue_timeout=60.0)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    released(n, "Kbot", t.uid, 11.0)
    assert n.tick(500.0, 0.0) == []


def test_timeout_from_arrival_when_the_start_floor_has_no_robot(faculty) -> None:
    no_tartalo = Building(faculty.id, faculty.name, faculty.path, faculty.floors, faculty.locations,
                          faculty.connectors, faculty.robots[1:])
    n = nav(no_tartalo, "MariSorgin", continue_timeout=60.0)
    t = replace(trip(faculty, "Tartalo", "301", "Tartalo/v/1"), start_robot="", start_state=LEG_NONE)
    acts = n.on_pending([t], 0.0, 1.0, 0.0)
    n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 10.0, 0.0)
    assert phases(n.tick(70.0, 0.0)) == [Phase.TIMEOUT]


def test_move_base_failure_is_unreachable_everywhere(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    nxt = trip(faculty, "Kbot", "101", "Kbot/v/2")
    acts = n.on_pending([t, nxt], 0.0, 1.0, 0.0)
    acts = n.on_move_base_result(moves(acts)[0].token, ABORTED, "no valid plan", 5.0, 0.0)
    assert phases(acts) == [Phase.UNREACHABLE, Phase.ON_THE_WAY]          # and the next visitor's trip starts
    assert "no valid plan" in evs(acts)[0].detail
    [c] = cancels(acts)
    assert (c.reason, c.goal_uid) == ("unreachable", t.uid)
    assert moves(acts)[0].x == faculty.location("101").pose.x


def test_someone_else_preempting_move_base_is_a_failure_but_stale_results_are_not(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    move = moves(n.on_pending([t], 0.0, 1.0, 0.0))[0]
    assert n.on_move_base_result(move.token + 7, ABORTED, "", 2.0, 0.0) == []
    acts = n.on_move_base_result(move.token, PREEMPTED, "", 3.0, 0.0)
    assert phases(acts) == [Phase.UNREACHABLE] and "another client" in evs(acts)[0].detail


def test_cancel_stops_at_once_and_frees_the_robot(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    move = moves(n.on_pending([t], 0.0, 1.0, 0.0))[0]
    c = CancelData(uid="Kbot/cancel/gm.t.1", goal_uid=t.uid, origin_robot="Kbot", reason="visitor")
    acts = n.on_cancel(c, 2.0, 0.0)
    assert acts == [StopMoving(move.token)] and n.leg is None and n.status(2.0).state == RobotState.IDLE
    # the late PREEMPTED result of the stopped goal is ignored, and the trip never restarts
    assert n.on_move_base_result(move.token, PREEMPTED, "", 2.1, 0.0) == []
    assert n.on_pending([t], 0.0, 3.0, 0.0) == []


def test_a_goal_leaving_the_pending_list_is_stopped(faculty) -> None:
    n = nav(faculty, "Kbot")
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    move = moves(n.on_pending([t], 0.0, 1.0, 0.0))[0]
    assert n.on_pending([], 0.0, 2.0, 0.0) == [StopMoving(move.token)]


def test_no_move_base_no_guiding(faculty) -> None:
    n = nav(faculty, "Kbot", nav_lost_timeout=10.0)
    n.on_move_base_available(False, 0.0)
    t = trip(faculty, "Kbot", "104", "Kbot/v/1")
    assert n.on_pending([t], 0.0, 1.0, 0.0) == [] and n.status(1.0).state == RobotState.ERROR
    n.on_move_base_available(True, 2.0)
    move = moves(n.tick(2.0, 0.0))[0]
    # move_base vanishes while driving
    n.on_move_base_available(False, 3.0)
    assert n.tick(12.0, 0.0) == []
    acts = n.tick(13.5, 0.0)
    assert phases(acts) == [Phase.UNREACHABLE] and StopMoving(move.token) in acts


def test_partner_offline_is_a_notice_then_the_goal_floor_gives_up(faculty) -> None:
    n, t, move = goal_floor_leg(faculty, partner_timeout=120.0, offline_after=5.0)
    for r in faculty.robots:
        n.on_status(r.name, 100.0)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 100.0)
    assert n.tick(11.0, 104.0) == []
    acts = n.tick(12.0, 106.0)
    assert phases(acts) == [Phase.PARTNER_LOST] and "Tartalo is offline" in evs(acts)[0].detail
    assert n.tick(13.0, 107.0) == []                              # told once
    n.on_status("Tartalo", 150.0)                                 # the link is back
    assert phases(n.tick(14.0, 150.5)) == [Phase.PARTNER_BACK]
    # offline again, for good this time
    assert phases(n.tick(15.0, 156.0)) == [Phase.PARTNER_LOST]
    assert n.tick(16.0, 274.0) == []
    acts = n.tick(17.0, 276.0)
    assert phases(acts) == [Phase.PARTNER_OFFLINE] and cancels(acts)[0].reason == "offline" and n.leg is None


def test_partner_offline_after_the_release_does_not_matter(faculty) -> None:
    n, t, move = goal_floor_leg(faculty, partner_timeout=120.0, offline_after=5.0)
    released(n, "Tartalo", t.uid, 5.0)
    n.on_move_base_result(move.token, SUCCEEDED, "", 10.0, 0.0)
    assert n.tick(12.0, 500.0) == [] and n.leg is not None


def test_start_floor_only_tells_the_visitor(faculty) -> None:
    n = nav(faculty, "Tartalo", partner_timeout=10.0, offline_after=5.0)
    t = trip(faculty, "Tartalo", "301", "Tartalo/v/1")
    move = moves(n.on_pending([t], 0.0, 1.0, 0.0))[0]
    assert phases(n.tick(2.0, 6.0)) == [Phase.PARTNER_LOST]
    assert n.tick(3.0, 1000.0) == [] and n.leg is not None        # keeps guiding to the stairs
    assert phases(n.on_move_base_result(move.token, SUCCEEDED, "", 4.0, 1000.0)) == [Phase.GO_TO_FLOOR]


def test_tour_steps_and_the_last_step(faculty) -> None:
    n = nav(faculty, "MariSorgin")
    n.on_catalog(catalog_of(faculty, TOURS / "real_world.tour"))
    step = trip(faculty, "MariSorgin", "325", "MariSorgin/v/1", tour_file="real_world.tour", tour_step=6)
    last = replace(step, uid="MariSorgin/v/2", goal_id="305", goal_x=faculty.location("305").pose.x,
                   goal_y=faculty.location("305").pose.y, tour_step=7)
    acts = n.on_pending([step, last], 0.0, 1.0, 0.0)
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 2.0, 0.0)
    assert phases(acts)[0] == Phase.TOUR_STEP_DONE and evs(acts)[0].tour_step == 6
    acts = n.on_move_base_result(moves(acts)[0].token, SUCCEEDED, "", 3.0, 0.0)
    assert phases(acts) == [Phase.TOUR_FINISHED] and evs(acts)[0].tour_file == "real_world.tour"


# ------------------------------------------------------------------ with the partners on the bus

def test_cross_floor_trip_on_the_bus(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    assert bus.phases("Tartalo", uid) == [Phase.ACCEPTED, Phase.ON_THE_WAY]
    assert bus.phases("MariSorgin", uid) == [Phase.ACCEPTED, Phase.GOING_TO_MEETING]
    # both drive to the same staircase
    assert bus.robots["Tartalo"].active.x == bus.robots["MariSorgin"].active.x == 4.4
    bus.finish_move("MariSorgin")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-1] == Phase.WAITING_VISITOR
    bus.finish_move("Tartalo")
    bus.pump()
    assert bus.phases("Tartalo", uid)[-1] == Phase.GO_TO_FLOOR and bus.queue_of("Tartalo") == []
    bus.cont("MariSorgin", uid)
    bus.finish_move("MariSorgin")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-2:] == [Phase.ON_THE_WAY, Phase.GOAL_REACHED]
    assert bus.queue_of("MariSorgin") == [] and bus.cancels == []


def test_cancel_from_the_start_floor_stops_the_partner(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    mari_move = bus.robots["MariSorgin"].active
    bus.cancel("Tartalo")
    assert bus.phases("Tartalo", uid)[-1] == Phase.CANCELLED_HERE
    assert bus.phases("MariSorgin", uid)[-1] == Phase.CANCELLED_ELSEWHERE
    assert [s.token for s in bus.robots["MariSorgin"].stops] == [mari_move.token]
    assert bus.robots["Tartalo"].stops and bus.queue_of("MariSorgin") == [] and bus.queue_of("Tartalo") == []
    assert bus.robots["MariSorgin"].nav.status(bus.now_ros).state == RobotState.IDLE


def test_cancel_from_the_goal_floor(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    bus.finish_move("MariSorgin")
    bus.finish_move("Tartalo")
    bus.pump()
    bus.cont("MariSorgin", uid)                   # the visitor is upstairs, being guided
    guiding = bus.robots["MariSorgin"].active
    bus.cancel("MariSorgin")
    assert bus.phases("MariSorgin", uid)[-1] == Phase.CANCELLED_HERE
    assert [s.token for s in bus.robots["MariSorgin"].stops] == [guiding.token]
    assert bus.cancels[-1].origin_robot == "MariSorgin"
    assert bus.phases("Tartalo", uid)[-1] == Phase.GO_TO_FLOOR      # Tartalo was done already: nothing to tell


def test_unreachable_goal_is_propagated_to_the_partner(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    bus.abort("MariSorgin", "the west staircase is closed")   # the goal-floor robot cannot get there
    assert bus.phases("MariSorgin", uid)[-1] == Phase.UNREACHABLE
    assert bus.phases("Tartalo", uid)[-1] == Phase.UNREACHABLE      # told to the visitor being guided downstairs
    assert "staircase is closed" in bus.last("Tartalo", Phase.UNREACHABLE).detail
    assert bus.robots["Tartalo"].stops and bus.queue_of("Tartalo") == [] and bus.queue_of("MariSorgin") == []
    assert [c.reason for c in bus.cancels] == ["unreachable"]


def test_a_partner_offline_at_request_time_is_refused_and_nothing_is_queued(faculty) -> None:
    bus = Bus(faculty)
    bus.status_all()
    bus.tick(wall_dt=4.0)
    bus.status_all(["Tartalo", "Kbot", "Galtxagorri"])
    bus.tick(wall_dt=2.0)
    bus.request("Tartalo", "301")
    assert bus.phases("Tartalo") == [Phase.PARTNER_OFFLINE] and bus.goals == []
    assert all(not r.gm.queue for r in bus.robots.values())


def test_a_link_outage_delays_but_never_loses_the_trip(faculty) -> None:
    """Events are queued across the outage (as the relays do); the goal-floor robot waits and goes on."""
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    bus.finish_move("MariSorgin")
    bus.pump()
    bus.down.add("MariSorgin")                    # MariSorgin's link is cut
    bus.finish_move("Tartalo")                    # GO_TO_FLOOR is held back
    bus.pump()
    bus.status_all(["Tartalo", "Kbot", "Galtxagorri"])
    for r in bus.robots.values():
        if r.name != "MariSorgin":
            r.nav.on_status("Tartalo", bus.now_wall)
    bus.robots["MariSorgin"].nav.on_status("MariSorgin", bus.now_wall)
    bus.tick(ros_dt=1.0, wall_dt=10.0)
    assert bus.phases("MariSorgin", uid)[-1] == Phase.PARTNER_LOST
    bus.link_up("MariSorgin")
    bus.status_all()
    bus.tick(ros_dt=1.0, wall_dt=1.0)
    assert bus.phases("MariSorgin", uid)[-1] == Phase.PARTNER_BACK
    bus.cont("MariSorgin", uid)
    bus.finish_move("MariSorgin")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-1] == Phase.GOAL_REACHED


def test_two_visitors_at_one_robot_are_guided_in_turn(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Kbot", "104")            # anne
    bus.request("Kbot", "113")            # bob, at the same spot, queued behind her
    anne, bob = bus.queue_of("Kbot")
    assert bus.phases("Kbot", anne) == [Phase.ACCEPTED, Phase.ON_THE_WAY]
    assert bus.phases("Kbot", bob) == [Phase.ACCEPTED]
    eta = bus.robots["Kbot"].gm.pending(bus.now_ros).eta
    assert eta[1] > eta[0] > 0
    bus.finish_move("Kbot")               # anne's goal reached
    bus.pump()
    assert bus.phases("Kbot", anne)[-1] == Phase.GOAL_REACHED
    # the robot is at anne's goal, far from where bob asked: it comes back for him first
    home = faculty.robot("Kbot").home
    assert bus.phases("Kbot", bob) == [Phase.ACCEPTED, Phase.GOING_TO_MEETING]
    assert (bus.robots["Kbot"].active.x, bus.robots["Kbot"].active.y) == (home.x, home.y)
    bus.finish_move("Kbot")
    bus.pump()
    assert bus.phases("Kbot", bob)[-1] == Phase.ON_THE_WAY
    bus.finish_move("Kbot")
    bus.pump()
    assert bus.phases("Kbot", bob)[-1] == Phase.GOAL_REACHED and bus.queue_of("Kbot") == []


def test_the_freshest_time_is_the_odometrys_when_it_is_ahead_of_the_ros_time() -> None:
    from gidabot_navigation.guiding.navigation import MAX_ODOM_LEAD_S, freshest_time

    assert freshest_time(100.0, None) == 100.0
    assert freshest_time(100.0, 101.1) == 101.1               # a coarse /clock: the step's stamp is fresher
    assert freshest_time(100.0, 99.0) == 100.0                # older odometry never takes time back
    assert freshest_time(100.0, 100.0 + MAX_ODOM_LEAD_S + 1) == 100.0    # an implausible stamp is not trusted
    assert freshest_time(100.0, float("nan")) == 100.0
    assert freshest_time(100.0, float("inf")) == 100.0
