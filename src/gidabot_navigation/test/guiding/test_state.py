"""Guiding across restarts of its nodes: state kept in a file, replayed messages ignored."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from guiding_support import Bus, ListLog

from gidabot_navigation.errors import GuidingStateError
from gidabot_navigation.guiding.goal_manager import GoalManagerConfig, GoalManagerCore
from gidabot_navigation.guiding.messages import (
    CancelData,
    CommandData,
    MoveTo,
    SendCancel,
    SendEvent,
    SendGoal,
    Trip,
    command_key,
)
from gidabot_navigation.guiding.navigation import SUCCEEDED, NavigationConfig, NavigationCore
from gidabot_navigation.guiding.state import StateFile, actions_from_list, actions_to_list
from gidabot_navigation.interface import LEG_GOAL, Cmd, Phase


def roundtrip(state: dict) -> dict:
    """What a restarted node reads back (JSON, as StateFile writes it)."""
    return json.loads(json.dumps(state, allow_nan=False))


def restart_goal_manager(bus: Bus, robot: str) -> GoalManagerCore:
    old = bus.robots[robot].gm
    new = GoalManagerCore(bus.building, GoalManagerConfig(robot=robot), bus.log, bus.now_wall, boot="t2")
    new.load_state(roundtrip(old.state()))
    new.on_catalog([])
    bus.robots[robot].gm = new
    bus.robots[robot].pending_version = -1
    return new


def restart_navigation(bus: Bus, robot: str) -> NavigationCore:
    old = bus.robots[robot].nav
    assert old is not None
    new = NavigationCore(bus.building, NavigationConfig(robot=robot), bus.log, bus.now_wall, boot="t2")
    new.load_state(roundtrip(old.state()))
    new.on_move_base_available(True, bus.now_ros)
    bus.robots[robot].nav = new
    bus.robots[robot].active = None          # the old process's move_base goal handle is gone
    return new


def test_a_restarted_goal_manager_keeps_its_queue_and_ignores_the_replayed_goal(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("MariSorgin")
    goal = bus.goals[0]
    gm = restart_goal_manager(bus, "MariSorgin")
    assert bus.queue_of("MariSorgin") == [uid]
    assert gm.on_goal(goal, bus.now_ros, bus.now_wall) == []          # the relay's replay: a duplicate
    assert gm.stats["duplicates"] == 1 and bus.queue_of("MariSorgin") == [uid]
    # the trip goes on to the end with the new goal manager
    bus.finish_move("MariSorgin")
    bus.finish_move("Tartalo")
    bus.pump()
    bus.cont("MariSorgin", uid)
    bus.finish_move("MariSorgin")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-1] == Phase.GOAL_REACHED
    assert bus.queue_of("MariSorgin") == []
    assert bus.phases("MariSorgin", uid).count(Phase.ACCEPTED) == 1


def test_a_cancel_seen_before_the_restart_still_wins_over_its_late_goal(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    gm = bus.robots["Kbot"].gm
    cancel = CancelData(uid="Tartalo/cancel/x.1", goal_uid="Tartalo/v/t.9", origin_robot="Tartalo", reason="visitor")
    gm.on_cancel(cancel, bus.now_ros, bus.now_wall, from_relay=True)
    gm = restart_goal_manager(bus, "Kbot")
    bus.request("Tartalo", "101")          # not the cancelled uid: queued
    assert len(bus.queue_of("Kbot")) == 1
    late = bus.goals[0].__class__(**{**bus.goals[0].__dict__, "uid": "Tartalo/v/t.9"})
    assert gm.on_goal(late, bus.now_ros, bus.now_wall) == []
    assert gm.stats["cancelled_before_arrival"] == 1


def test_replayed_commands_are_ignored_but_a_restarted_gui_counting_again_is_not(faculty) -> None:
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Tartalo"), ListLog(), 0.0, boot="t")
    cmd = CommandData(command=Cmd.REQUEST, uid="Tartalo/v/cmd/1", visitor_id="v", goal_id="008", stamp=12.5)
    assert any(isinstance(a, SendGoal) for a in gm.on_command(cmd, 12.5, 0.0))
    gm2 = GoalManagerCore(faculty, GoalManagerConfig(robot="Tartalo"), ListLog(), 0.0, boot="t2")
    gm2.load_state(roundtrip(gm.state()))
    assert gm2.on_command(cmd, 13.0, 1.0) == []                       # replayed: same uid and stamp
    assert gm2.stats["duplicate_commands"] == 1
    again = CommandData(command=Cmd.REQUEST, uid="Tartalo/v/cmd/1", visitor_id="v", goal_id="008", stamp=99.0)
    assert any(isinstance(a, SendGoal) for a in gm2.on_command(again, 99.0, 2.0))
    assert command_key("", 1.0) == "" and command_key("a", float("nan")) == "a@0.000000"


def test_tour_step_waiting_survives_a_restart(faculty, tmp_path: Path) -> None:
    from guiding_support import catalog_of

    tour = tmp_path / "two.tour"
    tour.write_text("Tour: Two\n0, 008, A\n0, 014, B\n", encoding="utf-8")
    catalog = catalog_of(faculty, tour)
    bus = Bus(faculty, catalog=catalog)
    bus.status_all()
    bus.start_tour("Tartalo", "two.tour")
    first = bus.goals[0].uid
    gm = restart_goal_manager(bus, "Tartalo")
    gm.on_catalog(catalog)
    bus.cont("Tartalo", first)                                         # Continue after step 1, at the new node
    assert [g.tour_step for g in bus.goals] == [0, 1]


def test_a_restarted_navigation_resumes_its_leg_and_sends_the_goal_again(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("Tartalo")
    first_move = bus.robots["Tartalo"].moves[-1]
    nav = restart_navigation(bus, "Tartalo")
    assert nav.leg is not None and nav.leg.trip.uid == uid and nav.leg.resend
    actions = nav.tick(bus.now_ros, bus.now_wall)
    [again] = [a for a in actions if isinstance(a, MoveTo)]
    assert (again.x, again.y) == (first_move.x, first_move.y) and again.token != first_move.token
    assert nav.on_move_base_result(first_move.token, SUCCEEDED, "", bus.now_ros, bus.now_wall) == []  # stale
    bus.run("Tartalo", actions)
    bus.finish_move("Tartalo")
    bus.pump()
    assert bus.phases("Tartalo", uid) == [Phase.ACCEPTED, Phase.ON_THE_WAY, Phase.GO_TO_FLOOR]


def test_a_navigation_restarted_while_waiting_does_not_move_and_takes_the_replayed_continue_once(faculty) -> None:
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "301")
    [uid] = bus.queue_of("MariSorgin")
    bus.finish_move("MariSorgin")
    bus.finish_move("Tartalo")
    bus.pump()
    assert bus.phases("MariSorgin", uid)[-1] == Phase.WAITING_VISITOR
    nav = restart_navigation(bus, "MariSorgin")
    assert not any(isinstance(a, MoveTo) for a in nav.tick(bus.now_ros, bus.now_wall))
    key = command_key("MariSorgin/v/cmd/1", 200.0)
    assert [type(a) for a in nav.on_continue(uid, bus.now_ros, bus.now_wall, key=key)] == [MoveTo, SendEvent]
    assert nav.on_continue(uid, bus.now_ros, bus.now_wall, key=key) == []      # replayed
    assert nav.stats["duplicate_commands"] == 1


def test_damaged_states_change_nothing(faculty) -> None:
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), 0.0, boot="t")
    for bad in ({"queue": [{"uid": 5}]}, {"queue": "x"}, {"goals_seen": [1, 2]}, {"phase": {"a": "b"}},
                {"waits": [{"goal_uid": None}]}):
        with pytest.raises(GuidingStateError):
            gm.load_state(bad)
    assert gm.queue == [] and len(gm._goals_seen) == 0
    nav = NavigationCore(faculty, NavigationConfig(robot="Kbot"), ListLog(), 0.0, boot="t")
    for bad in ({"leg": {"trip": {}, "role": "nope"}}, {"leg": {"target": [float("nan")]}}, {"token": "x"}):
        with pytest.raises(GuidingStateError):
            nav.load_state(bad)
    assert nav.leg is None


class _Clock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def test_state_file_round_trip_staleness_and_damage(tmp_path: Path, faculty) -> None:
    log, clock = ListLog(), _Clock()
    sf = StateFile(tmp_path / "g" / "goal_manager.json", "goal_manager", "Kbot", log, max_age=60.0, clock=clock)
    assert sf.load() is None
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "101")
    outbox = [SendGoal(bus.goals[0]), SendCancel(CancelData("K/cancel/1", bus.goals[0].uid, "Kbot", "visitor")),
              SendEvent(bus.events[0])]
    assert sf.save({"queue": [], "x": 1}, outbox)
    state, out = sf.load()
    assert state == {"queue": [], "x": 1} and out == outbox
    assert actions_from_list(actions_to_list(outbox)) == outbox
    assert not list((tmp_path / "g").glob(".goal_manager.json.*"))    # no temporary file left
    clock.t += 61.0
    assert sf.load() is None and "old" in log.lines[-1][1]
    other = StateFile(sf.path, "goal_manager", "Tartalo", log, clock=clock)
    assert other.load() is None and "belongs to" in log.lines[-1][1]
    sf.path.write_text("{not json", encoding="utf-8")
    assert sf.load() is None and log.lines[-1][0] == "error"
    with pytest.raises(GuidingStateError):
        actions_from_list([{"kind": "?"}])


def test_state_file_unwritable_is_reported_not_raised(tmp_path: Path) -> None:
    log = ListLog()
    sf = StateFile(tmp_path / "s.json", "goal_manager", "Kbot", log)
    (tmp_path / "s.json").mkdir()                   # a directory in the way: rename fails
    assert not sf.save({}, []) and sf.failures == 1 and log.lines[-1][0] == "error"


def test_continue_command_key_in_the_node_matches_the_core() -> None:
    cmd = CommandData(command=Cmd.CONTINUE, uid="R/v/cmd/3", stamp=7.25)
    assert cmd.key == command_key("R/v/cmd/3", 7.25)


def test_a_tour_continue_replayed_before_its_step_done_is_kept_until_the_step_is_done(faculty, tmp_path: Path) -> None:
    """After a restart the visitor's Continue (replayed by the visitor node) may arrive before the
    TOUR_STEP_DONE it answers (replayed by the navigation): it is applied once the step is done."""
    from guiding_support import catalog_of

    from gidabot_navigation.guiding.messages import NavEventData
    from gidabot_navigation.interface import Phase

    tour = tmp_path / "two.tour"
    tour.write_text("Tour: Two\n0, 008, A\n0, 014, B\n", encoding="utf-8")
    catalog = catalog_of(faculty, tour)
    bus = Bus(faculty, catalog=catalog, auto_move=False)
    bus.status_all()
    bus.start_tour("Tartalo", "two.tour")
    first = bus.goals[0].uid
    assert bus.phases("Tartalo", first)[-1] == Phase.ON_THE_WAY
    gm = restart_goal_manager(bus, "Tartalo")
    gm.on_catalog(catalog)
    meeting = CommandData(command=Cmd.CONTINUE, uid="Tartalo/v/cmd/8", visitor_id="v", goal_uid=first, stamp=150.0)
    assert gm.on_command(meeting, bus.now_ros, bus.now_wall) == []        # pressed before the step was done
    done = NavEventData(uid="Tartalo/event/nav.x.9", robot="Tartalo", floor=0.0, goal_uid=first,
                        phase=Phase.TOUR_STEP_DONE, tour_file="two.tour", tour_step=0, stamp=200.0)
    gm_copy = GoalManagerCore(faculty, GoalManagerConfig(robot="Tartalo"), bus.log, bus.now_wall, boot="t4")
    gm_copy.load_state(roundtrip(gm.state()))
    gm_copy.on_catalog(catalog)
    assert gm_copy.on_nav_event(done, bus.now_ros, bus.now_wall) == []    # not a Continue after the step
    cont = CommandData(command=Cmd.CONTINUE, uid="Tartalo/v/cmd/9", visitor_id="v", goal_uid=first, stamp=203.0)
    assert gm.on_command(cont, bus.now_ros, bus.now_wall) == []           # the step is not done yet here
    gm2 = GoalManagerCore(faculty, GoalManagerConfig(robot="Tartalo"), bus.log, bus.now_wall, boot="t3")
    gm2.load_state(roundtrip(gm.state()))                                  # and it survives another restart
    gm2.on_catalog(catalog)
    actions = gm2.on_nav_event(done, bus.now_ros, bus.now_wall)
    [goal] = [a.trip for a in actions if isinstance(a, SendGoal)]
    assert goal.tour_step == 1 and gm2.stats["early_continues"] == 1


# ---------------------------------------------------------------- when the state is written
class _Monotonic:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def _hostile(faculty, n: int) -> list[tuple[str, object]]:
    """Messages a goal manager rejects at once: invalid goals, cancels, events and visitor commands."""
    from dataclasses import replace

    from gidabot_navigation.guiding.messages import NavEventData

    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "101")
    good = bus.goals[0]
    out: list[tuple[str, object]] = []
    for i in range(n):
        out += [
            ("goal", replace(good, uid=f"Kbot/x/{i}", goal_id="nowhere")),                   # unknown location
            ("goal", replace(good, uid=f"Mallory/x/{i}", origin_robot="Mallory")),          # not a robot
            ("cancel", CancelData(f"Kbot/cancel/{i}", good.uid, "Mallory", "visitor")),      # not a robot
            ("event", NavEventData(uid=f"Kbot/event/{i}", robot="Mallory", floor=1.0, goal_uid="x",
                                   phase=Phase.ACCEPTED)),
            ("command", CommandData(command=99, uid=f"Kbot/v/cmd/{i}", stamp=float(i))),   # unknown command
            ("command", CommandData(command=Cmd.REQUEST, uid=f"Kbot/v/cmd/r{i}", goal_id="../x", stamp=float(i))),
        ]
    return out


def _feed(gm: GoalManagerCore, sf: StateFile, kind: str, msg: object, now: float) -> list:
    """What GoalManagerNode does with one input: the core's answer, committed (REJECTED answers are not kept)."""
    actions = {"goal": gm.on_goal, "cancel": gm.on_cancel, "event": gm.on_nav_event,
               "command": gm.on_command}[kind](msg, 100.0, now)
    durable = [a for a in actions if not (isinstance(a, SendEvent) and a.event.phase == Phase.REJECTED)]
    sf.commit(gm.state, actions, durable, lambda _a: None, changed=True)
    return actions


