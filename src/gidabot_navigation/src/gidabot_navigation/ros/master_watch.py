"""Keep a rospy node registered with its master across master restarts and outages.

rospy registers a node's publishers, subscribers and services once, when they are
created; a master that is killed and restarted (same URI, empty registry) never
hears of them again, so new nodes cannot find them. :func:`keep_registered`
(call once, right after ``rospy.init_node``) starts a daemon thread that polls the
master (``getPid``, every ``period`` s, each call bounded by ``timeout`` s) and,
when the master answers again after an outage or answers with another pid,
registers every publisher, subscriber and service of this node again. For each
subscription, the publisher list the master returns is fed to the node's own slave
API (``publisherUpdate``) so that connections to publishers are made.

Connections that already exist between nodes do not go through the master and
survive its restart; what re-registration restores is *discovery*: nodes that
start (or restart) after the master came back find this node's topics.

A restarted master has also lost every parameter, so a node that roslaunch respawns
afterwards (or that starts later) would miss its private parameters and
``/use_sim_time``. :class:`ParamKeeper` remembers, at start, the parameters of the
node's private namespace and ``/use_sim_time`` (and merges what appears there later,
e.g. a value the node itself writes back); after a re-registration it sets again
every remembered parameter the master does not have (never overwriting one it has).

The decision logic is :class:`MasterWatchCore` (ROS-free, driven by explicit poll
results so it is unit-tested without a master); :class:`MasterWatch` is the thread
and the XML-RPC calls. Liveness is measured in monotonic wall time, never ROS time.

No call of the node waits for an unreachable or frozen master without a bound: the watch's
own calls have ``timeout``; :func:`bound_master_calls` gives rospy's own proxy of the master
(registrations, parameters, lookups: one proxy and one lock for the whole process) a socket
timeout, and :func:`gidabot_navigation.ros.log.never_block_on_rosout` keeps rospy's logging
from calling the master at all. :func:`keep_registered` does both.
"""

from __future__ import annotations

import enum
import http.client
import threading
import time
import xmlrpc.client
from collections.abc import Callable
from dataclasses import dataclass, field

from gidabot_navigation.errors import MasterWatchError
from gidabot_navigation.logs import Logger

DEFAULT_PERIOD = 0.5     # s between polls
DEFAULT_TIMEOUT = 0.3    # s, socket timeout of one XML-RPC call
RPC_TIMEOUT = 5.0        # s, socket timeout of every call rospy itself makes to the master
DOWN_AFTER = 2           # consecutive failed polls before the master is declared down
PARAM_REFRESH = 30.0     # s between merges of the node's parameters into the remembered set
RESTORED_KEYS = ("/use_sim_time",)   # global parameters every node restores besides its private ones


class MasterEvent(enum.Enum):
    """What a poll result means for the node."""

    NONE = "none"                  # nothing changed
    FIRST_CONTACT = "first"        # first answer: rospy registered the node itself
    DOWN = "down"                  # the master stopped answering (DOWN_AFTER polls in a row)
    REREGISTER = "reregister"      # the master is back or restarted: register everything again


@dataclass
class MasterWatchCore:
    """ROS-free state of one node's view of its master.

    Feed every poll result to :meth:`observe` (``pid`` None = no answer); it returns
    the :class:`MasterEvent` to act on. After a REREGISTER, call :meth:`registered` (or
    :meth:`registration_failed`, and the next answered poll asks again).
    """

    down_after: int = DOWN_AFTER
    pid: int | None = None            # pid of the master last seen
    up: bool = False                  # the master answered the last poll(s)
    failures: int = 0                 # consecutive failed polls
    pending: bool = False             # a re-registration is due
    generation: int = 0               # successful re-registrations so far
    restarts: int = 0                 # pid changes seen
    outages: int = 0                  # times the master was declared down
    down_since: float | None = None   # monotonic time the current outage was declared
    last_answer: float | None = None  # monotonic time of the last answered poll

    def observe(self, pid: int | None, now: float) -> MasterEvent:
        if pid is None:
            self.failures += 1
            if self.up and self.failures >= self.down_after:
                self.up = False
                self.outages += 1
                self.down_since = now
                self.pending = True      # whatever comes back (same or new master), re-register
                return MasterEvent.DOWN
            return MasterEvent.NONE
        first = self.pid is None
        if first and self.failures:
            self.pending = True          # unreachable since start: it may have restarted meanwhile
        self.failures = 0
        self.last_answer = now
        if not first and pid != self.pid:
            self.restarts += 1
            self.pending = True
        self.pid = pid
        if first and not self.pending:
            self.up = True
            return MasterEvent.FIRST_CONTACT
        self.up = True
        self.down_since = None
        return MasterEvent.REREGISTER if self.pending else MasterEvent.NONE

    def registered(self) -> None:
        self.pending = False
        self.generation += 1

    def registration_failed(self) -> None:
        self.pending = True


