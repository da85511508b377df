"""Every sentence about trips (core.texts), in the three languages."""

from __future__ import annotations

from dataclasses import replace

import pytest

from gidabot_gui.core.flow import Notice, Outcome
from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.texts import Texts
from gidabot_navigation.interface import Phase

KINDS = [*(p for p in Phase if p is not Phase.ACCEPTED), *Outcome]


@pytest.mark.parametrize("language", ["eu", "en", "es"])
def test_every_notice_has_a_complete_text(faculty, locale_dir, language, ev, tour) -> None:
    tr = Translator(language, locale_dir)
    texts = Texts(tr, faculty, "Kbot")
    texts.tours = {tour.file_name: tour}
    for kind in KINDS:
        for way in ("stairs", "lift"):
            e = ev(Phase.ON_THE_WAY, "u", "g", way=way, target_floor=2.0, connector="lift", location_id="223",
                   tour_file=tour.file_name, tour_step=1)
            t = texts.notice(Notice(kind, e, goal_id="223", tour_file=tour.file_name, tour_step=1))
            assert t.title, kind
            for part in (t.title, t.body, t.speech):
                assert "{" not in part and "}" not in part, (kind, part)
    walk = texts.notice(Notice(Phase.ON_THE_WAY, ev(Phase.ON_THE_WAY, "u", "g"), goal_id="223"))
    assert walk.note and walk.speech


def test_walk_behind_and_floor_change_texts(faculty, locale_dir, ev) -> None:
    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    t = texts.notice(Notice(Phase.ON_THE_WAY, ev(Phase.ON_THE_WAY, "u", "g", connector="lift"), goal_id="223"))
    assert "walk behind me" in t.note and "M. Larrea's Office (223)" in t.body and "Lift" in t.body
    t = texts.notice(Notice(Phase.GO_TO_FLOOR, ev(Phase.GO_TO_FLOOR, "u", "g", way="stairs", target_floor=2.0,
                                               connector="stairs_west")))
    assert "stairs" in t.body and "Second floor" in t.body and "Galtxagorri will wait for you" in t.body
    t = texts.notice(Notice(Phase.WAITING_VISITOR, ev(Phase.WAITING_VISITOR, "u", "g")))
    assert "Press Continue when you are here" in t.body
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    t = es.notice(Notice(Phase.GO_TO_FLOOR, ev(Phase.GO_TO_FLOOR, "u", "g", way="lift", target_floor=3.0)))
    assert "Tercera planta" in t.body and "ascensor" in t.body.lower()


def test_waits_in_minutes(faculty, locale_dir) -> None:
    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    assert texts.minutes(None) == "wait unknown"
    assert texts.minutes(10) == "can start now"
    assert texts.minutes(300) == "about 5 minutes"
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    assert es.minutes(300) == "unos 5 minutos"


def test_texts_name_the_robot_of_each_leg(faculty6, locale_dir, ev) -> None:
    texts = Texts(Translator("en", locale_dir), faculty6, "Kbot")
    t = texts.notice(Notice(Phase.GO_TO_FLOOR, ev(Phase.GO_TO_FLOOR, "u", "g", way="stairs", target_floor=2.0,
                                               connector="stairs_west", assignee="Lamia")))
    assert "Lamia will wait for you there" in t.body
    t = texts.notice(Notice(Phase.ASSIGNED, ev(Phase.ASSIGNED, "u", "g", leg="start", assignee="Basajaun", eta=75.0)))
    assert t.title == "A guide is coming" and "Basajaun will guide you: it is coming here (about 2 minutes)" in t.body
    t = texts.notice(Notice(Phase.PARTNER_LOST, ev(Phase.PARTNER_LOST, "u", "g", target_floor=2.0, assignee="Lamia")))
    assert "Lamia cannot be reached" in t.body
    # two robots upstairs and none named: no guess
    t = texts.notice(Notice(Phase.PARTNER_LOST, ev(Phase.PARTNER_LOST, "u", "g", target_floor=2.0)))
    assert "Another robot cannot be reached" in t.body