def test_rejected_messages_cost_no_state_write(faculty, tmp_path: Path) -> None:
    """A flood of rejected goals, cancels, events and commands: not one write of the state file (today's
    main wrote it, with fsync, for every one of them)."""
    mono = _Monotonic()
    sf = StateFile(tmp_path / "goal_manager.json", "goal_manager", "Kbot", ListLog(), monotonic=mono)
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), 0.0, boot="t")
    sf.save(gm.state(), [])
    before = (sf.saves, sf.path.read_bytes())
    for k, (kind, msg) in enumerate(_hostile(faculty, 200)):
        mono.t = k * 0.001                              # 1,200 messages in 1.2 s
        _feed(gm, sf, kind, msg, mono.t)
    mono.t += 10.0
    sf.flush(gm.state)
    sf.flush(gm.state, force=True)
    assert gm.stats["rejected"] + gm.stats["rejected_location"] >= 1000
    assert (sf.saves, sf.path.read_bytes()) == before


def test_state_changes_are_written_before_publishing_or_within_the_soft_interval(faculty, tmp_path: Path) -> None:
    from gidabot_navigation.guiding.messages import NavEventData

    mono = _Monotonic()
    sf = StateFile(tmp_path / "goal_manager.json", "goal_manager", "Kbot", ListLog(), monotonic=mono)
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), 0.0, boot="t")
    gm.on_status("Tartalo", 0.0)
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "101")                       # a goal from floor 0 to floor 1: Kbot keeps it
    seen_at_publish: list[dict] = []
    actions = gm.on_goal(bus.goals[0], 100.0, 0.0)
    assert [type(a) for a in actions] == [SendEvent]     # ACCEPTED
    sf.commit(gm.state, actions, actions, lambda _a: seen_at_publish.append(json.loads(sf.path.read_bytes())))
    assert seen_at_publish[0]["outbox"] and [t["uid"] for t in seen_at_publish[0]["state"]["queue"]] == \
        [bus.goals[0].uid]                               # on disk, with its outbox, before it was published
    saves = sf.saves
    # valid events of other robots about trips that do not exist: remembered (state), published nothing
    for i in range(1000):
        mono.t = 0.1 + i * 0.001
        ev = NavEventData(uid=f"MariSorgin/event/flood.{i}", robot="MariSorgin", floor=3.0, goal_uid=f"M/v/{i}",
                          phase=Phase.ACCEPTED, leg=LEG_GOAL)
        sf.commit(gm.state, gm.on_nav_event(ev, 100.0, mono.t), [], lambda _a: None, changed=True)
    assert sf.saves - saves <= 2                         # one write per soft interval at most
    mono.t += 1.0
    sf.flush(gm.state)
    assert json.loads(sf.path.read_bytes())["state"] == roundtrip(gm.state())    # nothing lost after the interval
    assert json.loads(sf.path.read_bytes())["outbox"] == []


