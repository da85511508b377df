"""How the guiding, tour and GUI nodes start and run: :func:`start_node` (the exit guard installed before
``init_node``, for a prompt exit on SIGINT/SIGTERM, master frozen or not: docs/interfaces.md; then the node
found again after a master restart), :func:`run_node` (the ``main()`` of the guiding and tour nodes: a
fatal log line and exit status 1 when the node cannot start, a bad parameter or file; then the node's loop
and the guard's spin, the shutdown running in the guard's thread) and :func:`run_loop` (their loop)."""

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


def start_node(name: str, argv: list[str] | None = None) -> ExitGuard:
    """Start node ``name``: its exit guard (exit within 1 s of SIGINT/SIGTERM, master frozen or not), then
    ``init_node`` (rospy's own signal handlers off) and the master watch (:func:`keep_registered`)."""
    guard = rospy_exit_guard(name, main_loop=True)
    rospy.init_node(name, argv=argv if argv is not None else sys.argv, disable_signals=True)
    keep_registered()    # found again after its master restarts
    return guard


def run_loop(guard: ExitGuard, spin_once: Callable[[float], None], period: float, wake: Callable[[], None],
             finish: Callable[[], None]) -> None:
    """A node's loop: ``spin_once(period)`` (one input, or none within ``period`` wall s) until shutdown or the
    guard's signal, which calls ``wake`` (an input that ends the wait at once); then ``finish()`` (save, close)
    and the guard told the loop has stopped (only then does it close the topics)."""
    guard.set_wake(wake)
    try:
        while not rospy.is_shutdown() and not guard.requested:
            spin_once(period)
    finally:
        try:
            finish()
        finally:
            guard.loop_stopped()


def run_node(name: str, make: Callable[[], N], started: Callable[[N], str], argv: list[str] | None = None) -> int:
    """Run node ``name``: ``make()`` builds it once ROS is up (its GidaBotError, OSError or ValueError ends
    the process with a fatal log line, status 1), ``started(node)`` is logged, ``node.run(guard)`` runs its
    loop until shutdown."""
    guard = start_node(name, argv)
    try:
        node = make()
    except (GidaBotError, OSError, ValueError) as err:
        rospy.logfatal(f"{name} cannot start: {err}")
        return 1
    rospy.loginfo(started(node))
    node.run(guard)
    guard.spin(rospy.is_shutdown)     # the shutdown runs in the guard's thread, never in this one
    return 0
