"""The conversions between gidabot_msgs messages and their ROS-free forms (ros/convert.py), without a master.

Every message of gidabot_navigation goes form -> message -> bytes -> message -> form and comes back equal,
field by field, from a sample whose every field differs from its default; every field (``__slots__``) of
the message is written on the way (a field added to a .msg file that no conversion carries fails here);
every gidabot_msgs message has its conversion here or is the simulator's; no module of gidabot_navigation
or gidabot_gui but the conversion module builds one. Then the odd input the conversions handle: stamps
that are not finite or negative, orientations that are not finite, over-long details, more goals than a
PendingRequests can count, a TourIndex whose arrays differ in length, empty messages.
"""

from __future__ import annotations

import ast
import io
import math
from collections.abc import Callable
from dataclasses import MISSING, dataclass, fields, replace
from pathlib import Path

import genpy
import pytest

import gidabot_msgs.msg as gidabot_msgs
from gidabot_navigation.building.geometry import Pose2D
from gidabot_navigation.guiding import messages as forms
from gidabot_navigation.interface import (
    LEG_COMMITTED,
    LEG_GOAL,
    LEG_PROPOSED,
    REASON_UNREACHABLE,
    WAY_LIFT,
    Cmd,
    Phase,
    RobotState,
    Sight,
    StaffCmd,
)
from gidabot_navigation.perception.people import LastSeen, PeopleData, Track, VisitorReport, VisitorTrackData
from gidabot_navigation.relay.links import LinkData, LinkSummaryData
from gidabot_navigation.ros import convert
from gidabot_navigation.tours.tour_store import CatalogData, EditResultData, IndexEntry, TourIndexData, TourMessage

REPO = Path(__file__).resolve().parents[4]
SIMULATOR_MESSAGES = {"Obstacle", "ObstacleArray", "StepDone", "VisitorBody"}     # converted in gidabot_sim
PARTS = {"LinkState"}                                              # converted as part of LinkSummary
ELEMENT_MESSAGES = {"Person"}                                       # converted inside PersonArray

# samples: every field set to a value other than its default, numbers exact in float32
TRIP = forms.Trip(uid="Kbot/v/k1.2", origin_robot="Kbot", visitor_id="v", initial_floor=1.0, initial_x=30.5,
                  initial_y=12.25, goal_floor=2.0, goal_x=9.5, goal_y=11.75, goal_yaw=1.25, way=WAY_LIFT,
                  connector="lift", start_id="104", goal_id="223", language="eu", tour_file="real_world.tour",
                  tour_step=2, stamp=100.25, start_robot="Kbot", start_state=LEG_COMMITTED, goal_robot="Tartalo",
                  goal_state=LEG_PROPOSED, attempt=3)
EVENT = forms.NavEventData(uid="Kbot/event/n.1", robot="Kbot", floor=1.0, goal_uid=TRIP.uid, phase=Phase.GO_TO_FLOOR,
                           language="es", way=WAY_LIFT, connector="lift", target_floor=2.0, location_id="lift",
                           tour_file="real_world.tour", tour_step=2, detail="start leg done", stamp=120.5,
                           leg=LEG_GOAL, attempt=3, assignee="Tartalo", eta=42.5, x=3.25, y=-1.5)
A_CANCEL = forms.CancelData(uid="Kbot/cancel/n.2", goal_uid=TRIP.uid, origin_robot="Kbot", reason=REASON_UNREACHABLE,
                            detail="no path", stamp=121.75)
COMMAND = forms.CommandData(command=Cmd.SKIP, uid="Kbot/gui/cmd/3", visitor_id="gui", goal_id="104", way=WAY_LIFT,
                            language="eu", goal_uid=TRIP.uid, tour_file="real_world.tour", tour_step=4, stamp=99.5)
PENDING = forms.PendingData(robot="Kbot", floor=1.0, num=2, wait_new=250.5,
                            goals=(TRIP, replace(TRIP, uid="Kbot/v/k1.3", attempt=1)), eta=(100.5, 250.5), stamp=101.0)
STATUS = forms.RobotStatusData(robot="Kbot", floor=1.0, x=30.5, y=12.25, yaw=-2.5, linear=0.5, angular=-0.25,
                               battery=0.75, state=RobotState.GUIDING, pending=2, current_goal_uid=TRIP.uid,
                               busy_for=250.5, stamp=102.5, frame_id="map")
POSE = forms.PoseData(robot="Kbot", floor=1.0, x=31.5, y=12.5, yaw=3.0, stamp=102.75, frame_id="map")
ASK = forms.WayAsk(robot="Kbot", floor=1.0, robots=("Basajaun",), way=((30.5, 12.0), (40.25, 11.5)), stamp=102.5,
                   frame_id="map")