@pytest.mark.parametrize("language", ["eu", "en", "es"])
def test_stops_on_a_floor_without_robot(faculty3, locale_dir, ev, language) -> None:
    """Table 4 on faculty3: Kbot sends the visitor to 223 and 274 (floor 2, no robot), then on to floor 3 where
    MariSorgin waits; a tour ending on floor 2 says goodbye."""
    from gidabot_gui.core.model import TourInfo

    tour = TourInfo("real_world.tour", "", "en", ((0, "014", "a"), (0, "008", "b"), (1, "101", "c"), (1, "104", "d"),
                                                  (2, "223", "e"), (2, "274", "f"), (3, "325", "g"), (3, "305", "h")))
    ends = TourInfo("ends.tour", "", "en", ((1, "101", "c"), (2, "223", "e"), (2, "274", "f")))
    texts = Texts(Translator(language, locale_dir), faculty3, "Kbot")
    texts.tours = {tour.file_name: tour, ends.file_name: ends}
    e = ev(Phase.NO_ROBOT_ON_FLOOR, "u", "g", way="stairs", target_floor=2.0, connector="stairs_west",
           location_id="223", tour_file=tour.file_name, tour_step=4, assignee="MariSorgin")
    t = texts.notice(Notice(Phase.NO_ROBOT_ON_FLOOR, e, goal_id="223", tour_file=tour.file_name, tour_step=4))
    stairs = f"({faculty3.find_connector('stairs_west').names[language]})"
    for part in ("(223)", "(274)", "MariSorgin", faculty3.floor(3).names[language], stairs):
        assert part in t.body, (part, t.body)
    assert "{" not in t.body + t.speech and "MariSorgin" in t.speech and stairs in t.speech
    e = ev(Phase.TOUR_FINISHED, "u", "g", way="lift", target_floor=2.0, connector="lift", location_id="223",
           tour_file=ends.file_name, tour_step=1)
    t = texts.notice(Notice(Phase.TOUR_FINISHED, e, goal_id="223", tour_file=ends.file_name, tour_step=1))
    assert "(223)" in t.body and "(274)" in t.body and "{" not in t.body
    assert f"({faculty3.find_connector('lift').names[language]})" in t.body
    if language == "en":
        assert t.title == "The tour ends there" and "Goodbye" in t.body and "lift" in t.body


@pytest.mark.parametrize("connector", ["stairs_west", "stairs_east", "lift"])
@pytest.mark.parametrize("language", ["eu", "en", "es"])
def test_no_robot_on_floor_names_the_lift_or_staircase(faculty3, locale_dir, ev, language, connector) -> None:
    """Sent alone to a floor without robot, the visitor reads and hears which lift or staircase to take, by its name
    in the visitor's language; an event without connector falls back to the way alone."""
    conn = faculty3.find_connector(connector)
    texts = Texts(Translator(language, locale_dir), faculty3, "Kbot")
    e = ev(Phase.NO_ROBOT_ON_FLOOR, "u", "g", way=conn.kind, target_floor=2.0, connector=connector, location_id="223")
    t = texts.notice(Notice(Phase.NO_ROBOT_ON_FLOOR, e, goal_id="223"))
    name = f"({conn.names[language]})"
    assert name in t.body and name in t.speech, (name, t.body)
    assert "(223)" in t.body and faculty3.floor(2).names[language] in t.body and "{" not in t.body + t.speech
    if language == "en":
        assert f"Go there by the {conn.kind} {name} and look for the place on your own: " in t.body
    t = texts.notice(Notice(Phase.NO_ROBOT_ON_FLOOR, replace(e, connector=""), goal_id="223"))
    assert name not in t.body and "(223)" in t.body and "{" not in t.body + t.speech
    if language == "en":
        assert f"Go there by the {conn.kind} and look for the place on your own: " in t.body


def test_confirmation_names_who_serves_each_leg(faculty6, locale_dir) -> None:
    from gidabot_gui.core.plans import RequestPlan, RobotWait

    texts = Texts(Translator("en", locale_dir), faculty6, "Kbot")
    plan = RequestPlan("223", 2.0, 1.0, ("stairs", "lift"),
                       (RobotWait("Basajaun", 1.0, False, True, 0, 45.0, "start"),
                        RobotWait("Lamia", 2.0, False, True, 1, 130.0, "goal")), True)
    body = texts.confirm(plan).body
    assert "Basajaun comes here to guide you: about 1 minute" in body
    assert "Lamia meets you there: about 3 minutes" in body and "Second floor" in body