class _TimeoutTransport(xmlrpc.client.Transport):
    """XML-RPC transport with a per-connection socket timeout (never the process-wide default,
    which rospy itself changes while connecting topics)."""

    def __init__(self, timeout: float) -> None:
        super().__init__()
        self._timeout = timeout

    def make_connection(self, host: object) -> http.client.HTTPConnection:
        conn = super().make_connection(host)
        conn.timeout = self._timeout
        return conn


def proxy(uri: str, timeout: float) -> xmlrpc.client.ServerProxy:
    """An XML-RPC proxy whose every call is bounded by ``timeout`` seconds."""
    return xmlrpc.client.ServerProxy(uri, transport=_TimeoutTransport(timeout), allow_none=True)


def bound_master_calls(timeout: float = RPC_TIMEOUT) -> str:
    """Every XML-RPC call rospy makes to this process's master (``rospy.core.xmlrpcapi``: registrations,
    parameters, lookups) gets a socket timeout of ``timeout`` s; returns the master's URI.

    rospy keeps one proxy per URI for the whole process and serialises its calls with a lock, without
    a timeout: one call to a frozen master (or one behind a cut network) held every other thread's
    calls. Callable before ``rospy.init_node`` (then ``init_node``'s own calls are bounded too) and
    after (the existing proxy gets the bounded transport); rospy retries a registration that failed.
    """
    import rosgraph

    from gidabot_navigation.ros.rospy_internals import bound_master_proxy

    if not timeout > 0:
        raise MasterWatchError(f"timeout must be positive seconds, got {timeout!r}")
    uri = rosgraph.get_master_uri()
    if not bound_master_proxy(uri, _TimeoutTransport(timeout)):
        raise MasterWatchError(f"ROS_MASTER_URI {uri!r} is not a usable URI")
    return uri


def get_master_pid(master_uri: str, caller_id: str, timeout: float,
                   server: xmlrpc.client.ServerProxy | None = None) -> int | None:
    """The master's pid, or None if it does not answer within ``timeout``.

    ``server`` (from :func:`proxy`) keeps its HTTP/1.1 connection between calls, which
    spares the master a new connection and thread per poll."""
    try:
        code, _, pid = (server or proxy(master_uri, timeout)).getPid(caller_id)
    except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError):
        return None
    return int(pid) if code == 1 else None


@dataclass(frozen=True)
class Registrations:
    """What a node has to register: (topic, type) publications and subscriptions, (service, uri) services."""

    publications: list[tuple[str, str]]
    subscriptions: list[tuple[str, str]]
    services: list[tuple[str, str]]


def register_all(master_uri: str, caller_id: str, node_uri: str, regs: Registrations, timeout: float) -> int:
    """Register ``regs`` of the node ``caller_id`` (slave API ``node_uri``) with the master.

    Publisher lists returned for subscriptions are sent to the node's own ``publisherUpdate``.
    Returns the number of registrations made; raises :class:`MasterWatchError`.
    """
    master = proxy(master_uri, timeout)
    count = 0
    try:
        for topic, type_ in regs.publications:
            _check(master.registerPublisher(caller_id, topic, type_, node_uri), "publisher", topic)
            count += 1
        for topic, type_ in regs.subscriptions:
            publishers = _check(master.registerSubscriber(caller_id, topic, type_, node_uri), "subscriber", topic)
            count += 1
            if publishers:
                proxy(node_uri, timeout).publisherUpdate("/master", topic, list(publishers))
        for service, service_uri in regs.services:
            _check(master.registerService(caller_id, service, service_uri, node_uri), "service", service)
            count += 1
    except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError) as err:
        raise MasterWatchError(f"re-registration of {caller_id} with {master_uri} failed after {count} "
                               f"registration(s): {err}") from err
    return count


def _check(reply: object, what: str, name: str) -> object:
    if not isinstance(reply, (list, tuple)) or len(reply) != 3:
        raise MasterWatchError(f"master answered {reply!r} to register {what} {name}; expected [code, msg, value]")
    code, msg, value = reply
    if code != 1:
        raise MasterWatchError(f"master refused to register {what} {name}: {msg} (code {code})")
    return value


def _flatten(prefix: str, value: object, out: dict[str, object]) -> None:
    """Leaf parameters of a parameter (sub)tree: ``{"/ns/a/b": value, ...}``."""
    if isinstance(value, dict) and value:
        for key, sub in value.items():
            _flatten(f"{prefix.rstrip('/')}/{key}", sub, out)
    else:
        out[prefix] = value


