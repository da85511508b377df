"""One robot's screen for the simulated visitors (no ROS, no clock): its configuration, when a visit starts,
which visitor an event is for, the commands pressed, the record of what each visitor chose."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from sim_support import ListLog

from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.messages import NavEventData
from gidabot_navigation.interface import Cmd, Node, Phase, global_name, relay_end_name
from gidabot_navigation.senders import make_uid
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.behaviour import TIDY, draw_behaviour, parse_walk
from gidabot_sim.visitor.population import VisitorPlan
from gidabot_sim.visitor.station import VisitorStation, skips_of, station_config, walk_of
from gidabot_sim.world.people import FOLLOW, GONE, LEAVE

MAPS = Path(__file__).resolve().parents[4] / "maps"
TOUR = (Path(__file__).resolve().parents[4] / "tours" / "real_world.tour").read_text().splitlines()


@pytest.fixture(scope="module")
def faculty6():
    return load_building(MAPS / "faculty6")



def all_up(station: VisitorStation, building, now: float = 10.0) -> None:
    for r in building.robots:
        station.on_status(r.name, (r.home.x, r.home.y), now, 1000.0)


def event(uid: str, robot: str, phase: int, goal_uid: str = "", stamp: float = 0.0, floor: float = 0.0,
          target_floor: float = 0.0, tour_file: str = "") -> NavEventData:
    return NavEventData(uid=uid, robot=robot, floor=floor, goal_uid=goal_uid, phase=phase, target_floor=target_floor,
                        tour_file=tour_file, stamp=stamp)


def test_the_configuration_of_a_robot_s_node(faculty6) -> None:
    cfg = station_config(faculty6, "Galtxagorri", 1.0, goal_id="223", way="lift")
    assert (cfg.robot, cfg.floor, cfg.start_robot, cfg.robot_floors) == ("Galtxagorri", 2.0, "Kbot",
                                                                         (0.0, 1.0, 2.0, 3.0))
    assert station_config(faculty6, "Kbot", 5.0).start_robot == ""
    with pytest.raises(SimConfigError, match="~robot: unknown robot 'Nobody'"):
        station_config(faculty6, "Nobody", 0.0)
    with pytest.raises(SimConfigError, match="~way: 'rope' must be one of"):
        station_config(faculty6, "Kbot", 0.0, way="rope")
    assert skips_of([[3, 5]]) == ((3, 5),) and skips_of([]) == ()
    with pytest.raises(SimConfigError, match=r"~skips: .* \[k, m\] step pairs"):
        skips_of([3, 5])


def test_the_visit_starts_at_its_robot_once_every_robot_is_up_and_commands_are_numbered(faculty6) -> None:
    log = ListLog()
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, goal_id="223"), log, start_delay=2.0)
    elsewhere = VisitorStation(faculty6, station_config(faculty6, "Kbot", 0.0, goal_id="223"), ListLog())
    assert station.needs_status and not station.needs_goals and not station.needs_pending
    assert station.tick(50.0, 1000.0) == []                 # nobody reported yet
    all_up(station, faculty6, now=10.0)
    all_up(elsewhere, faculty6, now=10.0)
    assert not station.needs_status                          # no screen to show waits: statuses no longer needed
    assert station.tick(11.9, 1000.0) == [] and elsewhere.tick(20.0, 1000.0) == []
    [request] = station.tick(12.0, 1000.0)
    assert (request.command, request.goal_id, request.uid, request.visitor_id, request.stamp) == (
        Cmd.REQUEST, "223", "Tartalo/sim-visitor/cmd/1", "sim-visitor", 12.0)
    assert "starting the visit" in log.lines[0] and "command" in log.lines[1]
    station.on_event(event("Tartalo/e/1", "Tartalo", Phase.GO_TO_FLOOR, "g1", stamp=30.0, target_floor=2.0), 31.0)
    assert not station.cores["sim-visitor"].present             # sent to floor 2: gone from Tartalo's screen


def test_a_population_s_events_go_to_the_visitor_of_each_trip(faculty6) -> None:
    plans = [VisitorPlan("v1", 0.0, "Tartalo", "stairs", goal_id="223"),
             VisitorPlan("v2", 5.0, "Tartalo", "lift", goal_id="014"),
             VisitorPlan("v3", 0.0, "Kbot", "stairs", goal_id="104")]
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0), ListLog(), plans, start_delay=0.0)
    assert station.needs_goals and set(station.cores) == {"v1", "v2", "v3"}
    all_up(station, faculty6, now=0.0)
    assert [c.visitor_id for c in station.tick(1.0, 1000.0)] == ["v1"]     # v2 arrives at 5 s, v3 at Kbot
    assert [c.uid for c in station.tick(6.0, 1000.0)] == ["Tartalo/v2/cmd/2"]
    # an event of a trip not seen yet waits for its goal
    station.on_event(event("Tartalo/e/1", "Tartalo", Phase.GOAL_REACHED, "Tartalo/v2/1", stamp=40.0), 41.0)
    assert not station.cores["v2"].finished
    station.on_goal("Tartalo/v2/1", "v2", 42.0)
    assert station.cores["v2"].finished and station.cores["v2"].goal_uids == ["Tartalo/v2/1"]
    assert not station.cores["v1"].finished
    # the answer to a request, before any trip: the visitors who asked at that robot
    station.on_event(event("Tartalo/e/2", "Tartalo", Phase.REJECTED, stamp=43.0), 43.0)
    assert station.cores["v1"].finished and not station.cores["v3"].finished


def test_forged_goals_and_events_never_move_a_visitor(faculty6) -> None:
    """Only a robot's own nodes speak for it, and a relay end for its peer: a probe's event, an event through
    a relay end for another robot, an event with another robot's uid and a probe's goal are refused."""
    plans = [VisitorPlan("v1", 0.0, "Tartalo", "stairs", goal_id="223"),
             VisitorPlan("v2", 0.0, "Tartalo", "lift", goal_id="014")]
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0), ListLog(), plans, start_delay=0.0)
    all_up(station, faculty6, now=0.0)
    station.tick(1.0, 1000.0)
    real, relay = make_uid("Tartalo", "v1", "gm"), relay_end_name("Tartalo", "Kbot")
    station.on_goal_from("/chaos_probe", "Tartalo", real, "v2", 2.0)                   # the probe's, first
    station.on_goal_from(global_name(Node.GOAL_MANAGER), "Tartalo", real, "v1", 2.0)    # the real goal
    assert station._visitor_of == {real: "v1"}
    done = event(make_uid("Tartalo", "event", "nav"), "Tartalo", Phase.GOAL_REACHED, real, stamp=3.0)
    station.on_event_from("/chaos_probe", done, 3.0)
    station.on_event_from(relay, done, 3.0)                                         # Kbot's relay speaks for Kbot
    station.on_event_from(global_name(Node.MULTIROBOT_NAVIGATION),
                          event("Kbot/event/nav.0123456789abcdef", "Tartalo", Phase.GOAL_REACHED, real), 3.0)
    assert not station.cores["v1"].finished
    assert station.gate.refusals() == {"impostor": 2, "foreign": 1, "wrong_namespace": 1, "conflict": 0,
                                       "invalid": 0}
    station.on_event_from(global_name(Node.MULTIROBOT_NAVIGATION), done, 4.0)       # Tartalo's navigation
    assert station.cores["v1"].finished


def test_an_event_is_seen_when_it_happened_never_later_than_now(faculty6) -> None:
    station = VisitorStation(faculty6, station_config(faculty6, "Galtxagorri", 0.0, goal_id="223", think_s=0.0),
                             ListLog())
    core = station.cores["sim-visitor"]
    station.on_event(event("Tartalo/e/1", "Tartalo", Phase.GO_TO_FLOOR, "g1", stamp=50.0, floor=0.0,
                           target_floor=2.0), 49.0)          # another floor's clock a little ahead
    assert core.arrivals["g1"] == pytest.approx(49.0 + 40.0)
    station.on_event(event("Tartalo/e/2", "Tartalo", Phase.GO_TO_FLOOR, "g2", stamp=30.0, floor=0.0,
                           target_floor=2.0), 49.0)
    assert core.arrivals["g2"] == pytest.approx(30.0 + 40.0)


def tour_message(file_name: str, tour_name: str, goal_lines: tuple[str, ...]) -> TourMessage:
    return TourMessage(file_name=file_name, tour_name=tour_name, tour_goals_info=goal_lines)


def test_a_tour_starts_once_the_tour_store_holds_it(faculty6) -> None:
    log = ListLog()
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, tour_file="real_world.tour"), log,
                             start_delay=0.0)
    all_up(station, faculty6, now=0.0)
    assert station.needs_catalog and station.tick(5.0, 1000.0) == []
    station.on_catalog([tour_message("other.tour", "Other", ("0, 014, x",)),
                        tour_message("real_world.tour", "Real-world tour", ("0, 999, Nowhere",))])
    assert station.needs_catalog and log.lines[-1].startswith("W visitor on Tartalo: tour real_world.tour in the")
    station.on_catalog([tour_message("real_world.tour", TOUR[0].split(": ", 1)[1], tuple(TOUR[1:]))])
    assert not station.needs_catalog and station.cores["sim-visitor"].tour_floors[:3] == (0.0, 0.0, 1.0)
    [start] = station.tick(6.0, 1000.0)
    assert (start.command, start.tour_file) == (Cmd.START_TOUR, "real_world.tour")


def test_a_patient_visitor_sees_the_waits_and_what_it_chose_is_recorded(faculty6, tmp_path) -> None:
    record = tmp_path / "monitor.jsonl"
    plans = [VisitorPlan("quick", 0.0, "Tartalo", "stairs", goal_id="223", patience_s=1.0),
             VisitorPlan("calm", 0.0, "Tartalo", "stairs", goal_id="014", patience_s=10000.0)]
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0), ListLog(), plans, start_delay=0.0,
                             record=str(record))
    assert station.needs_pending and station.needs_status
    all_up(station, faculty6, now=0.0)
    assert station.needs_status                              # the screen shows the robots' poses
    station.on_pending("Tartalo", [], 0.0, 1000.0)
    pressed = station.tick(1.0, 1000.0)
    assert [c.visitor_id for c in pressed] == ["calm"]
    lines = [json.loads(line) for line in record.read_text().splitlines()]
    assert [(r["visitor"], r["event"]) for r in lines] == [("quick", "left"), ("calm", "asked")]
    assert lines[0]["shown"][1] > 1.0 and lines[0]["wall"] == 1000.0 and lines[0]["sim"] == 1.0


def test_the_visitor_s_body_follows_the_robot_it_is_with_leaves_and_is_gone(faculty6) -> None:
    start = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, goal_id="223"), ListLog())
    goal = VisitorStation(faculty6, station_config(faculty6, "Galtxagorri", 0.0, goal_id="223",
                                                   stairs_s_per_floor=20.0), ListLog())
    assert start.bodies(5.0) == [] and goal.bodies(5.0) == []        # not before the visit starts
    for station in (start, goal):
        all_up(station, faculty6)
    start.tick(20.0, 1000.0)
    (follow,) = start.bodies(20.0)
    assert (follow.visitor_id, follow.mode, follow.robot, follow.started) == ("sim-visitor", FOLLOW, "Tartalo", 20.0)
    assert follow.behaviour == TIDY and start.bodies(21.0) == []      # each change once
    go = event("e1", "Tartalo", Phase.GO_TO_FLOOR, "g1", stamp=100.0, floor=0.0, target_floor=2.0)
    waiting = event("e2", "Galtxagorri", Phase.WAITING_VISITOR, "g1", stamp=110.0, floor=2.0)
    for station in (start, goal):
        station.on_event(go, 100.0)
        station.on_event(waiting, 110.0)
    assert [d.mode for d in start.bodies(101.0)] == [LEAVE]
    goal.tick(120.0, 1000.0)
    assert goal.bodies(120.0) == []                                  # still on the stairs (40 s for two floors)
    goal.tick(141.0, 1000.0)
    (arrived,) = goal.bodies(141.0)
    assert (arrived.mode, arrived.robot, arrived.started) == (FOLLOW, "Galtxagorri", 100.0)
    goal.on_event(event("e3", "Galtxagorri", Phase.GOAL_REACHED, "g1", stamp=200.0, floor=2.0), 200.0)
    assert [d.mode for d in goal.bodies(200.0)] == [GONE]


def test_a_visitor_who_wanders_off_presses_nothing_more(faculty6) -> None:
    seed = next(s for s in range(1000) if draw_behaviour(s).wanders)
    wander_at = draw_behaviour(seed).wander_at
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, goal_id="223",
                                                      behaviour_seed=seed), ListLog())
    all_up(station, faculty6)
    assert [c.command for c in station.tick(20.0, 1000.0)] == [Cmd.REQUEST]
    core = station.cores["sim-visitor"]
    assert not core.wandered(20.0 + wander_at - 0.1) and core.wandered(20.0 + wander_at)
    station.on_event(event("e1", "Tartalo", Phase.TOUR_STEP_DONE, "g1", stamp=21.0), 21.0)
    station.on_event(event("e2", "Tartalo", Phase.WAITING_VISITOR, "g1", stamp=20.0 + wander_at + 1), 21.0)
    assert station.tick(20.0 + wander_at + 10, 1000.0) == []
    assert core.outcome == "wandered off for good" and not core.finished


def test_the_one_visitor_walks_as_given_else_as_drawn_from_its_seed(faculty6) -> None:
    assert walk_of("", -1) == {"behaviour_seed": -1, "behaviour": None}
    given = walk_of("speed=0.5,pause=15:60", 7)
    assert given["behaviour"] == parse_walk("speed=0.5,pause=15:60")
    station = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, goal_id="223", **given), ListLog())
    assert station.cores["sim-visitor"].behaviour == given["behaviour"]          # the seed is not used
    seeded = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, goal_id="223", **walk_of("", 7)),
                            ListLog())
    assert seeded.cores["sim-visitor"].behaviour == draw_behaviour(7)
    plan = VisitorPlan(visitor_id="v1", arrive_s=0.0, robot="Tartalo", way="stairs", goal_id="223",
                       behaviour_seed=-1)
    crowd = VisitorStation(faculty6, station_config(faculty6, "Tartalo", 0.0, **given), ListLog(), [plan])
    assert crowd.cores["v1"].behaviour == TIDY                                   # a population draws its own
    with pytest.raises(SimConfigError, match=r"walk 'group=9': .*group 9 must be 1\.\.4"):
        walk_of("group=9", -1)
    with pytest.raises(SimConfigError, match=r"~walk: 3 must be a string"):
        walk_of(3, -1)
    with pytest.raises(SimConfigError, match=r"~behaviour_seed: 'x' must be a whole number"):
        walk_of("", "x")
