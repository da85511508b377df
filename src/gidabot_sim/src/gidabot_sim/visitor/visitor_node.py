"""ROS adapter of the simulated visitor: the ``visitor`` node (cores: :mod:`gidabot_sim.visitor.station` on
:mod:`gidabot_sim.visitor.visitor`).

The node reads its parameters, hands what it receives to the station (conversions:
:mod:`gidabot_sim.ros.convert`), unsubscribes what the station no longer needs, and publishes the commands
its timer's ticks return.
"""

from __future__ import annotations

import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from gidabot_msgs.msg import Goal, NavEvent, PendingRequests, RobotStatus, TourCatalog, VisitorBody, VisitorCommand
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, WAY_STAIRS, Node, Topic
from gidabot_navigation.ros.adapter import diagnostics, refusal_values, sender
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.log import RosLog
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_sim.ros import convert
from gidabot_sim.visitor.population import plans_from_list
from gidabot_sim.visitor.station import VisitorStation, skips_of, station_config, walk_of

DIAG_TICKS = 5            # ticks between two diagnostics


class VisitorNode:
    """One robot's share of the simulated visitor (its touch screen), on that robot's master.

    Subscribes:
      /gidabot/nav_events (gidabot_msgs/NavEvent)   every robot's events (relayed)
      /gidabot/goals (gidabot_msgs/Goal)            population only: which visitor each trip is for
      /gidabot/status (gidabot_msgs/RobotStatus)    to start once every robot is up (then unsubscribed, unless a
                                                    visitor has a patience: the robots' poses for the screen)
      /gidabot/pending (gidabot_msgs/PendingRequests) population with a patience: every robot's queue, for the
                                                    waits the screen shows before a visitor confirms
      tour_store/catalog (gidabot_msgs/TourCatalog) tour mode: the tour's floors (stops on floors without robot);
                                                    the start robot starts once the tour is stored here
    Publishes:
      visitor/command (gidabot_msgs/VisitorCommand) Continue / skip / start, as the GUI would (the last 60 s
                                                    are sent again to a late subscriber: a restarted node)
      /sim/visitor_body (gidabot_msgs/VisitorBody)  simulator only: what the visitors' bodies do on this robot's
                                                    floor (follow this robot, leave, gone), at each change (the
                                                    last 60 s again to a late subscriber: a restarted simulator)
      /diagnostics (diagnostic_msgs/DiagnosticArray) ``sim: visitor <robot>`` every DIAG_TICKS ticks: the goals and
                                                    events refused by kind (refused_<kind>, refused; WARN once
                                                    any was: a forged event never moves a visitor)
    Params:
      ~building (str)             building.yaml path;  ~robot (str) this node's robot
      ~start_floor (float, 0)     where the visitor starts: the node of its first robot starts the visit
      ~tour_file (str, "")        tour to start, or ~goal_id (str, "") a single target
      ~way (str, "stairs")        stairs | lift, for every floor change
      ~language (str, "en")       eu | en | es
      ~skips (list of [k, m], []) after tour step k (0-based) is done, skip to step m
      ~think (float, 3.0 s)       time before pressing a button (sim time)
      ~stairs_s_per_floor (float, 20 s), ~lift_wait (float, 25 s), ~lift_s_per_floor (float, 5 s):
                                  walking time between floors (sim time)
      ~retry (float, 30 s), ~retry_for (float, 1800 s): a request of this visitor refused with
                                  PARTNER_OFFLINE is asked again after ~retry, for at most ~retry_for
      ~visit_time (float, 60 s)   time spent at a tour stop on a floor without robot (sim time)
      ~walk (str, "")             how the visitor's body walks (gidabot_sim.visitor.behaviour.parse_walk, e.g.
                                  "speed=0.5,pause=20:60,group=3,wander_at=40"; gidabot demo --walk); "": drawn from
      ~behaviour_seed (int, -1)   this seed (-1: tidy, 1.1 m/s, 1 m behind, no pauses)
      ~start_delay (float, 2.0 s) after every robot reported status (sim time): when the visit starts (the demo:
                                  3 s of wall time at its speed)
      ~rate (float, 1 Hz)         how often due commands are checked (sim time)
      ~population (list, [])      many visitors instead of one: their plans (gidabot_sim.visitor.population:
                                  visitor_id, arrive_s after ~start_delay (sim s), robot, way, goal_id or
                                  tour_file, cancel_after_s, no_show, patience_s); ~start_floor, ~tour_file,
                                  ~goal_id, ~way, ~skips, ~walk and ~behaviour_seed are then not used. A
                                  visitor with a patience sees the waits of its trip's legs before confirming,
                                  as the GUI shows them, and leaves instead when one is longer
      ~record (str, "")           a JSON-lines file (the demo's monitor.jsonl) to append what the visitors chose at
                                  the screen: ``{"kind": "visitor", "event": "asked" | "left", "visitor", "robot",
                                  "shown": [s or null per leg], "patience_s", "sim", "wall"}``
    """

    def __init__(self) -> None:
        building = load_building(str(rospy.get_param("~building")))
        cfg = station_config(
            building, str(rospy.get_param("~robot")), param_number("~start_floor", 0.0, -1e6, strict=False),
            visit_s=param_number("~visit_time", 60.0, strict=False),
            way=str(rospy.get_param("~way", WAY_STAIRS)), language=str(rospy.get_param("~language", DEFAULT_LANGUAGE)),
            stairs_s_per_floor=param_number("~stairs_s_per_floor", 20.0, strict=False),
            lift_wait_s=param_number("~lift_wait", 25.0, strict=False),
            lift_s_per_floor=param_number("~lift_s_per_floor", 5.0, strict=False),
            think_s=param_number("~think", 3.0, strict=False),
            tour_file=str(rospy.get_param("~tour_file", "")), goal_id=str(rospy.get_param("~goal_id", "")),
            skips=skips_of(rospy.get_param("~skips", [])),
            retry_s=param_number("~retry", 30.0, strict=False),
            retry_for_s=param_number("~retry_for", 1800.0, strict=False),
            **walk_of(rospy.get_param("~walk", ""), rospy.get_param("~behaviour_seed", -1)))
        self.station = VisitorStation(building, cfg, RosLog(),
                                      plans_from_list(rospy.get_param("~population", []), building),
                                      param_number("~start_delay", 2.0, strict=False),
                                      str(rospy.get_param("~record", "")))
        rate = param_number("~rate", 1.0)
        # a restarted guiding node gets the commands of the last minute again (it ignores those it handled)
        self.pub = ReplayPublisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=50)
        self.body_pub = ReplayPublisher(Topic.SIM_VISITOR_BODY, VisitorBody, queue_size=50)
        if self.station.needs_goals:
            rospy.Subscriber(Topic.GOALS, Goal, self._on_goal, queue_size=200)
        rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._on_event, queue_size=100)
        if self.station.needs_pending:
            rospy.Subscriber(Topic.PENDING, PendingRequests, self._on_pending, queue_size=50)
        self._status_sub = rospy.Subscriber(Topic.STATUS, RobotStatus, self._on_status, queue_size=50)
        self._catalog_sub = None
        if self.station.needs_catalog:
            self._catalog_sub = rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, self._on_catalog, queue_size=2)
        self.diag_pub = rospy.Publisher(Topic.DIAGNOSTICS, DiagnosticArray, queue_size=2)
        self.robot = cfg.robot
        self.ticks = 0
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate), self._tick)

    def _on_goal(self, msg: Goal) -> None:
        self.station.on_goal_from(sender(msg), msg.origin_robot, msg.uid, msg.visitor_id, rospy.get_time())

    def _on_event(self, msg: NavEvent) -> None:
        self.station.on_event_from(sender(msg), convert.nav_event_of(msg), rospy.get_time())

    def _on_catalog(self, msg: TourCatalog) -> None:
        self.station.on_catalog(convert.tours_of(msg))

    def _on_pending(self, msg: PendingRequests) -> None:
        self.station.on_pending(*convert.pending_of(msg), time.time())

    def _on_status(self, msg: RobotStatus) -> None:
        self.station.on_status(*convert.status_of(msg), rospy.get_time(), time.time())

    def _tick(self, _event: object) -> None:
        if self._status_sub is not None and not self.station.needs_status:
            self._status_sub.unregister()    # statuses are 4 x 2 Hz of sim time: only needed until all are up
            self._status_sub = None
        if self._catalog_sub is not None and not self.station.needs_catalog:
            self._catalog_sub.unregister()
            self._catalog_sub = None
        now = rospy.get_time()
        for command in self.station.tick(now, time.time()):
            self.pub.publish(convert.command_msg(command))
        for directive in self.station.bodies(now):
            self.body_pub.publish(convert.visitor_body_msg(directive))
        self.ticks += 1
        if self.ticks % DIAG_TICKS == 1:
            values = refusal_values(self.station.gate.refusals())
            self.diag_pub.publish(diagnostics(f"sim: visitor {self.robot}", self.robot, values, values["refused"] > 0,
                                              f"{values['refused']} refused", now))


def main() -> None:
    guard = rospy_exit_guard(Node.VISITOR)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not
    rospy.init_node(Node.VISITOR, disable_signals=True)
    keep_registered()
    try:
        VisitorNode()
    except (GidaBotError, KeyError) as err:
        rospy.logfatal("visitor: %s", err)
        raise SystemExit(2) from err
    guard.spin(rospy.is_shutdown)