@dataclass
class ParamKeeper:
    """The parameters a node needs again from a restarted master (its private namespace and
    ``keys``), remembered as leaf values; :meth:`restore` sets the missing ones.

    Only XML-RPC calls on the master (``getParam``, ``hasParam``, ``setParam``), each
    bounded by ``timeout``; never overwrites a parameter the master already has.
    """

    namespace: str                                   # e.g. "/goal_manager" (the node's private namespace)
    keys: tuple[str, ...] = RESTORED_KEYS
    remembered: dict[str, object] = field(default_factory=dict)
    restored: int = 0                                # parameters set again so far

    def take(self, master: xmlrpc.client.ServerProxy, caller_id: str) -> int:
        """Merge what the master holds now into the remembered set; returns the number of leaves seen."""
        found: dict[str, object] = {}
        for key in (self.namespace, *self.keys):
            code, _, value = master.getParam(caller_id, key)
            if code == 1:
                _flatten(key, value, found)
        self.remembered.update(found)
        return len(found)

    def restore(self, master: xmlrpc.client.ServerProxy, caller_id: str) -> list[str]:
        """Set every remembered parameter the master lacks; returns their names."""
        set_now = []
        for key, value in sorted(self.remembered.items()):
            code, _, has = master.hasParam(caller_id, key)
            if code == 1 and has:
                continue
            code, msg, _ = master.setParam(caller_id, key, value)
            if code != 1:
                raise MasterWatchError(f"master refused to set parameter {key}: {msg} (code {code})")
            set_now.append(key)
        self.restored += len(set_now)
        return set_now


Listener = Callable[[MasterEvent, "MasterWatch"], None]


@dataclass
class MasterWatch:
    """The polling thread of one node (see the module docstring). Thread-safe read-only properties.

    ``registrations`` returns the node's current registrations, ``log`` receives
    messages; listeners are called from the watch thread with DOWN and REREGISTER
    events (after the re-registration succeeded), and must return quickly.
    ``params`` (optional) is restored before every re-registration and refreshed
    every ``param_refresh`` s while the master is up.
    """

    master_uri: str
    caller_id: str
    node_uri: str
    registrations: Callable[[], Registrations]
    log: Logger
    period: float = DEFAULT_PERIOD
    timeout: float = DEFAULT_TIMEOUT
    core: MasterWatchCore = field(default_factory=MasterWatchCore)
    _listeners: list[Listener] = field(default_factory=list)
    _lock: threading.Lock = field(default_factory=threading.Lock)
    _stop: threading.Event = field(default_factory=threading.Event)
    _thread: threading.Thread | None = None
    _server: xmlrpc.client.ServerProxy | None = None
    params: ParamKeeper | None = None
    param_refresh: float = PARAM_REFRESH
    _next_refresh: float = 0.0

    @property
    def up(self) -> bool:
        """The master answered recently (False while an outage is declared)."""
        with self._lock:
            return self.core.up

    @property
    def generation(self) -> int:
        """Number of successful re-registrations (changes each time the master came back)."""
        with self._lock:
            return self.core.generation

    def add_listener(self, listener: Listener) -> None:
        with self._lock:
            self._listeners.append(listener)

    def start(self) -> MasterWatch:
        self._thread = threading.Thread(target=self._run, name="master_watch", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def poll_once(self, now: float | None = None) -> MasterEvent:
        """One poll and what follows from it (the thread calls this every ``period``)."""
        if self._server is None:
            self._server = proxy(self.master_uri, self.timeout)
        pid = get_master_pid(self.master_uri, self.caller_id, self.timeout, self._server)
        if pid is None:
            self._server = None            # a fresh connection next time (the old one may be dead)
        now = time.monotonic() if now is None else now
        with self._lock:
            event = self.core.observe(pid, now)
        if event is MasterEvent.DOWN:
            self.log.warning(f"{self.caller_id}: master {self.master_uri} is not answering "
                             f"({self.core.down_after} polls in a row); will re-register when it is back")
        elif event is MasterEvent.REREGISTER:
            try:
                self._restore_params()
                count = register_all(self.master_uri, self.caller_id, self.node_uri, self.registrations(),
                                     self.timeout)
            except MasterWatchError as err:
                with self._lock:
                    self.core.registration_failed()
                self.log.warning(f"{self.caller_id}: {err}; retrying")
                return MasterEvent.NONE
            with self._lock:
                self.core.registered()
            self.log.info(f"{self.caller_id}: master {self.master_uri} is back (pid {pid}); "
                          f"re-registered {count} publication(s), subscription(s) and service(s)")
        elif pid is not None:
            self._refresh_params(now)
        if event in (MasterEvent.DOWN, MasterEvent.REREGISTER):
            with self._lock:
                listeners = list(self._listeners)
            for listener in listeners:
                try:
                    listener(event, self)
                except Exception as err:  # noqa: BLE001 - a listener must never kill the watch
                    self.log.error(f"{self.caller_id}: master watch listener failed: {err!r}")
        return event

    def remember_params(self) -> None:
        """Merge the node's parameters as the master holds them now (also done every ``param_refresh`` s)."""
        if self.params is None:
            return
        try:
            self.params.take(proxy(self.master_uri, self.timeout), self.caller_id)
        except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError) as err:
            self.log.warning(f"{self.caller_id}: cannot read its parameters from {self.master_uri}: {err}")

    def _refresh_params(self, now: float) -> None:
        with self._lock:
            due = self.params is not None and not self.core.pending and now >= self._next_refresh
            if due:
                self._next_refresh = now + self.param_refresh
        if due:
            self.remember_params()

    def _restore_params(self) -> None:
        """Before re-registering: the parameters a restarted master lost (raises MasterWatchError)."""
        if self.params is None:
            return
        try:
            names = self.params.restore(proxy(self.master_uri, self.timeout), self.caller_id)
        except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError) as err:
            raise MasterWatchError(f"restoring the parameters of {self.caller_id} on {self.master_uri} "
                                   f"failed: {err}") from err
        if names:
            self.log.info(f"{self.caller_id}: master {self.master_uri} had lost {len(names)} parameter(s) of "
                          f"this node; set them again: {', '.join(names[:8])}{' ...' if len(names) > 8 else ''}")

    def _run(self) -> None:
        while not self._stop.is_set():
            start = time.monotonic()
            try:
                self.poll_once(start)
            except Exception as err:  # noqa: BLE001 - the watch thread must survive anything
                self.log.error(f"{self.caller_id}: master watch poll failed: {err!r}")
            self._stop.wait(max(0.0, self.period - (time.monotonic() - start)))


