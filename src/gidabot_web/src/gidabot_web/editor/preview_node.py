"""The building editor's pose reader (a ROS node, only in a preview): every robot's latest pose, in a JSON file.

Runs on the first robot's master of a preview's simulated building (the relays bring it every robot's
``/gidabot/poses``), keeps the latest valid pose of each robot (:class:`~gidabot_web.editor.preview.PoseBook`)
and replaces the file ``~out`` with them five times a second (wall time) when they changed. The editor's server
reads that file (:mod:`gidabot_web.editor.preview`): it needs no ROS itself.
"""

from __future__ import annotations

import threading
from pathlib import Path

import rospy

from gidabot_msgs.msg import NavPose
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.ros.convert import yaw_of
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_web.editor.preview import PoseBook

WRITE_PERIOD = 0.2    # wall s


class PreviewNode:
    def __init__(self, out: Path) -> None:
        self.out = out
        self.book = PoseBook()
        self._lock = threading.Lock()
        rospy.Subscriber(Topic.POSES, NavPose, self._on_pose, queue_size=50)

    def _on_pose(self, m: NavPose) -> None:
        p = m.nav_pose.position
        with self._lock:
            self.book.heard(m.robot, m.floor, p.x, p.y, yaw_of(m.nav_pose.orientation), m.header.stamp.to_sec())

    def write(self) -> None:
        with self._lock:
            if self.book.changed:
                self.book.write(self.out)


def main() -> None:
    guard = rospy_exit_guard(Node.EDITOR_PREVIEW)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not
    rospy.init_node(Node.EDITOR_PREVIEW, anonymous=True, disable_signals=True)
    keep_registered()
    node = PreviewNode(Path(str(rospy.get_param("~out"))))
    stop = threading.Event()

    def writer() -> None:
        while not stop.wait(WRITE_PERIOD):
            node.write()

    threading.Thread(target=writer, name="poses", daemon=True).start()
    try:
        guard.spin(rospy.is_shutdown)
    finally:
        stop.set()


if __name__ == "__main__":
    main()
