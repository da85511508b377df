"""The chaos probe: one process per master during ``gidabot chaos`` (not part of a robot's stack).

It watches what its master delivers and acts on it when the chaos runner asks:

* appends every goal, cancel, navigation event and tour seen on the shared topics to a
  JSON-lines file (``--out``): kind ``k``, this master's robot ``m``, the publisher's
  caller id ``c``, the connection it came through ``n`` (1, 2, ... in the order the probe's
  connections were made: a publisher that restarted, or a connection made again, has a new
  one), the wall time received ``w`` and the message's ids (no payloads);
* keeps the wall times at which each robot's ``/gidabot/status`` and ``/gidabot/pending``
  arrived (the runner asks for the first delivery after a fault was cleared);
* keeps this robot's latest ``amcl_pose`` and global plan (``move_base/NavfnROS/plan``,
  published by the move_base stand-in while somebody subscribes) to place obstacles;
* publishes hostile messages and ``/sim/obstacle`` commands;
* measures discovery on a restarted master with a *fresh* ``/gidabot/status``
  subscription (registered after the restart: it is found only through the restarted
  master);
* reads the ``/diagnostics`` counters of its master's nodes (rejected input, the relays' link
  losses and resent events): it keeps the latest values of every status it hears (a subscription
  made at start), so the runner can tell which node counted a hostile message it just sent.

Driven by JSON lines on stdin, one JSON reply per line on stdout (``ChaosProbeClient``
in :mod:`gidabot_sim.chaos.probe_client`). The probe keeps itself registered across master restarts
(``keep_registered``). Node name ``/chaos_probe`` (its caller id tells its own hostile
messages apart).

    {"op": "deliveries", "topic": "status", "since": T, "stamped": S}
                              -> {"first": {robot: wall time}} of the first received at or after wall time T,
                                 stamped at or after ROS time S (a message sent after a fault was cleared)
    {"op": "fresh"}                                         new /gidabot/status subscription
    {"op": "fresh_deliveries"}                              -> {"first": {robot: wall time}}
    {"op": "plan"}                                          -> {"pose": [x, y, yaw], "plan": [[x, y], ...], "age"}
    {"op": "pub", "topic": T, "type": "pkg/Type", "msg": {...}, "wait": 3.0}
    {"op": "obstacle", "action": "add"|"remove", "id": I, "x": X, "y": Y, "radius": R}
    {"op": "counters"}                                      -> {"status": {name: {key: int}} (whole numbers),
                                                                "heard": {name: wall time of its latest status}}
    {"op": "quit"}
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import threading
import time
from collections import defaultdict
from typing import Any

from gidabot_navigation.interface import Node, Topic

MAX_RECEIPTS = 20000         # per (topic, robot): far more than a run needs


def build_message(cls: type, data: dict[str, Any]) -> Any:
    """A message of ``cls`` from a dict: "nan"/"inf"/"-inf" for floats, ``["__repeat__", c, n]`` for a long
    string; nested messages as dicts; lists of floats element by element."""
    msg = cls()
    _fill(msg, data)
    return msg


def _value(v: Any) -> Any:
    if isinstance(v, str) and v in ("nan", "inf", "-inf"):
        return float(v)
    if isinstance(v, list) and len(v) == 3 and v[0] == "__repeat__":
        return str(v[1]) * int(v[2])
    if isinstance(v, list):
        return [_value(x) for x in v]
    return v


def _fill(msg: Any, data: dict[str, Any]) -> None:
    import genpy

    for key, val in data.items():
        current = getattr(msg, key)
        if isinstance(current, genpy.Message) and isinstance(val, dict):
            _fill(current, val)
        else:
            setattr(msg, key, _value(val))


class ChaosProbeNode:
    """See the module docstring. Topics: subscribes ``/gidabot/goals``, ``/gidabot/cancels``,
    ``/gidabot/nav_events``, ``/gidabot/tours``, ``/gidabot/status``, ``/gidabot/pending``, ``amcl_pose``,
    ``move_base/NavfnROS/plan``, ``/diagnostics``; publishes hostile messages on any topic
    it is asked to and ``/sim/obstacle``."""

    def __init__(self, robot: str, out_path: str) -> None:
        import rospy
        from geometry_msgs.msg import PoseWithCovarianceStamped
        from nav_msgs.msg import Path

        from gidabot_msgs.msg import Cancel, Goal, NavEvent, PendingRequests, RobotStatus, Tour

        self.rospy = rospy
        self.robot = robot
        self.lock = threading.Lock()
        self.out = open(out_path, "a", encoding="utf-8")  # noqa: SIM115 - closed in close()
        # topic -> robot -> [(wall time received, header stamp)]
        self.receipts: dict[str, dict[str, list[tuple[float, float]]]] = {"status": defaultdict(list),
                                                                             "pending": defaultdict(list)}
        self.fresh_first: dict[str, float] = {}
        self.pose: tuple[float, float, float] | None = None
        self.plan: list[tuple[float, float]] = []
        self.plan_wall = 0.0
        self.own_state = ("", "")          # this robot's latest RobotStatus: state, current goal uid
        self.pubs: dict[str, Any] = {}
        # id of a connection's header dict (rospy gives every message of a connection the same one) -> (that
        # dict, kept so that its id is never reused; the connection's number)
        self.conns: dict[int, tuple[dict[str, str], int]] = {}
        self.subs = [
            rospy.Subscriber(Topic.GOALS, Goal, self._on_goal, queue_size=500),
            rospy.Subscriber(Topic.CANCELS, Cancel, self._on_cancel, queue_size=500),
            rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._on_event, queue_size=1000),
            rospy.Subscriber(Topic.TOURS, Tour, self._on_tour, queue_size=100),
            rospy.Subscriber(Topic.PENDING, PendingRequests, self._on_state, callback_args="pending",
                             queue_size=200),
            rospy.Subscriber(Topic.AMCL_POSE, PoseWithCovarianceStamped, self._on_pose, queue_size=1),
            rospy.Subscriber(Topic.MOVE_BASE_PLAN, Path, self._on_plan, queue_size=1),
        ]
        self.status_cls = RobotStatus
        self.status_sub = rospy.Subscriber(Topic.STATUS, RobotStatus, self._on_status, queue_size=200)
        from diagnostic_msgs.msg import DiagnosticArray

        self.counters: dict[str, dict[str, int]] = {}     # status name -> its counters (whole numbers)
        self.heard: dict[str, float] = {}                  # status name -> wall time of its latest status
        self.diag_sub = rospy.Subscriber(Topic.DIAGNOSTICS, DiagnosticArray, self._on_diag, queue_size=100)
        # publishers of every hostile message, made now: when one is sent, every subscriber (the relays
        # too, which carry it to the other robots) is connected already
        from gidabot_sim.chaos.hostile import HOSTILE_MESSAGES

        for h in HOSTILE_MESSAGES:
            self._publisher(h.topic, h.type)
        self._publisher(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle")

    # -- recording --------------------------------------------------------------------------
    def _write(self, kind: str, msg: Any, **data: Any) -> None:
        header = getattr(msg, "_connection_header", None)
        conn = 0
        if isinstance(header, dict):
            with self.lock:
                known = self.conns.get(id(header))
                if known is None or known[0] is not header:
                    known = self.conns[id(header)] = (header, len(self.conns) + 1)
            conn = known[1]
        else:
            header = {}
        rec = {"k": kind, "m": self.robot, "c": header.get("callerid", ""), "n": conn, "w": time.time(), **data}
        line = json.dumps(rec, allow_nan=True)
        with self.lock:
            if not self.out.closed:
                self.out.write(line + "\n")
                self.out.flush()

    @staticmethod
    def _clip(text: Any, n: int = 160) -> str:
        return text[:n] if isinstance(text, str) else ""

    def _on_goal(self, m: Any) -> None:
        self._write("goal", m, uid=self._clip(m.uid), origin=self._clip(m.origin_robot, 64),
                    initial_floor=_num(m.initial_floor), goal_floor=_num(m.goal_floor),
                    goal_id=self._clip(m.goal_id, 64), connector=self._clip(m.connector, 64),
                    tour_file=self._clip(m.tour_file, 64), tour_step=int(m.tour_step), attempt=int(m.attempt),
                    start_robot=self._clip(m.start_robot, 64), start_state=int(m.start_state),
                    goal_robot=self._clip(m.goal_robot, 64), goal_state=int(m.goal_state))

    def _on_cancel(self, m: Any) -> None:
        self._write("cancel", m, uid=self._clip(m.uid), goal_uid=self._clip(m.goal_uid),
                    origin=self._clip(m.origin_robot, 64), reason=self._clip(m.reason, 32))

    def _on_event(self, m: Any) -> None:
        self._write("event", m, uid=self._clip(m.uid), robot=self._clip(m.robot, 64), goal_uid=self._clip(m.goal_uid),
                    phase=int(m.phase), s=_num(m.header.stamp.to_sec()), tour_file=self._clip(m.tour_file, 64),
                    tour_step=int(m.tour_step), leg=self._clip(m.leg, 8), attempt=int(m.attempt),
                    assignee=self._clip(m.assignee, 64),
                    location_id=self._clip(m.location_id, 64), detail=self._clip(m.detail, 200))

    def _on_tour(self, m: Any) -> None:
        self._write("tour", m, uid=self._clip(m.uid), file_name=self._clip(m.file_name, 80),
                    origin=self._clip(m.origin_robot, 64), deleted=bool(m.deleted))

    def _on_state(self, m: Any, topic: str) -> None:
        now = time.time()
        robot = self._clip(m.robot, 64)
        stamp = m.header.stamp.to_sec()
        with self.lock:
            times = self.receipts[topic][robot]
            times.append((now, stamp))
            if len(times) > MAX_RECEIPTS:
                del times[: len(times) // 2]

    def _on_status(self, m: Any) -> None:
        self._on_state(m, "status")
        now = time.time()
        with self.lock:
            self.fresh_first.setdefault(self._clip(m.robot, 64), now)
            if m.robot == self.robot:
                self.own_state = (self._clip(m.state, 32), self._clip(m.current_goal_uid))

    def _on_diag(self, arr: Any) -> None:
        now = time.time()
        for st in arr.status:
            values = {}
            for kv in st.values:
                if kv.value.isdigit():
                    values[kv.key] = int(kv.value)
            with self.lock:
                self.counters[st.name] = values
                self.heard[st.name] = now

    def _on_pose(self, m: Any) -> None:
        from gidabot_navigation.building.geometry import quaternion_to_yaw

        p = m.pose.pose
        q = p.orientation
        self.pose = (p.position.x, p.position.y, quaternion_to_yaw(q.x, q.y, q.z, q.w))

    def _on_plan(self, m: Any) -> None:
        points = [(ps.pose.position.x, ps.pose.position.y) for ps in m.poses]
        step = max(1, len(points) // 400)
        sampled = points[::step] + (points[-1:] if points and (len(points) - 1) % step else [])
        with self.lock:
            self.plan, self.plan_wall = sampled, time.time()

    # -- commands ---------------------------------------------------------------------------
    def handle(self, cmd: dict[str, Any]) -> dict[str, Any]:
        op = cmd.get("op")
        if op == "deliveries":
            since = float(cmd.get("since", 0.0))
            stamped = float(cmd.get("stamped", -math.inf))   # only messages stamped at or after this (ROS time)
            with self.lock:
                first = {r: next((t for t, st in ts if t >= since and st >= stamped), None)
                         for r, ts in self.receipts[cmd["topic"]].items()}
            return {"ok": True, "first": {r: t for r, t in first.items() if t is not None}}
        if op == "fresh":
            # rospy shares one subscription per topic and process: drop it (its connections close and it
            # is unregistered), then subscribe again, which registers with the master as it is now
            self.status_sub.unregister()
            with self.lock:
                self.fresh_first = {}
            self.status_sub = self.rospy.Subscriber(Topic.STATUS, self.status_cls, self._on_status,
                                                    queue_size=200)
            return {"ok": True}
        if op == "fresh_deliveries":
            with self.lock:
                return {"ok": True, "first": dict(self.fresh_first)}
        if op == "plan":
            with self.lock:
                plan, age, (state, goal) = list(self.plan), time.time() - self.plan_wall, self.own_state
            return {"ok": True, "pose": list(self.pose) if self.pose else None, "plan": plan, "age": age,
                    "state": state, "goal_uid": goal}
        if op == "pub":
            self.publish(cmd["topic"], cmd["type"], cmd.get("msg", {}), float(cmd.get("wait", 3.0)))
            return {"ok": True}
        if op == "obstacle":
            add = cmd.get("action") == "add"
            msg = {"id": cmd["id"], "action": 0 if add else 1, "shape": 0, "x": cmd.get("x", 0.0),
                   "y": cmd.get("y", 0.0), "radius": cmd.get("radius", 0.3)}
            msg["header"] = {"frame_id": "map"}
            self.publish(Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle", msg, 3.0)
            return {"ok": True}
        if op == "counters":
            with self.lock:
                return {"ok": True, "status": {k: dict(v) for k, v in self.counters.items()},
                        "heard": dict(self.heard)}
        raise ValueError(f"unknown op {op!r}")

    def _publisher(self, topic: str, type_: str) -> tuple[Any, type]:
        import roslib.message

        cls = roslib.message.get_message_class(type_)
        if cls is None:
            raise ValueError(f"unknown message type {type_}")
        key = f"{topic} {type_}"
        if key not in self.pubs:
            self.pubs[key] = self.rospy.Publisher(topic, cls, queue_size=10)
        return self.pubs[key], cls

    def _subscribers(self, topic: str) -> int:
        """How many nodes the master lists as subscribers of ``topic`` (0 if it does not answer)."""
        import rosgraph

        try:
            _, subs, _ = rosgraph.Master(self.rospy.get_name()).getSystemState()
        except Exception:  # noqa: BLE001 - rosgraph raises several types; a master away means "unknown"
            return 0
        name = self.rospy.resolve_name(topic)
        return next((len(nodes) for t, nodes in subs if t == name), 0)

    def publish(self, topic: str, type_: str, data: dict[str, Any], wait: float) -> None:
        pub, cls = self._publisher(topic, type_)
        want = max(1, self._subscribers(topic))
        deadline = time.monotonic() + wait
        while pub.get_num_connections() < want and time.monotonic() < deadline:
            time.sleep(0.02)
        header = data.pop("header", None)
        msg = build_message(cls, data)
        if getattr(msg, "_has_header", False):
            msg.header.stamp = self.rospy.Time.now()
            if isinstance(header, dict):
                msg.header.frame_id = str(header.get("frame_id", ""))
        pub.publish(msg)

    def close(self) -> None:
        with self.lock:
            self.out.close()


def _num(v: Any) -> float | str:
    """JSON-safe float (a hostile NaN floor is written as a string)."""
    return float(v) if isinstance(v, (int, float)) and math.isfinite(v) else str(v)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog=Node.CHAOS_PROBE)
    ap.add_argument("--robot", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args([a for a in (sys.argv[1:] if argv is None else argv) if ":=" not in a])
    # replies own the real stdout; everything else (rospy's log lines) goes to stderr
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    import rospy

    from gidabot_navigation.ros.exit_guard import rospy_exit_guard
    from gidabot_navigation.ros.master_watch import keep_registered

    rospy_exit_guard(Node.CHAOS_PROBE)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not
    rospy.init_node(Node.CHAOS_PROBE, disable_signals=True, disable_rostime=True)
    keep_registered()
    node = ChaosProbeNode(args.robot, args.out)
    replies.write(json.dumps({"ok": True, "ready": True}) + "\n")
    for line in sys.stdin:
        if not line.strip():
            continue
        try:
            cmd = json.loads(line)
            if cmd.get("op") == "quit":
                replies.write(json.dumps({"ok": True}) + "\n")
                break
            reply = node.handle(cmd)
        except (KeyError, ValueError, TypeError, AttributeError, rospy.ROSException) as err:
            reply = {"ok": False, "error": f"{type(err).__name__}: {err}"}
        except Exception as err:  # noqa: BLE001 - a genpy/serialisation error of a hostile message: report it
            reply = {"ok": False, "error": f"{type(err).__name__}: {err}"}
        replies.write(json.dumps(reply) + "\n")
    node.close()
    rospy.signal_shutdown("chaos probe done")
    return 0