TOUR = TourMessage(uid="Kbot/tour/b.1", origin_robot="Tartalo", editor_robot="Kbot", version=1_700_000_000_123_456_789,
                   deleted=True, language="es", floor=1.0, tour_name="Open day", file_name="open_day.tour",
                   tour_goals_info=("1, 101, Secretary's Office", "2, 223, Lab"), stamp=103.5)
INDEX = TourIndexData(robot="Kbot", entries=(IndexEntry("a.tour", 5, "Kbot", False),
                                             IndexEntry("b.tour", 2**63, "Tartalo", True)), stamp=104.0)
CATALOG = CatalogData(robot="Kbot", tours=(TOUR, replace(TOUR, file_name="b.tour", deleted=False)), stamp=104.5)
RESULT = EditResultData(uid="Kbot/gui/tour-edit/1", file_name="open_day.tour", deleted=True, ok=True, version=7,
                        reason="in_the_way", error="a directory is in the way", stamp=105.25)
STAFF = forms.StaffCommandData(uid="Kbot/staff/d.1", robot="Kbot", user="ana", command=StaffCmd.BACK_IN_SERVICE,
                               target_robot="Tartalo", version=1_800_000_000_123_456_789, detail="fixed", stamp=106.5)
LINKS = LinkSummaryData(robot="Kbot", links=(
    LinkData(peer="Tartalo", known=True, connected=True, down_s=1.5, heard_s=0.5, rtt_ms=0.75, queued=3, resent=4,
             dropped=5, duplicates_suppressed=6, link_losses=7, peer_master_up=True),
    LinkData(peer="MariSorgin")), stamp=107.0)
PERSON = Track(id=7, x=3.5, y=-1.25, vx=0.5, vy=-0.25, confidence=0.75, unseen=0.5, confirmed=True, visitor=True)
PEOPLE = PeopleData(tracks=(PERSON, replace(PERSON, id=8, visitor=False)), stamp=106.5)
VISITOR = VisitorTrackData(VisitorReport(sight=Sight.HIDDEN, track_id=7, x=3.5, y=-1.25, vx=0.5, vy=-0.25,
                                         distance=1.5, behind=1.25, bearing=3.0, unseen=0.75,
                                         last_seen=LastSeen(Pose2D(3.0, -1.0, 1.5), 105.5), confidence=0.5),
                           stamp=106.75)


@dataclass(frozen=True)
class Case:
    cls: type
    to_msg: Callable
    from_msg: Callable
    sample: object


CASES = [
    Case(gidabot_msgs.Goal, convert.trip_to_msg, convert.trip_from_msg, TRIP),
    Case(gidabot_msgs.NavEvent, convert.event_to_msg, convert.event_from_msg, EVENT),
    Case(gidabot_msgs.Cancel, convert.cancel_to_msg, convert.cancel_from_msg, A_CANCEL),
    Case(gidabot_msgs.VisitorCommand, convert.command_to_msg, convert.command_from_msg, COMMAND),
    Case(gidabot_msgs.PendingRequests, convert.pending_to_msg, convert.pending_from_msg, PENDING),
    Case(gidabot_msgs.RobotStatus, convert.status_to_msg, convert.status_from_msg, STATUS),
    Case(gidabot_msgs.NavPose, convert.pose_to_msg, convert.pose_from_msg, POSE),
    Case(gidabot_msgs.MakeWay, convert.make_way_to_msg, convert.make_way_from_msg, ASK),
    Case(gidabot_msgs.Tour, convert.tour_to_msg, convert.tour_from_msg, TOUR),
    Case(gidabot_msgs.TourIndex, convert.index_to_msg, convert.index_from_msg, INDEX),
    Case(gidabot_msgs.TourCatalog, convert.catalog_to_msg, convert.catalog_from_msg, CATALOG),
    Case(gidabot_msgs.TourEditResult, convert.edit_result_to_msg, convert.edit_result_from_msg, RESULT),
    Case(gidabot_msgs.StaffCommand, convert.staff_to_msg, convert.staff_from_msg, STAFF),
    Case(gidabot_msgs.LinkSummary, convert.links_to_msg, convert.links_from_msg, LINKS),
    Case(gidabot_msgs.PersonArray, convert.people_to_msg, convert.people_from_msg, PEOPLE),
    Case(gidabot_msgs.VisitorTrack, convert.visitor_track_to_msg, convert.visitor_track_from_msg, VISITOR),
]
IDS = [c.cls._type for c in CASES]


