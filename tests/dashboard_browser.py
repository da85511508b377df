"""Debian's headless chromium driven by selenium (chromedriver at /usr/bin/chromedriver), for the dashboard's system
tests: conditions waited for with deadlines (never fixed sleeps), screenshots for docs/screenshots/."""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from selenium import webdriver
from selenium.common.exceptions import JavascriptException, StaleElementReferenceException, WebDriverException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webelement import WebElement

REPO = Path(__file__).resolve().parents[1]
CHROMEDRIVER = "/usr/bin/chromedriver"
T = TypeVar("T")


def screenshot_dir() -> Path:
    """docs/screenshots/ (``GIDABOT_SCREENSHOT_DIR`` to write elsewhere)."""
    return Path(os.environ.get("GIDABOT_SCREENSHOT_DIR", REPO / "docs" / "screenshots"))


class Browser:
    def __init__(self, profile: Path, width: int = 1400, height: int = 1000) -> None:
        opts = webdriver.ChromeOptions()
        for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                    "--disable-component-update", "--disable-sync", "--no-first-run", f"--user-data-dir={profile}",
                    f"--window-size={width},{height}", "--lang=en-GB", "--force-device-scale-factor=1"):
            opts.add_argument(arg)
        self.driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
        self.driver.set_page_load_timeout(120)

    def close(self) -> None:
        self.driver.quit()

    def open(self, url: str, view: str = "building") -> None:
        self.driver.get(url.rstrip("/") + "/#" + view)
        self.wait(lambda: self.css("#conn").get_attribute("data-state") == "live", 60, "the page live")

    def css(self, selector: str) -> WebElement:
        return self.driver.find_element(By.CSS_SELECTOR, selector)

    def all(self, selector: str) -> list[WebElement]:
        return self.driver.find_elements(By.CSS_SELECTOR, selector)

    def text(self, selector: str) -> str:
        """The text of every element matching ``selector``, shown or not, read in one script turn: the page rebuilds
        its views with every update (4 a second), so an element found by one WebDriver command is often replaced
        before the next one reads it on a loaded machine."""
        return self.driver.execute_script(
            "return Array.from(document.querySelectorAll(arguments[0]), (e) => e.textContent).join(' ');", selector)

    def shown_text(self, selector: str) -> str:
        """The text of the first element matching ``selector`` if it is shown (rendered, not hidden), else ""."""
        return self.driver.execute_script(
            "const e = document.querySelector(arguments[0]);"
            "return e && e.getClientRects().length > 0 ? e.textContent : '';", selector)

    def attr(self, selector: str, name: str) -> str | None:
        """Attribute ``name`` of the first element matching ``selector`` (None when there is none), read in one
        script turn (see :meth:`text`)."""
        return self.driver.execute_script(
            "const e = document.querySelector(arguments[0]); return e ? e.getAttribute(arguments[1]) : null;",
            selector, name)

    def wait(self, cond: Callable[[], T], timeout: float, what: str, interval: float = 0.05) -> T:
        deadline = time.monotonic() + timeout
        while True:
            try:
                got = cond()
            except (StaleElementReferenceException, JavascriptException):
                got = None
            if got:
                return got
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
            time.sleep(interval)

    def view(self, name: str) -> None:
        self.css(f'#tabs button[data-view="{name}"]').click()
        self.wait(lambda: self.css(f"#view-{name}").is_displayed(), 5, f"view {name}")

    def click(self, selector: str, timeout: float = 10.0) -> None:
        """Click the first element matching ``selector`` once there is one (the page re-renders often)."""
        def go() -> bool:
            found = self.all(selector)
            if not found:
                return False
            try:
                found[0].click()
            except (StaleElementReferenceException, WebDriverException):
                return False
            return True
        self.wait(go, timeout, f"{selector} to click")

    def click_mark(self, selector: str, timeout: float = 10.0) -> None:
        """Click an SVG mark (a robot on a blueprint) as a click on it does, by its event (a WebDriver click aims at
        the element's middle, which a robot's label or heading line may cover)."""
        script = ("const m = document.querySelector(arguments[0]); if (!m) return false;"
                  "m.dispatchEvent(new MouseEvent('click', {bubbles: true})); return true;")
        self.wait(lambda: self.driver.execute_script(script, selector), timeout, f"{selector} to click")

    def confirm(self, selector: str, timeout: float = 10.0) -> None:
        """Press a two-step button matching ``selector`` (the page's "Cancel trip", then "Confirm: cancel trip"), as
        staff do: once to arm it, then the armed button the page renders in its place. Both presses happen in one
        script turn: the page disarms a button after 5 s of its own clock, which a loaded machine can let pass
        between two WebDriver commands, and a confirm on a disarmed button only arms it again. Done when the
        confirm went through (the button disables itself while its action is sent); else pressed again."""
        script = ("const sel = arguments[0];"
                  "let b = document.querySelector(sel + '[data-step=\"2\"]');"
                  "if (!b) { const first = document.querySelector(sel + '[data-step=\"1\"]');"
                  "          if (!first) return false;"
                  "          first.click(); b = document.querySelector(sel + '[data-step=\"2\"]'); }"
                  "if (!b) return false;"
                  "b.click(); return b.disabled;")
        self.wait(lambda: self.driver.execute_script(script, selector), timeout, f"{selector} pressed and confirmed")

    def login(self, user: str, password: str) -> None:
        self.css("#login-user").clear()
        self.css("#login-user").send_keys(user)
        self.css("#login-password").send_keys(password)
        self.css("#login-button").click()
        self.wait(lambda: self.css("#whoami").is_displayed(), 10, f"{user} logged in")

    def language(self, code: str) -> None:
        self.css(f'#language option[value="{code}"]').click()
        self.wait(lambda: self.driver.execute_script("return document.documentElement.lang") == code, 5,
                  f"language {code}")

    def shot(self, name: str) -> Path:
        path = screenshot_dir() / f"dashboard-{name}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        self.driver.save_screenshot(str(path))
        return path

    def errors(self) -> list[str]:
        """The page's console errors so far."""
        return [e["message"] for e in self.driver.get_log("browser") if e["level"] == "SEVERE"]
