"""ROS adapter of the relay supervisor: the ``/relay_supervisor`` node.

Core: :mod:`gidabot_navigation.relay.supervisor`. This module reads the node's parameters
(:class:`Params`), starts the supervisor on this robot's ends and publishes its status
(:func:`diagnostic_status`).
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError, RelayConfigError
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.relay.end import read_secret
from gidabot_navigation.relay.supervisor import EndOptions, EndSpec, RelaySupervisor, plan_relays

if TYPE_CHECKING:
    from diagnostic_msgs.msg import DiagnosticStatus


class RelaySupervisorNode:
    """Starts and keeps running this robot's relay ends (node ``/relay_supervisor``).

    For every other robot of the building, this robot's end of their relay ``/gidabot_relay_<A>_<B>``
    (A listed first; see :class:`gidabot_navigation.relay.end_node.RelayEndNode`), on this robot's
    master: it connects to the other robot's end (listed after this one) or listens for it (listed
    before), on the ports of the building file (docs/deploy.md).

    Published topics:
      - ``/diagnostics`` (diagnostic_msgs/DiagnosticArray, wall-time stamps: no ``/clock``), 1 Hz:
        ``relay_supervisor: <robot>``
        with, per end (key ``<A>_<B>.<side>``), "pid P, restarts R, last exit E, link host:port".

    Parameters:
      - ``~building`` (str, required): building.yaml or its directory.
      - ``~robot`` (str, required): this robot's name in the building.
      - ``~state_dir`` (str, required): directory of the ends' journals.
      - ``~secret_file`` (str, default ''): file holding the shared secret (HMAC-SHA256); '' = none.
      - ``~topics_file`` (str, default the package's ``config/shared_topics.yaml``).
      - ``~end_params`` (dict, default {}): further options for every end
        (e.g. ``{max_queue: 10000, heartbeat: 0.5}``; see RelayEndNode).
    """

    def __init__(self, params: Params) -> None:
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray

        self.rospy = rospy
        self.robot = params.robot
        building = load_building(params.building)
        building.robot(self.robot)                    # KeyError with the known names
        ends = plan_relays(building, self.robot)
        self.sup = RelaySupervisor(ends, params.end_options(), self._log)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        rospy.loginfo(f"relay_supervisor of {self.robot}: {len(ends)} relay end(s)"
                      f"{': ' + ', '.join(_describe(e) for e in ends) if ends else ' (the only robot)'}; "
                      f"{'HMAC-SHA256' if params.secret_file else 'NO authentication (no secret file)'}")

    def _log(self, level: str, msg: str) -> None:
        {"info": self.rospy.loginfo, "warning": self.rospy.logwarn, "error": self.rospy.logerr}[level](msg)

    def run(self) -> None:
        rospy = self.rospy
        next_diag = 0.0
        try:
            while not rospy.is_shutdown():
                now = time.monotonic()
                self.sup.step(now)
                if now >= next_diag:
                    next_diag = now + 1.0
                    self._diagnostics()
                time.sleep(0.2)
        finally:
            self.sup.stop()

    def _diagnostics(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray

        arr = DiagnosticArray()
        arr.header.stamp = self.rospy.Time.now()
        arr.status = [diagnostic_status(self.robot, self.sup.status())]
        with contextlib.suppress(self.rospy.ROSException):
            self.diag_pub.publish(arr)


@dataclass(frozen=True)
class Params:
    """The supervisor's private parameters (see :class:`RelaySupervisorNode`)."""

    building: str
    robot: str
    state_dir: str
    secret_file: str = ""
    topics_file: str = ""
    end_params: tuple[tuple[str, str], ...] = ()

    @staticmethod
    def parse(get_param: Callable[[str, object], object]) -> Params:
        """Read them with ``get_param(name, default)`` (``rospy.get_param``); RelayConfigError names
        what is missing or wrong. A secret file is read once here: it fails clearly here, not in every end."""
        building, robot, state_dir = (str(get_param(f"~{k}", "") or "") for k in ("building", "robot", "state_dir"))
        if not building or not robot or not state_dir:
            raise RelayConfigError(f"~building, ~robot and ~state_dir are required (got {building!r}, {robot!r}, "
                                   f"{state_dir!r})")
        secret_file = str(get_param("~secret_file", "") or "")
        if secret_file:
            read_secret(secret_file)
            secret_file = str(Path(secret_file).resolve())
        extra = get_param("~end_params", {}) or {}
        if not isinstance(extra, dict):
            raise RelayConfigError(f"~end_params must be a mapping, got {extra!r}")
        return Params(building=building, robot=robot, state_dir=state_dir, secret_file=secret_file,
                      topics_file=str(get_param("~topics_file", "") or ""),
                      end_params=tuple((str(k), str(v)) for k, v in extra.items()))

    def end_options(self) -> EndOptions:
        """What every end gets; creates the state directory."""
        Path(self.state_dir).mkdir(parents=True, exist_ok=True)
        return EndOptions(state_dir=str(Path(self.state_dir).resolve()), secret_file=self.secret_file,
                          topics_file=self.topics_file, extra=self.end_params)


def diagnostic_status(robot: str, rows: list[tuple[str, int | None, int, int | None, str]]) -> DiagnosticStatus:
    """The supervisor's ``/diagnostics`` status from :meth:`RelaySupervisor.status` rows
    ``(key, pid or None, restarts, last exit, link)``: WARN while an end is not running."""
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

    status = DiagnosticStatus()
    status.name = f"relay_supervisor: {robot}"
    status.hardware_id = robot
    down = [row[0] for row in rows if row[1] is None]
    status.level = DiagnosticStatus.WARN if down else DiagnosticStatus.OK
    status.message = f"{len(rows) - len(down)}/{len(rows)} relay ends running"
    for key, pid, restarts, last, link in rows:
        status.values.append(KeyValue(key, f"pid {pid if pid else '-'}, restarts {restarts}, "
                                           f"last exit {last}, link {link}"))
    return status


def _describe(end: EndSpec) -> str:
    if end.side == "a":
        return f"{end.pair} (connects to {end.robot_b} at {end.link_host}:{end.link_port})"
    return f"{end.pair} (listens for {end.robot_a} on {end.link_host}:{end.link_port})"


def main(argv: list[str] | None = None) -> int:
    import rospy

    from gidabot_navigation.ros.exit_guard import rospy_exit_guard
    from gidabot_navigation.ros.master_watch import bound_master_calls, keep_registered

    # exit within 1.5 s of SIGINT/SIGTERM, master frozen or not: the ends it stops exit within 1 s
    # (their own guards), and any end still there then gets SIGTERM from the kernel (PR_SET_PDEATHSIG)
    bound_master_calls()     # init_node's own calls to a master that does not answer are bounded too
    guard = rospy_exit_guard(Node.RELAY_SUPERVISOR, grace=1.5)
    rospy.init_node(Node.RELAY_SUPERVISOR, argv=argv if argv is not None else sys.argv, disable_rostime=True,
                    disable_signals=True)
    keep_registered()
    try:
        node = RelaySupervisorNode(Params.parse(rospy.get_param))
    except (GidaBotError, KeyError, OSError) as err:
        rospy.logfatal(f"relay_supervisor cannot start: {err}")
        return 1
    node.run()
    guard.spin(rospy.is_shutdown)     # the shutdown runs in the guard's thread, never in this one
    return 0