def wire(msg: genpy.Message) -> genpy.Message:
    """``msg`` serialised and read back, as a subscriber gets it."""
    buf = io.BytesIO()
    msg.serialize(buf)
    out = type(msg)()
    out.deserialize(buf.getvalue())
    return out


def same(a: object, b: object) -> bool:
    """Equal, floats within float32 precision (NaN equals NaN), dataclasses and tuples field by field."""
    if isinstance(a, float) or isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-6)
    if hasattr(a, "__dataclass_fields__"):
        return type(a) is type(b) and all(same(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))
    if isinstance(a, tuple):
        return isinstance(b, tuple) and len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def differences(a: object, b: object) -> list[str]:
    return [f"{f.name}: {getattr(a, f.name)!r} != {getattr(b, f.name)!r}" for f in fields(a)
            if not same(getattr(a, f.name), getattr(b, f.name))]


def test_every_message_has_its_conversion() -> None:
    messages = {name for name, cls in vars(gidabot_msgs).items()
                if isinstance(cls, type) and issubclass(cls, genpy.Message)}
    assert messages == {c.cls.__name__ for c in CASES} | SIMULATOR_MESSAGES | ELEMENT_MESSAGES | PARTS


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_the_sample_sets_every_field(case: Case) -> None:
    unset = [f.name for f in fields(case.sample)
             if getattr(case.sample, f.name) == (f.default if f.default is not MISSING else None)
             or getattr(case.sample, f.name) in ("", 0, (), False)]
    assert not unset, f"the {type(case.sample).__name__} sample leaves {unset} at their defaults"


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_form_to_message_to_form(case: Case) -> None:
    back = case.from_msg(wire(case.to_msg(case.sample)))
    assert same(back, case.sample), differences(back, case.sample)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_every_message_field_is_carried(case: Case) -> None:
    msg, empty = case.to_msg(case.sample), case.cls()
    assert list(case.cls.__slots__), case.cls
    left = [slot for slot in case.cls.__slots__ if getattr(msg, slot) == getattr(empty, slot)]
    assert not left, f"{case.cls._type}: {left} not written by {case.to_msg.__name__}"
    assert msg.header.stamp.to_sec() > 0 if "header" in case.cls.__slots__ else True


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_an_empty_message_converts(case: Case) -> None:
    form = case.from_msg(case.cls())
    assert type(form) is type(case.sample)
    case.to_msg(form).serialize(io.BytesIO())


def test_the_vocabulary_goes_on_the_wire_as_the_messages_spell_it() -> None:
    assert wire(convert.event_to_msg(EVENT)).phase == gidabot_msgs.NavEvent.GO_TO_FLOOR
    assert wire(convert.command_to_msg(COMMAND)).command == gidabot_msgs.VisitorCommand.SKIP
    status = wire(convert.status_to_msg(STATUS))
    assert status.state == RobotState.GUIDING.value and type(status.state) is str
    assert convert.status_from_msg(status).state == RobotState.GUIDING


@pytest.mark.parametrize("stamp", [math.nan, math.inf, -math.inf, -3.0, 0.0])
def test_a_stamp_that_is_no_ros_time_is_sent_as_zero(stamp: float) -> None:
    for case in CASES:
        msg = wire(case.to_msg(replace(case.sample, stamp=stamp)))
        assert msg.header.stamp == genpy.Time(0), case.cls._type
        assert case.from_msg(msg).stamp == 0.0


def test_stamps_keep_their_nanoseconds() -> None:
    assert convert.ros_time(1_700_000_000.25) == genpy.Time(1_700_000_000, 250_000_000)
    assert convert.ros_time(12.000001) == genpy.Time(12, 1000)            # rounded, not cut to 999 ns
    assert convert.ros_time(12.9999999999) == genpy.Time(13, 0)
    assert convert.stamp_of(object()) == 0.0


def test_an_orientation_that_is_not_finite_is_a_nan_yaw() -> None:
    msg = convert.trip_to_msg(TRIP)
    msg.goal_pose.orientation.w = math.inf
    assert math.isnan(convert.trip_from_msg(msg).goal_yaw)
    bad = convert.status_to_msg(replace(STATUS, yaw=math.nan))
    assert math.isnan(convert.status_from_msg(wire(bad)).yaw)
    assert math.isnan(convert.pose_from_msg(wire(convert.pose_to_msg(replace(POSE, yaw=math.inf)))).yaw)
    nan_pose = convert.pose_to_msg(replace(POSE, x=math.nan))
    assert math.isnan(convert.pose_from_msg(wire(nan_pose)).x)


