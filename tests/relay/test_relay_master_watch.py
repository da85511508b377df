"""keep_registered() against a real master that is killed and restarted on the same port."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
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
        pub.pub(TOPIC, TYPE, {"data": "before"}, to=[sub1.name])
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

        pub.pub(TOPIC, TYPE, {"data": "after"}, to=[sub1.name])   # the existing connection still works
        sub1.wait(TOPIC, lambda m: m["data"] == "after", 10, "message after the restart")

        with Probe(env, tmp_path / "sub2.log") as sub2:        # a node that appears after the restart
            sub2.sub(TOPIC, TYPE)
            pub.pub(TOPIC, TYPE, {"data": "new"}, to=[sub1.name, sub2.name])   # sub2 connected too
            sub2.wait(TOPIC, lambda m: m["data"] == "new", 10, "the new subscriber got the message")
            sub1.wait(TOPIC, lambda m: m["data"] == "new", 10, "the old subscriber got it too")


FROZEN_MASTER_NODE = r'''
import sys, time, rospy
from gidabot_navigation.ros.master_watch import keep_registered
rospy.init_node("frozen_master_test", disable_signals=True, disable_rostime=True)
if sys.argv[1] == "bounded":
    keep_registered()
print("ready", flush=True)
sys.stdin.readline()                         # the master is frozen now
t = time.monotonic()
rospy.logwarn("master is not answering")     # rospy's /rosout handler asked the master, without a timeout
print(f"log {time.monotonic() - t:.3f}", flush=True)
t = time.monotonic()
try:
    rospy.get_param("/anything")
except Exception as err:
    print(f"param error {type(err).__name__}", flush=True)
print(f"param_s {time.monotonic() - t:.3f}", flush=True)
'''


def _frozen_master_run(procs, tmp_path, mode: str, timeout: float) -> list[str]:
    ip = robot_address(0)
    uri = start_master(procs, f"master_{mode}", ip)
    env = ros_env(uri, ip, log_dir=tmp_path / "ros")
    node = subprocess.Popen([sys.executable, "-c", FROZEN_MASTER_NODE, mode], env=env, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, start_new_session=True)
    master = procs.get(f"master_{mode}").popen
    try:
        assert node.stdout.readline().strip() == "ready"
        os.kill(master.pid, signal.SIGSTOP)
        node.stdin.write("go\n")
        node.stdin.flush()
        try:
            out, _ = node.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            return ["blocked"]
        return out.split("\n")
    finally:
        os.kill(master.pid, signal.SIGCONT)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(node.pid, signal.SIGKILL)
        node.wait(timeout=10)


def test_log_calls_and_parameter_reads_do_not_block_on_a_frozen_master(procs, tmp_path) -> None:
    plain = _frozen_master_run(procs, tmp_path, "plain", timeout=2.0)
    assert plain == ["blocked"], plain                 # rospy alone: its first log line waits for the master
    lines = _frozen_master_run(procs, tmp_path, "bounded", timeout=20.0)
    log_s = float(next(line.split()[1] for line in lines if line.startswith("log ")))
    param_s = float(next(line.split()[1] for line in lines if line.startswith("param_s ")))
    assert log_s < 0.5, lines                          # logging never calls the master
    assert any(line.startswith("param error") for line in lines) and param_s < 7.0, lines   # bounded (5 s)
