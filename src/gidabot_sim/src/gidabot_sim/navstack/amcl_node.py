"""ROS adapter of the amcl stand-in: the ``/amcl`` node (core: :class:`gidabot_sim.navstack.amcl.AmclLoop`).

A lockstep participant of the floor's simulator (docs/simulator.md, "Lockstep"): it answers every
ground-truth message, so the world does not step on before the estimate for it is out. The node reads its
parameters, hands each message to the core and publishes what the core returns (conversions:
:mod:`gidabot_sim.ros.convert`).
"""

from __future__ import annotations

import math

import numpy as np
import rospy
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from tf2_msgs.msg import TFMessage

from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import Node, Topic
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_sim.navstack.amcl import AmclConfig, AmclCore, AmclLoop
from gidabot_sim.ros import convert
from gidabot_sim.ros.participant import StepAnswers, own_time


class AmclNode:
    """Localisation as amcl reports it, from the simulator's ground truth plus plausible error.

    Subscribes:
      ``base_pose_ground_truth`` (nav_msgs/Odometry, map frame): the simulator's true pose.
      ``odom`` (nav_msgs/Odometry): odometry, paired by stamp for the ``map -> odom`` transform
        (subscribed only while somebody listens to /tf).
      (``initialpose`` is handled by the simulator, which moves the simulated robot; the
      estimate follows the new ground truth at once.)
    Publishes:
      ``amcl_pose`` (geometry_msgs/PoseWithCovarianceStamped, latched, frame ``map``): after the robot
        moved ``~update_min_d`` or turned ``~update_min_a``, and at once after a relocation;
        covariance filled (x, y, yaw variances).
      tf ``map -> odom`` (while /tf has subscribers) at ``~tf_rate`` and with every estimate, stamped
        ``~transform_tolerance`` ahead as amcl does.
    Params:
      ``~noise_xy`` (m, 0.03), ``~noise_yaw`` (rad, 0.02): standard deviations of the estimate's error;
      ``~noise_tau`` (s, 3): its correlation time; ``~update_min_d`` (m, 0.1), ``~update_min_a`` (rad, 0.1);
      ``~tf_rate`` (Hz sim, 10), ``~transform_tolerance`` (s, 0.1); ``~global_frame_id`` (map),
      ``~odom_frame_id`` (odom); ``~seed`` (int, -1 = random).
    Lockstep (docs/simulator.md): ROS time is the stamp of the latest ground truth (no ``/clock``); every
      ground-truth message is answered on ``/sim/step_done`` (gidabot_msgs/StepDone) once its estimate (if
      any) is published.
    Shutdown: the process exits within 1 wall second of SIGINT/SIGTERM (:mod:`gidabot_navigation.ros.exit_guard`).
    """

    def __init__(self) -> None:
        def num(name: str, default: float) -> float:
            return param_number(f"~{name}", default, -math.inf, strict=False)

        config = AmclConfig(**{name: num(name, getattr(AmclConfig, name))
                               for name in ("noise_xy", "noise_yaw", "noise_tau", "update_min_d", "update_min_a")})
        seed = int(num("seed", -1))
        self.loop = AmclLoop(AmclCore(config, np.random.default_rng(None if seed < 0 else seed)), RosLog(),
                             param_number("~tf_rate", 10.0), num("transform_tolerance", 0.1))
        self.global_frame = str(rospy.get_param("~global_frame_id", "map"))
        self.odom_frame = str(rospy.get_param("~odom_frame_id", "odom"))
        self.pose_pub = rospy.Publisher(Topic.AMCL_POSE, PoseWithCovarianceStamped, queue_size=5, latch=True)
        self.tf_pub = rospy.Publisher(Topic.TF, TFMessage, queue_size=10)
        self.odom_sub: rospy.Subscriber | None = None
        self.set_time = own_time()
        self.answers = StepAnswers()
        self.truth_topic = rospy.resolve_name(Topic.BASE_POSE_GROUND_TRUTH)
        self.answers.answer(0.0, idle=True, inputs=[self.truth_topic])     # known to the simulator from the start
        rospy.Subscriber(Topic.BASE_POSE_GROUND_TRUTH, Odometry, self._on_truth, queue_size=10, tcp_nodelay=True)

    def _on_odom(self, msg: Odometry) -> None:
        self.loop.on_odom(lambda: convert.odometry_of(msg, Topic.ODOM)[:2])

    def _on_truth(self, msg: Odometry) -> None:
        t = msg.header.stamp.to_sec()
        self.set_time(t)
        out = self.loop.on_truth(t, lambda: convert.odometry_of(msg, Topic.BASE_POSE_GROUND_TRUTH)[1],
                                 self.tf_pub.get_num_connections() > 0)
        if out.follow_odom and self.odom_sub is None:
            self.odom_sub = rospy.Subscriber(Topic.ODOM, Odometry, self._on_odom, queue_size=10)
        elif not out.follow_odom and self.odom_sub is not None:
            self.odom_sub.unregister()
            self.odom_sub = None
        if out.estimate is not None:
            self.pose_pub.publish(convert.estimate_msg(out.estimate, self.global_frame))
        if out.map_odom is not None:
            tf = convert.transform(self.global_frame, self.odom_frame, out.map_odom, out.tf_stamp)
            self.tf_pub.publish(TFMessage(transforms=[tf]))
        self.answers.answer(out.done, idle=True, inputs=[self.truth_topic])

def main() -> None:
    # installed before init_node: a signal while init_node waits on a frozen master would run rospy's
    # handler, which never returns (exit within 1 s of SIGINT/SIGTERM, whatever happens)
    guard = rospy_exit_guard(Node.AMCL)
    rospy.init_node(Node.AMCL, disable_signals=True)
    keep_registered()     # re-register with a restarted master
    try:
        AmclNode()
    except (GidaBotError, OSError, ValueError, TypeError) as err:     # bad parameters or files
        rospy.logfatal(f"amcl: cannot start: {err}")
        raise SystemExit(1) from err
    guard.spin(rospy.is_shutdown)
