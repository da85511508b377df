"""The move_base stand-in as its node runs it (no ROS, no clock): goals, cancels, steps and the lockstep answers,
obstacle and robot updates, make_plan; the port's calls recorded."""

from __future__ import annotations

import math
from functools import partialmethod
from pathlib import Path

import pytest
from sim_support import FakeActionServer, ListLog

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.building.model import load_building
from gidabot_navigation.building.planning import Circle
from gidabot_sim.errors import NavGoalRejected, PlanRefused, PoseRejected
from gidabot_sim.navstack.move_base import MoveBaseCore, State
from gidabot_sim.navstack.move_base_loop import CANCELLED, MoveBaseLoop
from gidabot_sim.world.kinematics import ZERO, Limits, Twist2D

FACULTY = Path(__file__).resolve().parents[4] / "maps" / "faculty"
HOME = Pose2D(30.0, 12.0, 0.0)
ODOM = "/odom"



class Port(FakeActionServer):
    """The node's side: the action server's state (goals: Pose2D, or the error their conversion raises) and
    every other call recorded."""

    def __init__(self) -> None:
        super().__init__()
        self.calls: list[tuple] = []
        self.goals: list[Pose2D | Exception] = []     # sent, not accepted yet
        self.listening = True

    def new_goal_available(self) -> bool:
        return bool(self.goals)

    def accept_new_goal(self) -> Pose2D | None:
        self.new = self.goals.pop(0) if self.goals else None
        goal = super().accept_new_goal() if self.new is not None else None
        if isinstance(goal, Exception):
            raise goal
        return goal

    goal_active = FakeActionServer.is_active
    preempt_requested = FakeActionServer.is_preempt_requested

    def _end(self, kind: str, text: str) -> None:
        super()._end(kind, text)
        self.calls.append((kind, text))

    preempted = partialmethod(_end, "preempted")
    succeeded = partialmethod(_end, "succeeded")
    aborted = partialmethod(_end, "aborted")

    def feedback(self, pose: Pose2D, t: float) -> None:
        self.calls.append(("feedback", t))

    def command(self, cmd: Twist2D) -> None:
        self.calls.append(("cmd", cmd))

    def current_goal(self, pose: Pose2D, t: float) -> None:
        self.calls.append(("current_goal", pose, t))

    def wants_plan(self) -> bool:
        return self.listening

    def plan(self, path, goal_yaw: float, t: float) -> None:
        self.calls.append(("plan", goal_yaw, t))

    def answer(self, t: float, idle: bool, inputs) -> None:
        self.calls.append(("answer", round(t, 3), idle, tuple(inputs)))

    def set_time(self, t: float) -> None:
        pass

    def take(self, kind: str | None = None) -> list[tuple]:
        calls, self.calls = self.calls, []
        return [c for c in calls if kind is None or c[0] == kind]


@pytest.fixture(scope="module")
def floor_map():
    return load_building(FACULTY).floor(1).map


def make(floor_map, **kw) -> tuple[MoveBaseLoop, Port, ListLog]:
    port, log = Port(), ListLog()
    nav = MoveBaseCore.for_robot(floor_map, 0.3, Limits(0.6, 1.0, 0.5, 1.5), log=log, name="Kbot")
    loop = MoveBaseLoop(nav, port, log, ODOM, **kw)
    loop.on_odom(lambda: (0.0, Pose2D(0.0, 0.0, 0.0), ZERO))
    loop.on_estimate(lambda: (0.0, HOME))
    return loop, port, log


def odom(loop: MoveBaseLoop, t: float, moved: float = 0.0) -> None:
    loop.on_odom(lambda: (t, Pose2D(moved, 0.0, 0.0), ZERO))


def test_known_to_the_simulator_from_the_start_idle_and_silent_without_a_goal(floor_map) -> None:
    loop, port, _ = make(floor_map)
    loop.start()
    assert port.take() == [("answer", 0.0, True, ())]
    early, port = make(floor_map)[:2]
    port.goals.append(HOME)
    early.on_goal()                                             # a goal before the loop started
    early.start()
    assert port.take() == [("answer", 0.0, False, (ODOM,))]
    for k in range(1, 5):
        odom(loop, 0.1 * k)
    loop.idle_turn()
    assert port.take() == [] and loop.now == pytest.approx(0.4)


def test_a_goal_is_owed_at_once_then_planned_and_driven_at_each_step_with_an_answer_after_its_command(
        floor_map) -> None:
    loop, port, _ = make(floor_map)
    odom(loop, 0.5)
    port.goals.append(Pose2D(40.0, 12.0, 0.0))
    loop.on_goal()
    assert port.take() == [("answer", 0.5, False, (ODOM,))]      # before the goal is planned
    loop.on_goal()                                              # already owing every step: nothing more to say
    assert port.take() == []
    odom(loop, 0.6)
    calls = port.take()
    assert calls[0] == ("current_goal", Pose2D(40.0, 12.0, 0.0), 0.6)
    kinds = [c[0] for c in calls]
    assert kinds.index("cmd") < kinds.index("answer") and calls[-1] == ("answer", 0.6, False, (ODOM,))
    assert ("plan", 0.0, 0.6) in calls and ("feedback", 0.6) in calls
    odom(loop, 0.55)                                            # a late delivery: the world is past it
    assert port.take() == []
    odom(loop, 0.7, moved=0.05)
    calls = port.take()
    assert [c[0] for c in calls] == ["cmd", "answer"]           # no re-plan, feedback at 5 Hz


