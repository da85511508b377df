"""The staff dashboard on the simulated building, through Debian's headless chromium (selenium).

Four masters on this session's loopback addresses joined by the relays, ``launch/robot.launch sim:=true
gui:=false dashboard:=true`` on each (every robot serves its dashboard on its own address), sim at SPEED x. The
browser uses Kbot's page (and Galtxagorri's for the tour), as staff would:

- a robot that moves in the simulator moves on the page (Tartalo guides a visitor on floor 0);
- a cancel from the page stops the trip on every robot involved (MariSorgin, driving to meet the visitor, and
  Tartalo unless it already sent the visitor up the stairs, drop it: their final events, their queues) and the page
  says so;
- a tour uploaded on Kbot's page appears on Galtxagorri's page (the tour store shares it);
- killing MariSorgin's master greys it on Kbot's page and raises an alert within 5 s;
- the page survives its own robot's master restarting (it says so meanwhile, and goes on);
- the history survives a restart of the dashboard node (killed; roslaunch starts it again; the page reconnects).

Screenshots of every view go to docs/screenshots/dashboard-*.png (``GIDABOT_SCREENSHOT_DIR`` to write elsewhere).
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Iterator

import pytest
from dashboard_browser import Browser
from sim_stack import (
    CANCELLED_ELSEWHERE,
    EVENTS,
    GO_TO_FLOOR,
    GOAL_REACHED,
    GOING_TO_MEETING,
    SimStack,
)

from gidabot_navigation.interface import FINAL_PHASES
from gidabot_sim.runner.procs import wait_until
from gidabot_web.web.auth import ADMIN, STAFF, make_user, save_users

pytestmark = [pytest.mark.system, pytest.mark.slow]

SPEED = 10.0
STAFF_USER, STAFF_PASSWORD = "sara", "staff-password-1"
ADMIN_USER, ADMIN_PASSWORD = "ada", "admin-password-1"
FAR_FROM_THE_STAIRS = (8.0, 12.0)          # on floor 3, far from the east staircase
TOUR = "Tour: Dashboard test\n0, 014, Computer Technicians 1\n2, 207, Seminar Room 2.3\n"


@pytest.fixture(scope="module")
def stack(tmp_path_factory) -> Iterator[SimStack]:
    tmp = tmp_path_factory.mktemp("dashboard_system")
    with SimStack(tmp, speed=SPEED, dashboard=True) as st:
        users = {STAFF_USER: make_user(STAFF_USER, STAFF_PASSWORD, STAFF),
                 ADMIN_USER: make_user(ADMIN_USER, ADMIN_PASSWORD, ADMIN)}
        for r in st.robots:
            save_users(st.sim.run_dir / "dashboard" / r / "users.json", users)
        st.wait_ready(timeout=180)
        yield st


@pytest.fixture(scope="module")
def browser(tmp_path_factory) -> Iterator[Browser]:
    b = Browser(tmp_path_factory.mktemp("chromium"))
    yield b
    b.close()


def kbot(stack: SimStack) -> str:
    return stack.sim.staff_url("Kbot")


def marker(browser: Browser, robot: str) -> tuple[str | None, str | None]:
    """(transform, liveness) of ``robot``'s mark on the blueprint."""
    sel = f'#floors g.robot[data-robot="{robot}"]'
    return browser.attr(sel, "transform"), browser.attr(sel, "data-live")


def position(browser: Browser, robot: str) -> tuple[float, float] | None:
    """(u, v) of ``robot``'s mark on the blueprint (None while the page re-renders it)."""
    transform = marker(browser, robot)[0]
    if not transform or not transform.startswith("translate("):
        return None
    u, v = transform[len("translate("):-1].split(",")
    return float(u), float(v)


def every_robot_online(browser: Browser, stack: SimStack) -> bool:
    return all(marker(browser, r)[1] == "online" for r in stack.robots)


