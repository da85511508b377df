"""The worker of ``gidabot bench relay``: one rospy node on one robot's master that publishes and/or records goals.

Run by the benchmark as ``python -m gidabot_sim.bench.relay_node --robot R --role pub|sub|both ...`` (a
:class:`~gidabot_sim.bench.workers.Worker`).
"""

from __future__ import annotations

import argparse
import json
import os
import select
import sys
import time
from collections.abc import Sequence

from gidabot_navigation.interface import Topic


def main(argv: Sequence[str] | None = None) -> int:
    """``relay_node --robot R --role pub|sub|both --expect A,B --rate HZ --count N``.

    Line protocol on stdin/stdout: prints ``{"event": "warm_ok"}`` once a warm-up message of
    every expected origin arrived (pub: at once); on ``go`` publishes ``count`` goals at
    ``rate`` and prints ``{"event": "sent"}``; on ``report`` prints every receipt; ``quit``.
    """
    import genpy
    import rospy

    from gidabot_msgs.msg import Goal

    ap = argparse.ArgumentParser(prog="relay_node")
    ap.add_argument("--robot", required=True)
    ap.add_argument("--role", choices=("pub", "sub", "both"), required=True)
    ap.add_argument("--expect", default="")
    ap.add_argument("--subs", type=int, default=1)
    ap.add_argument("--rate", type=float, default=100.0)
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--phase", type=float, default=0.0, help="s to wait after 'go' (spreads the robots' sends)")
    args = ap.parse_args(sys.argv[1:] if argv is None else list(argv))
    out = os.fdopen(os.dup(sys.stdout.fileno()), "w", buffering=1)
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())          # rospy's log lines stay off the protocol
    rospy.init_node(f"bench_{args.role}_{args.robot}", disable_signals=True)
    expect = {e for e in args.expect.split(",") if e}
    warm_from: set[str] = set()
    recv: dict[str, list[tuple[int, float]]] = {}

    def on_goal(msg: Goal) -> None:
        now = time.time()
        origin, _, k = msg.uid.rpartition("/")
        if origin.startswith("warm:"):
            warm_from.add(origin[5:])
            return
        recv.setdefault(origin, []).append((int(k), (now - msg.header.stamp.to_sec()) * 1000.0))

    if args.role in ("sub", "both"):
        rospy.Subscriber(Topic.GOALS, Goal, on_goal, queue_size=None, tcp_nodelay=True)
    pub = rospy.Publisher(Topic.GOALS, Goal, queue_size=1000) if args.role in ("pub", "both") else None

    def send(uid: str) -> None:
        g = Goal()
        g.uid, g.origin_robot, g.goal_id, g.tour_step = uid, args.robot, "bench", -1
        g.header.stamp = genpy.Time.from_sec(time.time())
        assert pub is not None
        pub.publish(g)

    if pub is not None:
        deadline = time.monotonic() + 120
        while pub.get_num_connections() < args.subs and time.monotonic() < deadline:
            time.sleep(0.05)
    warm_ok = False
    next_warm = 0.0
    while True:
        if not warm_ok and warm_from >= expect:
            warm_ok = True
            out.write(json.dumps({"event": "warm_ok"}) + "\n")
        if pub is not None and time.monotonic() >= next_warm:
            next_warm = time.monotonic() + 0.3
            send(f"warm:{args.robot}/0")
        ready, _, _ = select.select([sys.stdin], [], [], 0.05)
        if not ready:
            continue
        line = sys.stdin.readline()
        if not line or line.strip() == "quit":
            break
        cmd = line.strip()
        if cmd == "go" and pub is not None:
            period = 1.0 / args.rate
            start = time.monotonic() + args.phase
            for k in range(args.count):
                delay = start + k * period - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                send(f"{args.robot}/{k}")
            out.write(json.dumps({"event": "sent"}) + "\n")
            next_warm = float("inf")
        elif cmd == "go":
            next_warm = float("inf")
        elif cmd == "report":
            out.write(json.dumps({"event": "report", "recv": recv}) + "\n")
    rospy.signal_shutdown("bench done")
    return 0


if __name__ == "__main__":
    sys.exit(main())
