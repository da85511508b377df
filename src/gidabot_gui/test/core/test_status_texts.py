"""What the screen says about where things stand (core.status_texts): the info line, robot labels and cards."""

from __future__ import annotations

from dataclasses import replace

import pytest

from gidabot_gui.core.flow import Mode, VisitorFlow
from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.model import Fleet
from gidabot_gui.core.status_texts import here_line, mark_label, out_of_service_line, robot_card, trip_line
from gidabot_gui.core.texts import Texts
from gidabot_navigation.guiding.messages import StaffCommandData
from gidabot_navigation.interface import RobotState, StaffCmd


@pytest.fixture
def texts(faculty, locale_dir) -> Texts:
    return Texts(Translator("en", locale_dir), faculty, "Kbot")


def test_here_line(faculty, texts, status) -> None:
    fleet = Fleet(faculty)
    assert here_line(texts, fleet) == "Here: First floor"                    # position unknown
    fleet.update_status(status("Kbot", 1), 1.0)
    assert here_line(texts, fleet) == "Here: Ada Lovelace Auditorium (104) · First floor"
    fleet.update_status(status("Kbot", 1, x=22.0), 2.0)                   # 4 m from room 112
    assert here_line(texts, fleet) == "Here: near Laboratory 1.2 (112) · First floor"
    texts.tr.set_language("es")
    assert here_line(texts, fleet).endswith(" · Primera planta")


def test_trip_line_follows_the_flow(faculty, texts) -> None:
    flow = VisitorFlow(faculty, "Kbot", "gui-test")
    assert trip_line(texts, flow, "") == "Choose a destination: tap a place, or search in Offices."
    assert trip_line(texts, flow, "I am going to meet a visitor at: Lift.") == "I am going to meet a visitor at: Lift."
    flow.set_mode(Mode.TOUR)
    assert trip_line(texts, flow, "") == "Choose a tour and start it."
    flow.request("223", "stairs", "en", 0.0, start_id="104")
    assert trip_line(texts, flow, "") == ("From: Ada Lovelace Auditorium (104) → To: M. Larrea's Office (223) · "
                                          "Request sent, waiting for an answer…")


def test_robot_cards_and_labels(faculty, texts, status) -> None:
    fleet = Fleet(faculty, offline_after=5.0)
    card = robot_card(texts, fleet, "Kbot", 0.0)
    assert (card.title, card.floor, card.state, card.state_code, card.battery) == (
        "Kbot · this robot", "First floor", "No contact yet", "", None)
    fleet.update_status(status("Tartalo", 0, x=9.0, y=11.4, state=RobotState.GUIDING, linear=0.3, pending=2,
                               busy_for=300.0), 10.0)
    card = robot_card(texts, fleet, "Tartalo", 11.0)
    assert (card.state, card.state_code, card.battery_text) == ("Guiding a visitor", "guiding", "Battery 90 %")
    assert card.motion == "Speed 0.30 m/s · turning 0.00 rad/s"
    assert card.pending == "2 pending requests · about 5 minutes"
    card = robot_card(texts, fleet, "Tartalo", 16.5)
    assert card.offline and card.state_code == "" and card.state == "Offline · last seen 6 s ago"
    assert card.motion == "Last known position: Copy Shop (001) (x 9.0 m, y 11.4 m)"
    assert mark_label(texts, "Tartalo", here=False, offline=True) == "Tartalo · offline"
    assert mark_label(texts, "Kbot", here=True, offline=False) == "Kbot · You are here"
    assert mark_label(texts, "Galtxagorri", here=False, offline=False) == "Galtxagorri"


def test_a_robot_out_of_service_says_so(faculty, texts, status) -> None:
    """Staff took Kbot out of service from a dashboard: its screen says so while no trip is shown; its card too;
    a later command puts it back, an older one changes nothing, an invalid one is counted."""
    fleet = Fleet(faculty)
    fleet.update_status(status("Kbot", 1), 1.0)
    assert out_of_service_line(texts, fleet) == ""
    out = StaffCommandData(uid="Tartalo/staff/d.1", robot="Tartalo", user="sara", command=StaffCmd.OUT_OF_SERVICE,
                           target_robot="Kbot", version=5, detail="cleaning")
    assert fleet.update_staff(out, 2.0)
    assert out_of_service_line(texts, fleet).startswith("This guide is out of service")
    assert robot_card(texts, fleet, "Kbot", 2.0).state.startswith("Out of service · ")
    texts.tr.set_language("eu")
    assert out_of_service_line(texts, fleet).startswith("Gidari hau zerbitzutik kanpo dago")
    texts.tr.set_language("en")
    back = replace(out, uid="Tartalo/staff/d.2", command=StaffCmd.BACK_IN_SERVICE)
    assert fleet.update_staff(replace(back, version=4), 3.0) and fleet.out_of_service("Kbot")     # older
    assert fleet.update_staff(replace(back, version=6), 3.0) and out_of_service_line(texts, fleet) == ""
    assert not fleet.update_staff(replace(out, version=0), 4.0) and fleet.rejected == 1
