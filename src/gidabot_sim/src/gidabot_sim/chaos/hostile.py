"""The hostile messages ``gidabot chaos`` publishes (ROS-free): one at a time, on one master, each to be rejected
and counted by a node of that master.

Goals with NaN or infinite poses, unknown floors or rooms, 300,000-character strings or a robot that does not
exist; cancels of goals nobody knows; tours with path or device file names; events with unknown phases; statuses,
poses and pending lists with NaN numbers; visitor commands of unknown kinds; an ``initialpose`` and an obstacle
with NaN coordinates. A message is a template (:class:`Hostile`); :func:`fill_placeholders` makes it for one
master's robot, and the chaos probe (``gidabot_sim.chaos.probe_node``) publishes it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from gidabot_navigation.interface import Topic

# counters by which a node says it refused (or, for a cancel of a goal never seen, kept aside) a message
HOSTILE_COUNTERS = ("rejected_", "cancel_unknown")


@dataclass(frozen=True)
class Hostile:
    """One hostile message: ``msg`` fields ("nan", "inf", "-inf" for floats; ``["__repeat__", c, n]`` for
    a string of n characters c); ``{robot}`` in a string is this master's robot, ``{other}`` another's."""

    name: str
    topic: str
    type: str
    msg: dict[str, Any]


def _goal(**kw: Any) -> dict[str, Any]:
    base = {"uid": "{robot}/chaos/h.1", "origin_robot": "{robot}", "visitor_id": "chaos", "initial_floor": 0.0,
            "initial_pose": {"x": 30.0, "y": 12.0}, "goal_floor": 0.0,
            "goal_pose": {"position": {"x": 30.0, "y": 12.0}, "orientation": {"w": 1.0}}, "way": "stairs",
            "connector": "", "start_id": "robot", "goal_id": "001", "language": "en", "tour_step": -1}
    base.update(kw)
    return base


HOSTILE_MESSAGES: tuple[Hostile, ...] = (
    Hostile("goal_nan_pose", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/nan.1", initial_pose={"x": "nan", "y": 12.0})),
    Hostile("goal_inf_pose", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/inf.1", goal_pose={"position": {"x": "inf", "y": "-inf"},
                                                        "orientation": {"w": "nan"}})),
    Hostile("goal_unknown_floor", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/floor.1", goal_floor=7.5)),
    Hostile("goal_unknown_room", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/room.1", goal_id="999")),
    Hostile("goal_huge_strings", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="{robot}/chaos/huge.1", goal_id=["__repeat__", "9", 300_000],
                  visitor_id=["__repeat__", "v", 200_000])),
    Hostile("goal_ghost_robot", Topic.GOALS, "gidabot_msgs/Goal",
            _goal(uid="Ghost/chaos/ghost.1", origin_robot="Ghost")),
    Hostile("cancel_unknown_goal", Topic.CANCELS, "gidabot_msgs/Cancel",
            {"uid": "{robot}/cancel/chaos.1", "goal_uid": "{robot}/nobody/chaos.404", "origin_robot": "{robot}",
             "reason": "visitor"}),
    Hostile("cancel_ghost_robot", Topic.CANCELS, "gidabot_msgs/Cancel",
            {"uid": "Ghost/cancel/chaos.2", "goal_uid": "{other}/v/gm.x.1", "origin_robot": "Ghost",
             "reason": "because"}),
    Hostile("tour_path_name", Topic.TOURS, "gidabot_msgs/Tour",
            {"uid": "{robot}/tour/chaos.1", "origin_robot": "{robot}", "editor_robot": "{robot}",
             "version": 4_000_000_000_000_000_000, "language": "en", "floor": 0.0, "tour_name": "Escape",
             "file_name": "../../../etc/chaos.tour", "tour_goals_info": ["0, 001, Copy Shop"]}),
    Hostile("tour_device_name", Topic.TOURS, "gidabot_msgs/Tour",
            {"uid": "{robot}/tour/chaos.2", "origin_robot": "{robot}", "editor_robot": "{robot}",
             "version": 1_700_000_000_000_000_000, "language": "en", "floor": 0.0, "tour_name": "Dev",
             "file_name": "con.tour", "tour_goals_info": ["0, 001, Copy Shop"]}),
    Hostile("tour_edit_hidden_name", Topic.TOUR_EDIT, "gidabot_msgs/Tour",
            {"file_name": ".gidabot-tours.json", "tour_name": "Hidden", "language": "en", "floor": 0.0,
             "tour_goals_info": ["0, 001, Copy Shop\n9, 999, injected line"]}),
    Hostile("event_unknown_phase", Topic.NAV_EVENTS, "gidabot_msgs/NavEvent",
            {"uid": "Ghost/event/chaos.1", "robot": "Ghost", "floor": "nan", "goal_uid": "{robot}/v/x",
             "phase": 200, "tour_step": 9999}),
    Hostile("status_nan_pose", Topic.STATUS, "gidabot_msgs/RobotStatus",
            {"robot": "Ghost", "floor": "inf", "nav_pose": {"position": {"x": "nan", "y": "nan"},
                                                            "orientation": {"w": "nan"}},
             "battery": "nan", "state": ["__repeat__", "s", 100_000]}),
    Hostile("pose_inf", Topic.POSES, "gidabot_msgs/NavPose",
            {"robot": "Ghost", "floor": 42.0, "nav_pose": {"position": {"x": "inf", "y": "-inf"}}}),
    Hostile("pending_spoofed", Topic.PENDING, "gidabot_msgs/PendingRequests",
            {"robot": "{robot}", "floor": "nan", "num": 3, "eta": ["nan", "inf"], "wait_new": "-inf"}),
    Hostile("command_unknown_room", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": "{robot}/chaos/cmd/1", "visitor_id": "chaos", "command": 0, "goal_id": "no-such-room",
             "way": "stairs", "language": "en", "tour_step": -1}),
    Hostile("command_hostile_tour", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": "{robot}/chaos/cmd/2", "visitor_id": "chaos", "command": 3, "tour_file": "../../x\\y.tour",
             "language": "xx", "tour_step": -5}),
    Hostile("command_unknown_kind", Topic.VISITOR_COMMAND, "gidabot_msgs/VisitorCommand",
            {"uid": ["__repeat__", "u", 5000], "visitor_id": "chaos", "command": 77, "goal_uid": "nope"}),
    Hostile("initialpose_nan", Topic.INITIALPOSE, "geometry_msgs/PoseWithCovarianceStamped",
            {"header": {"frame_id": "map"}, "pose": {"pose": {"position": {"x": "nan", "y": 3.0},
                                                              "orientation": {"w": 1.0}}}}),
    Hostile("obstacle_nan", Topic.SIM_OBSTACLE, "gidabot_msgs/Obstacle",
            {"id": "chaos_nan", "action": 0, "shape": 0, "x": "nan", "y": "inf", "radius": -1.0}),
)


def hostile_by_name(name: str) -> Hostile:
    for h in HOSTILE_MESSAGES:
        if h.name == name:
            return h
    raise KeyError(f"unknown hostile message {name!r} (known: {', '.join(h.name for h in HOSTILE_MESSAGES)})")


def fill_placeholders(value: Any, robot: str, other: str) -> Any:
    """``{robot}`` / ``{other}`` in every string of a message template."""
    if isinstance(value, str):
        return value.replace("{robot}", robot).replace("{other}", other)
    if isinstance(value, dict):
        return {k: fill_placeholders(v, robot, other) for k, v in value.items()}
    if isinstance(value, list) and not (value and value[0] == "__repeat__"):
        return [fill_placeholders(v, robot, other) for v in value]
    return value
