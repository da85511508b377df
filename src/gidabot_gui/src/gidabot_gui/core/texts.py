"""Every sentence the GUI shows or speaks about trips (ROS-free).

Texts are built from records (:class:`~gidabot_gui.core.flow.Notice`, wait estimates)
each time they are shown, in the translator's current language, so a pop-up on
screen is re-translated when the visitor switches language. Source strings are
English; ``src/gidabot_gui/tools/update-translations.sh`` extracts them into the catalogs.
Place and floor names come from the building file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from gidabot_gui.core.flow import LocalNotice, Notice, NoticeKind
from gidabot_gui.core.i18n import N_, Translator
from gidabot_gui.core.model import TourInfo, finite
from gidabot_gui.core.places import floor_name, place_name
from gidabot_gui.core.plans import RequestPlan, RobotWait
from gidabot_navigation.building.model import Building
from gidabot_navigation.guiding.messages import NavEventData
from gidabot_navigation.interface import LEG_GOAL, WAY_LIFT, Phase, RobotState


@dataclass(frozen=True)
class PopupText:
    title: str
    body: str
    speech: str
    tone: str       # info | success | warning | error | action
    note: str = ""  # highlighted reminder (walk behind the robot)


STATE_LABELS = {
    RobotState.IDLE: N_("Ready"),
    RobotState.GUIDING: N_("Guiding a visitor"),
    RobotState.TO_MEETING: N_("Going to meet a visitor"),
    RobotState.WAITING: N_("Waiting for a visitor"),
    RobotState.RETURNING: N_("Going back home"),
    RobotState.ERROR: N_("Navigation problem"),
}


# notices whose body is also what is said: kind -> (title, body, tone)
SAID_AS_SHOWN: dict[NoticeKind, tuple[str, str, str]] = {
    Phase.CANCELLED_ELSEWHERE: (N_("Trip cancelled"), N_("The trip was cancelled at another robot."), "warning"),
    Phase.TIMEOUT: (N_("Request dropped"), N_("Nobody pressed Continue in time, so the request was dropped."),
                    "warning"),
    LocalNotice.NO_ANSWER: (N_("No answer"), N_("The guiding system did not answer. Please try again in a moment."),
                            "error"),
    LocalNotice.BUSY: (N_("A trip is running"), N_("Finish or cancel the current trip first."), "warning"),
}


class Texts:
    """Sentences in the translator's current language."""

    def __init__(self, tr: Translator, building: Building, robot: str) -> None:
        self.tr = tr
        self.building = building
        self.robot = robot
        self.tours: dict[str, TourInfo] = {}

    @property
    def lang(self) -> str:
        return self.tr.language

    # ------------------------------------------------------------------ names
    def place(self, place_id: str) -> str:
        """A location as "name (room)", a connector by name; "" if unknown."""
        loc = self.building.find_location(place_id)
        if loc is not None:
            name = loc.name(self.lang)
            return name if loc.id in name else f"{name} ({loc.id})"
        return place_name(self.building, place_id, self.lang)

    def spoken_place(self, place_id: str) -> str:
        return place_name(self.building, place_id, self.lang)

    def floor(self, floor: float) -> str:
        name = floor_name(self.building, floor, self.lang)
        return name or self.tr._("floor {floor}").format(floor=_num(floor))

    def state(self, state: str) -> str:
        label = STATE_LABELS.get(state)
        return self.tr._(label) if label else self.tr._("Unknown state")

    def minutes(self, seconds: float | None) -> str:
        """A wait as the visitor wants to read it."""
        t = self.tr
        if seconds is None or not math.isfinite(seconds):
            return t._("wait unknown")
        if seconds < 30:
            return t._("can start now")
        m = max(1, math.ceil(seconds / 60.0 - 1e-9))
        return t.n_("about {n} minute", "about {n} minutes", m).format(n=m)

    def wait_line(self, w: RobotWait) -> str:
        """This robot's wait; or the other robot of this floor that would come, or the robot that would meet the
        visitor on the goal floor, and how soon it would be there."""
        t = self.tr
        if not w.here and w.known:
            line = t._("{robot} meets you there: {wait}") if w.leg == LEG_GOAL else \
                t._("{robot} comes here to guide you: {wait}")
            return line.format(robot=w.robot, wait=self.minutes(w.wait_s))
        who = t._("{robot} (this robot)").format(robot=w.robot) if w.here else w.robot
        if not w.known:
            return t._("{who}: not available right now").format(who=who)
        if w.num == 0 and (w.wait_s is None or w.wait_s < 30):
            return t._("{who}: free, can start now").format(who=who)
        pending = t.n_("{n} request before yours", "{n} requests before yours", w.num).format(n=w.num)
        return t._("{who}: {pending}, {wait}").format(who=who, pending=pending, wait=self.minutes(w.wait_s))

    # ------------------------------------------------------------------ confirmation
    def confirm(self, plan: RequestPlan) -> PopupText:
        t = self.tr
        lines = [self.floor(plan.goal_floor), "", t._("Waiting time:")]
        lines += ["• " + self.wait_line(w) for w in plan.waits]
        if plan.changes_floor and not plan.robot_on_goal_floor:
            lines += ["", t._("No robot serves {floor}: there you will have to find the place on your own.")
                      .format(floor=self.floor(plan.goal_floor))]
        return PopupText(self.place(plan.goal_id), "\n".join(lines), "", "action")

    def confirm_tour(self, tour: TourInfo, waits: tuple[RobotWait, ...]) -> PopupText:
        t = self.tr
        floors = len(tour.floors)
        stops = t.n_("{n} stop", "{n} stops", len(tour.goals)).format(n=len(tour.goals))
        on = t.n_("on {n} floor", "on {n} floors", floors).format(n=floors)
        lines = [f"{stops} {on}", "", t._("Waiting time:")] + ["• " + self.wait_line(w) for w in waits]
        return PopupText(tour.title, "\n".join(lines), "", "action")

    # ------------------------------------------------------------------ events
    def _other(self, ev: NavEventData | None) -> str:
        """The other robot an event is about: the one it names, else the only robot of its target floor."""
        if ev is None:
            return ""
        if ev.assignee:
            return ev.assignee
        robots = self.building.robots_on(ev.target_floor) if finite(ev.target_floor) else []
        return robots[0].name if len(robots) == 1 else ""

    def _naming(self, ev: NavEventData | None, named: str, anonymous: str) -> str:
        """``named`` with the other robot the event is about (:meth:`_other`), or ``anonymous`` when there is none."""
        robot = self._other(ev)
        return named.format(robot=robot) if robot else anonymous

    def _alone(self, n: Notice) -> tuple[list[str], float | None]:
        """A tour stop on a floor without robot: the places the visitor finds alone (that stop and the next ones
        on floors without robot) and the floor of the tour's next stop with a robot (None: the tour ends)."""
        tour = self.tours.get(n.tour_file)
        if tour is None or not 0 <= n.tour_step < len(tour.goals):
            return ([self.place(n.goal_id)] if n.goal_id else []), None
        places, first = [], tour.goals[n.tour_step][0]
        for floor, room, desc in tour.goals[n.tour_step:]:
            if self.building.has_robot(floor):
                return places, floor
            name = self.place(room) or desc
            places.append(name if floor == first else t_floor(name, self.floor(floor)))
        return places, None

    def _go_alone(self, n: Notice, way: str, connector: str) -> tuple[str, str]:
        """(text, speech) sending the visitor to a floor without robot by the lift or staircase ``connector`` (its
        name; "" if unknown), and on."""
        t = self.tr
        ev = n.event
        target = ev.target_floor if ev is not None else math.nan
        places, nxt = self._alone(n)
        first = t._("No robot serves this floor: {floor}.").format(floor=self.floor(target))
        lift = way == WAY_LIFT
        if len(places) > 1:
            go = (t._("Go there by the lift ({connector}) and look for these places on your own: {places}.") if lift
                  else t._("Go there by the stairs ({connector}) and look for these places on your own: {places}."))
            if not connector:
                go = (t._("Go there by the lift and look for these places on your own: {places}.") if lift else
                      t._("Go there by the stairs and look for these places on your own: {places}."))
        else:
            go = (t._("Go there by the lift ({connector}) and look for the place on your own: {place}.") if lift else
                  t._("Go there by the stairs ({connector}) and look for the place on your own: {place}."))
            if not connector:
                go = (t._("Go there by the lift and look for the place on your own: {place}.") if lift else
                      t._("Go there by the stairs and look for the place on your own: {place}."))
        go = go.format(connector=connector, places="; ".join(places), place=places[0] if places else "-")
        lines = [f"{first} {go}"]
        if nxt is not None:
            robot = ev.assignee if ev is not None else ""
            then = (t._("Then go to {floor} by the lift: {robot} waits for you there.") if way == WAY_LIFT else
                    t._("Then go to {floor} by the stairs: {robot} waits for you there.")) if robot else \
                (t._("Then go to {floor} by the lift: a robot waits for you there.") if way == WAY_LIFT else
                 t._("Then go to {floor} by the stairs: a robot waits for you there."))
            lines.append(then.format(floor=self.floor(nxt), robot=robot))
        elif n.tour_file:
            lines.append(t._("That is the end of the tour. Goodbye, and thank you for your visit!"))
        return "\n\n".join(lines), " ".join(lines)

    def _tour_stop(self, n: Notice) -> tuple[str, str]:
        """(title, next stop sentence) of a tour step notice."""
        t = self.tr
        tour = self.tours.get(n.tour_file)
        step = n.tour_step
        if tour is None or step < 0:
            return t._("Stop reached"), ""
        title = t._("Stop {n} of {total}").format(n=step + 1, total=len(tour.goals))
        if step + 1 < len(tour.goals):
            _floor, room, desc = tour.goals[step + 1]
            name = self.place(room) or desc
            return title, t._("Next stop: {place}.").format(place=name)
        return title, ""

    def notice(self, n: Notice) -> PopupText:  # noqa: C901 - one branch per phase
        t = self.tr
        ev = n.event
        goal = self.place(n.goal_id) if n.goal_id else ""
        spoken_goal = self.spoken_place(n.goal_id) if n.goal_id else ""
        target = ev.target_floor if ev is not None else math.nan
        connector = self.place(ev.connector) if ev is not None and ev.connector else ""
        way = ev.way if ev is not None else ""
        kind = n.kind
        if kind is Phase.ON_THE_WAY:
            behind = t._("Please walk behind me, not in front of me or beside me: I need to see the way clear.")
            lines = [t._("Destination: {place}.").format(place=goal)] if goal else []
            loc = self.building.find_location(n.goal_id)
            if connector and loc is not None and loc.floor != self.building.robot(self.robot).floor:
                lines.append(t._("First we go to: {connector}.").format(connector=connector))
            speech = [t._("Follow me.")]
            if spoken_goal:
                speech.append(t._("Destination: {place}.").format(place=spoken_goal))
            speech.append(t._("Please walk behind me."))
            return PopupText(t._("Follow me"), "\n".join(lines), " ".join(speech), "info", note=behind)
        if kind is Phase.ASSIGNED:
            robot = ev.assignee if ev is not None else ""
            coming = t._("{robot} will guide you: it is coming here ({wait}).").format(
                robot=robot, wait=self.minutes(ev.eta if ev is not None else None))
            stay = t._("Please wait by this screen.")
            return PopupText(t._("A guide is coming"), f"{coming}\n\n{stay}", f"{coming} {stay}", "info")
        if kind is Phase.GO_TO_FLOOR:
            floor = self.floor(target)
            go = (t._("Take the lift ({connector}) to: {floor}.") if way == WAY_LIFT else
                  t._("Take the stairs ({connector}) to: {floor}.")).format(connector=connector or "-", floor=floor)
            if not connector:
                go = (t._("Take the lift to: {floor}.") if way == WAY_LIFT else
                      t._("Take the stairs to: {floor}.")).format(floor=floor)
            wait = self._naming(ev, t._("{robot} will wait for you there and guide you on."),
                                t._("Nobody can guide you there: find the place on your own."))
            return PopupText(t._("Please change floors"), f"{go}\n\n{wait}", f"{go} {wait}", "action")
        if kind is Phase.WAITING_VISITOR:
            hello = t._("Hello, I am {robot}.").format(robot=self.robot)
            lines = [hello]
            if goal:
                lines.append(t._("I will take you to: {place}.").format(place=goal))
            press = t._("Press Continue when you are here.")
            lines.append(press)
            return PopupText(t._("Welcome!"), "\n\n".join(lines), f"{hello} {press}", "action")
        if kind is Phase.GOING_TO_MEETING:
            where = connector or goal
            text = (t._("I am going to meet a visitor at: {place}.").format(place=where) if where else
                    t._("I am going to meet a visitor."))
            return PopupText(text, "", "", "info")
        if kind is Phase.GOAL_REACHED:
            here = t._("This is: {place}.").format(place=goal) if goal else ""
            thanks = t._("Thank you for your visit!")
            return PopupText(t._("You have arrived"), "\n\n".join(x for x in (here, thanks) if x),
                             " ".join(x for x in (t._("You have arrived."), thanks) if x), "success")
        if kind is Phase.TOUR_STEP_DONE:
            title, nxt = self._tour_stop(n)
            here = t._("This is: {place}.").format(place=goal) if goal else ""
            press = t._("Press Continue to go on, or choose another stop from the list.")
            body = "\n\n".join(x for x in (here, nxt, press) if x)
            speech = " ".join(x for x in (here.replace(f" ({n.goal_id})", ""), press) if x)
            return PopupText(title, body, speech, "success")
        if kind is Phase.TOUR_FINISHED and ev is not None and finite(ev.target_floor) \
                and not self.building.has_robot(ev.target_floor):
            body, speech = self._go_alone(n, way, connector)       # the tour ends on floors without robot
            return PopupText(t._("The tour ends there"), body, speech, "success")
        if kind is Phase.TOUR_FINISHED:
            here = t._("This is: {place}.").format(place=goal) if goal else ""
            thanks = t._("Thank you for your visit!")
            return PopupText(t._("The tour is over"), "\n\n".join(x for x in (here, thanks) if x),
                             " ".join((t._("The tour is over."), thanks)), "success")
        if kind is Phase.UNREACHABLE:
            body = (t._("The way to {place} is blocked, so I cannot help you with this destination.")
                    .format(place=goal) if goal else
                    t._("The way is blocked, so I cannot help you with this destination."))
            ask = t._("Please ask the staff of the building.")
            return PopupText(t._("Sorry, I cannot get there"), f"{body}\n\n{ask}",
                             t._("Sorry, I cannot help you: the way is blocked."), "error")
        if kind is Phase.NO_ROBOT_ON_FLOOR:
            body, speech = self._go_alone(n, way, connector)
            return PopupText(t._("No guide on that floor"), body, speech, "warning")
        if kind is Phase.CANCELLED_HERE:
            ready = t._("I am ready for a new destination.")
            spoken = t._("Trip cancelled.")
            return PopupText(t._("Trip cancelled"), ready, f"{spoken} {ready}", "info")
        if kind is Phase.PARTNER_OFFLINE:
            body = self._naming(ev, t._("{robot} cannot be reached right now, so the trip was stopped."),
                                t._("Another robot cannot be reached right now, so the trip was stopped."))
            again = t._("Please try again later.")
            return PopupText(t._("A guide is not available"), f"{body}\n\n{again}", f"{body} {again}", "error")
        if kind is Phase.PARTNER_LOST:
            body = self._naming(
                ev, t._("{robot} cannot be reached right now. The trip waits for it: please wait a moment."),
                t._("Another robot cannot be reached right now. The trip waits for it: please wait a moment."))
            return PopupText(t._("Please wait"), body, body, "warning")
        if kind is Phase.PARTNER_BACK:
            body = self._naming(ev, t._("{robot} is back. The trip goes on."),
                                t._("The other robot is back. The trip goes on."))
            return PopupText(t._("The trip goes on"), body, body, "success")
        if kind is Phase.REJECTED:
            body = t._("Please choose another destination.")
            spoken = t._("Sorry, I cannot take this request.")
            return PopupText(t._("Sorry, I cannot take this request"), body, f"{spoken} {body}", "error")
        if kind in SAID_AS_SHOWN:
            title, body, tone = SAID_AS_SHOWN[kind]
            return PopupText(t._(title), t._(body), t._(body), tone)
        return PopupText(t._("Information"), "", "", "info")


def t_floor(place: str, floor: str) -> str:
    """A place with its floor, when it is on another floor than the stop before it."""
    return f"{place} ({floor})"


def _num(value: float) -> str:
    return f"{value:g}" if finite(value) else "?"
