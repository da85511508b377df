"""When a relay end may publish the events it received again (ROS-free): the delivery hold.

A restarted master has no subscriber registered; an event a relay end published then would reach
nobody and be lost. So an end holds delivery (:meth:`RelayEndCore.set_delivery_open`) at start
and whenever its master went away, and :class:`DeliveryHold` decides when to release it: once the
master answers again and every subscriber of the shared event topics is connected to the end's
publishers, or ``grace`` s after the master came back (then it says who is still missing).

"Every subscriber" is the union of the non-relay subscribers connected before the hold (remembered
while delivery is open) and those the master lists now; relays are never waited for. The adapter
(:mod:`gidabot_navigation.relay.end_node`) reports the master's events, passes the subscribers
connected to its publishers and those the master lists (it asks the master only while
:meth:`DeliveryHold.deciding`), and opens delivery when :meth:`DeliveryHold.update` says so.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from gidabot_navigation.interface import is_relay_end

Subscribers = Mapping[str, Iterable[str]]     # topic -> caller ids of its subscribers


@dataclass(frozen=True)
class Release:
    """Delivery opens again; ``missing``: topic -> subscribers still not connected (grace over)."""

    missing: dict[str, list[str]]

    @property
    def why(self) -> str:
        if not self.missing:
            return "every subscriber is connected"
        return "grace period over, still missing " + "; ".join(f"{t}: {', '.join(m)}"
                                                                 for t, m in self.missing.items())


class DeliveryHold:
    """The hold of one relay end over its event topics ``topics`` (times in the caller's clock, s).

    It starts held, released at the latest ``grace`` s after ``now``.
    """

    def __init__(self, topics: Iterable[str], grace: float, now: float) -> None:
        self.grace = grace
        self.expected: dict[str, set[str]] = {t: set() for t in topics}
        self.held = True
        self.deadline: float | None = now + grace

    def master_down(self) -> None:
        """The master stopped answering: hold, with no deadline until it is back."""
        self.held = True
        self.deadline = None

    def master_back(self, now: float) -> None:
        """The master answers again (this end registered anew): hold, at most ``grace`` s more."""
        self.held = True
        self.deadline = now + self.grace

    def deciding(self, master_up: bool) -> bool:
        """Whether :meth:`update` decides a release now (then it needs the registered subscribers)."""
        return self.held and self.deadline is not None and master_up

    def update(self, now: float, connected: Subscribers, master_up: bool,
               registered: Subscribers) -> Release | None:
        """A look at the subscribers: ``connected`` are those connected to this end's publishers now,
        ``registered`` those the master lists (asked only when :meth:`deciding`; {} if it does not
        answer). Returns a :class:`Release` when the hold ends now, else None. While delivery is open,
        it remembers who is connected (the subscribers a later hold waits for)."""
        current = {t: {n for n in connected.get(t, ()) if not is_relay_end(n or "")} for t in self.expected}
        if not self.held:
            if master_up:
                self.expected = current
            return None
        deadline = self.deadline
        if deadline is None or not master_up:
            return None
        want = {t: {n for n in self.expected[t] | set(registered.get(t, ())) if not is_relay_end(n)}
                for t in current}
        missing = {t: sorted(want[t] - current[t]) for t in current if want[t] - current[t]}
        if missing and now < deadline:
            return None
        self.held = False
        self.deadline = None
        return Release(missing)


def subscribers_in_system_state(state: object, topics: Iterable[str]) -> dict[str, set[str]]:
    """The subscribers of ``topics`` in the ``[publishers, subscribers, services]`` of a master's
    ``getSystemState`` answer ({} for anything else)."""
    wanted = set(topics)
    try:
        subs = state[1]                                      # type: ignore[index]
        return {str(topic): {str(n) for n in nodes} for topic, nodes in subs if topic in wanted}
    except (TypeError, IndexError, ValueError):
        return {}
