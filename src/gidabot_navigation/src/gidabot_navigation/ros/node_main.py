"""The ``main()`` of a robot's long-running guiding and tour nodes: the exit guard installed before
``init_node`` (a prompt exit on SIGINT/SIGTERM, master frozen or not: docs/interfaces.md), found again
after a master restart, a fatal log line and exit status 1 when the node cannot start (a bad parameter or
file), then the node's loop and the guard's spin (the shutdown runs in the guard's thread)."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Protocol, TypeVar

import rospy

from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.ros.exit_guard import ExitGuard, rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered


class GuardedNode(Protocol):
    def run(self, guard: ExitGuard) -> None: ...


N = TypeVar("N", bound=GuardedNode)


def run_node(name: str, make: Callable[[], N], started: Callable[[N], str], argv: list[str] | None = None) -> int:
    """Run node ``name``: ``make()`` builds it once ROS is up (its GidaBotError, OSError or ValueError ends
    the process with a fatal log line, status 1), ``started(node)`` is logged, ``node.run(guard)`` runs its
    loop until shutdown."""
    guard = rospy_exit_guard(name, main_loop=True)   # exit within 1 s of SIGINT/SIGTERM, master frozen
    rospy.init_node(name, argv=argv if argv is not None else sys.argv, disable_signals=True)
    keep_registered()    # found again after its master restarts
    try:
        node = make()
    except (GidaBotError, OSError, ValueError) as err:
        rospy.logfatal(f"{name} cannot start: {err}")
        return 1
    rospy.loginfo(started(node))
    node.run(guard)
    guard.spin(rospy.is_shutdown)     # the shutdown runs in the guard's thread, never in this one
    return 0
