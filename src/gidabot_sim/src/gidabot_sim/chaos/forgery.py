"""Forged messages about real trips (ROS-free): what ``gidabot chaos`` publishes to try to take a trip over.

For a goal uid a forger has seen on its master (a real trip), :func:`forgeries` makes the messages an attacker
on the robots' network would send to end or hijack it: a goal with that uid and other content, a cancel of it, a
final event (``GOAL_REACHED``, ``REJECTED``) for it, all speaking for the trip's origin robot; and the same for
the uids that would come next if uids were predictable (the token counted on: :func:`next_uids`), to squat them
before they exist. The forger is not one of the robot's nodes (the chaos probe ``/chaos_probe``, or a node named
like the relay end of a link the building does not have, :func:`impostor_relay`): every node that receives one
must refuse it and count it (``refused_*``, ``rejected_impostor`` in its ``/diagnostics``), never answer it.

:data:`RECEIVERS` says which of a robot's nodes with refusal counters subscribe each forged topic, and
:func:`account` checks, node by node, that each counted at least as many refusals as forged messages reached it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from gidabot_navigation.interface import Phase, Topic, relay_end_name
from gidabot_navigation.senders import UID_RE

GOAL_TYPE, CANCEL_TYPE, EVENT_TYPE = "gidabot_msgs/Goal", "gidabot_msgs/Cancel", "gidabot_msgs/NavEvent"
NEXT_UIDS = 2                  # uids after a real one a forger tries to squat
GHOST = "Ghost"                # a robot no building has: the far end of an impostor relay's link
# the diagnostics status (name without its robot) of each node of a robot that counts refusals, and the forged
# topics it subscribes: each forged message on one of them reaches it once
RECEIVERS: dict[str, tuple[str, ...]] = {
    "guiding: goal_manager": (Topic.GOALS, Topic.CANCELS, Topic.NAV_EVENTS),
    "guiding: navigation": (Topic.CANCELS, Topic.NAV_EVENTS),
    "sim: visitor": (Topic.NAV_EVENTS,),
}


@dataclass(frozen=True)
class Forged:
    """One forged message: ``name`` says what it tries, ``msg`` its fields (the chaos probe's message dicts)."""

    name: str
    topic: str
    type: str
    msg: dict[str, Any]


def impostor_relay(robot: str) -> str:
    """A node name like a relay end on ``robot``'s master, of a link to a robot the building does not have."""
    return relay_end_name(robot, GHOST)


def next_uids(uid: str, n: int = NEXT_UIDS) -> list[str]:
    """The ``n`` uids after ``uid`` if its token were a counter (same length, hex); for a uid not of
    ``senders.UID_FORMAT``, ``uid`` with a digit appended."""
    m = UID_RE.match(uid)
    if m is None:
        return [f"{uid}{k}" for k in range(1, n + 1)]
    token = m.group("token")
    head = uid[: m.start("token")]
    width = len(token)
    return [head + format((int(token, 16) + k) % (1 << (4 * width)), f"0{width}x") for k in range(1, n + 1)]


def _goal(uid: str, origin: str) -> dict[str, Any]:
    """A goal of ``origin`` with ``uid`` and content no real trip of the tour has (a room on floor 0)."""
    return {"uid": uid, "origin_robot": origin, "visitor_id": "forged", "initial_floor": 0.0,
            "initial_pose": {"x": 30.0, "y": 12.0}, "goal_floor": 0.0,
            "goal_pose": {"position": {"x": 9.0, "y": 11.4}, "orientation": {"w": 1.0}}, "way": "stairs",
            "connector": "", "start_id": "robot", "goal_id": "001", "language": "en", "tour_step": -1,
            "start_robot": origin, "start_state": 2, "attempt": 99}


def forgeries(uid: str, origin: str, serial: int, n_next: int = NEXT_UIDS) -> list[Forged]:
    """What a forger sends for the real goal ``uid`` of robot ``origin``: a goal with its uid and other content,
    a cancel, a ``GOAL_REACHED`` and a ``REJECTED`` for it; a goal, a cancel and a ``GOAL_REACHED`` for each of
    the ``n_next`` uids after it. The forged messages' own uids are in ``origin``'s namespace (``serial`` makes
    them unique per forger)."""

    def own_uid(scope: str, k: int) -> str:
        return f"{origin}/{scope}/forge.{serial:08x}{k:08x}"

    def cancel(goal_uid: str, k: int) -> dict[str, Any]:
        return {"uid": own_uid("cancel", k), "goal_uid": goal_uid, "origin_robot": origin, "reason": "visitor"}

    def event(goal_uid: str, phase: Phase, k: int) -> dict[str, Any]:
        return {"uid": own_uid("event", k), "robot": origin, "floor": 0.0, "goal_uid": goal_uid, "phase": int(phase),
                "tour_step": -1, "leg": "start", "detail": "forged"}

    out = [Forged("goal_same_uid", Topic.GOALS, GOAL_TYPE, _goal(uid, origin)),
           Forged("cancel", Topic.CANCELS, CANCEL_TYPE, cancel(uid, 0)),
           Forged("event_goal_reached", Topic.NAV_EVENTS, EVENT_TYPE, event(uid, Phase.GOAL_REACHED, 1)),
           Forged("event_rejected", Topic.NAV_EVENTS, EVENT_TYPE, event(uid, Phase.REJECTED, 2))]
    for i, nxt in enumerate(next_uids(uid, n_next)):
        k = 3 * (i + 1)
        out += [Forged("goal_next_uid", Topic.GOALS, GOAL_TYPE, _goal(nxt, origin)),
                Forged("cancel_next_uid", Topic.CANCELS, CANCEL_TYPE, cancel(nxt, k)),
                Forged("event_next_uid", Topic.NAV_EVENTS, EVENT_TYPE, event(nxt, Phase.GOAL_REACHED, k + 1))]
    return out


def reaching(sent: Mapping[str, int]) -> dict[str, int]:
    """Forged messages that reached each refusing node (:data:`RECEIVERS`), from the number sent per topic."""
    return {node: sum(sent.get(t, 0) for t in topics) for node, topics in RECEIVERS.items()}


@dataclass(frozen=True)
class NodeAccount:
    """One node of one master: forged messages that reached it and refusals it counted meanwhile."""

    robot: str
    node: str
    sent: int
    refused: int

    @property
    def accounted(self) -> bool:
        return self.refused >= self.sent

    def row(self) -> dict[str, Any]:
        return {"robot": self.robot, "node": self.node, "sent": self.sent, "refused": self.refused,
                "accounted": self.accounted}


def account(robot: str, sent: Mapping[str, int], refused: Mapping[str, int]) -> list[NodeAccount]:
    """Each refusing node of ``robot``'s master: forged messages ``sent`` (per topic) that reached it against its
    ``refused`` count (status name without the robot -> refusals counted while they were sent). The relay ends
    are not among them: an end drops its connection to any publisher named like a relay end at once, so what a
    forger of such a name publishes does not reach it (and the chaos probe's messages are the hostile faults')."""
    return [NodeAccount(robot, node, n, int(refused.get(node, 0))) for node, n in reaching(sent).items()]


def status_node(status_name: str, robot: str) -> str:
    """A diagnostics status name without its robot (``guiding: goal_manager Tartalo`` -> ``guiding: goal_manager``)."""
    suffix = f" {robot}"
    return status_name[: -len(suffix)] if status_name.endswith(suffix) else status_name


def refusals(counters: Mapping[str, Mapping[str, int]], robot: str) -> dict[str, int]:
    """The ``refused`` total of each node of ``robot``'s master from the chaos probe's counters (status name ->
    counters)."""
    return {status_node(name, robot): int(values["refused"]) for name, values in counters.items()
            if "refused" in values}


def grown(before: Mapping[str, int], after: Mapping[str, int]) -> dict[str, int]:
    """Refusals counted between two readings, per node; a node that restarted meanwhile (its count went down)
    counts from 0."""
    return {n: (v - before.get(n, 0) if v >= before.get(n, 0) else v) for n, v in after.items()}
