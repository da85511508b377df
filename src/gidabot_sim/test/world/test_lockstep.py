"""The lockstep core: a floor steps on only when its controllers answered, the other floors allow it and
its speed ceiling is met; explicit events and wall times, no clock."""

from __future__ import annotations

import math

import pytest

from gidabot_sim.errors import SimConfigError, StepDoneRejected
from gidabot_sim.world.clock import Pacer
from gidabot_sim.world.lockstep import CEILING, CONTROLLERS, FLOORS, MAX_PARTICIPANTS, Answer, Lockstep, Stepper

TRUTH, ODOM = "/base_pose_ground_truth", "/odom"


def stepper(speed: float | None = None, timeout: float = 2.0, max_drift: float | None = None) -> Stepper:
    return Stepper(0.1, Pacer(speed, start_wall=0.0), Lockstep(timeout), max_drift=max_drift)


def run(s: Stepper, wall: float, until: float) -> list[float]:
    """Step as long as nothing is waited for (at one wall time); the stops reached."""
    reached = []
    while s.t < until - 1e-9 and s.check(wall) is None:
        reached.append(s.advance(wall))
    return reached


def test_without_participants_the_clock_follows_the_ceiling_and_never_runs_ahead() -> None:
    s = stepper(speed=10.0)
    wait = s.check(0.0)
    assert wait is not None and wait.reason == CEILING and wait.until == pytest.approx(0.01)
    assert s.check(0.01) is None and s.advance(0.01) == pytest.approx(0.1)
    assert run(s, 0.05, 10.0) == pytest.approx([0.2, 0.3, 0.4, 0.5])     # due at 0.02 .. 0.05 wall
    assert s.steps == 5 and s.behind(0.05) == 0.0
    assert s.waited[CEILING] == pytest.approx(0.01)


def test_a_controller_that_has_not_answered_holds_the_world_at_its_stop() -> None:
    s = stepper()                                           # no ceiling: as fast as the controller allows
    s.lockstep.answer(Answer("/move_base", 7, done=0.0), 0.0)
    assert s.check(0.0) is None and s.advance(0.0) == pytest.approx(0.1)
    wait = s.check(0.001)
    assert wait is not None and wait.reason == CONTROLLERS and wait.who == ("/move_base",)
    assert wait.until == pytest.approx(2.0)                 # it has the timeout from when the stop was reached
    s.lockstep.answer(Answer("/move_base", 7, done=0.1), 0.0)
    assert s.check(0.004) is None and s.advance(0.004) == pytest.approx(0.2)
    assert s.waited[CONTROLLERS] == pytest.approx(0.003)
    stats = s.lockstep.stats()["/move_base"]
    assert (stats["owed"], stats["answered"], stats["missed"]) == (1, 1, 0)
    assert stats["waited_s"] == pytest.approx(0.003)


def test_a_driving_participant_gets_its_inputs_at_every_stop_also_when_it_wakes_up_in_the_middle_of_one() -> None:
    lock = Lockstep()
    lock.answer(Answer("/move_base", 7, done=0.0, idle=True), 0.0)
    assert lock.inputs_due() == set()
    lock.published(ODOM, 4.0)                              # at rest: odometry once a second
    lock.answer(Answer("/move_base", 7, done=4.0, idle=False, inputs=(ODOM,)), 1.0)   # a goal at 4.3
    assert lock.inputs_due() == {ODOM} and lock.missing_inputs(4.3) == {ODOM}
    lock.published(ODOM, 4.3)
    assert lock.missing_inputs(4.3) == set()


def test_an_answer_waits_for_the_commands_it_says_were_sent_on_the_other_connection() -> None:
    s = stepper()
    s.lockstep.answer(Answer("/move_base", 7, done=0.0, commands=1), 0.0)     # its cmd_vel has not arrived yet
    wait = s.check(0.0)
    assert wait is not None and wait.reason == CONTROLLERS
    s.lockstep.command("/move_base")
    assert s.check(0.001) is None
    s.advance(0.001)
    s.lockstep.command("/teleop")                         # commands of non-participants are applied, never waited for
    s.lockstep.answer(Answer("/move_base", 7, done=0.1, commands=1), 0.0)
    assert s.check(0.002) is None


