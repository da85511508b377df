"""One robot's screen for the simulated visitors (no ROS, no clock): its configuration, when a visit starts,
which visitor an event is for, the commands pressed, the record of what each visitor chose."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from sim_support import ListLog

from gidabot_navigation.building.model import load_building
from gidabot_navigation.guiding.messages import NavEventData
from gidabot_navigation.interface import Cmd, Phase
from gidabot_navigation.tours.tour_store import TourMessage
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.population import VisitorPlan
from gidabot_sim.visitor.station import VisitorStation, skips_of, station_config

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
