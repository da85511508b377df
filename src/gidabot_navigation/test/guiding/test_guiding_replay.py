"""Table 3 replay (ROS-free): the paper's tours run through four robots' guiding cores.

Four goal managers and four navigations, every goal/cancel/event delivered to every robot
(as the relays do), move_base succeeding at once, a visitor who presses Continue at each
meeting point and after each tour step at the robot where it is.
"""

from __future__ import annotations

from pathlib import Path

from guiding_support import Bus, catalog_of

from gidabot_navigation.guiding.messages import NavEventData
from gidabot_navigation.interface import (
    ACCEPTED,
    GO_TO_FLOOR,
    GOAL_REACHED,
    TOUR_FINISHED,
    TOUR_STEP_DONE,
    WAITING_VISITOR,
)

TOURS = Path(__file__).resolve().parents[4] / "tours"
ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")


def run_tour(faculty, tour_file: str, skips: dict[int, int] | None = None, start: str = "Tartalo") -> Bus:
    bus = Bus(faculty, catalog=catalog_of(faculty, TOURS / tour_file))
    bus.status_all()
    skips = skips or {}

    def visitor(ev: NavEventData) -> None:
        if ev.phase == WAITING_VISITOR:
            bus.soon(lambda: bus.cont(ev.robot, ev.goal_uid))
        elif ev.phase == TOUR_STEP_DONE:
            if ev.tour_step in skips:
                bus.soon(lambda: bus.skip(ev.robot, tour_file, skips[ev.tour_step], goal_uid=ev.goal_uid))
            else:
                bus.soon(lambda: bus.cont(ev.robot, ev.goal_uid))

    bus.on_event = visitor
    bus.start_tour(start, tour_file)
    bus.pump()
    return bus


def test_table3_long_tour_received_and_processed(faculty) -> None:
    bus = run_tour(faculty, "long_tour.tour")
    received = {n: r.gm.stats["received"] for n, r in bus.robots.items()}
    processed = {n: len({e.goal_uid for e in bus.events if e.robot == n and e.phase == ACCEPTED}) for n in ROBOTS}
    assert received == dict.fromkeys(ROBOTS, 15)
    assert processed == {"Tartalo": 7, "Kbot": 8, "Galtxagorri": 8, "MariSorgin": 6}
    assert len({g.uid for g in bus.goals}) == 15
    # every step done once, in order, the last one finishing the tour
    done = [e for e in bus.events if e.phase in (TOUR_STEP_DONE, TOUR_FINISHED)]
    assert [e.tour_step for e in done] == list(range(15)) and done[-1].phase == TOUR_FINISHED
    assert [e.location_id for e in done] == ["005", "301", "203", "103", "205", "303", "014", "104", "207", "020",
                                             "113", "305", "227", "101", "001"]
    # 14 floor changes, each released by the start robot with GO_TO_FLOOR; nothing left anywhere
    assert sum(1 for e in bus.events if e.phase == GO_TO_FLOOR) == 14
    assert not any(e.phase == GOAL_REACHED for e in bus.events)
    assert all(not r.gm.queue and r.nav.leg is None for r in bus.robots.values())
    assert bus.cancels == []


def test_table4_tour_with_a_skip(faculty) -> None:
    bus = run_tour(faculty, "real_world.tour", skips={3: 5})
    done = [e for e in bus.events if e.phase in (TOUR_STEP_DONE, TOUR_FINISHED)]
    assert [e.tour_step for e in done] == [0, 1, 2, 3, 5, 6, 7]
    assert [e.robot for e in done] == ["Tartalo", "Tartalo", "Kbot", "Kbot", "Galtxagorri", "MariSorgin",
                                       "MariSorgin"]
    assert done[-1].phase == TOUR_FINISHED
    # the skipped step was never issued
    assert 4 not in {g.tour_step for g in bus.goals} and len(bus.goals) == 7


def test_tour_started_on_another_floor(faculty) -> None:
    bus = run_tour(faculty, "real_world.tour", start="Galtxagorri")
    done = [e for e in bus.events if e.phase in (TOUR_STEP_DONE, TOUR_FINISHED)]
    assert [e.tour_step for e in done] == list(range(8))
    assert bus.goals[0].origin_robot == "Galtxagorri" and bus.goals[0].goal_floor == 0.0
