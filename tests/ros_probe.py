#!/usr/bin/env python3
"""A ROS probe process for system tests: publishes and records messages on one master.

Driven by JSON lines on stdin, one JSON reply line on stdout per command (see
:class:`probe.Probe` for the Python side). Commands::

    {"op": "sub", "topic": T, "type": "pkg/Type"}          subscribe and record every message
    {"op": "pub", "topic": T, "type": "pkg/Type", "msg": {...}, "subs": 1, "latch": false}
                                                          publish once at least `subs` subscribers are connected
    {"op": "msgs", "topic": T, "since": 0}                 messages recorded on T (as dicts) from index `since`
    {"op": "status"}                                       master watch: master_up, generation (re-registrations)
    {"op": "quit"}

Messages are converted to and from plain dicts (times as float seconds). The probe keeps
itself registered across master restarts (gidabot_navigation.ros.master_watch.keep_registered).
"""

from __future__ import annotations

import json
import os
import sys
import threading
import time

import genpy
import roslib.message
import rospy

from gidabot_navigation.ros.master_watch import keep_registered


def to_dict(value: object) -> object:
    if isinstance(value, genpy.Message):
        return {slot: to_dict(getattr(value, slot)) for slot in value.__slots__}
    if isinstance(value, (genpy.Time, genpy.Duration)):
        return value.to_sec()
    if isinstance(value, (list, tuple)):
        return [to_dict(v) for v in value]
    if isinstance(value, bytes):
        return list(value)
    if isinstance(value, float) and value != value:
        return "nan"
    return value


def fill(msg: genpy.Message, data: dict) -> genpy.Message:
    for key, val in data.items():
        if key == "header":
            continue
        if val == "nan":
            val = float("nan")
        current = getattr(msg, key)
        if isinstance(current, genpy.Message) and isinstance(val, dict):
            fill(current, val)
        else:
            setattr(msg, key, val)
    return msg


def main() -> int:
    # replies own the real stdout; everything else printed (rospy's log lines) goes to stderr
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    rospy.init_node("tour_probe", anonymous=True, disable_signals=True)
    watch = keep_registered()
    lock = threading.Lock()
    recorded: dict[str, list] = {}
    subs: dict[str, rospy.Subscriber] = {}
    pubs: dict[str, rospy.Publisher] = {}

    def record(msg: genpy.Message, topic: str) -> None:
        with lock:
            recorded[topic].append(to_dict(msg))

    def reply(obj: dict) -> None:
        replies.write(json.dumps(obj) + "\n")
        replies.flush()

    for line in sys.stdin:
        if not line.strip():
            continue
        cmd = json.loads(line)
        op = cmd.get("op")
        try:
            if op == "sub":
                topic = cmd["topic"]
                if topic not in subs:
                    recorded[topic] = []
                    cls = roslib.message.get_message_class(cmd["type"])
                    subs[topic] = rospy.Subscriber(topic, cls, record, callback_args=topic, queue_size=1000)
                reply({"ok": True})
            elif op == "pub":
                topic = cmd["topic"]
                cls = roslib.message.get_message_class(cmd["type"])
                if topic not in pubs:
                    pubs[topic] = rospy.Publisher(topic, cls, queue_size=1000, latch=bool(cmd.get("latch")))
                deadline = time.monotonic() + float(cmd.get("timeout", 15.0))
                while pubs[topic].get_num_connections() < int(cmd.get("subs", 1)):
                    if time.monotonic() > deadline:
                        raise TimeoutError(f"no subscriber on {topic}")
                    time.sleep(0.02)
                msg = fill(cls(), cmd.get("msg", {}))
                if getattr(msg, "_has_header", False):
                    msg.header.stamp = rospy.Time.now()
                pubs[topic].publish(msg)
                reply({"ok": True})
            elif op == "msgs":
                with lock:
                    got = recorded.get(cmd["topic"], [])[int(cmd.get("since", 0)):]
                reply({"ok": True, "msgs": got})
            elif op == "status":
                reply({"ok": True, "master_up": watch.up, "generation": watch.generation})
            elif op == "quit":
                reply({"ok": True})
                break
            else:
                reply({"ok": False, "error": f"unknown op {op!r}"})
        except (KeyError, ValueError, TypeError, TimeoutError, AttributeError, rospy.ROSException) as err:
            reply({"ok": False, "error": f"{type(err).__name__}: {err}"})
    rospy.signal_shutdown("probe done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