def test_a_leg_committed_in_the_published_pending_list_survives_a_restart_right_after(faculty, tmp_path: Path) -> None:
    """The quick chaos run on machines (seed 3): Kbot's goal_manager applied attempt 3 of a trip (its goal leg
    committed to Kbot: a change that publishes nothing, saved within the soft interval), published its pending
    list (its navigation started for the meeting point) and was killed 0.3 s later. The restarted one resumed
    attempt 2 (the leg only proposed), published that, and its navigation stopped the leg for good: the
    visitor was sent upstairs to nobody, the goal lost. The pending list is now published only once saved."""
    from gidabot_navigation.interface import LEG_COMMITTED, LEG_PROPOSED

    mono = _Monotonic()
    sf = StateFile(tmp_path / "goal_manager.json", "goal_manager", "Kbot", ListLog(), monotonic=mono)
    gm = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), 0.0, boot="t")
    bus = Bus(faculty, auto_move=False)
    bus.status_all()
    bus.request("Tartalo", "101")
    proposed = next(g for g in bus.goals if g.goal_robot == "Kbot" and g.goal_state == LEG_PROPOSED)
    committed = next(g for g in bus.goals if g.goal_robot == "Kbot" and g.goal_state == LEG_COMMITTED)
    actions = gm.on_goal(proposed, 100.0, 0.0)                  # ACCEPTED: written before it is published
    sf.commit(gm.state, actions, actions, lambda _a: None)
    mono.t = 0.3
    sf.commit(gm.state, gm.on_goal(committed, 100.3, 0.3), [], lambda _a: None, changed=True)
    shown: list[Trip] = []
    sf.publish_state(gm.state, lambda: shown.extend(gm.pending(100.3).goals))   # what the node does
    assert shown[0].goal_state == LEG_COMMITTED                 # its navigation starts the leg
    # killed now: the restarted goal manager shows what its navigation acts on, not an older list
    again = GoalManagerCore(faculty, GoalManagerConfig(robot="Kbot"), ListLog(), 10.0, boot="t2")
    loaded = StateFile(sf.path, "goal_manager", "Kbot", ListLog()).load()
    assert loaded is not None
    again.load_state(loaded[0])
    assert [(t.uid, t.attempt, t.goal_state) for t in again.pending(110.0).goals] == [
        (committed.uid, committed.attempt, LEG_COMMITTED)]