def rospy_registrations() -> Registrations:
    """The current publications, subscriptions and services of this rospy node."""
    from gidabot_navigation.ros.rospy_internals import node_registrations

    publications, subscriptions, services = node_registrations()
    return Registrations(publications=publications, subscriptions=subscriptions, services=services)


def keep_registered(period: float = DEFAULT_PERIOD, timeout: float = DEFAULT_TIMEOUT,
                    log: Logger | None = None, restore_keys: tuple[str, ...] = RESTORED_KEYS) -> MasterWatch:
    """Start the master watch of this rospy node (call once, right after ``rospy.init_node``).

    Returns the :class:`MasterWatch`: ``up`` tells whether the master answers,
    ``add_listener`` gets DOWN / REREGISTER events. Parameters in seconds (wall time).
    The node's private parameters and ``restore_keys`` are remembered now and set again
    on a restarted master that lost them (:class:`ParamKeeper`). rospy's own calls to the
    master are bounded (:func:`bound_master_calls`) and its logging never calls the master
    (:func:`gidabot_navigation.ros.log.never_block_on_rosout`).
    """
    import rosgraph
    import rospy

    from gidabot_navigation.ros.log import ROSOUT_TOPICS_PARAM, RosLog, never_block_on_rosout
    from gidabot_navigation.ros.rospy_internals import node_initialized

    if not node_initialized():
        raise MasterWatchError("keep_registered() must be called after rospy.init_node()")
    if not period > 0 or not timeout > 0:
        raise MasterWatchError(f"period and timeout must be positive seconds, got {period!r} and {timeout!r}")
    node_uri = rospy.get_node_uri()
    if not node_uri:
        raise MasterWatchError("this node has no slave API URI yet; call keep_registered() after rospy.init_node()")
    bound_master_calls()
    try:   # what the master says, if it answers at once; rospy's default otherwise
        code, _, value = proxy(rosgraph.get_master_uri(), timeout).getParam(rospy.get_caller_id(), ROSOUT_TOPICS_PARAM)
    except (OSError, xmlrpc.client.Error, http.client.HTTPException, ValueError):
        code, value = 0, False
    never_block_on_rosout(bool(value) if code == 1 else None)
    watch = MasterWatch(master_uri=rosgraph.get_master_uri(), caller_id=rospy.get_caller_id(), node_uri=node_uri,
                        registrations=rospy_registrations, log=log or RosLog(), period=period,
                        timeout=timeout, params=ParamKeeper(rospy.get_name(), tuple(restore_keys)))
    watch.remember_params()
    watch._next_refresh = time.monotonic() + watch.param_refresh
    return watch.start()
