"""Out of service from the staff dashboard on the simulated maps/faculty6, through Debian's headless chromium.

faculty6: Tartalo on floor 0, Kbot and Basajaun on floor 1, Galtxagorri and Lamia on floor 2, MariSorgin alone on
floor 3; six masters joined by the relays, every robot serving its dashboard. Staff use Kbot's page:

- taking a robot of a two-robot floor out of service sends its queued leg to the other robot: Galtxagorri holds the
  goal leg of a visitor from Tartalo behind its own visitor; taken out from the page, it hands the leg back (saying
  why) and Lamia takes it through the assignment;
- taking the only robot of a floor out makes the next visitor to that floor be told to go alone: MariSorgin out,
  a visitor at Kbot asking for 305 is guided to the stairs and told to find 305 alone (NO_ROBOT_ON_FLOOR);
- a visitor at a robot out of service is refused, saying so.

Screenshots: docs/screenshots/dashboard-out-of-service.png (``GIDABOT_SCREENSHOT_DIR`` to write elsewhere).
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from dashboard_browser import Browser
from sim_stack import EVENTS, REPO, SimStack

from gidabot_navigation.interface import LEG_GOAL, Cmd, Phase
from gidabot_sim.runner.procs import wait_until
from gidabot_web.web.auth import STAFF, make_user, save_users

pytestmark = [pytest.mark.system, pytest.mark.slow]

SPEED = 4.0            # Galtxagorri's own visitor keeps it busy for about 45 s of wall time (test 1: below)
FLOOR2_WEST_END = (8.0, 12.0)
USER, PASSWORD = "sara", "staff-password-1"
FACULTY6 = REPO / "maps" / "faculty6"


@pytest.fixture(scope="module")
def stack(tmp_path_factory) -> Iterator[SimStack]:
    tmp = tmp_path_factory.mktemp("dashboard_service")
    with SimStack(tmp, speed=SPEED, building=FACULTY6, dashboard=True) as st:
        for r in st.robots:
            save_users(st.sim.run_dir / "dashboard" / r / "users.json", {USER: make_user(USER, PASSWORD, STAFF)})
        st.wait_ready(timeout=240)
        yield st


@pytest.fixture(scope="module")
def browser(tmp_path_factory, stack: SimStack) -> Iterator[Browser]:
    b = Browser(tmp_path_factory.mktemp("chromium"))
    b.open(stack.sim.staff_url("Kbot"))
    b.login(USER, PASSWORD)
    yield b
    b.close()


def queued(stack: SimStack, robot: str) -> set[str]:
    """The goal uids in ``robot``'s latest pending list (seen on its own master)."""
    return {g["uid"] for g in (stack.pending(robot, robot) or {"goals": []})["goals"]}


def set_service(browser: Browser, robot: str, out: bool, reason: str = "") -> None:
    """Open ``robot``'s panel on the page and take it out of service (or back), confirming, as staff do."""
    browser.view("building")
    browser.click_mark(f'#floors g.robot[data-robot="{robot}"]')
    browser.wait(lambda: robot in browser.shown_text("#robot-panel h2"), 20, f"{robot}'s panel")
    if reason:                     # typed into the panel's field (rebuilt with every update: kept by the page)
        browser.wait(lambda: browser.driver.execute_script(
            "const i = document.getElementById('service-reason'); if (!i) return false;"
            "i.focus(); i.value = arguments[0]; i.dispatchEvent(new Event('input')); return true;", reason),
            20, "the reason typed")
    button = f'#robot-panel button[data-action="service"][data-robot="{robot}"]'
    # the panel's button toggles the state it shows: it must show the other one
    browser.wait(lambda: browser.all(button) and shown_out(browser, robot) != out, 20,
                 f"{robot}'s panel offering to take it {'out of' if out else 'back in'} service")
    browser.confirm(button)
    browser.wait(lambda: shown_out(browser, robot) == out, 30,
                 f"{robot} {'out of' if out else 'back in'} service on the page")


