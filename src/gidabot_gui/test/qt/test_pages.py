"""The pages (qt/pages.py): what each shows of what it is given, and what it tells of the visitor's taps."""

from __future__ import annotations

import pytest

from gidabot_gui.core.i18n import Translator
from gidabot_gui.core.model import TourInfo
from gidabot_gui.qt.pages import BADGE, MAIN, STATE, FloorPage, InfoPage, OfficesPage, ToursPage
from gidabot_gui.qt.theme import Theme

SHORT = TourInfo("short.tour", "Short", "en", ((1, "101", "Secretary's Office"), (1, "103", "Dean's Office")))
LONG = TourInfo("long.tour", "", "en", ((0, "014", "Lab"), (1, "101", "Secretary"), (2, "223", "Larrea"),
                                        (3, "301", "IXA")))


@pytest.fixture
def tr(locale_dir) -> Translator:
    return Translator("en", locale_dir)


@pytest.fixture
def shown(qapp):
    """Show a page at 800x400 (themed); closed after the test."""
    pages = []

    def show(page):
        page.set_theme(Theme())
        page.resize(800, 400)
        page.show()
        qapp.processEvents()
        pages.append(page)
        return page

    yield show
    for p in pages:
        p.close()
        p.deleteLater()


def recorder(signal) -> list:
    got: list = []
    signal.connect(lambda *a: got.append(a[0] if len(a) == 1 else a))
    return got


# ---------------------------------------------------------------------- a floor
def test_a_floor_offers_its_featured_places_and_taps_on_the_plan(shown, tr, faculty) -> None:
    page = shown(FloorPage(tr, faculty, faculty.floor(2), here=False))
    picked = recorder(page.destination)
    assert list(page.buttons) == [loc.id for loc in faculty.locations if loc.floor == 2 and loc.featured]
    first = next(iter(page.buttons.values()))
    first.click()
    page.view.location_tapped.emit(37.0, 8.5)                     # inside room 223
    page.view.location_tapped.emit(-0.5, 25.0)                    # outside the building
    assert picked == [next(iter(page.buttons)), "223"]
    assert "Tap a place to be guided there." in page.legend.text()


def test_set_location_takes_the_page_and_applies_only_after_a_drag(shown, tr, faculty) -> None:
    page = shown(FloorPage(tr, faculty, faculty.floor(1), here=True))
    poses, done = recorder(page.pose_set), recorder(page.set_location_done)
    page.set_setting_location(True)
    assert page.setbar.isVisible() and not page.scroll.isVisible() and not page.under.isVisible()
    assert page.view.setting_pose and not page.apply_btn.isEnabled()
    page.view.pose_dragged.emit(100.0, 200.0, 120.0, 200.0)
    assert poses == [(100.0, 200.0, 120.0, 200.0)] and page.apply_btn.isEnabled()
    page.apply_btn.click()
    page.cancel_set_btn.click()
    assert done == [True, False]
    page.set_setting_location(False)
    assert not page.setbar.isVisible() and page.scroll.isVisible() and not page.view.setting_pose


def test_a_floor_page_follows_the_language(shown, tr, faculty) -> None:
    page = shown(FloorPage(tr, faculty, faculty.floor(1), here=True))
    tr.set_language("es")
    page.retranslate()
    assert page.buttons["101"].text() == "Secretaría" and page.set_location_btn.text() == "Fijar ubicación"
    assert "Toca un lugar para que te guíe hasta allí." in page.legend.text()


# ---------------------------------------------------------------------- offices
def test_offices_filter_by_floor_and_search(shown, tr, faculty) -> None:
    page = shown(OfficesPage(tr, faculty))
    asked, picked = recorder(page.search_requested), recorder(page.destination)
    assert page.list.count() == len(faculty.locations) and not page.clear.isVisible()
    page.set_floor(3)
    assert page.list.count() == len(faculty.locations_on(3)) and page.chips[3].isChecked()
    page.set_floor(None)
    page.set_query("larrea")
    assert page.list.count() == 1 and page.list.item(0).data(BADGE) == "223"
    assert page.search.text() == "“larrea”" and page.clear.isVisible()
    page.list.itemClicked.emit(page.list.item(0))
    assert picked == ["223"]
    page.set_query("zzz")
    assert not page.list.isVisible() and page.empty.isVisible()
    assert page.empty.text() == "No place matches “zzz”."
    page.clear.click()
    assert page.query == "" and page.search.text() == "Search"
    page.search.click()
    assert len(asked) == 1


