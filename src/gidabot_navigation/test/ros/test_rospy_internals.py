"""rospy's private API behind ros/rospy_internals.py: every name it relies on exists in the installed rospy
(an upgrade that removes or renames one fails here), and each function works on rospy's real objects
(publisher and subscriber implementations with stand-in connections; no master)."""

from __future__ import annotations

import importlib
import inspect
import re
import types
import xmlrpc.client

import pytest
import rospy
import rospy.topics
from rospy.impl.transport import INBOUND, OUTBOUND, Transport

from gidabot_navigation.interface import Node, global_name, is_relay_end, relay_end_name
from gidabot_navigation.ros import rospy_internals as ri

GM = global_name(Node.GOAL_MANAGER)
RELAY = relay_end_name("Tartalo", "Kbot")


def _assigned_in_source(owner: object, attr: str) -> bool:
    """``attr`` is an instance attribute set in a method of class ``owner`` (or a base), or a global that
    module ``owner`` sets in a function (``global x`` ... ``x = ``)."""
    if inspect.ismodule(owner):
        return re.search(rf"^\s*global .*\b{attr}\b", inspect.getsource(owner), re.M) is not None
    mangled = re.sub(r"^_[A-Za-z]+__", "__", attr)            # _ServerProxy__transport is self.__transport
    return any(re.search(rf"self\.{re.escape(mangled)}\s*=", inspect.getsource(cls))
               for cls in inspect.getmro(owner) if cls is not object and cls.__module__ != "builtins")


@pytest.mark.parametrize(("module", "dotted"), ri.PRIVATE_API, ids=[f"{m}:{d}" for m, d in ri.PRIVATE_API])
def test_every_private_name_used_exists_in_the_installed_rospy(module: str, dotted: str) -> None:
    owner: object = importlib.import_module(module)
    *path, last = dotted.split(".")
    for name in path:
        owner = getattr(owner, name)
    assert hasattr(owner, last) or _assigned_in_source(owner, last), \
        f"{module}.{dotted} is gone: rospy changed; update gidabot_navigation/ros/rospy_internals.py"


def test_the_module_docstring_lists_every_function() -> None:
    doc = ri.__doc__ or ""
    public = [n for n, f in vars(ri).items() if inspect.isfunction(f) and not n.startswith("_")
              and f.__module__ == ri.__name__]
    assert public and all(f":func:`{n}`" in doc and vars(ri)[n].__doc__ for n in public)


class Conn(Transport):
    """A stand-in connection (no socket), as rospy's TCPROS transports look to a topic."""

    def __init__(self, direction: str, caller_id: str) -> None:
        super().__init__(direction, "test")
        self.endpoint_id = caller_id
        self.header = {"callerid": caller_id}

    def fileno(self) -> None:
        return None

    def close(self) -> None:
        """Once, as rospy's TCPROS transports close: a topic's cleanup closes the connection it removes again, and
        a double closing every time recursed until the interpreter aborted (when a topic was collected)."""
        if not self.done:
            super().close()


def publisher() -> tuple[types.SimpleNamespace, list]:
    """A rospy publisher implementation (as ``rospy.Publisher(...).impl``) whose listener keeps every
    ``peer_publish`` it is given."""
    impl = rospy.topics._PublisherImpl("/rospy_internals_test", rospy.AnyMsg)
    peers: list = []

    class Listener(rospy.SubscribeListener):
        def peer_subscribe(self, topic_name, topic_publish, peer_publish) -> None:
            peers.append(peer_publish)

    impl.add_subscriber_listener(Listener())
    return types.SimpleNamespace(impl=impl), peers


def test_subscribers_of_a_publisher_and_the_peer_of_a_peer_publish() -> None:
    pub, peers = publisher()
    for who in (GM, RELAY):
        pub.impl.add_connection(Conn(OUTBOUND, who))
    assert ri.connected_subscribers(pub) == {GM, RELAY}
    assert [ri.peer_of(p) for p in peers] == [GM, RELAY]          # rospy's publish_single closes over its connection
    assert ri.peer_of(lambda data: None) == ""


def test_the_publisher_lock_is_the_one_publish_takes() -> None:
    pub, _ = publisher()
    lock = ri.publisher_lock(pub)
    with lock:
        assert pub.impl.publock._is_owned()
    with lock:                                                     # reusable
        pass
    assert not pub.impl.publock._is_owned()


def test_closing_a_subscriber_s_connections_to_relays() -> None:
    impl = rospy.topics._SubscriberImpl("/rospy_internals_test", rospy.AnyMsg)
    conns = [Conn(INBOUND, who) for who in (RELAY, GM)]
    for c in conns:
        impl.add_connection(c)
    assert ri.close_connections_from(types.SimpleNamespace(impl=impl), is_relay_end) == 1
    assert [c.done for c in conns] == [True, False] and [c.endpoint_id for c in impl.connections] == [GM]


def test_the_node_side_without_init_node() -> None:
    assert ri.node_initialized() is False
    assert ri.node_registrations() == ([], [], [])
    assert ri.take_over_ros_time() is None                         # no /clock subscription: nothing changed
    key = "/gidabot_test/rospy_internals_param"
    assert ri.param_cache_get_or_set(key, True) is True
    assert ri.param_cache_get_or_set(key, False) is True           # what the cache holds wins
    transport = xmlrpc.client.Transport()
    assert ri.bound_master_proxy("not a uri", transport) is False
    assert ri.bound_master_proxy("http://127.0.0.1:9/", transport) is True
    import rospy.core

    assert rospy.core.xmlrpcapi("http://127.0.0.1:9/")._ServerProxy__transport is transport