def shown_out(browser: Browser, robot: str) -> bool:
    """Whether Kbot's page shows ``robot`` out of service (its mark on the blueprint)."""
    return "out" in (browser.attr(f'#floors g.robot[data-robot="{robot}"]', "class") or "").split()


def test_a_robot_taken_out_of_service_hands_its_queued_leg_to_the_other_robot_of_its_floor(
        stack: SimStack, browser: Browser) -> None:
    set_service(browser, "Lamia", out=True)                      # the next goal leg of floor 2 queues at Galtxagorri
    # Galtxagorri's own visitor, the head of its queue, from the west end of floor 2 to 231 at its east end: a long
    # guide, which must outlast the two staff actions below (on a loaded machine the page takes its time), or
    # Galtxagorri would start the queued leg before it is taken out of service (and rightly keep it)
    stack.relocate("Galtxagorri", *FLOOR2_WEST_END)
    own, _ = stack.request("Galtxagorri", "231")
    since_g = stack.rec["Galtxagorri"].count(EVENTS)
    uid, _ = stack.request("Tartalo", "223")
    stack.wait_event("Galtxagorri", Phase.ACCEPTED, uid, timeout=60, since=since_g)
    wait_until(lambda: uid in queued(stack, "Galtxagorri"), 20, "the goal leg queued at Galtxagorri")
    set_service(browser, "Lamia", out=False)
    since_l = stack.rec["Lamia"].count(EVENTS)
    set_service(browser, "Galtxagorri", out=True, reason="battery swap")
    back = stack.wait_event("Galtxagorri", Phase.DECLINED, uid, timeout=20, since=since_g)
    assert back["leg"] == LEG_GOAL and "out of service" in back["detail"] and "battery swap" in back["detail"]
    stack.wait_event("Lamia", Phase.GOING_TO_MEETING, uid, timeout=60, since=since_l)      # Lamia took it
    row = f'#trips-active tr[data-trip="{uid}"]'
    browser.view("trips")
    browser.wait(lambda: "Lamia" in browser.text(row), 20, "the page showing Lamia on the goal leg")
    # Galtxagorri finishes its own visitor, and never started the leg it handed back
    assert all(e["phase"] not in (Phase.GOING_TO_MEETING, Phase.WAITING_VISITOR)
               for e in stack.events("Galtxagorri", uid, "Galtxagorri"))
    assert own in queued(stack, "Galtxagorri")
    browser.view("building")
    browser.click_mark('#floors g.robot[data-robot="Galtxagorri"]')
    browser.wait(lambda: "Galtxagorri" in browser.shown_text("#robot-panel h2") and
                 "out of service" in browser.shown_text("#robot-panel"), 20, "Galtxagorri's panel says so")
    browser.shot("out-of-service")


def test_a_visitor_at_a_robot_out_of_service_is_told_so(stack: SimStack) -> None:
    rec = stack.rec["Galtxagorri"]
    since = rec.count(EVENTS)
    stack.command("Galtxagorri", Cmd.REQUEST, goal_id="207", way="stairs")
    refused = rec.wait(EVENTS, lambda m: m["robot"] == "Galtxagorri" and m["phase"] == Phase.REJECTED, 20,
                       "Galtxagorri's refusal", since=since)
    assert "Galtxagorri is out of service" in refused["detail"]


def test_the_only_robot_of_a_floor_out_of_service_sends_the_next_visitor_alone(stack: SimStack,
                                                                                browser: Browser) -> None:
    set_service(browser, "MariSorgin", out=True)
    browser.view("alerts")
    browser.wait(lambda: browser.all('#alerts tr[data-kind="floor_out_of_service"].open.active'), 15,
                 "the alert: every robot of floor 3 out of service")
    browser.shot("floor-out-of-service")
    uid, since = stack.request("Kbot", "305")
    alone = stack.wait_event("Kbot", Phase.NO_ROBOT_ON_FLOOR, uid, timeout=180, since=since)
    assert "find 305 yourself" in alone["detail"]
    assert all(e["robot"] != "MariSorgin" for e in stack.events("Kbot", uid))
    set_service(browser, "MariSorgin", out=False)