def test_an_idle_participant_owes_only_the_stops_that_published_its_inputs() -> None:
    s = stepper()
    s.lockstep.answer(Answer("/amcl", 3, done=0.0, idle=True, inputs=(TRUTH,)), 0.0)
    assert run(s, 0.0, 0.5) == pytest.approx([0.1, 0.2, 0.3, 0.4, 0.5])   # nothing published for it
    s.lockstep.published(TRUTH, 0.5)
    wait = s.check(0.0)
    assert wait is not None and wait.who == ("/amcl",)
    s.lockstep.answer(Answer("/amcl", 3, done=0.5, idle=True, inputs=(TRUTH,)), 0.0)
    assert s.check(0.0) is None
    assert s.lockstep.stats()["/amcl"]["owed"] == 0        # counted when the world leaves the stop
    s.advance(0.0)
    assert s.lockstep.stats()["/amcl"]["owed"] == 1


def test_a_frozen_controller_is_given_up_after_the_timeout_counted_and_rejoins_when_it_answers() -> None:
    s = stepper(timeout=2.0)
    s.lockstep.answer(Answer("/move_base", 7, done=0.0), 0.0)
    s.check(10.0)
    s.advance(10.0)                                       # at 0.1: it owes the stop from 10.0 wall on
    assert s.check(10.0) is not None and s.check(11.9) is not None    # still waited for
    assert s.check(12.01) is None                         # 2 s: absent, the world goes on
    assert s.lockstep.timed_out == ["/move_base"]
    assert run(s, 12.01, 1.0) == pytest.approx([0.2 + k / 10 for k in range(9)])   # not waited for any more
    stats = s.lockstep.stats()["/move_base"]
    assert (stats["owed"], stats["answered"], stats["missed"], stats["timeouts"], stats["absent"]) == (9, 0, 9, 1, 1)
    assert stats["waited_s"] == pytest.approx(2.01)
    s.lockstep.answer(Answer("/move_base", 7, done=0.3), 12.015)  # it wakes up, still on an old step
    assert s.lockstep.rejoined == ["/move_base"]
    wait = s.check(12.02)
    assert wait is not None and wait.who == ("/move_base",)
    s.lockstep.answer(Answer("/move_base", 7, done=1.0), 12.025)
    assert s.check(12.03) is None


def test_a_restarted_participant_is_a_new_session_with_its_own_command_count() -> None:
    lock = Lockstep()
    lock.answer(Answer("/move_base", 1, done=5.0, commands=3), 0.0)
    for _ in range(3):
        lock.command("/move_base")
    lock.command("/move_base")                             # a new process: its first command, then its answer
    lock.answer(Answer("/move_base", 2, done=5.0, commands=1), 1.0)
    p = lock.participants["/move_base"]
    assert p.sessions == 2 and not lock.owes(p, 5.0)
    lock.answer(Answer("/move_base", 2, done=5.1, commands=2), 1.1)
    assert lock.owes(p, 5.1)                              # its second command is still on its way
    lock.command("/move_base")
    assert not lock.owes(p, 5.1)


def test_a_floor_stays_within_the_drift_bound_of_the_slowest_live_floor() -> None:
    s = stepper(max_drift=0.5)
    for _ in range(5):
        assert s.check(0.0, peers=0.0) is None
        s.advance(0.0)
    wait = s.check(0.0, peers=0.0)
    assert wait is not None and wait.reason == FLOORS and s.t == pytest.approx(0.5)
    assert s.check(0.003, peers=0.1) is None
    assert s.waited[FLOORS] == pytest.approx(0.003) and s.max_lead == pytest.approx(0.5)


def test_malformed_answers_and_one_participant_too_many_are_refused_with_what_is_wrong() -> None:
    lock = Lockstep()
    for bad, match in ((Answer("", 1, 0.0), "node"), (Answer("/x", 1, math.nan), "done"),
                       (Answer("/x", 1, -1.0), "done"), (Answer("/x", 1, 0.0, inputs=("\n",)), "inputs"),
                       (Answer("/x", 1, 0.0, inputs=("a",) * 17), "inputs"),
                       (Answer("/x", 1, 0.0, commands=-1), "commands")):
        with pytest.raises(StepDoneRejected, match=match):
            lock.answer(bad, 0.0)
    for i in range(MAX_PARTICIPANTS):
        lock.answer(Answer(f"/n{i}", 1, 0.0, idle=True), 0.0)
    with pytest.raises(StepDoneRejected, match="participants"):
        lock.answer(Answer("/one_more", 1, 0.0), 0.0)
    assert len(lock.participants) == MAX_PARTICIPANTS
    with pytest.raises(SimConfigError, match="timeout"):
        Lockstep(0.0)
    with pytest.raises(SimConfigError, match="max_drift"):
        Stepper(0.1, Pacer(None, 0.0), max_drift=0.05)