def test_a_robot_that_moves_in_the_simulator_moves_on_the_page(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack))
    browser.wait(lambda: every_robot_online(browser, stack), 30, "every robot online on Kbot's page")
    start = browser.wait(lambda: position(browser, "Tartalo"), 5, "Tartalo's mark")
    uid, since = stack.request("Tartalo", "014")
    moved = browser.wait(lambda: (p := position(browser, "Tartalo")) and abs(p[0] - start[0]) > 40 and p,
                         60, "Tartalo's mark to move on Kbot's page")
    browser.shot("building")
    stack.wait_event("Tartalo", GOAL_REACHED, uid, timeout=120, since=since)
    loc = stack.building.location("014").pose
    u, _v = stack.building.floor(0.0).transform.to_pixel(loc.x, loc.y)
    browser.wait(lambda: (p := position(browser, "Tartalo")) and abs(p[0] - u) < 25, 30, "Tartalo at 014 on the page")
    assert moved[0] < start[0]                      # 014 is west of Tartalo's home
    browser.click_mark('#floors g.robot[data-robot="Tartalo"]')
    browser.wait(lambda: "Tartalo" in browser.shown_text("#robot-panel h2"), 20, "Tartalo's panel")
    browser.shot("robot-panel")
    assert not browser.errors()


def test_a_cancel_from_the_page_stops_the_trip_on_every_robot_involved(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack), "trips")
    browser.login(STAFF_USER, STAFF_PASSWORD)
    stack.relocate("MariSorgin", *FAR_FROM_THE_STAIRS)     # a long drive to meet the visitor: still under way
    since_m = stack.rec["MariSorgin"].count(EVENTS)
    uid, since = stack.request("Tartalo", "305", way="stairs")
    stack.wait_event("MariSorgin", GOING_TO_MEETING, uid, timeout=60, since=since_m)
    row = f'#trips-active tr[data-trip="{uid}"]'
    browser.wait(lambda: "MariSorgin" in browser.text(row), 30, "the trip in progress on Kbot's page, both legs")
    browser.shot("trips")
    browser.confirm(f'{row} button[data-action="cancel"]')
    done = f'#trips-done tr[data-trip="{uid}"] .cancel-state[data-confirmed="true"]'
    browser.wait(lambda: browser.all(done), 60, "the page to confirm the cancel")
    # every robot involved dropped it (its final event, and its queue without it): MariSorgin, still driving to
    # the meeting point, and Tartalo unless its part was over before the cancel reached it (it sent the visitor
    # up the stairs: GO_TO_FLOOR; the page waits only for the robots whose part is not over)
    for robot, over, first in (("Tartalo", {GO_TO_FLOOR}, since), ("MariSorgin", set(), since_m)):
        last = stack.wait_event(robot, set(FINAL_PHASES), uid, timeout=30, on=robot, since=first)
        assert last["phase"] in {CANCELLED_ELSEWHERE, *over}, (robot, last)
        wait_until(lambda robot=robot: uid not in {g["uid"] for g in stack.pending(robot, robot)["goals"]}, 30,
                   f"{robot}'s queue without the trip")
    wait_until(lambda: all(g["uid"] != uid for r in stack.robots
                           for g in (stack.pending("Kbot", r) or {"goals": []})["goals"]), 30,
               "every robot's queue without the trip, as Kbot hears them")
    busy = {"Guiding a visitor", "Going to meet a visitor", "Waiting for a visitor"}
    browser.wait(lambda: all(browser.text(f'#queues tr[data-robot="{r}"] td:nth-child(3)') not in busy
                             for r in ("Tartalo", "MariSorgin")), 30,
                 "Tartalo and MariSorgin no longer serving the trip on the page (their next status)")
    browser.shot("trips-cancelled")


def test_a_tour_uploaded_on_one_robots_page_appears_on_another_robots_page(stack: SimStack,
                                                                            browser: Browser) -> None:
    browser.open(kbot(stack), "tours")
    if browser.css("#whoami").is_displayed():
        browser.click("#logout-button")
        browser.wait(lambda: browser.css("#login").is_displayed(), 5, "logged out")
    browser.login(ADMIN_USER, ADMIN_PASSWORD)
    browser.wait(lambda: browser.css("#tour-form").is_displayed(), 5, "the tour form (admin)")
    browser.css("#tour-file").send_keys("dashboard_test.tour")
    browser.driver.execute_script("document.getElementById('tour-text').value = arguments[0];", TOUR)
    browser.css("#tour-save").click()
    browser.wait(lambda: browser.css("#tour-result").get_attribute("class") == "ok", 15, "the store's answer")
    browser.wait(lambda: browser.all('#catalog tr[data-tour-file="dashboard_test.tour"]'), 10, "the tour on Kbot")
    browser.shot("tours")
    browser.open(stack.sim.staff_url("Galtxagorri"), "tours")
    browser.wait(lambda: browser.all('#catalog tr[data-tour-file="dashboard_test.tour"]'), 30,
                 "the tour on Galtxagorri's page")
    assert (stack.sim.run_dir / "tours" / "Galtxagorri" / "dashboard_test.tour").exists()


