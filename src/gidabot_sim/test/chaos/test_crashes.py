"""Crashed nodes from the logs: process deaths and the tracebacks that mean our code failed."""

from __future__ import annotations

from pathlib import Path

from gidabot_sim.chaos.crashes import (
    crash_tracebacks,
    log_sizes,
    relay_end_exits,
    roslaunch_deaths,
    scan_logs,
    tracebacks,
)


def test_crash_tracebacks_tell_crashes_from_library_reports() -> None:
    benign = ("[rospy.internal][WARNING] 2026: Unknown error initiating TCP/IP socket to x: Traceback (most recent "
              "call last):\n  File \"a.py\", line 1, in f\nrosgraph.network.ROSHandshakeException: gone\n\n"
              "[rospy.rosout][ERROR] 2026: Unable to report rosout: [Errno 111] Connection refused\n"
              "Traceback (most recent call last):\n  File \"b.py\", line 2, in g\nKeyError: 'x'\n\n"
              "During handling of the above exception, another exception occurred:\n\n"
              "Traceback (most recent call last):\n  File \"c.py\", line 3, in h\nConnectionRefusedError: no\n"
              "--- Logging error ---\nTraceback (most recent call last):\n  File \"d.py\", line 4\nOSError: x\n")
    assert crash_tracebacks(benign) == []
    crash = ("[rospy.topics][ERROR] 2026: bad callback: <bound method GoalManagerNode._enqueue>\n"
             "Traceback (most recent call last):\n  File \"gm.py\", line 9, in _enqueue\nValueError: boom\n\n"
             "Exception in thread Thread-3:\nTraceback (most recent call last):\n  File \"t.py\"\nRuntimeError: t\n"
             "Traceback (most recent call last):\n  File \"/work/main/nodes/sim\", line 5\nZeroDivisionError: z\n")
    assert crash_tracebacks(crash) == ["ValueError: boom", "RuntimeError: t", "ZeroDivisionError: z"]
    assert tracebacks(benign + crash) == 3


def test_roslaunch_and_supervisor_lines_are_parsed() -> None:
    text = ("\x1b[31m[goal_manager-5] process has died [pid 14940, exit code -9, cmd /x __name:=goal_manager].\n"
            "[multirobot_navigation-6] process has died [pid 77, exit code 1, cmd y].\n"
            "[WARN] [1.0]: relay end Tartalo_Kbot.b exited with -15; restarting in 0.5 s\n")
    assert roslaunch_deaths(text) == [("goal_manager", 14940, -9), ("multirobot_navigation", 77, 1)]
    assert relay_end_exits(text) == [("Tartalo_Kbot.b", -15)]


def test_a_runs_logs_are_read_up_to_where_they_were_when_everything_began_to_stop(tmp_path: Path) -> None:
    logs, ros = tmp_path / "logs", tmp_path / "ros" / "Kbot"
    logs.mkdir()
    ros.mkdir(parents=True)
    robot = logs / "robot_Kbot.log"
    robot.write_text("[goal_manager-3] process has died [pid 41, exit code -9, cmd x].\n"
                     "[sim-4] process has died [pid 42, exit code 1, cmd y].\n"
                     "relay end Kbot_Tartalo.a exited with 1\n")
    node = ros / "sim.log"
    node.write_text("Traceback (most recent call last):\n  File \"s.py\", line 1\nValueError: v\n")
    sizes = log_sizes(tmp_path)
    assert sizes == {robot: robot.stat().st_size, node: node.stat().st_size}
    with open(node, "a") as f:                  # written while everything stops: not read
        f.write("Traceback (most recent call last):\n  File \"s.py\", line 2\nKeyError: k\n")
    crashes, tbs = scan_logs(tmp_path, sizes, killed={41})
    assert crashes == ["Kbot/sim died (pid 42, exit code 1)", "Kbot: relay end Kbot_Tartalo.a exited with 1"]
    assert tbs == {"ros/Kbot/sim.log": 1}
