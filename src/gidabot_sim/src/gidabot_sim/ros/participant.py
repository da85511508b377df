"""The participants' side of the floor simulator's lockstep (ROS adapter; docs/simulator.md, "Lockstep").

A participant (the move_base and amcl stand-ins) takes its ROS time from the simulator instead of
``/clock`` (:func:`own_time`), and answers what it owes with a ``gidabot_msgs/StepDone``
(:class:`StepAnswers`): the simulator does not step on before it has them (core:
:mod:`gidabot_sim.world.lockstep`).
"""

from __future__ import annotations

import random
import warnings
from collections.abc import Callable, Iterable

import rospy

from gidabot_msgs.msg import StepDone
from gidabot_navigation.interface import Topic
from gidabot_navigation.ros.rospy_internals import take_over_ros_time
from gidabot_sim.ros.convert import stamp, step_done_msg
from gidabot_sim.world.lockstep import Answer


def synchronous_publisher(topic: str, msg_type: type, latch: bool = False) -> rospy.Publisher:
    """A publisher that writes in the publishing thread (no queue thread per subscriber): what the lockstep
    sends must leave at once, in the order it is published (rospy warns about queue_size=None: intended)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SyntaxWarning)
        return rospy.Publisher(topic, msg_type, queue_size=None, latch=latch)


def own_time() -> Callable[[float], None]:
    """Stop receiving ``/clock`` (rospy subscribed this node to it, ``/use_sim_time`` being set) and return a
    setter of this process's ROS time: the simulator sets its own, the participants set it from what the
    simulator sends them (their work is stamped with the step it is for, never with a later ``/clock``).
    Uses rospy internals (:func:`gidabot_navigation.ros.rospy_internals.take_over_ros_time`); without them
    (another rospy) the node keeps ``/clock`` and the setter does nothing."""
    setter = take_over_ros_time()
    if setter is None:
        return lambda _t: None
    return lambda t: setter(stamp(t))


class StepAnswers:
    """This node's answers to the simulator; :meth:`command_sent` counts the cmd_vel messages it publishes."""

    def __init__(self) -> None:
        self.node = rospy.get_name()
        self.session = random.SystemRandom().randrange(1, 2**32)
        self.commands = 0
        self.answers = 0
        self.pub = synchronous_publisher(Topic.SIM_STEP_DONE, StepDone)

    def command_sent(self) -> None:
        self.commands += 1

    def answer(self, done: float, idle: bool, inputs: Iterable[str] = ()) -> None:
        """Everything up to sim time ``done`` is done and published; ``idle`` and ``inputs`` (resolved names) as in
        gidabot_msgs/StepDone."""
        self.pub.publish(step_done_msg(Answer(self.node, self.session, done, idle, tuple(inputs), self.commands)))
        self.answers += 1
