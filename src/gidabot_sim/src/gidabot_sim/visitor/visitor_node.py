"""ROS adapter of the simulated visitor (core: :mod:`gidabot_sim.visitor.visitor`)."""

from __future__ import annotations

import json
import threading
import time
from collections import deque
from dataclasses import replace

import rospy

from gidabot_msgs.msg import Goal, NavEvent, PendingRequests, RobotStatus, TourCatalog, VisitorCommand
from gidabot_navigation.building.model import load_building
from gidabot_navigation.errors import GidaBotError, TourError, TourNameError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, WAY_STAIRS, WAYS, Node, Topic
from gidabot_navigation.ros.convert import trip_from_msg
from gidabot_navigation.ros.exit_guard import rospy_exit_guard
from gidabot_navigation.ros.master_watch import keep_registered
from gidabot_navigation.ros.params import param_number
from gidabot_navigation.ros.replay import ReplayPublisher
from gidabot_navigation.tours.tour_file import tour_from_lines
from gidabot_sim.errors import SimConfigError
from gidabot_sim.visitor.population import plans_from_list
from gidabot_sim.visitor.visitor import ButtonPress, Screen, VisitorConfig, VisitorCore


def _skips_param(raw: object) -> tuple[tuple[int, int], ...]:
    try:
        return tuple((int(k), int(m)) for k, m in raw)  # type: ignore[union-attr]
    except (TypeError, ValueError) as err:
        raise SimConfigError(f"~skips: {raw!r} must be a list of [k, m] step pairs") from err


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
      ~start_delay (float, 2.0 s) after every robot reported status (sim time): when the visit starts (the demo:
                                  3 s of wall time at its speed)
      ~rate (float, 1 Hz)         how often due commands are checked (sim time)
      ~population (list, [])      many visitors instead of one: their plans (gidabot_sim.visitor.population:
                                  visitor_id, arrive_s after ~start_delay (sim s), robot, way, goal_id or
                                  tour_file, cancel_after_s, no_show, patience_s); ~start_floor, ~tour_file,
                                  ~goal_id, ~way and ~skips are then not used. A visitor with a patience sees
                                  the waits of its trip's legs before confirming, as the GUI shows them, and
                                  leaves instead when one is longer
      ~record (str, "")           a JSON-lines file (the demo's monitor.jsonl) to append what the visitors chose at
                                  the screen: ``{"kind": "visitor", "event": "asked" | "left", "visitor", "robot",
                                  "shown": [s or null per leg], "patience_s", "sim", "wall"}``
    """

    def __init__(self) -> None:
        building = load_building(str(rospy.get_param("~building")))
        robot = building.robot(str(rospy.get_param("~robot")))
        start_floor = param_number("~start_floor", 0.0, -1e6, strict=False)
        starters = building.robots_on(start_floor)
        self.cfg = VisitorConfig(
            robot=robot.name, floor=robot.floor, start_floor=start_floor,
            start_robot=starters[0].name if starters else "",
            robot_floors=tuple(sorted({r.floor for r in building.robots})),
            visit_s=param_number("~visit_time", 60.0, strict=False),
            way=str(rospy.get_param("~way", WAY_STAIRS)), language=str(rospy.get_param("~language", DEFAULT_LANGUAGE)),
            stairs_s_per_floor=param_number("~stairs_s_per_floor", 20.0, strict=False),
            lift_wait_s=param_number("~lift_wait", 25.0, strict=False),
            lift_s_per_floor=param_number("~lift_s_per_floor", 5.0, strict=False),
            think_s=param_number("~think", 3.0, strict=False),
            tour_file=str(rospy.get_param("~tour_file", "")), goal_id=str(rospy.get_param("~goal_id", "")),
            skips=_skips_param(rospy.get_param("~skips", [])),
            retry_s=param_number("~retry", 30.0, strict=False),
            retry_for_s=param_number("~retry_for", 1800.0, strict=False))
        if self.cfg.way not in WAYS:
            raise SimConfigError(f"~way: {self.cfg.way!r} must be one of {', '.join(WAYS)}")
        population = plans_from_list(rospy.get_param("~population", []), building)
        # one core per visitor: the single visitor of the params, or each of the population
        self.cores = {p.visitor_id: VisitorCore(replace(
            self.cfg, start_floor=building.robot(p.robot).floor, start_robot=p.robot, way=p.way, goal_id=p.goal_id,
            tour_file=p.tour_file, skips=(), visitor_id=p.visitor_id, arrive_s=p.arrive_s,
            cancel_after_s=p.cancel_after_s, no_show=p.no_show, patience_s=p.patience_s)) for p in population} \
            or {self.cfg.visitor_id: VisitorCore(self.cfg)}
        self.robots = {r.name for r in building.robots}
        self.start_delay = param_number("~start_delay", 2.0, strict=False)
        rate = param_number("~rate", 1.0)
        self.building = building
        self._lock = threading.Lock()
        self._seen: set[str] = set()
        self._all_up_at: float | None = None
        self._visitor_of: dict[str, str] = {}          # goal uid -> visitor id (population: from the goals)
        self._unrouted: deque[NavEvent] = deque(maxlen=2000)   # events whose goal was not seen yet
        # tour mode: the tours' floors, and the start robot waits until its tour store holds the tour (START_TOUR
        # reads it there)
        self._tours_missing = {c.cfg.tour_file for c in self.cores.values() if c.cfg.tour_file}
        self._seq = 0
        self._record = str(rospy.get_param("~record", ""))
        self._first_stop: dict[str, str] = {}               # tour file -> the room of its first stop (the screen)
        self.screen = Screen(building) if any(c.cfg.patience_s >= 0 for c in self.cores.values()) else None
        if self.screen is not None:
            self.screen.planner.warm_up()   # not at the first visitor's screen, while the floors wait for the CPU
        # a restarted guiding node gets the commands of the last minute again (it ignores those it handled)
        self.pub = ReplayPublisher(Topic.VISITOR_COMMAND, VisitorCommand, queue_size=50)
        if population:
            rospy.Subscriber(Topic.GOALS, Goal, self._on_goal, queue_size=200)
        rospy.Subscriber(Topic.NAV_EVENTS, NavEvent, self._on_event, queue_size=100)
        if self.screen is not None:
            rospy.Subscriber(Topic.PENDING, PendingRequests, self._on_pending, queue_size=50)
        self._status_sub = rospy.Subscriber(Topic.STATUS, RobotStatus, self._on_status, queue_size=50)
        self._catalog_sub = None
        if self._tours_missing:
            self._catalog_sub = rospy.Subscriber(Topic.TOUR_CATALOG, TourCatalog, self._on_catalog, queue_size=2)
        self.timer = rospy.Timer(rospy.Duration(1.0 / rate), self._tick)

    def _on_goal(self, msg: Goal) -> None:
        """Population: which visitor a trip is for (Goal.visitor_id); its events held back so far go to it."""
        with self._lock:
            core = self.cores.get(msg.visitor_id)
            if core is None or msg.uid in self._visitor_of:
                return
            self._visitor_of[msg.uid] = msg.visitor_id
            core.on_goal(msg.uid)
            held = [m for m in self._unrouted if m.goal_uid == msg.uid]
            for m in held:
                self._unrouted.remove(m)
                self._deliver(core, m)

    def _on_event(self, msg: NavEvent) -> None:
        with self._lock:
            if len(self.cores) == 1:
                self._deliver(next(iter(self.cores.values())), msg)
            elif msg.goal_uid:
                visitor = self._visitor_of.get(msg.goal_uid)
                if visitor is None:
                    self._unrouted.append(msg)
                else:
                    self._deliver(self.cores[visitor], msg)
            else:      # an answer to a request, before any trip: the visitors who asked at that robot
                for core in self.cores.values():
                    if core.cfg.start_robot == msg.robot:
                        self._deliver(core, msg)

    @staticmethod
    def _deliver(core: VisitorCore, msg: NavEvent) -> None:
        # the visitor sees what a robot does when it happens (the event's stamp), not when its message got here:
        # the messages' wall latency would otherwise add sim time, the more the faster the run (never later than
        # now: another floor's clock may be a little ahead)
        now, happened = rospy.get_time(), msg.header.stamp.to_sec()
        core.on_event(min(happened, now) if happened > 0 else now, msg.uid, msg.robot, msg.phase, msg.goal_uid,
                      msg.floor, msg.target_floor, msg.tour_step, tour_file=msg.tour_file, location_id=msg.location_id)

    def _on_catalog(self, msg: TourCatalog) -> None:
        for t in msg.tours:
            if t.file_name not in self._tours_missing:
                continue
            try:
                tour = tour_from_lines(t.file_name, t.tour_name, list(t.tour_goals_info), self.building)
            except (TourError, TourNameError) as err:
                rospy.logwarn("visitor on %s: tour %s in the catalog is invalid: %s", self.cfg.robot, t.file_name, err)
                continue
            with self._lock:
                for core in self.cores.values():
                    if core.cfg.tour_file == t.file_name:
                        core.on_tour(tuple(g.floor for g in tour.goals))
                if tour.goals:
                    self._first_stop[t.file_name] = tour.goals[0].room
                self._tours_missing.discard(t.file_name)

    def _on_pending(self, msg: PendingRequests) -> None:
        goals = [trip_from_msg(g) for g in msg.goals[:256]]
        with self._lock:
            if self.screen is not None:
                self.screen.on_pending(msg.robot, goals, msg.wait_new, time.time())

    def _on_status(self, msg: RobotStatus) -> None:
        with self._lock:
            if self.screen is not None:
                p = msg.nav_pose.position
                self.screen.on_status(msg.robot, time.time(), (p.x, p.y))
            self._seen.add(msg.robot)
            if self._all_up_at is None and self.robots <= self._seen:
                self._all_up_at = rospy.get_time()

    def _tick(self, _event: object) -> None:
        now = rospy.get_time()
        if self._all_up_at is not None and self._status_sub is not None and self.screen is None:
            self._status_sub.unregister()    # statuses are 4 x 2 Hz of sim time: only needed until all are up
            self._status_sub = None
        if not self._tours_missing and self._catalog_sub is not None:
            self._catalog_sub.unregister()
            self._catalog_sub = None
        presses: list[tuple[VisitorConfig, ButtonPress]] = []
        with self._lock:
            for core in self.cores.values():
                commands = core.step(now)
                if (self._all_up_at is not None and not self._tours_missing and not core.started
                        and now >= self._all_up_at + self.start_delay + core.cfg.arrive_s and core.on_start_floor):
                    shown = self._shown(core)
                    commands = core.start(now, shown) + commands
                    if core.started:
                        rospy.loginfo("visitor %s on %s: %s (waits shown: %s)", core.cfg.visitor_id, self.cfg.robot,
                                      core.outcome if core.left else "starting the visit", shown)
                        self._write_record(core, now)
                presses += [(core.cfg, cmd) for cmd in commands]
        for cfg, cmd in presses:
            self._publish(cfg, cmd)

    def _shown(self, core: VisitorCore) -> tuple[float | None, ...]:
        """The waits this robot's screen shows the visitor before it confirms (its trip's legs)."""
        if self.screen is None or core.cfg.patience_s < 0:
            return ()
        goal = core.cfg.goal_id or self._first_stop.get(core.cfg.tour_file, "")
        return self.screen.waits(self.cfg.robot, goal, core.cfg.way, time.time()) if goal else ()

    def _write_record(self, core: VisitorCore, now: float) -> None:
        """What the visitor chose at the screen, for the demo's statistics (one line, appended in one write)."""
        if not self._record:
            return
        line = json.dumps({"kind": "visitor", "event": "left" if core.left else "asked", "wall": time.time(),
                           "sim": now, "visitor": core.cfg.visitor_id, "robot": self.cfg.robot,
                           "shown": [None if w is None else round(w, 1) for w in core.shown],
                           "patience_s": core.cfg.patience_s, "detail": core.outcome if core.left else ""})
        try:
            with open(self._record, "a", encoding="utf-8") as out:
                out.write(line + "\n")
        except OSError as err:
            rospy.logwarn("visitor on %s: cannot append to %s: %s", self.cfg.robot, self._record, err)

    def _publish(self, cfg: VisitorConfig, cmd: ButtonPress) -> None:
        self._seq += 1
        msg = VisitorCommand(uid=f"{cfg.robot}/{cfg.visitor_id}/cmd/{self._seq}",
                             visitor_id=cfg.visitor_id, command=cmd.command, goal_id=cmd.goal_id,
                             way=cmd.way, language=cmd.language, goal_uid=cmd.goal_uid, tour_file=cmd.tour_file,
                             tour_step=cmd.tour_step)
        msg.header.stamp = rospy.Time.now()
        rospy.loginfo("visitor %s on %s: command %d %s", cfg.visitor_id, cfg.robot, cmd.command, cmd)
        self.pub.publish(msg)


def main() -> None:
    guard = rospy_exit_guard(Node.VISITOR)   # exit within 1 s of SIGINT/SIGTERM, master frozen or not (issue 19.5)
    rospy.init_node(Node.VISITOR, disable_signals=True)
    keep_registered()
    try:
        VisitorNode()
    except (GidaBotError, KeyError) as err:
        rospy.logfatal("visitor: %s", err)
        raise SystemExit(2) from err
    guard.spin(rospy.is_shutdown)
