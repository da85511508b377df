"""Every sentence about trips (core.texts), in the three languages."""

from __future__ import annotations

import pytest

from gidabot_gui.core.flow import Notice
from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.texts import Texts
from gidabot_navigation.interface import Phase

KINDS = [p.name for p in Phase if p not in (Phase.ACCEPTED,)] + ["NO_ANSWER", "BUSY"]


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
    walk = texts.notice(Notice("ON_THE_WAY", ev(Phase.ON_THE_WAY, "u", "g"), goal_id="223"))
    assert walk.note and walk.speech


def test_walk_behind_and_floor_change_texts(faculty, locale_dir, ev) -> None:
    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    t = texts.notice(Notice("ON_THE_WAY", ev(Phase.ON_THE_WAY, "u", "g", connector="lift"), goal_id="223"))
    assert "walk behind me" in t.note and "M. Larrea's Office (223)" in t.body and "Lift" in t.body
    t = texts.notice(Notice("GO_TO_FLOOR", ev(Phase.GO_TO_FLOOR, "u", "g", way="stairs", target_floor=2.0,
                                               connector="stairs_west")))
    assert "stairs" in t.body and "Second floor" in t.body and "Galtxagorri will wait for you" in t.body
    t = texts.notice(Notice("WAITING_VISITOR", ev(Phase.WAITING_VISITOR, "u", "g")))
    assert "Press Continue when you are here" in t.body
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    t = es.notice(Notice("GO_TO_FLOOR", ev(Phase.GO_TO_FLOOR, "u", "g", way="lift", target_floor=3.0)))
    assert "Tercera planta" in t.body and "ascensor" in t.body.lower()


def test_waits_in_minutes(faculty, locale_dir) -> None:
    texts = Texts(Translator("en", locale_dir), faculty, "Kbot")
    assert texts.minutes(None) == "wait unknown"
    assert texts.minutes(10) == "can start now"
    assert texts.minutes(300) == "about 5 minutes"
    es = Texts(Translator("es", locale_dir), faculty, "Kbot")
    assert es.minutes(300) == "unos 5 minutos"
