"""The exception hierarchy of gidabot_sim (ROS-free).

Every message names the bad value and what was expected. The simulator and the
navigation stand-ins catch these at their ROS boundary: the input is logged,
counted and dropped, the node keeps running.
"""

from __future__ import annotations

from gidabot_navigation.errors import GidaBotError


class SimError(GidaBotError):
    """Base class of every error raised by gidabot_sim."""


class SimConfigError(SimError):
    """A simulator / stand-in parameter is invalid (not finite, out of range, unknown robot or floor)."""


class PoseRejected(SimError):
    """A pose cannot be used: not finite, outside the map, inside a wall, an obstacle or another robot."""


class CommandRejected(SimError):
    """A velocity command is not usable (NaN or infinite components)."""


class ObstacleRejected(SimError):
    """A run-time obstacle command is invalid (bad id, shape, size, action, or it overlaps a robot)."""


class NavGoalRejected(SimError):
    """A navigation goal (of the move_base stand-in) is invalid (not finite, invalid quaternion, wrong frame)."""


class PlanRefused(SimError):
    """The move_base stand-in refuses a make_plan request (as move_base does while a goal runs)."""


class StepDoneRejected(SimError):
    """A lockstep participant's answer (gidabot_msgs/StepDone) is malformed, or one participant too many."""


class ProcessError(SimError):
    """A managed process could not be started or stopped, or a wait timed out."""


class DemoError(SimError):
    """The simulated building cannot be started or run (a master, a launch or a recorder failed)."""


class ChaosError(DemoError):
    """The chaos run cannot go on (a probe died, the building did not come up)."""


class FaultError(SimError):
    """A fault could not be injected or cleared."""


class ReportError(SimError):
    """A run folder cannot be reported on (missing files, unreadable bags)."""


class MachinesError(SimError):
    """The separate machines (network namespaces, links, firewalls, faults) cannot be set up or changed."""
