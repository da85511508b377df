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


def test_plan_gives_n_n_minus_1_over_2_relays_two_ends_each(faculty) -> None:
    names = [r.name for r in faculty.robots]
    ports = iter(range(40000, 40100))
    plans = {r: plan_relays(faculty, r, lambda i, host: next(ports), is_local=lambda ip: True) for r in names}
    assert [len(plans[r]) for r in names] == [6, 4, 2, 0]          # robot i starts the relays to i+1..n-1
    pairs = {e.pair for ends in plans.values() for e in ends}
    assert len(pairs) == len(names) * (len(names) - 1) // 2
    t, k = faculty.robot("Tartalo"), faculty.robot("Kbot")
    a, b = plans["Tartalo"][0], plans["Tartalo"][1]
    assert (a.side, a.master_uri, a.ros_ip, a.bind_ip) == ("a", t.master_uri, t.ip, t.ip)
    assert (b.side, b.master_uri, b.ros_ip, b.link_host) == ("b", k.master_uri, k.ip, k.ip)
    assert a.link_port == b.link_port and a.node_name == b.node_name == relay_end_name("Tartalo", "Kbot")


def test_plan_on_a_real_robot_keeps_the_link_on_this_machine(faculty) -> None:
    ends = plan_relays(faculty, "Kbot", lambda i, host: 41000 + i, is_local=lambda ip: False)
    kbot = faculty.robot("Kbot")
    for e in ends:
        assert e.link_host == kbot.ip and e.bind_ip == kbot.ip
        assert e.ros_ip == kbot.ip                  # end b talks to the far master from this machine
    pairs = faculty.relay_pairs()
    index = next(i for i, (x, y) in enumerate(pairs) if (x.name, y.name) == ("Kbot", "Galtxagorri"))
    assert ends[0].link_port == 41000 + index      # link_port_base + pair index: fixed ports


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
            "side, port, code = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])\n"
            "if side == 'b' and port == 1111: sys.exit(3)\n"
            "if code: sys.exit(code)\n"
            "time.sleep(60)\n")


def _supervisor(code: int = 0) -> tuple[RelaySupervisor, list[str]]:
    lines: list[str] = []
    ends = [EndSpec("A", "B", side, "http://127.0.0.1:1/", "127.0.0.1", "127.0.0.1", 1111 if code == 0 else 5,
                    "127.0.0.1") for side in "ab"]
    sup = RelaySupervisor(ends, EndOptions(state_dir="/tmp"), lambda level, msg: lines.append(f"{level}: {msg}"),
                          new_port=lambda host: 2222,
                          argv_for=lambda spec, opts: [sys.executable, "-c", STAND_IN, spec.side, str(spec.link_port),
                                                       str(code)])
    return sup, lines


def _step_until(sup: RelaySupervisor, cond, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not cond():
        assert time.monotonic() < deadline, "supervisor did not get there in time"
        sup.step(time.monotonic())
        time.sleep(0.05)


def test_taken_link_port_moves_the_pair_to_a_new_port() -> None:
    sup, lines = _supervisor()
    try:
        sup.step(time.monotonic())
        a, b = sup.children
        first_a = a.pid
        assert first_a is not None
        _step_until(sup, lambda: b.spec.link_port == 2222 and b.pid is not None and a.pid not in (None, first_a))
        assert a.spec.link_port == 2222
        assert any("is taken; moving to 2222" in line for line in lines)
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
