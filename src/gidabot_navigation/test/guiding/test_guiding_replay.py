"""Table 3 replay (ROS-free): the paper's tours run through four robots' guiding cores.

Four goal managers and four navigations, every goal/cancel/event delivered to every robot
(as the relays do), move_base succeeding at once, a visitor who presses Continue at each
meeting point and after each tour step at the robot where it is.
"""

from __future__ import annotations

from pathlib import Path

from guiding_support import Bus, catalog_of

from gidabot_navigation.guiding.messages import NavEventData
from gidabot_navigation.interface import LEG_COMMITTED, LEG_NONE, Phase

TOURS = Path(__file__).resolve().parents[4] / "tours"
ROBOTS = ("Tartalo", "Kbot", "Galtxagorri", "MariSorgin")


def run_tour(faculty, tour_file: str, skips: dict[int, int] | None = None, start: str = "Tartalo") -> Bus:
    bus = Bus(faculty, catalog=catalog_of(faculty, TOURS / tour_file))
    bus.status_all()
    skips = skips or {}

    def visitor(ev: NavEventData) -> None:
        if ev.phase == Phase.WAITING_VISITOR:
            bus.soon(lambda: bus.cont(ev.robot, ev.goal_uid))
        elif ev.phase == Phase.TOUR_STEP_DONE:
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
    processed = {n: len({e.goal_uid for e in bus.events if e.robot == n and e.phase == Phase.ACCEPTED}) for n in ROBOTS}
    assert received == dict.fromkeys(ROBOTS, 15)
    assert processed == {"Tartalo": 7, "Kbot": 8, "Galtxagorri": 8, "MariSorgin": 6}
    assert len({g.uid for g in bus.goals}) == 15
    # every step done once, in order, the last one finishing the tour
    done = [e for e in bus.events if e.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED)]
    assert [e.tour_step for e in done] == list(range(15)) and done[-1].phase == Phase.TOUR_FINISHED
    assert [e.location_id for e in done] == ["005", "301", "203", "103", "205", "303", "014", "104", "207", "020",
                                             "113", "305", "227", "101", "001"]
    # 14 floor changes, each released by the start robot with GO_TO_FLOOR; nothing left anywhere
    assert sum(1 for e in bus.events if e.phase == Phase.GO_TO_FLOOR) == 14
    assert not any(e.phase == Phase.GOAL_REACHED for e in bus.events)
    assert all(not r.gm.queue and r.nav.leg is None for r in bus.robots.values())
    assert bus.cancels == []


def test_table4_tour_with_a_skip(faculty) -> None:
    bus = run_tour(faculty, "real_world.tour", skips={3: 5})
    done = [e for e in bus.events if e.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED)]
    assert [e.tour_step for e in done] == [0, 1, 2, 3, 5, 6, 7]
    assert [e.robot for e in done] == ["Tartalo", "Tartalo", "Kbot", "Kbot", "Galtxagorri", "MariSorgin",
                                       "MariSorgin"]
    assert done[-1].phase == Phase.TOUR_FINISHED
    # the skipped step was never issued
    assert 4 not in {g.tour_step for g in bus.goals} and len({g.uid for g in bus.goals}) == 7


def test_tour_started_on_another_floor(faculty) -> None:
    bus = run_tour(faculty, "real_world.tour", start="Galtxagorri")
    done = [e for e in bus.events if e.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED)]
    assert [e.tour_step for e in done] == list(range(8))
    assert bus.goals[0].origin_robot == "Galtxagorri" and bus.goals[0].goal_floor == 0.0


# ------------------------------------------------------------------- floors without robot

