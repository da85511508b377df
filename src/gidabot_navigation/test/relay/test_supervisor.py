"""Relay supervisor without a master: the plan from the building, options, backoff, child handling."""

from __future__ import annotations

import sys
import time

from gidabot_navigation.interface import relay_end_name
from gidabot_navigation.relay.end import PARENT_ENV
from gidabot_navigation.relay.supervisor import (
    Backoff,
    EndOptions,
    EndSpec,
    RelaySupervisor,
    end_argv,
    end_env,
    plan_relays,
)


def test_every_robot_runs_one_end_per_other_robot_on_its_own_master(faculty) -> None:
    names = [r.name for r in faculty.robots]
    plans = {r: plan_relays(faculty, r) for r in names}
    assert [len(plans[r]) for r in names] == [3, 3, 3, 3]             # n - 1 ends per robot
    for r in names:
        me = faculty.robot(r)
        assert all(e.master_uri == me.master_uri and e.ros_ip == me.ip for e in plans[r])   # only its own master
    pairs = {e.pair for ends in plans.values() for e in ends}
    assert len(pairs) == len(names) * (len(names) - 1) // 2        # n(n-1)/2 relays, one end on each robot
    assert sorted(e.key for ends in plans.values() for e in ends) == sorted(f"{x}.{s}" for x in pairs for s in "ab")


def test_the_later_robot_listens_on_its_address_and_the_earlier_connects(faculty) -> None:
    t, k, m = (faculty.robot(n) for n in ("Tartalo", "Kbot", "MariSorgin"))
    a = next(e for e in plan_relays(faculty, "Kbot") if e.pair == "Kbot_MariSorgin")
    b = next(e for e in plan_relays(faculty, "MariSorgin") if e.pair == "Kbot_MariSorgin")
    assert (a.side, a.link_host, a.link_port, a.bind_ip) == ("a", m.ip, m.relay_port + 1, k.ip)
    assert (b.side, b.link_host, b.link_port, b.ros_ip) == ("b", m.ip, m.relay_port + 1, m.ip)
    assert a.node_name == b.node_name == relay_end_name("Kbot", "MariSorgin")
    tk = next(e for e in plan_relays(faculty, "Kbot") if e.pair == "Tartalo_Kbot")
    assert (tk.side, tk.link_host, tk.link_port) == ("b", k.ip, k.relay_port)       # Tartalo is robot 0
    assert {e.side for e in plan_relays(faculty, "Tartalo")} == {"a"} and t.ip not in \
        {e.link_host for e in plan_relays(faculty, "Tartalo")}


def test_end_command_line_and_environment() -> None:
    spec = EndSpec("A", "B", "b", "http://10.0.0.2:11311/", "10.0.0.2", "10.0.0.2", 4000, "10.0.0.1")
    argv = end_argv(spec, EndOptions(state_dir="/var/lib/r", secret_file="/etc/gidabot/relay.secret",
                                     extra=(("max_queue", "50"),)))
    assert argv[1:3] == ["-m", "gidabot_navigation.relay.end_node"]     # found as a module: no file to look up
    assert "--secret_file" in argv and "/etc/gidabot/relay.secret" in argv
    assert not any(":=" in a for a in argv)        # no _param:= (rospy would upload it to a maybe-dead master)
    assert argv[argv.index("--max_queue") + 1] == "50"
    env = end_env(spec, {"ROS_HOSTNAME": "robot.local", "ROS_MASTER_URI": "http://x:1/", "PATH": "/bin"}, 1234)
    assert env["ROS_MASTER_URI"] == spec.master_uri and env["ROS_IP"] == "10.0.0.2"
    assert "ROS_HOSTNAME" not in env and env[PARENT_ENV] == "1234" and env["PATH"] == "/bin"


def test_backoff_doubles_to_a_ceiling_and_resets_after_a_stable_run() -> None:
    b = Backoff(initial=0.5, maximum=4.0, stable=30.0)
    assert [b.next_delay(1.0) for _ in range(6)] == [0.5, 1.0, 2.0, 4.0, 4.0, 4.0]
    assert b.next_delay(31.0) == 0.5


STAND_IN = ("import sys, time\n"
            "code = int(sys.argv[1])\n"
            "if code: sys.exit(code)\n"
            "time.sleep(60)\n")


def _supervisor(code: int = 0) -> tuple[RelaySupervisor, list[str]]:
    lines: list[str] = []
    ends = [EndSpec("A", "B", side, "http://127.0.0.1:1/", "127.0.0.1", "127.0.0.1", 1111, "127.0.0.1")
            for side in "ab"]
    sup = RelaySupervisor(ends, EndOptions(state_dir="/tmp"), lambda level, msg: lines.append(f"{level}: {msg}"),
                          argv_for=lambda spec, opts: [sys.executable, "-c", STAND_IN, str(code)])
    return sup, lines


def _step_until(sup: RelaySupervisor, cond, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "supervisor did not get there in time"
        sup.step(time.monotonic())
        time.sleep(0.05)


def test_an_end_that_cannot_listen_is_restarted_on_the_same_port() -> None:
    sup, lines = _supervisor(code=3)                          # EXIT_PORT: the building's port is taken
    try:
        sup.step(time.monotonic())
        _step_until(sup, lambda: all(c.restarts >= 2 for c in sup.children))
        assert all(c.spec.link_port == 1111 for c in sup.children)    # the other robot connects there: kept
        assert any("cannot listen on 127.0.0.1:1111" in line for line in lines)
    finally:
        sup.stop()
    assert all(pid is None for _, pid, *_ in sup.status())


def test_a_crashing_end_is_restarted_with_backoff() -> None:
    sup, lines = _supervisor(code=1)
    try:
        sup.step(time.monotonic())
        _step_until(sup, lambda: all(c.restarts >= 3 for c in sup.children))
        c = sup.children[0]
        assert c.last_exit == 1 and c.backoff.delay >= 4.0        # 0.5, 1, 2 s waited, next 4 s
        assert any("exited with 1; restarting in" in line for line in lines)
    finally:
        sup.stop()
