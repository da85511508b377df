"""master_watch without a ROS master: the decision core, and re-registration against fake XML-RPC servers."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from xmlrpc.server import SimpleXMLRPCRequestHandler, SimpleXMLRPCServer

import pytest

from gidabot_navigation.errors import MasterWatchError
from gidabot_navigation.interface import Topic
from gidabot_navigation.ros.master_watch import (
    MasterEvent,
    MasterWatch,
    MasterWatchCore,
    ParamKeeper,
    Registrations,
    get_master_pid,
    register_all,
)


def test_first_contact_then_quiet() -> None:
    core = MasterWatchCore()
    assert core.observe(100, 0.0) is MasterEvent.FIRST_CONTACT
    assert core.up
    assert core.observe(100, 0.5) is MasterEvent.NONE
    assert core.generation == 0


def test_one_failed_poll_is_not_an_outage() -> None:
    core = MasterWatchCore(down_after=2)
    core.observe(100, 0.0)
    assert core.observe(None, 0.5) is MasterEvent.NONE
    assert core.up
    assert core.observe(100, 1.0) is MasterEvent.NONE


def test_outage_then_same_master_reregisters() -> None:
    core = MasterWatchCore(down_after=2)
    core.observe(100, 0.0)
    assert core.observe(None, 0.5) is MasterEvent.NONE
    assert core.observe(None, 1.0) is MasterEvent.DOWN
    assert not core.up and core.down_since == 1.0
    assert core.observe(None, 1.5) is MasterEvent.NONE        # DOWN is reported once
    assert core.observe(100, 2.0) is MasterEvent.REREGISTER   # a network outage: registrations may be stale too
    core.registered()
    assert core.generation == 1 and core.up and core.outages == 1
    assert core.observe(100, 2.5) is MasterEvent.NONE


def test_fast_restart_between_polls_is_a_pid_change() -> None:
    core = MasterWatchCore()
    core.observe(100, 0.0)
    assert core.observe(200, 0.5) is MasterEvent.REREGISTER
    assert core.restarts == 1
    core.registered()
    assert core.observe(200, 1.0) is MasterEvent.NONE


def test_failed_registration_is_retried_on_the_next_answer() -> None:
    core = MasterWatchCore()
    core.observe(100, 0.0)
    assert core.observe(200, 0.5) is MasterEvent.REREGISTER
    core.registration_failed()
    assert core.observe(200, 1.0) is MasterEvent.REREGISTER
    core.registered()
    assert core.generation == 1


def test_master_unreachable_at_start_reregisters_on_first_contact() -> None:
    core = MasterWatchCore()
    assert core.observe(None, 0.0) is MasterEvent.NONE
    assert core.observe(None, 0.5) is MasterEvent.NONE         # never up: no DOWN event
    assert core.observe(100, 1.0) is MasterEvent.REREGISTER


class _Quiet(SimpleXMLRPCRequestHandler):
    def log_message(self, *args: object) -> None:
        pass


class FakeMaster:
    """Records registrations; answers like rosmaster."""

    def __init__(self, pid: int = 4242, publishers: list[str] | None = None, refuse: str = "") -> None:
        self.calls: list[tuple] = []
        self.pid = pid
        self.publishers = publishers or []
        self.refuse = refuse

    def getPid(self, caller: str) -> list:  # noqa: N802 - XML-RPC API name
        return [1, "", self.pid]

    def registerPublisher(self, caller: str, topic: str, type_: str, api: str) -> list:  # noqa: N802
        self.calls.append(("pub", caller, topic, type_, api))
        return [1, "", []]

    def registerSubscriber(self, caller: str, topic: str, type_: str, api: str) -> list:  # noqa: N802
        self.calls.append(("sub", caller, topic, type_, api))
        if self.refuse == topic:
            return [-1, "refused", []]
        return [1, "", self.publishers]

    def registerService(self, caller: str, service: str, service_uri: str, api: str) -> list:  # noqa: N802
        self.calls.append(("srv", caller, service, service_uri, api))
        return [1, "", 1]

    # the parameter server: a flat dict of leaf keys, answered like rosmaster (subtrees as dicts)
    params: dict

    def getParam(self, caller: str, key: str) -> list:  # noqa: N802
        params = getattr(self, "params", {})
        if key in params:
            return [1, "", params[key]]
        tree: dict = {}
        for k, v in params.items():
            if k.startswith(key.rstrip("/") + "/"):
                node = tree
                parts = k[len(key.rstrip("/")) + 1:].split("/")
                for part in parts[:-1]:
                    node = node.setdefault(part, {})
                node[parts[-1]] = v
        return [1, "", tree] if tree else [-1, f"Parameter [{key}] is not set", 0]

    def hasParam(self, caller: str, key: str) -> list:  # noqa: N802
        return [1, "", self.getParam(caller, key)[0] == 1]

    def setParam(self, caller: str, key: str, value: object) -> list:  # noqa: N802
        self.calls.append(("set", caller, key, value))
        if not hasattr(self, "params"):
            self.params = {}
        self.params[key] = value
        return [1, "", 0]


class FakeSlave:
    def __init__(self) -> None:
        self.updates: list[tuple] = []

    def publisherUpdate(self, caller: str, topic: str, publishers: list) -> list:  # noqa: N802
        self.updates.append((caller, topic, publishers))
        return [1, "", 0]


def _serve(obj: object) -> tuple[SimpleXMLRPCServer, str]:
    server = SimpleXMLRPCServer(("127.0.0.1", 0), requestHandler=_Quiet, allow_none=True, logRequests=False)
    server.register_instance(obj)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


@pytest.fixture
def servers() -> Iterator[tuple[FakeMaster, str, FakeSlave, str]]:
    master, slave = FakeMaster(publishers=["http://127.0.0.1:1/"]), FakeSlave()
    ms, muri = _serve(master)
    ss, suri = _serve(slave)
    yield master, muri, slave, suri
    for s in (ms, ss):
        s.shutdown()
        s.server_close()


REGS = Registrations(publications=[("/chatter", "std_msgs/String"), ("/rosout", "rosgraph_msgs/Log")],
                     subscriptions=[(Topic.GOALS, "*")],
                     services=[("/node/get_loggers", "rosrpc://127.0.0.1:5555")])


def test_register_all_registers_everything_and_feeds_publisher_update(servers) -> None:
    master, muri, slave, suri = servers
    assert register_all(muri, "/node", suri, REGS, timeout=2.0) == 4
    assert [c[0] for c in master.calls] == ["pub", "pub", "sub", "srv"]
    assert all(c[1] == "/node" and c[4] == suri for c in master.calls)
    assert master.calls[2][3] == "*"
    assert slave.updates == [("/master", Topic.GOALS, ["http://127.0.0.1:1/"])]


def test_register_all_refusal_names_what(servers) -> None:
    master, muri, _, suri = servers
    master.refuse = Topic.GOALS
    with pytest.raises(MasterWatchError, match=f"refused to register subscriber {Topic.GOALS}"):
        register_all(muri, "/node", suri, REGS, timeout=2.0)


def test_unreachable_master_is_none_quickly() -> None:
    import socket

    with socket.socket() as s:           # a bound but never accepting port: connection refused
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert get_master_pid(f"http://127.0.0.1:{port}/", "/x", 0.3) is None


class _Log:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def info(self, msg: str) -> None:
        self.lines.append("I " + msg)

    def warning(self, msg: str) -> None:
        self.lines.append("W " + msg)

    def error(self, msg: str) -> None:
        self.lines.append("E " + msg)


def test_watch_reregisters_after_pid_change_and_tells_listeners(servers) -> None:
    master, muri, slave, suri = servers
    log = _Log()
    watch = MasterWatch(master_uri=muri, caller_id="/node", node_uri=suri, registrations=lambda: REGS, log=log)
    seen: list[MasterEvent] = []
    watch.add_listener(lambda ev, w: seen.append(ev))
    assert watch.poll_once(0.0) is MasterEvent.FIRST_CONTACT
    assert master.calls == []
    master.pid = 5151                                    # "restarted"
    assert watch.poll_once(0.5) is MasterEvent.REREGISTER
    assert watch.generation == 1 and watch.up
    assert len(master.calls) == 4 and seen == [MasterEvent.REREGISTER]
    assert any("re-registered 4" in line for line in log.lines)


def test_listener_errors_do_not_stop_the_watch(servers) -> None:
    master, muri, _, suri = servers
    log = _Log()
    watch = MasterWatch(master_uri=muri, caller_id="/node", node_uri=suri, registrations=lambda: REGS, log=log)

    def bad(ev: MasterEvent, w: MasterWatch) -> None:
        raise RuntimeError("boom")

    watch.add_listener(bad)
    watch.poll_once(0.0)
    master.pid += 1
    assert watch.poll_once(0.5) is MasterEvent.REREGISTER
    assert any(line.startswith("E ") and "boom" in line for line in log.lines)


def test_param_keeper_restores_what_a_restarted_master_lost(servers) -> None:
    from gidabot_navigation.ros.master_watch import proxy

    master, muri, _, _ = servers
    master.params = {"/goal_manager/building": "/b/building.yaml", "/goal_manager/robot": "Kbot",
                     "/goal_manager/wait/lift": 25.0, "/use_sim_time": True, "/other/x": 1}
    keeper = ParamKeeper("/goal_manager")
    assert keeper.take(proxy(muri, 2.0), "/goal_manager") == 4
    assert keeper.remembered["/goal_manager/wait/lift"] == 25.0 and "/other/x" not in keeper.remembered
    master.params = {"/goal_manager/robot": "Changed"}          # restarted: empty, one set again by someone
    set_now = keeper.restore(proxy(muri, 2.0), "/goal_manager")
    assert set_now == ["/goal_manager/building", "/goal_manager/wait/lift", "/use_sim_time"]
    assert master.params["/goal_manager/robot"] == "Changed"    # never overwritten
    assert master.params["/use_sim_time"] is True and keeper.restored == 3
    assert keeper.restore(proxy(muri, 2.0), "/goal_manager") == []


def test_watch_sets_parameters_again_before_reregistering(servers) -> None:
    master, muri, _, suri = servers
    master.params = {"/node/speed": 20.0, "/use_sim_time": True}
    log = _Log()
    watch = MasterWatch(master_uri=muri, caller_id="/node", node_uri=suri, registrations=lambda: REGS, log=log,
                        params=ParamKeeper("/node"))
    watch.remember_params()
    watch.poll_once(0.0)
    master.params["/node/start_wall"] = 1234.5                  # written by the node after start
    watch.poll_once(100.0)                                      # a refresh is due: merged
    master.params, master.calls = {}, []
    master.pid += 1                                             # restarted, parameters gone
    assert watch.poll_once(100.5) is MasterEvent.REREGISTER
    kinds = [c[0] for c in master.calls]
    assert kinds[:3] == ["set", "set", "set"] and "pub" in kinds[3:]
    assert master.params == {"/node/speed": 20.0, "/node/start_wall": 1234.5, "/use_sim_time": True}
    assert any("lost 3 parameter(s)" in line for line in log.lines)