def test_killing_a_robots_master_greys_it_and_raises_an_alert_within_5_s(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack))
    browser.wait(lambda: every_robot_online(browser, stack), 30, "every robot online")
    killed = time.monotonic()
    stack.sim.stop_master("MariSorgin", crash=True)
    try:
        browser.wait(lambda: marker(browser, "MariSorgin")[1] not in (None, "online"), 5, "MariSorgin greyed")
        alert = '#alerts tr[data-kind="robot_offline"].open.active'
        browser.wait(lambda: "MariSorgin" in browser.text(alert), 5.0 - (time.monotonic() - killed) + 0.5,
                     "the offline alert")
        took = time.monotonic() - killed
        print(f"\n[dashboard] MariSorgin's master killed: greyed and alerted on Kbot's page after {took:.1f} s")
        assert took < 5.0
        browser.shot("building-offline")
        browser.view("alerts")
        browser.shot("alerts")
        browser.view("links")
        browser.shot("links")
    finally:
        stack.sim.start_master_again("MariSorgin")
    browser.view("building")
    browser.wait(lambda: marker(browser, "MariSorgin")[1] == "online", 60, "MariSorgin back online")


def test_the_page_survives_its_robots_master_restarting(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack))
    stack.sim.stop_master("Kbot", crash=True)
    try:
        browser.wait(lambda: browser.css("#banner").get_attribute("hidden") is None and
                     "Kbot" in browser.css("#banner").text, 10, "the page to say Kbot's master is down")
        assert browser.css("#conn").get_attribute("data-state") == "live"      # the dashboard itself still serves
        browser.shot("master-down")
    finally:
        stack.sim.start_master_again("Kbot")
    browser.wait(lambda: browser.css("#banner").get_attribute("hidden") is not None, 30, "the banner gone")
    browser.wait(lambda: every_robot_online(browser, stack), 60, "every robot online again")
    uid, since = stack.request("Tartalo", "016")         # and the page still follows what happens
    browser.view("trips")
    browser.wait(lambda: browser.all(f'tr[data-trip="{uid}"]'), 30, "a new trip on the page")
    stack.wait_event("Tartalo", GOAL_REACHED, uid, timeout=120, since=since)


def test_the_history_survives_a_restart_of_the_dashboard_node(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack), "history")
    cell = '#history td[data-count="completed"]'
    browser.wait(lambda: int(browser.text(cell) or 0) >= 2, 30, "two completed trips")
    before = {k: browser.text(f'#history td[data-count="{k}"]') for k in ("completed", "cancelled")}
    assert before["cancelled"] == "1"
    browser.shot("history")
    [pid] = [int(r["pid"]) for r in stack.sim.cpu_usage()
             if r["owner"] == "robot_Kbot" and r["process"] == "dashboard"]
    os.kill(pid, signal.SIGKILL)
    browser.wait(lambda: browser.css("#conn").get_attribute("data-state") == "reconnecting", 10, "reconnecting")
    browser.shot("reconnecting")
    browser.wait(lambda: browser.css("#conn").get_attribute("data-state") == "live", 40, "the page live again")
    browser.wait(lambda: {k: browser.text(f'#history td[data-count="{k}"]') for k in before} == before, 20,
                 "the same history")
    [again] = [int(r["pid"]) for r in stack.sim.cpu_usage()
               if r["owner"] == "robot_Kbot" and r["process"] == "dashboard"]
    assert again != pid


def test_the_page_in_basque_and_spanish(stack: SimStack, browser: Browser) -> None:
    browser.open(kbot(stack), "trips")
    browser.errors()               # what the page said while its dashboard restarted (above) is not this test's
    browser.language("eu")
    browser.wait(lambda: browser.css('#tabs button[data-view="trips"]').text == "Ilarak eta ibilbideak", 5, "Basque")
    browser.shot("trips-eu")
    browser.language("es")
    browser.view("building")
    browser.wait(lambda: browser.css('#tabs button[data-view="building"]').text == "Edificio", 5, "Spanish")
    browser.shot("building-es")
    browser.language("en")
    assert not browser.errors()
