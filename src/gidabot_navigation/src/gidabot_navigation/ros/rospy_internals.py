"""Every use of rospy's private API, in one place (no other module of ours touches it).

rospy's public API has no way to do a few things our nodes need; each function here does one of
them through rospy internals, says which, and what to check when rospy changes.
``test_rospy_internals.py`` checks that every name in :data:`PRIVATE_API` still exists in the
installed rospy (an upgrade that removes one fails there, loudly), and
``tests/foundation/test_rospy_internals_use.py`` that no other module uses them.

Publishers and subscribers (``rospy.topics``: ``Topic.impl``, ``_PublisherImpl``, connections):

- :func:`publisher_lock`: the lock ``Publisher.publish`` takes, for sending to one new subscriber
  from a ``SubscribeListener`` (latched states, replayed events).
- :func:`peer_of`: the subscriber a ``SubscribeListener``'s ``peer_publish`` sends to.
- :func:`connected_subscribers`: the caller ids of the subscribers connected to a publisher.
- :func:`close_connections_from`: close a subscriber's connections to some publishers.

The node and its master (``rospy.core``, ``rospy.impl.registration``, ``rospy.impl.paramserver``):

- :func:`node_initialized`: whether ``rospy.init_node`` ran.
- :func:`node_registrations`: this node's publications, subscriptions and services.
- :func:`bound_master_proxy`: give rospy's one proxy of the master a transport with a timeout.
- :func:`param_cache_get_or_set`: answer a parameter from rospy's cache, never the master.
- :func:`wake_registration_thread_on_shutdown`: a prompt ``rospy.signal_shutdown``.

Time (``rospy.impl.simtime``, ``rospy.rostime``):

- :func:`take_over_ros_time`: stop receiving ``/clock`` and set this process's ROS time directly.

Not here, because rospy documents them as the way to use messages: ``msg._connection_header``
(the connection header of a received message) and ``rospy.AnyMsg._buff`` (its raw bytes).
"""

from __future__ import annotations

import contextlib
import xmlrpc.client
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import rospy

# (module, dotted attribute) of every private rospy name used here; instance attributes are listed
# by the class that sets them in __init__ (checked on an instance by the test)
PRIVATE_API: tuple[tuple[str, str], ...] = (
    ("rospy.topics", "Topic.impl"),                       # instance attribute of Publisher/Subscriber
    ("rospy.topics", "_PublisherImpl.acquire"),
    ("rospy.topics", "_PublisherImpl.release"),
    ("rospy.topics", "_PublisherImpl.add_connection"),    # defines publish_single, closing over the connection
    ("rospy.topics", "_TopicImpl.connections"),           # instance attribute
    ("rospy.impl.transport", "Transport.endpoint_id"),    # instance attribute
    ("rospy.impl.tcpros_base", "TCPROSTransport.header"),  # instance attribute (None until the handshake)
    ("rospy.impl.transport", "Transport.close"),
    ("rospy.core", "is_initialized"),
    ("rospy.core", "xmlrpcapi"),
    ("rospy.core", "add_shutdown_hook"),
    ("rospy.impl.registration", "get_topic_manager"),
    ("rospy.impl.registration", "get_service_manager"),
    ("rospy.impl.registration", "get_registration_listeners"),
    ("rospy.impl.registration", "RegManager"),
    ("rospy.impl.registration", "RegManager.cond"),      # instance attribute
    ("rospy.impl.paramserver", "get_param_server_cache"),
    ("rospy.impl.simtime", "_clock_sub"),
    ("rospy.rostime", "_set_rostime"),
    ("xmlrpc.client", "ServerProxy._ServerProxy__transport"),  # instance attribute (name-mangled)
)


class _PublisherLock:
    def __init__(self, impl: Any) -> None:
        self.impl = impl

    def __enter__(self) -> None:
        self.impl.acquire()

    def __exit__(self, *exc: object) -> None:
        self.impl.release()


def publisher_lock(pub: rospy.Publisher) -> contextlib.AbstractContextManager[None]:
    """The lock ``pub.publish`` holds while it serialises (``pub.impl.acquire()`` / ``release()`` of
    ``rospy.topics._PublisherImpl``), reusable: ``with lock: peer_publish(msg)``.

    Why: rospy calls ``SubscribeListener.peer_subscribe`` from the thread accepting the connection
    without that lock, while another thread may be publishing; both serialise into the publisher's
    one buffer (empty or garbled messages). On a rospy upgrade: ``_PublisherImpl.acquire/release``
    and whether ``peer_publish`` still needs the caller to lock."""
    return _PublisherLock(pub.impl)


def peer_of(peer_publish: Callable[..., Any]) -> str:
    """The caller id of the subscriber a ``peer_publish`` callable sends to ("" if unknown).

    Why: a relay's publisher replays nothing to a relay. How: rospy's ``publish_single`` (defined in
    ``_PublisherImpl.add_connection``) closes over the new connection, whose ``endpoint_id`` is the
    subscriber's caller id; best effort, an unknown peer is "". On a rospy upgrade: ``add_connection``
    still defines a closure over the connection, which still has ``endpoint_id``."""
    for cell in getattr(peer_publish, "__closure__", None) or ():
        try:
            endpoint = getattr(cell.cell_contents, "endpoint_id", None)
        except (AttributeError, ValueError):     # an empty cell
            continue
        if isinstance(endpoint, str):
            return endpoint
    return ""


def connected_subscribers(pub: rospy.Publisher) -> set[str]:
    """The caller ids of the subscribers connected to ``pub`` now (``pub.impl.connections``, each
    connection's ``endpoint_id``).

    Why: ``get_num_connections`` does not say who; a relay end waits for the subscribers it had
    before its master restarted, and a node checks that the action server it talks to is connected.
    On a rospy upgrade: ``_TopicImpl.connections`` (a list replaced, never changed in place) and
    ``Transport.endpoint_id``."""
    return {c.endpoint_id for c in list(pub.impl.connections) if c.endpoint_id}


