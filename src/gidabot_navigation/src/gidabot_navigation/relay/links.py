"""A robot's relay links as it sees them, from its relay ends' diagnostics (ROS-free).

Every relay end publishes ``relay <A>-<B>: <robot>`` on ``/diagnostics`` of its own master at 1 Hz, hardware
id = its node name (docs/relay.md, *Diagnostics*). :func:`link_of` recognises the status of one of this robot's
own ends and reads what a staff dashboard shows of the link; :class:`LinkSummaryData` is
``gidabot_msgs/LinkSummary`` (``/gidabot/links``), what a robot tells the others about its links.
Diagnostic values are text: anything that does not read as its type counts as unknown, never as an error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from gidabot_navigation.building.model import Building
from gidabot_navigation.interface import relay_end_name

RELAY_STATUS_PREFIX = "relay "


@dataclass(frozen=True)
class DiagnosticData:
    """One ``diagnostic_msgs/DiagnosticStatus``: its name, level (0 OK, 1 WARN, 2 ERROR, 3 STALE), message,
    hardware id and values."""

    name: str
    level: int
    message: str = ""
    hardware_id: str = ""
    values: Mapping[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class LinkData:
    """``gidabot_msgs/LinkState``: one link as the robot at one end sees it."""

    peer: str
    known: bool = False
    connected: bool = False
    down_s: float = 0.0
    heard_s: float = 0.0
    rtt_ms: float = -1.0
    queued: int = 0
    resent: int = 0
    dropped: int = 0
    duplicates_suppressed: int = 0
    link_losses: int = 0
    peer_master_up: bool = False   # False only when the peer said its master does not answer


@dataclass(frozen=True)
class LinkSummaryData:
    """``gidabot_msgs/LinkSummary``: ``robot``'s links, one per other robot of the building."""

    robot: str
    links: tuple[LinkData, ...] = ()
    stamp: float = 0.0


def own_ends(building: Building, robot: str) -> dict[str, str]:
    """The node names of ``robot``'s relay ends (one per other robot), each mapped to the robot at its other end."""
    out = {}
    for a, b in building.relay_pairs():
        if robot in (a.name, b.name):
            out[relay_end_name(a.name, b.name)] = b.name if a.name == robot else a.name
    return out


def _number(values: Mapping[str, str], key: str, default: float) -> float:
    try:
        number = float(values.get(key, ""))
    except (TypeError, ValueError):
        return default
    return number if math.isfinite(number) else default


def _count(values: Mapping[str, str], key: str) -> int:
    number = _number(values, key, 0.0)
    return int(number) if 0 <= number < 2 ** 32 else 0


def _flag(values: Mapping[str, str], key: str) -> bool:
    return values.get(key) == "True"


def link_of(status: DiagnosticData, ends: Mapping[str, str], heard_s: float = 0.0) -> LinkData | None:
    """The link a relay end's status describes when it is one of this robot's own ends (``ends``:
    :func:`own_ends`), else None. ``heard_s``: s since the status was received."""
    if not status.name.startswith(RELAY_STATUS_PREFIX) or status.hardware_id not in ends:
        return None
    v = status.values
    connected = _flag(v, "connected")
    down = 0.0 if connected else max(0.0, _number(v, "link_down_s", 0.0))
    rtt = _number(v, "rtt_ms", -1.0)
    return LinkData(peer=ends[status.hardware_id], known=True, connected=connected, down_s=down,
                    heard_s=max(0.0, heard_s), rtt_ms=rtt if rtt >= 0 else -1.0, queued=_count(v, "queue_depth"),
                    resent=_count(v, "resent"), dropped=_count(v, "dropped"),
                    duplicates_suppressed=_count(v, "duplicates_suppressed"),
                    link_losses=_count(v, "link_losses"), peer_master_up=v.get("peer_master_up") != "False")
