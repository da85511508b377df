"""The cores' logger in a node: rospy's (rosout). The ROS adapters pass it to the cores."""

from __future__ import annotations

import rospy


class RosLog:
    """:class:`gidabot_navigation.logs.Logger` on rospy's logger."""

    def info(self, msg: str) -> None:
        rospy.loginfo(msg)

    def warning(self, msg: str) -> None:
        rospy.logwarn(msg)

    def error(self, msg: str) -> None:
        rospy.logerr(msg)