def test_a_goal_reached_is_reported_then_one_idle_answer_then_silence(floor_map) -> None:
    loop, port, _ = make(floor_map)
    port.goals.append(HOME)                                     # where it stands
    loop.on_goal()
    calls: list[tuple] = []
    t = 0.0
    while ("succeeded", "Goal reached.") not in calls and t < 5.0:
        t += 0.1
        odom(loop, t)
        calls += port.take()
    assert ("succeeded", "Goal reached.") in calls and calls[-1] == ("answer", round(t, 3), True, ())
    odom(loop, t + 0.1)
    assert port.take() == [] and loop.nav.state is State.IDLE


def test_an_invalid_goal_is_aborted_and_counted(floor_map) -> None:
    loop, port, log = make(floor_map)
    port.goals.append(NavGoalRejected("goal: frame 'odom' is not the map frame 'map'"))
    loop.on_goal()
    odom(loop, 0.1)
    calls = port.take()
    assert ("cmd", ZERO) in calls and calls[-1] == ("answer", 0.1, True, ())
    [(kind, text)] = [c for c in calls if c[0] == "aborted"]
    assert text.startswith("Aborting on goal because it was sent with an invalid pose: goal: frame 'odom'")
    assert loop.rejected.counts == {"goal": 1} and log.lines[-1].startswith("E rejected goal (#1)")


def test_a_cancel_stops_the_robot_unless_a_newer_goal_replaced_the_one_cancelled(floor_map) -> None:
    loop, port, _ = make(floor_map)
    port.goals.append(Pose2D(40.0, 12.0, 0.0))
    loop.on_goal()
    odom(loop, 0.1)
    port.preempt = True
    port.goals.append(Pose2D(45.0, 12.0, 0.0))                 # the cancel comes after a newer goal
    loop.on_goal()
    loop.on_preempt()
    odom(loop, 0.2)
    calls = port.take()
    assert not any(c[0] == "preempted" for c in calls) and loop.nav.goal == Pose2D(45.0, 12.0, 0.0)
    port.preempt = True
    loop.on_preempt()
    odom(loop, 0.3)
    calls = port.take()
    assert ("cmd", ZERO) in calls and ("preempted", CANCELLED) in calls and calls[-1] == ("answer", 0.3, True, ())
    assert loop.nav.state is State.IDLE


def test_idle_a_goal_is_taken_at_once_without_waiting_for_a_step(floor_map) -> None:
    loop, port, _ = make(floor_map)
    odom(loop, 2.0)
    port.goals.append(Pose2D(40.0, 12.0, 0.0))
    loop.on_goal()
    port.take()
    loop.active = False                                         # as if the answer had not been given
    loop.idle_turn()
    calls = port.take()
    assert calls[0][0] == "current_goal" and calls[-1] == ("answer", 2.0, False, (ODOM,))
    loop.idle_turn()                                            # answering every step now: the steps drive
    assert port.take() == []


def test_only_the_newest_obstacles_and_robots_count_and_a_change_is_logged(floor_map) -> None:
    loop, port, log = make(floor_map)
    read = []
    loop.on_obstacles(lambda: read.append("old") or ({}, []))
    loop.on_obstacles(lambda: read.append("new") or ({"p": Circle(40.0, 12.0, 0.3)}, ["obstacle 'x': bad radius"]))
    loop.on_robots(list)
    loop.idle_turn()
    assert read == ["new"] and "W move_base: ignoring obstacle 'x': bad radius" in log.lines
    assert "move_base: costmap updated (1 obstacle(s))" in log.lines and port.take() == []


def test_bad_odometry_and_estimates_are_counted_and_ignored(floor_map) -> None:
    loop, port, _ = make(floor_map)

    def bad():
        raise PoseRejected("odom: non-finite values (nan, ...)")

    loop.on_odom(bad)
    loop.on_estimate(bad)
    assert loop.rejected.counts == {"odom": 1, "amcl_pose": 1} and loop.now == 0.0


def test_make_plan_refuses_while_a_goal_runs_and_returns_none_when_there_is_no_plan(floor_map) -> None:
    loop, port, log = make(floor_map)
    odom(loop, 0.1)
    assert loop.make_plan(lambda: (None, Pose2D(40.0, 12.0, 1.0), 0.0)) is None     # no pose yet: no start
    assert "robot's pose is not known yet" in log.lines[-1]
    path, yaw = loop.make_plan(lambda: (HOME, Pose2D(40.0, 12.0, 1.0), 0.0))
    assert yaw == 1.0 and path.points[0] == pytest.approx((30.0, 12.0), abs=0.05)

    def bad():
        raise NavGoalRejected("goal: position (nan, 0.0) is not finite (m)")

    assert loop.make_plan(bad) is None and log.lines[-1].startswith("W move_base: make_plan: no plan: goal")
    assert loop.make_plan(lambda: (Pose2D(30.0, 12.0, 0.0), Pose2D(30.0, 10.35, 0.0), 0.0)) is None
    port.active = True
    with pytest.raises(PlanRefused, match="inactive state"):
        loop.make_plan(lambda: (HOME, Pose2D(40.0, 12.0, 0.0), 0.0))
    loop.plan_while_active = True
    assert loop.make_plan(lambda: (HOME, Pose2D(40.0, 12.0, 0.0), 0.0)) is not None
    loop.clear_costmaps()
    assert log.lines[-1] == "move_base: costmaps cleared" and math.isfinite(yaw)
