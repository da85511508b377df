"""The cores' logger in a node: rospy's (rosout). The ROS adapters pass it to the cores.

rospy's ``/rosout`` handler asks the master for ``/rosout_disable_topics_generation`` on every
log call for as long as the master has no such parameter (``subscribeParam``: an XML-RPC call
without a timeout, under the lock rospy holds for all its calls to that master): a node whose
master does not answer (frozen, or unreachable) would block in its first log line about it.
:func:`never_block_on_rosout` answers that question from the process's parameter cache, once
and for all (through :mod:`gidabot_navigation.ros.rospy_internals`);
:func:`gidabot_navigation.ros.master_watch.keep_registered` calls it.
"""

from __future__ import annotations

import rospy

ROSOUT_TOPICS_PARAM = "/rosout_disable_topics_generation"


class RosLog:
    """:class:`gidabot_navigation.logs.Logger` on rospy's logger."""

    def info(self, msg: str) -> None:
        rospy.loginfo(msg)

    def warning(self, msg: str) -> None:
        rospy.logwarn(msg)

    def error(self, msg: str) -> None:
        rospy.logerr(msg)


def never_block_on_rosout(value: bool | None = None) -> bool:
    """Put ``/rosout_disable_topics_generation`` in rospy's parameter cache (``value``, or rospy's
    default False) unless it is there already, so that logging never calls the master. Returns the
    value the cache holds."""
    from gidabot_navigation.ros.rospy_internals import param_cache_get_or_set

    return param_cache_get_or_set(ROSOUT_TOPICS_PARAM, bool(value))