def test_a_tour_goes_on_past_a_floor_without_robot(faculty3) -> None:
    """maps/faculty3 has no robot on floor 2: Table 4's stops 223 and 274 are found alone. Kbot sends the
    visitor there (NO_ROBOT_ON_FLOOR, one message for both stops) and the tour goes on at MariSorgin, who
    meets the visitor at the staircase of floor 3 coming from 274 and guides on; the tour completes."""
    bus = run_tour(faculty3, "real_world.tour")
    done = [e for e in bus.events if e.phase in (Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED)]
    assert [(e.tour_step, e.robot) for e in done] == [(0, "Tartalo"), (1, "Tartalo"), (2, "Kbot"), (3, "Kbot"),
                                                      (6, "MariSorgin"), (7, "MariSorgin")]
    assert done[-1].phase == Phase.TOUR_FINISHED
    [alone] = [e for e in bus.events if e.phase == Phase.NO_ROBOT_ON_FLOOR]
    assert (alone.robot, alone.tour_step, alone.location_id, alone.target_floor) == ("Kbot", 4, "223", 2.0)
    # the trip to step 6 starts at 274 on floor 2: nobody guides there; MariSorgin meets the visitor upstairs
    [on] = [g for g in bus.goals if g.tour_step == 6 and g.attempt == max(x.attempt for x in bus.goals
                                                                           if x.uid == g.uid)]
    assert (on.origin_robot, on.initial_floor, on.start_id, on.start_state) == ("Kbot", 2.0, "274", LEG_NONE)
    assert (on.goal_robot, on.goal_state) == ("MariSorgin", LEG_COMMITTED)
    assert [e.phase for e in bus.events if e.goal_uid == on.uid and e.robot == "MariSorgin"][-3:] == [
        Phase.WAITING_VISITOR, Phase.ON_THE_WAY, Phase.TOUR_STEP_DONE]
    # no goal for step 5: the visitor finds 274 alone, right after 223
    assert 5 not in {g.tour_step for g in bus.goals} and len({g.uid for g in bus.goals}) == 7
    assert nothing_left(bus)


def test_a_tour_ending_on_a_floor_without_robot_ends_there(faculty3, tmp_path) -> None:
    (tmp_path / "ends_upstairs.tour").write_text("Tour: Ends upstairs\n0, 014, Technicians\n2, 223, Larrea\n2, 274, "
                                                 "Sarasola\n", encoding="utf-8")
    bus = Bus(faculty3, catalog=catalog_of(faculty3, tmp_path / "ends_upstairs.tour"))
    bus.status_all()
    bus.on_event = lambda ev: bus.soon(lambda: bus.cont(ev.robot, ev.goal_uid)) \
        if ev.phase == Phase.TOUR_STEP_DONE else None
    bus.start_tour("Tartalo", "ends_upstairs.tour")
    bus.pump()
    last = bus.events[-1]
    assert (last.robot, last.phase, last.tour_step, last.location_id, last.target_floor) == (
        "Tartalo", Phase.TOUR_FINISHED, 1, "223", 2.0)
    assert not any(e.phase == Phase.NO_ROBOT_ON_FLOOR for e in bus.events) and len({g.uid for g in bus.goals}) == 2
    assert nothing_left(bus)


def test_a_single_target_on_a_floor_without_robot_leaves_nothing_anywhere(faculty3) -> None:
    bus = Bus(faculty3)
    bus.status_all()
    bus.request("Tartalo", "223")
    [uid] = {g.uid for g in bus.goals}
    assert bus.phases("Tartalo", uid) == [Phase.ACCEPTED, Phase.ON_THE_WAY, Phase.NO_ROBOT_ON_FLOOR]
    ev = bus.last("Tartalo", Phase.NO_ROBOT_ON_FLOOR)
    name = faculty3.find_connector(ev.connector).name("en")        # the lift or staircase the trip goes by
    assert ev.detail == f"no robot serves floor 2: take the {ev.way} ({name}) to floor 2 and find 223 yourself"
    assert nothing_left(bus)


def nothing_left(bus: Bus) -> bool:
    """No robot holds, runs, waits for or still assigns anything."""
    return all(not r.gm.queue and r.nav.leg is None and not len(r.gm.waits) and not len(r.gm.assigner)
               for r in bus.robots.values())