def close_connections_from(sub: rospy.Subscriber, drop: Callable[[str], bool]) -> int:
    """Close ``sub``'s connections to the publishers whose caller id ``drop`` accepts; their number.

    Why: a relay end receives what the other relay ends of its master publish and never forwards
    it; closing those connections saves the CPU of receiving. rospy reconnects only when the
    master's publisher list changes. How: ``sub.impl.connections``, each TCPROS connection's
    ``header["callerid"]`` and ``close()``; best effort (a connection closing meanwhile is skipped).
    On a rospy upgrade: ``_TopicImpl.connections``, ``TCPROSTransport.header``, ``Transport.close``."""
    closed = 0
    for c in list(sub.impl.connections):
        header = getattr(c, "header", None) or {}
        if drop(str(header.get("callerid", ""))):
            with contextlib.suppress(Exception):     # rospy transport internals: best effort
                c.close()
            closed += 1
    return closed


def node_initialized() -> bool:
    """Whether ``rospy.init_node`` ran in this process (``rospy.core.is_initialized``, not exported by rospy).

    On a rospy upgrade: ``rospy.core.is_initialized``."""
    import rospy.core

    return bool(rospy.core.is_initialized())


def node_registrations() -> tuple[list[tuple[str, str]], list[tuple[str, str]], list[tuple[str, str]]]:
    """This node's (publications, subscriptions, services): ``(topic, type)``, ``(topic, type)``,
    ``(service, uri)``, from rospy's topic and service managers (``rospy.impl.registration``).

    Why: to register them again with a master that restarted (rospy registers them once).
    On a rospy upgrade: ``get_topic_manager().get_publications()/get_subscriptions()`` and
    ``get_service_manager().get_services()``."""
    from rospy.impl.registration import get_service_manager, get_topic_manager

    tm, sm = get_topic_manager(), get_service_manager()
    return ([(n, t) for n, t in tm.get_publications()] if tm else [],
            [(n, t) for n, t in tm.get_subscriptions()] if tm else [],
            [(n, u) for n, u in sm.get_services()] if sm else [])


def bound_master_proxy(uri: str, transport: xmlrpc.client.Transport) -> bool:
    """Give rospy's proxy of the master ``uri`` (``rospy.core.xmlrpcapi``: one per URI for the whole
    process, used for every registration, parameter and lookup) ``transport``; False if ``uri`` is not
    a usable URI.

    Why: that proxy has no timeout, and one call to a frozen master held every other thread's calls.
    How: ``ServerProxy`` keeps its transport in the name-mangled ``_ServerProxy__transport``. On a
    rospy upgrade: ``rospy.core.xmlrpcapi`` still caches a ``ServerProxy`` per URI."""
    import rospy.core

    server = rospy.core.xmlrpcapi(uri)
    if server is None:
        return False
    server._ServerProxy__transport = transport  # type: ignore[attr-defined]
    return True


def param_cache_get_or_set(key: str, value: bool) -> bool:
    """The value of parameter ``key`` in rospy's parameter cache; if it is not there, ``value`` is put there
    first (``rospy.impl.paramserver.get_param_server_cache``).

    Why: rospy's ``/rosout`` handler asks the master for ``/rosout_disable_topics_generation`` on every
    log call until the cache has it (an XML-RPC call without timeout). On a rospy upgrade: the cache's
    ``get`` (KeyError when missing) and ``set``, and whether rosout still reads that parameter."""
    from rospy.impl.paramserver import get_param_server_cache

    cache = get_param_server_cache()
    try:
        return bool(cache.get(key))
    except KeyError:
        cache.set(key, bool(value))
        return bool(value)


def wake_registration_thread_on_shutdown() -> None:
    """Make ``rospy.signal_shutdown`` prompt: a shutdown hook (``rospy.core.add_shutdown_hook``)
    notifies the conditions of rospy's registration managers (``rospy.impl.registration``:
    ``get_registration_listeners().listeners``, ``RegManager.cond``).

    Why: the registration thread waits 0.5 s on that condition between two looks at the shutdown flag,
    and ``signal_shutdown`` joins it (~0.6 s -> ~0.1 s). On a rospy upgrade: those names, and whether
    the shutdown still joins that thread."""
    import rospy.core
    import rospy.impl.registration as registration

    listeners = getattr(registration.get_registration_listeners(), "listeners", [])
    conds = [m.cond for m in list(listeners) if isinstance(m, registration.RegManager)]

    def wake_registration_thread(_reason: str) -> None:
        for cond in conds:
            with cond:
                cond.notify_all()

    rospy.core.add_shutdown_hook(wake_registration_thread)


def take_over_ros_time() -> Callable[[rospy.Time], None] | None:
    """Stop this process's ``/clock`` subscription (``rospy.impl.simtime._clock_sub``, made by
    ``init_node`` when ``/use_sim_time`` is set) and return the setter of its ROS time
    (``rospy.rostime._set_rostime``); None, changing nothing, when either is missing.

    Why: the simulator's lockstep participants take their time from what the simulator sends them,
    never from a later ``/clock``. On a rospy upgrade: both names, and that ``rospy.get_rostime`` still
    reads what ``_set_rostime`` sets."""
    import rospy.impl.simtime
    import rospy.rostime

    sub = getattr(rospy.impl.simtime, "_clock_sub", None)
    setter = getattr(rospy.rostime, "_set_rostime", None)
    if sub is None or setter is None:
        return None
    sub.unregister()
    return setter