# ---------------------------------------------------------------------- tours
def test_tours_list_their_stops_and_start(shown, tr, faculty) -> None:
    page = shown(ToursPage(tr, faculty))
    assert page.no_tours.isVisible() and not page.start_btn.isEnabled()
    started = recorder(page.start)
    page.set_tours([SHORT, LONG])
    assert page.selected() is SHORT and page.stop_list.count() == 2
    assert page.tour_list.item(1).data(MAIN) == "Long"           # the title from the file name
    page.start_btn.click()
    assert started == ["short.tour"] and page.start_btn.text() == "Start the tour"
    page.select("long.tour")
    page.set_tours([SHORT, LONG])                                           # a new catalog keeps the selection
    assert page.selected() is LONG and page.stop_list.item(3).data(BADGE) == "4"


def test_a_running_tour_marks_its_stops_and_offers_the_later_ones(shown, tr, faculty) -> None:
    page = shown(ToursPage(tr, faculty))
    page.set_tours([SHORT, LONG])
    page.select("long.tour")
    skipped = recorder(page.skip)
    page.set_progress(("long.tour", {0}, 1), True, lambda step: step > 1, busy=False)
    assert [page.stop_list.item(i).data(STATE) for i in range(4)] == ["done", "current", "", ""]
    assert page.start_btn.text() == "Start again" and page.continue_btn.isEnabled()
    page.select_stop(1)
    assert not page.skip_btn.isEnabled()
    page.select_stop(3)
    assert page.skip_btn.isEnabled()
    page.skip_btn.click()
    assert skipped == [("long.tour", 3)]
    page.set_progress(None, False, lambda _s: False, busy=True)
    assert not page.start_btn.isEnabled() and not page.skip_btn.isEnabled()
    assert page.stop_list.item(0).data(STATE) == ""


def test_admin_buttons_act_on_the_selected_tour(shown, tr, faculty) -> None:
    page = shown(ToursPage(tr, faculty))
    assert not page.admin_row.isVisible()
    page.set_admin(True)
    new, edit, delete = recorder(page.new_tour), recorder(page.edit_tour), recorder(page.delete_tour)
    assert page.admin_row.isVisible() and not page.edit_btn.isEnabled()
    page.set_tours([SHORT])
    page.new_btn.click()
    page.edit_btn.click()
    page.delete_btn.click()
    assert (len(new), edit, delete) == (1, ["short.tour"], ["short.tour"])


# ---------------------------------------------------------------------- information
def test_a_robot_card_shows_what_it_is_given(shown, tr, faculty) -> None:
    page = shown(InfoPage(tr, faculty))
    assert set(page.cards) == {r.name for r in faculty.robots}
    page.set_card("Tartalo", title="Tartalo", floor="Ground floor", state="Guiding a visitor", state_color="#1F6FB2",
                  motion="Speed 0.30 m/s", battery=0.15, battery_text="Battery 15 %", pending="2 pending requests",
                  here=False, offline=True)
    card = page.cards["Tartalo"]
    assert (card.title.text(), card.floor.text(), card.state_text, card.motion.text(), card.pending.text()) == (
        "Tartalo", "Ground floor", "Guiding a visitor", "Speed 0.30 m/s", "2 pending requests")
    assert card.battery.value() == 15 and card.battery.property("low") and card.battery.format() == "Battery 15 %"
    assert card.property("offline") and not card.property("here") and "#1F6FB2" in card.dot.styleSheet()
    page.set_card("Tartalo", title="Tartalo", floor="", state="", state_color="#2E7D32", motion="", battery=None,
                  battery_text="Battery unknown", pending="", here=True, offline=False)
    assert card.battery.value() == 0 and not card.battery.property("low") and card.property("here")


def test_cards_fill_as_many_columns_as_asked(shown, tr, faculty) -> None:
    page = shown(InfoPage(tr, faculty))
    names = [r.name for r in faculty.robots]

    def position(name: str) -> tuple[int, int]:
        r, c, _rs, _cs = page.grid.getItemPosition(page.grid.indexOf(page.cards[name]))
        return r, c

    assert position(names[2]) == (1, 0)
    page.set_columns(3)
    assert position(names[2]) == (0, 2) and position(names[3]) == (1, 0)
