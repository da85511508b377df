"""The drivers of ``gidabot bench sim``: rospy nodes on the floor's master that drive the floor through ROS.

Run by the benchmark as ``python -m gidabot_sim.bench.sim_node ros-driver GOALS`` (move_base action goals,
``base_scan`` subscribed or not, then parked: one JSON line per phase) or ``... stack-driver SPEC`` (a visitor's
requests to the floor's guiding nodes, then the rates in the floor's ``/diagnostics`` over the drive). Each
prints ``READY``, waits for ``GO`` on its stdin, and prints its results.
"""

from __future__ import annotations

import json
import sys
import time

from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.interface import Node, Topic
from gidabot_sim.bench.sim import PHASES
from gidabot_sim.navstack.move_base import SUCCEEDED
from gidabot_sim.report.bags import DiagSample
from gidabot_sim.report.rates import controller_rates, loop_rates

IDLE_SIM_S = 60.0


def stack_driver(spec: dict) -> int:
    """Runs in a subprocess on the floor's master: a visitor's requests, one after the other; JSON of the drive,
    with the rates in the floor's /diagnostics over it."""
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray

    from gidabot_msgs.msg import NavEvent, VisitorCommand

    robot, goals = spec["robot"], spec["goals"]
    # the simulated visitor's screen is the one node besides the GUI whose visitor commands a robot takes
    rospy.init_node(Node.VISITOR, disable_signals=True)
    events: list[tuple[float, NavEvent]] = []       # (wall s received, event)
    diags: list[DiagSample] = []
    rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, lambda m: events.append((time.monotonic(), m)), queue_size=100)
    rospy.Subscriber(Topic.DIAGNOSTICS, DiagnosticArray, lambda m: diags.extend(
        DiagSample(m.header.stamp.to_sec(), st.name, tuple((kv.key, kv.value) for kv in st.values))
        for st in m.status), queue_size=100)
    pub = rospy.Publisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=10)
    deadline = time.monotonic() + 60.0
    while (pub.get_num_connections() < 2 or rospy.get_time() <= 0.0) and time.monotonic() < deadline:
        time.sleep(0.05)       # goal_manager and multirobot_navigation subscribe; the clock runs
    time.sleep(6.0)            # (a robot never heard counts as online for 5 s: the others must be offline)
    print("READY", flush=True)
    if sys.stdin.readline().strip() != "GO":
        return 1
    wall0, sim0 = time.monotonic(), rospy.get_time()
    outcomes = []
    guiding_sim = guiding_wall = 0.0
    for k, goal in enumerate(goals):
        n = len(events)
        msg = VisitorCommand(uid=f"{robot}/bench/cmd/{k}", visitor_id="bench", command=VisitorCommand.REQUEST,
                             goal_id=goal, way="stairs", language="en")
        msg.header.stamp = rospy.Time.now()
        pub.publish(msg)
        end = time.monotonic() + 120.0
        done = None
        while done is None and time.monotonic() < end:
            done = next(((w, e) for w, e in events[n:] if e.robot == robot and e.location_id == goal
                         and e.phase in (NavEvent.GOAL_REACHED, NavEvent.UNREACHABLE, NavEvent.REJECTED)), None)
            time.sleep(0.01)
        start = next(((w, e) for w, e in events[n:] if e.robot == robot and e.phase == NavEvent.ON_THE_WAY), None)
        if done is not None and start is not None and done[1].phase == NavEvent.GOAL_REACHED:
            guiding_sim += done[1].header.stamp.to_sec() - start[1].header.stamp.to_sec()
            guiding_wall += done[0] - start[0]
        phase = None if done is None else done[1].phase
        outcomes.append({NavEvent.GOAL_REACHED: "reached", None: "timed out"}.get(phase, f"phase {phase}"))
    sim1, wall1 = rospy.get_time(), time.monotonic()
    print("DONE", flush=True)
    time.sleep(1.5)            # the diagnostics after the drive
    samples = sorted(diags, key=lambda d: d.t)
    rates = {node: r["rate_pct"] for node, r in controller_rates(samples, sim0, sim1).items()}
    rates.update({node: r["rate_pct"] for node, r in loop_rates(samples, sim0, sim1).items()})
    print(json.dumps({"sim_s": sim1 - sim0, "wall_s": wall1 - wall0, "outcomes": outcomes, "places": goals,
                      "guiding_sim_s": guiding_sim, "guiding_wall_s": guiding_wall, "rates_pct": rates}), flush=True)
    return 0


def ros_driver(goals: list[list[float]]) -> int:
    """Runs in a subprocess on the floor's master: subscribe base_scan, drive the goals, print JSON."""
    import actionlib
    import rospy
    from move_base_msgs.msg import MoveBaseAction, MoveBaseGoal
    from sensor_msgs.msg import LaserScan

    from gidabot_sim.ros.convert import pose_msg

    rospy.init_node("bench_driver", disable_signals=True)
    scans = [0]
    scan_sub = rospy.Subscriber(Topic.BASE_SCAN, LaserScan, lambda _m: scans.__setitem__(0, scans[0] + 1),
                                queue_size=50)
    client = actionlib.SimpleActionClient(Topic.MOVE_BASE, MoveBaseAction)
    deadline = time.monotonic() + 60.0
    while not client.wait_for_server(rospy.Duration(0.5)):     # sim time: the clock may not run yet
        if time.monotonic() > deadline:
            print("NOSERVER", flush=True)
            return 1
    while scans[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    print("READY", flush=True)
    for phase in PHASES:
        if sys.stdin.readline().strip() != "GO":
            return 1
        if phase == "no_laser":
            scan_sub.unregister()
            goals = goals[::-1]
        wall0, sim0, scans0 = time.monotonic(), rospy.get_time(), scans[0]
        outcomes = []
        if phase == "idle":                       # parked, waiting for visitors: most of a demo
            goals = []
            while rospy.get_time() - sim0 < IDLE_SIM_S and time.monotonic() - wall0 < 60.0:
                time.sleep(0.05)
        for x, y, yaw in goals:
            goal = MoveBaseGoal()
            goal.target_pose.header.frame_id = "map"
            goal.target_pose.pose = pose_msg(Pose2D(x, y, yaw))
            client.send_goal(goal)
            end = time.monotonic() + 120.0
            while not client.wait_for_result(rospy.Duration(1.0)) and time.monotonic() < end:
                pass
            state = client.get_state()
            outcomes.append({3: SUCCEEDED, 4: "aborted", 2: "preempted"}.get(state, f"state {state}"))
        print(json.dumps({"phase": phase, "wall_s": time.monotonic() - wall0, "sim_s": rospy.get_time() - sim0,
                          "scans": scans[0] - scans0, "outcomes": outcomes}), flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``ros-driver GOALS`` or ``stack-driver SPEC`` (JSON)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    drivers = {"ros-driver": ros_driver, "stack-driver": stack_driver}
    if len(argv) != 2 or argv[0] not in drivers:
        print(f"usage: sim_node {{{'|'.join(drivers)}}} JSON", file=sys.stderr)
        return 2
    return drivers[argv[0]](json.loads(argv[1]))


if __name__ == "__main__":
    sys.exit(main())
