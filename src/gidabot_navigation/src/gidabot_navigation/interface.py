"""The interface vocabulary of GidaBot (ROS-free): every name that more than one module spells.

Topic, service and node names, the relay ends' node names, the topics the relays share,
and the constants of the gidabot_msgs messages (NavEvent phases :class:`Phase`, VisitorCommand
commands :class:`Cmd`, RobotStatus states :class:`RobotState`, Cancel reasons, Goal ways and legs)
and the visitors' languages are defined here once and imported everywhere else. Unit tests
(``test/test_interface.py``) check the constants against ``src/gidabot_msgs/msg`` and the relays'
whitelist ``config/shared_topics.yaml``, and fail on a ``/gidabot/`` topic literal, or a phase,
command or robot state spelled as a literal, anywhere else in the repository.
What each topic carries: docs/interfaces.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum, StrEnum

# ---------------------------------------------------------------------------
# Node names
# ---------------------------------------------------------------------------

class Node:
    """Our node names (base names: every node of a robot runs in the root namespace of its master)."""

    GOAL_MANAGER = "goal_manager"
    MULTIROBOT_NAVIGATION = "multirobot_navigation"   # the paper's name of the node that drives move_base
    TOUR_STORE = "tour_store"
    RELAY_SUPERVISOR = "relay_supervisor"
    PEOPLE = "people"                  # the people detector and tracker (the visitor behind the robot)
    GUI = "gui"
    DASHBOARD = "dashboard"            # the staff web dashboard (gidabot_web): its staff commands and cancels speak for
    #                                    this robot
    # the simulated floor, and the stand-ins of a robot's own navigation stack
    SIM = "sim"
    MOVE_BASE = "move_base"
    AMCL = "amcl"
    # what runs the simulated building, never on a robot
    VISITOR = "visitor"                # the simulated visitor (one per floor)
    MONITOR = "monitor"                # the demo's progress monitor (anonymous: rospy appends a suffix)
    CHAOS_PROBE = "chaos_probe"
    EDITOR_PREVIEW = "gidabot_editor_preview"   # the building editor's pose reader in a preview (anonymous)


GUIDING_NODES = (Node.GOAL_MANAGER, Node.MULTIROBOT_NAVIGATION)


def global_name(node: str) -> str:
    """The global name of node ``node``: what subscribers see as the callerid of its messages."""
    return "/" + node


GUIDING_CALLERIDS = tuple(global_name(n) for n in GUIDING_NODES)   # the callerids of a robot's guiding nodes


# -- relay ends ---------------------------------------------------------------------------------
RELAY_PREFIX = "/gidabot_relay_"


def relay_end_name(robot_a: str, robot_b: str) -> str:
    """Node name of both ends of the relay between ``robot_a`` (first in the building) and ``robot_b``."""
    return f"{RELAY_PREFIX}{robot_a}_{robot_b}"


def is_relay_end(callerid: str) -> bool:
    """True if ``callerid`` names a relay end: its messages came from another robot, and are never
    forwarded again."""
    return callerid.startswith(RELAY_PREFIX)


# ---------------------------------------------------------------------------
# Topic and service names
# ---------------------------------------------------------------------------

class Topic:
    """Topic names. ``/gidabot/*`` are shared between the robots' masters by the relays
    (:data:`SHARED_TOPICS`); relative names resolve in the node's namespace (the root)."""

    # shared between robots (events: exactly once to every robot; states: the latest per publisher)
    GOALS = "/gidabot/goals"
    CANCELS = "/gidabot/cancels"
    NAV_EVENTS = "/gidabot/nav_events"
    TOURS = "/gidabot/tours"
    STATUS = "/gidabot/status"
    POSES = "/gidabot/poses"
    MAKE_WAY = "/gidabot/make_way"
    PENDING = "/gidabot/pending"
    TOUR_INDEX = "/gidabot/tour_index"
    STAFF = "/gidabot/staff"             # staff commands from a robot's dashboard (out of service and back)
    LINKS = "/gidabot/links"             # each robot's relay links as it sees them (its dashboard publishes them)
    # one robot's own: the visitor's buttons, the tour store
    VISITOR_COMMAND = "visitor/command"
    TOUR_EDIT = "tour_store/edit"
    TOUR_EDIT_RESULT = "tour_store/edit_result"
    TOUR_CATALOG = "tour_store/catalog"
    # the people the robot's laser tracks, and the visitor it guides: never shared with other robots
    PEOPLE_TRACKS = "people/tracks"
    PEOPLE_VISITOR = "people/visitor"
    PEOPLE_VISITOR_LOCK = "people/visitor_lock"
    PEOPLE_WATCH = "people/watch"                         # the guiding core's wish to have people watched (a trip)
    # the robot's navigation stack and base (standard names)
    MOVE_BASE = "move_base"                               # the move_base action's namespace
    MOVE_BASE_GOAL = "move_base/goal"
    MOVE_BASE_RESULT = "move_base/result"
    MOVE_BASE_FEEDBACK = "move_base/feedback"
    MOVE_BASE_CURRENT_GOAL = "move_base/current_goal"
    MOVE_BASE_PLAN = "move_base/NavfnROS/plan"
    MOVE_BASE_SIMPLE_GOAL = "move_base_simple/goal"
    MOVE_BASE_SPEED_LIMIT = "move_base/speed_limit"        # std_msgs/Float32, m/s (0: none): guiding at a pace
    AMCL_POSE = "amcl_pose"
    INITIALPOSE = "initialpose"
    ODOM = "odom"
    CMD_VEL = "cmd_vel"
    BATTERY = "battery"
    BASE_SCAN = "base_scan"
    BASE_POSE_GROUND_TRUTH = "base_pose_ground_truth"
    MAP = "map"
    MAP_METADATA = "map_metadata"
    # the simulator's run-time obstacles (topics of the node /sim)
    SIM_OBSTACLE = "/sim/obstacle"
    SIM_OBSTACLES = "/sim/obstacles"
    # several robots on a floor: the other robots a robot's laser sees (/sim publishes, its move_base marks them)
    ROBOTS_SEEN = "robots_seen"
    # the simulator only: what a simulated visitor's body does on a floor (gidabot_msgs/VisitorBody), from the visitor
    # node of the floor's robot to its simulator (docs/simulator.md, "People")
    SIM_VISITOR_BODY = "/sim/visitor_body"
    # the lockstep participants' answers to their floor's simulator (gidabot_msgs/StepDone; docs/simulator.md)
    SIM_STEP_DONE = "/sim/step_done"
    # ROS-wide
    DIAGNOSTICS = "/diagnostics"
    CLOCK = "/clock"
    TF = "/tf"
    TF_STATIC = "/tf_static"


class Service:
    """Service names (relative: the robot's own)."""

    MAKE_PLAN = "move_base/make_plan"
    CLEAR_COSTMAPS = "move_base/clear_costmaps"
    STATIC_MAP = "static_map"


EVENT, STATE = "event", "state"


@dataclass(frozen=True)
class TopicSpec:
    """A topic the relays share: its global name, ROS type and class (:data:`EVENT` or :data:`STATE`)."""

    name: str
    type: str
    kind: str


SHARED_TOPICS = (
    TopicSpec(Topic.GOALS, "gidabot_msgs/Goal", EVENT),
    TopicSpec(Topic.CANCELS, "gidabot_msgs/Cancel", EVENT),
    TopicSpec(Topic.NAV_EVENTS, "gidabot_msgs/NavEvent", EVENT),
    TopicSpec(Topic.TOURS, "gidabot_msgs/Tour", EVENT),
    TopicSpec(Topic.STATUS, "gidabot_msgs/RobotStatus", STATE),
    TopicSpec(Topic.POSES, "gidabot_msgs/NavPose", STATE),
    TopicSpec(Topic.MAKE_WAY, "gidabot_msgs/MakeWay", STATE),
    TopicSpec(Topic.PENDING, "gidabot_msgs/PendingRequests", STATE),
    TopicSpec(Topic.TOUR_INDEX, "gidabot_msgs/TourIndex", STATE),
    TopicSpec(Topic.STAFF, "gidabot_msgs/StaffCommand", EVENT),
    TopicSpec(Topic.LINKS, "gidabot_msgs/LinkSummary", STATE),
)


# ---------------------------------------------------------------------------
# gidabot_msgs constants (a unit test checks them against src/gidabot_msgs/msg)
# ---------------------------------------------------------------------------

class Phase(IntEnum):
    """gidabot_msgs/NavEvent phases (same numbers)."""

    ACCEPTED = 0
    ON_THE_WAY = 1
    GOAL_REACHED = 2
    GO_TO_FLOOR = 3
    GOING_TO_MEETING = 4
    WAITING_VISITOR = 5
    UNREACHABLE = 6
    NO_ROBOT_ON_FLOOR = 7
    CANCELLED_HERE = 8
    CANCELLED_ELSEWHERE = 9
    TIMEOUT = 10
    PARTNER_OFFLINE = 11
    REJECTED = 12
    TOUR_STEP_DONE = 13
    TOUR_FINISHED = 14
    PARTNER_LOST = 15
    PARTNER_BACK = 16
    DECLINED = 17
    ASSIGNED = 18
    VISITOR_LOST = 19
    WAITING_FOR_YOU = 20
    FOLLOW_ME = 21
    SEARCHING_VISITOR = 22
    PRESS_CONTINUE = 23


PHASE_NAMES = {
    Phase.ACCEPTED: "accepted", Phase.ON_THE_WAY: "on the way", Phase.GOAL_REACHED: "goal reached",
    Phase.GO_TO_FLOOR: "go to floor", Phase.GOING_TO_MEETING: "going to meeting point",
    Phase.WAITING_VISITOR: "waiting for the visitor", Phase.UNREACHABLE: "unreachable",
    Phase.NO_ROBOT_ON_FLOOR: "no robot on floor", Phase.CANCELLED_HERE: "cancelled here",
    Phase.CANCELLED_ELSEWHERE: "cancelled elsewhere", Phase.TIMEOUT: "timeout",
    Phase.PARTNER_OFFLINE: "partner offline",
    Phase.REJECTED: "rejected", Phase.TOUR_STEP_DONE: "tour step done", Phase.TOUR_FINISHED: "tour finished",
    Phase.PARTNER_LOST: "partner lost", Phase.PARTNER_BACK: "partner back", Phase.DECLINED: "declined",
    Phase.ASSIGNED: "assigned", Phase.VISITOR_LOST: "visitor lost", Phase.WAITING_FOR_YOU: "waiting for you",
    Phase.FOLLOW_ME: "follow me", Phase.SEARCHING_VISITOR: "searching the visitor",
    Phase.PRESS_CONTINUE: "press continue",
}
# phases after which the emitting robot is done with the trip (it left its queue)
FINAL_PHASES = frozenset({Phase.GOAL_REACHED, Phase.GO_TO_FLOOR, Phase.UNREACHABLE, Phase.NO_ROBOT_ON_FLOOR,
                          Phase.CANCELLED_HERE, Phase.CANCELLED_ELSEWHERE, Phase.TIMEOUT, Phase.PARTNER_OFFLINE,
                          Phase.REJECTED, Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED, Phase.DECLINED,
                          Phase.VISITOR_LOST})
# phases that hand the visitor over to another floor (the start robot released the visitor)
RELEASE_PHASES = frozenset({Phase.GO_TO_FLOOR, Phase.NO_ROBOT_ON_FLOOR})
# phases of a robot serving a leg (multirobot_navigation): only the robot the leg is assigned to sends them
SERVING_PHASES = frozenset({Phase.ON_THE_WAY, Phase.GOAL_REACHED, Phase.GO_TO_FLOOR, Phase.GOING_TO_MEETING,
                            Phase.WAITING_VISITOR, Phase.NO_ROBOT_ON_FLOOR, Phase.TOUR_STEP_DONE,
                            Phase.TOUR_FINISHED, Phase.PARTNER_LOST, Phase.PARTNER_BACK, Phase.WAITING_FOR_YOU,
                            Phase.FOLLOW_ME, Phase.SEARCHING_VISITOR, Phase.PRESS_CONTINUE})
# phases by which a guiding robot tells its visitor how it keeps their pace (not final; docs/guiding.md)
PACE_PHASES = frozenset({Phase.WAITING_FOR_YOU, Phase.FOLLOW_ME, Phase.SEARCHING_VISITOR})
# phases by which a robot says it brought the visitor to the trip's goal (a tour's stop, or its last)
GOAL_REACHED_PHASES = frozenset({Phase.GOAL_REACHED, Phase.TOUR_STEP_DONE, Phase.TOUR_FINISHED})
# phases after which a visitor's trip counts as done: its goal reached, or the visitor sent alone to a floor
# without robot (NO_ROBOT_ON_FLOOR: they find the place there)
TRIP_DONE_PHASES = GOAL_REACHED_PHASES | {Phase.NO_ROBOT_ON_FLOOR}


def phase_name(phase: int) -> str:
    return PHASE_NAMES.get(phase, f"phase {phase}")


class Cmd(IntEnum):
    """gidabot_msgs/VisitorCommand commands (same numbers)."""

    REQUEST = 0
    CONTINUE = 1
    CANCEL = 2
    START_TOUR = 3
    SKIP = 4


COMMAND_NAMES = {Cmd.REQUEST: "request", Cmd.CONTINUE: "continue", Cmd.CANCEL: "cancel",
                 Cmd.START_TOUR: "start tour", Cmd.SKIP: "skip"}

class StaffCmd(IntEnum):
    """gidabot_msgs/StaffCommand commands (same numbers)."""

    OUT_OF_SERVICE = 0
    BACK_IN_SERVICE = 1


STAFF_COMMAND_NAMES = {StaffCmd.OUT_OF_SERVICE: "out of service", StaffCmd.BACK_IN_SERVICE: "back in service"}

# -- gidabot_msgs/Cancel reasons -------------------------------------------------------------
REASON_VISITOR = "visitor"
REASON_UNREACHABLE = "unreachable"
REASON_TIMEOUT = "timeout"
REASON_OFFLINE = "offline"
REASON_ADMIN = "admin"
REASON_VISITOR_LOST = "visitor_lost"     # the guiding robot lost its visitor and did not find them again
REASONS = (REASON_VISITOR, REASON_UNREACHABLE, REASON_TIMEOUT, REASON_OFFLINE, REASON_ADMIN, REASON_VISITOR_LOST)

class RobotState(StrEnum):
    """gidabot_msgs/RobotStatus states (the same strings: a state received as text compares equal)."""

    IDLE = "idle"                  # no request; ready
    GUIDING = "guiding"            # guiding the visitor to a goal or connector
    TO_MEETING = "to_meeting"      # driving alone to the meeting point of a connector (or to pick a visitor up)
    WAITING = "waiting"            # at the meeting point, waiting for the visitor
    RETURNING = "returning"        # driving back to its home pose
    ERROR = "error"                # navigation stack not available


# -- gidabot_msgs/Goal ways: how a visitor changes floors (also the kinds of a building's connectors)
# the simulator's people in a robot's ``robots_seen`` (its move_base's obstacle layer): their ids start so; robots
# are named by their names, which never do (a building's robot names are identifiers)
PERSON_ID_PREFIX = "person/"

WAY_LIFT = "lift"
WAY_STAIRS = "stairs"
WAYS = (WAY_LIFT, WAY_STAIRS)

# -- gidabot_msgs/Goal legs of a trip and their assignment states (docs/guiding.md, who serves a leg)
LEG_START = "start"      # from the start point (the whole trip on one floor; else to the connector)
LEG_GOAL = "goal"        # on the goal floor of a cross-floor trip: meet the visitor, guide to the goal
LEGS = (LEG_START, LEG_GOAL)
LEG_NONE = 0             # no robot serves the leg (one-floor trip's goal leg, a floor without robot)
LEG_PROPOSED = 1         # the origin robot asked that robot; it answers ACCEPTED or DECLINED
LEG_COMMITTED = 2        # that robot serves the leg; never changes afterwards
LEG_STATES = (LEG_NONE, LEG_PROPOSED, LEG_COMMITTED)
LEG_STATE_NAMES = {LEG_NONE: "none", LEG_PROPOSED: "proposed", LEG_COMMITTED: "committed"}

# -- gidabot_msgs/VisitorTrack sights: what the robot's laser knows of the visitor it guides (docs/perception.md)
class Sight(IntEnum):
    """gidabot_msgs/VisitorTrack ``sight`` (same numbers)."""

    NONE = 0            # no visitor locked
    ACQUIRING = 1       # a lock was asked for; no track in the lock cone yet
    SEEN = 2            # the visitor's track was updated by the latest scan
    HIDDEN = 3          # predicted inside the laser's field of view but not seen (occluded, missed)
    OUT_OF_VIEW = 4     # predicted outside the laser's field of view (e.g. behind a front laser): turn to look
    LOST = 5            # unseen beyond the budgets, or never found in the lock cone


SIGHT_NAMES = {s: s.name.lower().replace("_", " ") for s in Sight}

# -- the visitors' languages (building names, tours, pop-ups, speech) -------------------------
LANGUAGES = ("eu", "en", "es")
DEFAULT_LANGUAGE = "en"
