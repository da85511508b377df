"""keep_registered() against a real master that is killed and restarted on the same port."""

from __future__ import annotations

import xmlrpc.client

import pytest
from probe import Probe

from gidabot_sim.runner.procs import master_pid, robot_address, ros_env, start_master, wait_until

pytestmark = pytest.mark.system

TOPIC = "/watch_test/chatter"
TYPE = "std_msgs/String"


def _publishers(uri: str, topic: str) -> list[str]:
    _, _, state = xmlrpc.client.ServerProxy(uri).getSystemState("/test")
    return next((nodes for name, nodes in state[0] if name == topic), [])


def test_nodes_keep_talking_and_new_subscribers_connect_after_master_restart(procs, tmp_path) -> None:
    ip = robot_address(0)
    uri = start_master(procs, "master", ip)
    env = ros_env(uri, ip, log_dir=tmp_path / "ros")
    with Probe(env, tmp_path / "pub.log") as pub, Probe(env, tmp_path / "sub1.log") as sub1:
        sub1.sub(TOPIC, TYPE)
        pub.pub(TOPIC, TYPE, {"data": "before"})
        sub1.wait(TOPIC, lambda m: m["data"] == "before", 10, "message before the restart")
        old_pid = master_pid(uri)

        master = procs.get("master")
        master.popen.kill()                                   # SIGKILL: the master just vanishes
        master.popen.wait(timeout=10)
        procs.start("master", master.argv, master.env)        # same address and port
        wait_until(lambda: master_pid(uri) not in (None, old_pid), 15, "the master restarted")
        for p in (pub, sub1):
            wait_until(lambda p=p: p.call(op="status")["generation"] >= 1, 5, "probe re-registered")
        assert len(_publishers(uri, TOPIC)) == 1               # the new master knows the publisher again

        pub.pub(TOPIC, TYPE, {"data": "after"})                # the existing connection still works
        sub1.wait(TOPIC, lambda m: m["data"] == "after", 10, "message after the restart")

        with Probe(env, tmp_path / "sub2.log") as sub2:        # a node that appears after the restart
            sub2.sub(TOPIC, TYPE)
            pub.pub(TOPIC, TYPE, {"data": "new"}, subs=2)      # waits until sub2 is connected too
            sub2.wait(TOPIC, lambda m: m["data"] == "new", 10, "the new subscriber got the message")
            sub1.wait(TOPIC, lambda m: m["data"] == "new", 10, "the old subscriber got it too")
