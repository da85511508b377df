"""What the screen says about where things stand (ROS-free, Qt-free): the navigation info line at the
bottom (where this robot is, the trip at this screen), the robots' labels on the blueprints and the
cards of the Information tab. Built at display time, in the translator's current language.
"""

from __future__ import annotations

from dataclasses import dataclass

from gidabot_gui.core.flow import Activity, Mode, VisitorFlow
from gidabot_gui.core.i18n import format_number
from gidabot_gui.core.model import Fleet, finite
from gidabot_gui.core.places import nearest_place
from gidabot_gui.core.texts import Texts


@dataclass(frozen=True)
class RobotCard:
    """The Information tab's card of one robot."""

    title: str
    floor: str
    state: str
    state_code: str               # the robot's state when online ("" otherwise): the colour of the state
    motion: str
    battery: float | None         # 0..1, None when unknown
    battery_text: str
    pending: str
    here: bool
    offline: bool


def here_line(texts: Texts, fleet: Fleet) -> str:
    """Where this robot is: the nearest place ("at" or "near" it) and the floor."""
    t = texts.tr
    robot = fleet.building.robot(texts.robot)
    live = fleet.robots[robot.name]
    floor = texts.floor(robot.floor)
    if live.pose is None:
        return t._("Here: {floor}").format(floor=floor)
    place = nearest_place(fleet.building, robot.floor, live.pose[0], live.pose[1])
    if place is None:
        return t._("Here: {floor}").format(floor=floor)
    name = texts.place(place.id)
    text = t._("Here: {place}") if place.at else t._("Here: near {place}")
    return text.format(place=name) + f" · {floor}"


def out_of_service_line(texts: Texts, fleet: Fleet) -> str:
    """What the screen says while staff have taken this robot out of service ("" when in service)."""
    if not fleet.out_of_service(texts.robot):
        return ""
    return texts.tr._("This guide is out of service: please ask another guide or the staff of the building.")


def trip_line(texts: Texts, flow: VisitorFlow, banner: str) -> str:
    """The trip at this screen and what to do now (or what the visitor can do, when idle)."""
    t = texts.tr
    cur = flow.current
    if cur is None:
        if flow.coming is not None or banner:
            return banner or t._("I am going to meet a visitor.")
        if flow.mode is Mode.TOUR:
            return t._("Choose a tour and start it.")
        return t._("Choose a destination: tap a place, or search in Offices.")
    start = texts.place(cur.start_id) if cur.start_id else t._("here")
    route = (t._("From: {start} → To: {goal}").format(start=start, goal=texts.place(cur.goal_id))
             if cur.goal_id else t._("From: {start}").format(start=start))
    status = {
        Activity.PENDING: t._("Request sent, waiting for an answer…"),
        Activity.QUEUED: t._("In the queue: the robot will come for you."),
        Activity.GUIDING: t._("On the way: walk behind the robot."),
        Activity.WAITING: t._("Press Continue when you are here."),
        Activity.STEP_DONE: t._("Stop reached: press Continue or choose the next stop."),
    }.get(cur.activity, "")
    return f"{route} · {status}" if status else route


def mark_label(texts: Texts, name: str, here: bool, offline: bool) -> str:
    """The label of a robot on the blueprint."""
    if offline:
        return texts.tr._("{robot} · offline").format(robot=name)
    if here:
        return texts.tr._("{robot} · You are here").format(robot=name)
    return name


def robot_card(texts: Texts, fleet: Fleet, name: str, now: float) -> RobotCard:
    """The card of robot ``name`` at wall time ``now``: state, motion, battery and pending requests."""
    t, lang = texts.tr, texts.lang
    live = fleet.robots[name]
    here = name == texts.robot
    offline = fleet.is_offline(name, now)
    s = live.status
    title = name + (" · " + t._("this robot") if here else "")
    floor = texts.floor(live.robot.floor)
    battery = s.battery if s is not None and finite(s.battery) and 0 <= s.battery <= 1 else None
    pending = ""
    code = ""
    if not fleet.ever_seen(name):
        state, motion = t._("No contact yet"), t._("Position unknown")
    elif offline:
        ago = fleet.seen_ago(name, now) or 0.0
        state = t._("Offline · last seen {s} s ago").format(s=int(ago))
        motion = t._("Position unknown")
        if live.pose is not None:
            place = nearest_place(fleet.building, live.robot.floor, live.pose[0], live.pose[1])
            where = texts.place(place.id) if place is not None else "-"
            motion = t._("Last known position: {place} (x {x} m, y {y} m)").format(
                place=where, x=format_number(live.pose[0], 1, lang), y=format_number(live.pose[1], 1, lang))
    else:
        code = s.state if s is not None else ""
        state = texts.state(code)
        if fleet.out_of_service(name):
            state = t._("Out of service") + " · " + state
        lin = s.linear if s is not None and finite(s.linear) else 0.0
        ang = s.angular if s is not None and finite(s.angular) else 0.0
        motion = t._("Speed {v} m/s · turning {w} rad/s").format(v=format_number(lin, 2, lang),
                                                                  w=format_number(ang, 2, lang))
        wait = fleet.wait_of(name, now)
        if wait is not None:
            n, w = wait
            pending = (t.n_("{n} pending request", "{n} pending requests", n).format(n=n) + " · "
                       + texts.minutes(w)) if n else t._("No pending requests")
    battery_text = (t._("Battery {percent} %").format(percent=int(round(battery * 100)))
                    if battery is not None else t._("Battery unknown"))
    return RobotCard(title, floor, state, code, motion, battery, battery_text, pending, here, offline)