def test_details_are_cut_to_400_characters() -> None:
    long = "x" * 1000
    assert convert.event_to_msg(replace(EVENT, detail=long)).detail == "x" * 400
    assert convert.cancel_to_msg(replace(A_CANCEL, detail=long)).detail == "x" * 400
    msg = gidabot_msgs.NavEvent(detail=long)
    assert convert.event_from_msg(msg).detail == long       # received text is the core's to check


def test_a_pending_list_counts_at_most_255_goals() -> None:
    many = replace(PENDING, num=300, goals=(TRIP,) * 300, eta=(1.0,) * 300)
    msg = wire(convert.pending_to_msg(many))
    assert (msg.num, len(msg.goals), len(msg.eta)) == (255, 255, 255)
    back = convert.pending_from_msg(msg)
    assert (back.num, len(back.goals), len(back.eta)) == (255, 255, 255)


def test_a_diagnostic_status_is_read_with_its_values() -> None:
    from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

    status = DiagnosticStatus(level=DiagnosticStatus.ERROR, name="relay Kbot-MariSorgin: Kbot", message="down",
                              hardware_id="/gidabot_relay_Kbot_MariSorgin",
                              values=[KeyValue("connected", "False"), KeyValue("rtt_ms", "")])
    d = convert.diagnostic_from_msg(wire(status))
    assert (d.name, d.level, d.message, d.hardware_id, dict(d.values)) == (
        "relay Kbot-MariSorgin: Kbot", 2, "down", "/gidabot_relay_Kbot_MariSorgin",
        {"connected": "False", "rtt_ms": ""})


def test_a_visitor_report_without_values_goes_as_nan_and_comes_back_as_none() -> None:
    none = VisitorTrackData(VisitorReport(sight=Sight.ACQUIRING), stamp=3.0)
    msg = wire(convert.visitor_track_to_msg(none))
    assert math.isnan(msg.distance) and msg.id == 0 and msg.last_seen_stamp == genpy.Time(0)
    assert convert.visitor_track_from_msg(msg) == none
    assert convert.person_from_msg(convert.person_to_msg(PERSON)) == PERSON


def test_a_visitor_track_with_an_unknown_sight_is_refused() -> None:
    with pytest.raises(ValueError, match="sight 9"):
        convert.visitor_track_from_msg(gidabot_msgs.VisitorTrack(sight=9))


def test_a_tour_index_with_arrays_of_different_lengths_is_refused() -> None:
    msg = gidabot_msgs.TourIndex(robot="Kbot", file_names=["a.tour", "b.tour"], versions=[1], editor_robots=["Kbot"],
                                 deleted=[False])
    with pytest.raises(ValueError, match="different lengths"):
        convert.index_from_msg(msg)
    odd = gidabot_msgs.TourIndex(robot="Kbot", file_names=["a.tour", 7], versions=[1, 2], editor_robots=["K", "K"],
                                 deleted=[False, True])
    assert convert.index_from_msg(odd).entries == (IndexEntry("a.tour", 1, "K", False),)   # a bad entry left out


# -- one place: no other module of gidabot_navigation, gidabot_gui or gidabot_web builds a gidabot_msgs message
MESSAGE_NAMES = {name for name, cls in vars(gidabot_msgs).items()
                 if isinstance(cls, type) and issubclass(cls, genpy.Message)}


def messages_built(path: Path) -> list[str]:
    """``file:line: Name()`` of every gidabot_msgs message class a module calls (builds)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    imported = {a.asname or a.name: a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
                and n.module == "gidabot_msgs.msg" for a in n.names if a.name in MESSAGE_NAMES}
    return [f"{path}:{n.lineno}: {imported[n.func.id]}()" for n in ast.walk(tree)
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id in imported]


def test_messages_are_built_only_in_the_conversion_module() -> None:
    files = [p for pkg in ("gidabot_navigation", "gidabot_gui", "gidabot_web")
             for p in (REPO / "src" / pkg / "src").rglob("*.py")
             if p.resolve() != Path(convert.__file__).resolve()]
    assert len(files) > 30
    found = [hit for f in sorted(files) for hit in messages_built(f)]
    assert not found, "gidabot_msgs messages are built in gidabot_navigation/ros/convert.py only:\n" + "\n".join(found)


def test_the_check_finds_a_message_built_elsewhere(tmp_path: Path) -> None:
    planted = tmp_path / "node.py"
    planted.write_text("from gidabot_msgs.msg import NavEvent as Ev, Goal\nfrom std_msgs.msg import String\n"
                       "def f(m):\n    e = Ev()\n    e.uid = m.uid\n    return e, String(), Goal._type\n")
    assert [h.split(": ", 1)[1] for h in messages_built(planted)] == ["NavEvent()"]
