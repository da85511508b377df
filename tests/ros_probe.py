#!/usr/bin/env python3
"""A ROS probe process for system tests: publishes and records messages on one master.

Driven by JSON lines on stdin, one JSON reply line on stdout per command (see
:class:`probe.Probe` for the Python side). Commands::

    {"op": "sub", "topic": T, "type": "pkg/Type"}          subscribe and record every message
    {"op": "pub", "topic": T, "type": "pkg/Type", "msg": {...}, "to": ["/node", ...], "latch": false,
     "timeout": 60, "raw": null}                          publish once every node of `to` is connected (and
                                                          this probe, when it records T); `raw`: a list of
                                                          bytes published as the message instead
    {"op": "name"}                                         this probe's node name
    {"op": "msgs", "topic": T, "since": 0}                 messages recorded on T (as dicts) from index `since`
    {"op": "status"}                                       master watch: master_up, generation (re-registrations)
    {"op": "quit"}

Messages are converted to and from plain dicts (times as float seconds). The probe keeps
itself registered across master restarts (gidabot_navigation.ros.master_watch.keep_registered).
Argument: ``--name NODE`` to run as node NODE instead of an anonymous probe.
"""

from __future__ import annotations

import json
import os
import sys
import threading

import genpy
import roslib.message
import rospy
from probe import wait_subscribers

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
    args = rospy.myargv(sys.argv)[1:]
    name = args[args.index("--name") + 1] if "--name" in args else ""
    rospy.init_node(name or "tour_probe", anonymous=not name, disable_signals=True)
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
                raw = cmd.get("raw")
                if topic not in pubs:
                    if raw is not None:
                        from gidabot_navigation.relay.end_node import raw_class  # the relay's raw messages
                        cls = raw_class(cls)
                    pubs[topic] = rospy.Publisher(topic, cls, queue_size=1000, latch=bool(cmd.get("latch")))
                want = set(cmd.get("to") or [])
                if topic in subs:
                    want.add(rospy.get_name())
                if not want:
                    raise ValueError(f"publish on {topic} to whom? name the subscribers that must get it (to)")
                pub = pubs[topic]
                wait_subscribers(lambda pub=pub: {c.endpoint_id for c in pub.impl.connections}, want,
                                 float(cmd.get("timeout", 60.0)), f"publishing on {topic}")
                if raw is not None:
                    msg = pub.data_class()
                    msg._buff = bytes(raw)
                else:
                    msg = fill(cls(), cmd.get("msg", {}))
                    if getattr(msg, "_has_header", False):
                        msg.header.stamp = rospy.Time.now()
                pub.publish(msg)
                reply({"ok": True})
            elif op == "name":
                reply({"ok": True, "name": rospy.get_name()})
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
