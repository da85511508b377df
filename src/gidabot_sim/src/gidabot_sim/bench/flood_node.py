"""The worker of ``gidabot bench flood``: the visitor at one robot's screen, and the flood on its master (a rospy
node).

Run by the benchmark as ``python -m gidabot_sim.bench.flood_node --building B --robot R --rate HZ`` (a
:class:`~gidabot_sim.bench.workers.Worker`): timed requests, each cancelled once answered, with or without
``--rate`` invalid messages per second published on the master meanwhile.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import select
import sys
import threading
import time
from collections.abc import Sequence

from gidabot_navigation.building.model import load_building

FLOOD_ONLY_S = 4.0     # s of flood without requests, in which the goal manager's state writes are counted
SETTLE_S = 2.5         # s without a state write (1 s soft interval, 1 Hz diagnostics) before the flood starts


def main(argv: Sequence[str] | None = None) -> int:
    """``flood_node --building B --robot R --rate HZ``; stdin/stdout line protocol: prints
    ``{"event": "ready"}`` once the goal manager listens; ``requests N [flood]`` makes N timed requests
    (flood: after the flood ran alone for a while) and prints ``{"event": "done", "ms": [...], "rate": hz,
    "writes": n}`` (n: the goal manager's state writes while the flood ran alone); ``quit``."""
    import genpy
    import rospy
    from diagnostic_msgs.msg import DiagnosticArray

    from gidabot_msgs.msg import Cancel, Goal, NavEvent, RobotStatus, Tour, VisitorCommand
    from gidabot_navigation.interface import Cmd, Node, Phase, RobotState, Topic, global_name

    ap = argparse.ArgumentParser(prog="flood_node")
    ap.add_argument("--building", required=True)
    ap.add_argument("--robot", required=True)
    ap.add_argument("--rate", type=float, default=1000.0)
    args = ap.parse_args(sys.argv[1:] if argv is None else list(argv))
    out = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())          # rospy's log lines stay off the protocol
    building = load_building(args.building)
    me = building.robot(args.robot)
    places = [loc.id for loc in building.locations if loc.floor == me.floor][:6]
    if len(places) < 2:
        raise SystemExit(f"bench_flood worker: floor {me.floor:g} of {args.robot} has fewer than 2 places")
    rospy.init_node(f"bench_flood_{args.robot}", disable_signals=True, disable_rostime=True)

    answered = threading.Event()
    answer: dict[str, str] = {}
    saves = [-1]

    def on_event(m: NavEvent) -> None:
        sender = (m._connection_header or {}).get("callerid", "")
        if m.robot == args.robot and m.phase == Phase.ACCEPTED and sender == global_name(Node.GOAL_MANAGER) and \
                m.location_id == answer.get("want"):
            answer["goal_uid"] = m.goal_uid
            answered.set()

    def on_diag(m: DiagnosticArray) -> None:
        for st in m.status:
            if st.name == f"guiding: goal_manager {args.robot}":
                saves[0] = int(next((kv.value for kv in st.values if kv.key == "state_saves"), -1))

    rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, on_event, queue_size=None, tcp_nodelay=True)
    rospy.Subscriber(Topic.DIAGNOSTICS, DiagnosticArray, on_diag, queue_size=10)
    command = rospy.Publisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=10)
    hostile = {Topic.GOALS: Goal, Topic.CANCELS: Cancel, Topic.NAV_EVENTS: NavEvent,
               Topic.STATUS: RobotStatus, Topic.TOURS: Tour}
    pubs = {topic: rospy.Publisher(topic, cls, queue_size=10000) for topic, cls in hostile.items()}

    def invalid(k: int) -> tuple[str, genpy.Message]:
        """The k-th hostile message: a new uid every time (nothing is dropped as a duplicate)."""
        kind = k % 8
        if kind < 3:
            g = Goal(uid=f"Mallory/x/{k}", origin_robot="Mallory" if kind == 0 else args.robot,
                     goal_id="nowhere" if kind == 1 else places[0], initial_floor=me.floor,
                     goal_floor=math.nan if kind == 2 else me.floor, language="en")
            g.goal_pose.orientation.w = 1.0
            return Topic.GOALS, g
        if kind == 3:
            return Topic.CANCELS, Cancel(uid=f"Mallory/cancel/{k}", goal_uid=f"{args.robot}/v/{k}",
                                              origin_robot="Mallory", reason="visitor")
        if kind == 4:
            return Topic.NAV_EVENTS, NavEvent(uid=f"Mallory/event/{k}", robot="Mallory", phase=Phase.UNREACHABLE,
                                                   goal_uid=f"{args.robot}/v/{k}")
        if kind == 5:
            return Topic.NAV_EVENTS, NavEvent(uid=f"Mallory/event/{k}", robot=args.robot, phase=250,
                                                   goal_uid=f"{args.robot}/v/{k}")
        if kind == 6:
            s = RobotStatus(robot="Mallory", floor=math.nan, state=RobotState.GUIDING)
            s.nav_pose.position.x = math.nan
            return Topic.STATUS, s
        return Topic.TOURS, Tour(uid=f"Mallory/tour/{k}", file_name=f"../../escape{k}.tour",
                                      editor_robot=args.robot, version=1, language="en",
                                      tour_goals_info=[f"{me.floor:g}, {places[0]}, x"])

    flooding = threading.Event()
    sent = [0]

    def flood() -> None:
        step = 0.01                                   # publish in 10 ms batches
        per_step = args.rate * step
        due = time.monotonic()
        owed = 0.0
        while flooding.is_set():
            owed += per_step
            while owed >= 1.0:
                topic, msg = invalid(sent[0])
                pubs[topic].publish(msg)
                sent[0] += 1
                owed -= 1.0
            due += step
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            else:
                due = time.monotonic()

    def request(place: str, n: int) -> float:
        answered.clear()
        answer.clear()
        answer["want"] = place
        cmd = VisitorCommand(uid=f"{args.robot}/bench/cmd/{n}", visitor_id="bench", command=Cmd.REQUEST,
                             goal_id=place, way="stairs", language="en")
        cmd.header.stamp = rospy.Time.now()
        t0 = time.monotonic()
        command.publish(cmd)
        if not answered.wait(10.0):
            return math.inf
        took = time.monotonic() - t0
        cancel = VisitorCommand(uid=f"{args.robot}/bench/cmd/{n}c", visitor_id="bench", command=Cmd.CANCEL,
                                goal_uid=answer.get("goal_uid", ""), language="en")
        cancel.header.stamp = rospy.Time.now()
        command.publish(cancel)
        return took

    def settled_saves() -> int:
        """The goal manager's state writes once the count has not changed over SETTLE_S (its writes of the last
        request, within its 1 s soft interval, are done); -1 if /diagnostics never told it."""
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:
            seen = saves[0]
            time.sleep(SETTLE_S)
            if seen >= 0 and saves[0] == seen:
                return seen
        return -1

    deadline = time.monotonic() + 120
    while command.get_num_connections() < 1 or any(p.get_num_connections() < 1 for p in pubs.values()):
        if time.monotonic() > deadline:
            out.write(json.dumps({"event": "error", "error": "the robot's nodes did not subscribe"}) + "\n")
            return 1
        time.sleep(0.05)
    n = 0
    while request(places[0], n) == math.inf:         # warm up: the goal manager plans its first leg
        n += 1
        if n == 5:
            out.write(json.dumps({"event": "error", "error": f"{args.robot} accepts no request to {places[0]}"})
                      + "\n")
            return 1
    out.write(json.dumps({"event": "ready"}) + "\n")
    while True:
        ready, _, _ = select.select([sys.stdin], [], [], 0.5)
        if not ready:
            continue
        line = sys.stdin.readline().split()
        if not line or line[0] == "quit":
            break
        if line[0] != "requests":
            continue
        count, flooded = int(line[1]), "flood" in line[2:]
        writes = 0
        if flooded:
            before = settled_saves()   # the last request's writes done: what is written now is the flood's
            flooding.set()
            threading.Thread(target=flood, daemon=True).start()
            time.sleep(FLOOD_ONLY_S)   # the flood alone; /diagnostics (1 Hz) then reports at least 3 s of it
            writes = saves[0] - before if before >= 0 else -1
        sent_before, t_begin = sent[0], time.monotonic()
        times = []
        for k in range(count):
            n += 1
            times.append(request(places[1 + k % (len(places) - 1)], n))
            time.sleep(0.2)
        flooding.clear()
        elapsed = time.monotonic() - t_begin
        out.write(json.dumps({"event": "done", "ms": [t * 1000.0 for t in times],
                              "rate": (sent[0] - sent_before) / elapsed if flooded else 0.0,
                              "writes": writes}) + "\n")
    rospy.signal_shutdown("bench done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
