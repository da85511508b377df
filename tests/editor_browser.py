"""Driving the building editor (``gidabot edit``) in headless Debian chromium through selenium, as a person would:
clicks on the maps and the blueprints, typing in the forms. For the editor's system tests and its screenshots.

The page tells where it draws a map point (``window.gidabotEditor.toScreen``); everything that changes the building
is a real click, drag or keystroke. Each change is waited for: the page's revision grows and its live check of
that revision is in.
"""

from __future__ import annotations

import math
import re
import subprocess
import tempfile
import time
from pathlib import Path

from selenium import webdriver
from selenium.common.exceptions import StaleElementReferenceException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select

REPO = Path(__file__).resolve().parents[1]
GIDABOT = REPO / "bin" / "gidabot"
CHROME_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--disable-sync", "--no-first-run")


def wait_for(predicate, timeout: float, what: str, interval: float = 0.05):
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(interval)


class EditorProcess:
    """``gidabot edit DIR`` on a free port, in its own process group; ``url`` is the address it printed."""

    def __init__(self, directory: Path, log: Path, *extra: str) -> None:
        self.log = log
        self.proc = subprocess.Popen([str(GIDABOT), "edit", str(directory), "--port", "0", *extra],
                                     stdout=open(log, "wb"), stderr=subprocess.STDOUT,  # noqa: SIM115
                                     start_new_session=True)
        found = wait_for(lambda: re.search(r"open (http://\S+)", log.read_text()) or self.proc.poll() is not None,
                         60, "gidabot edit to print its address")
        if self.proc.poll() is not None:
            raise AssertionError(f"gidabot edit exited: {log.read_text()}")
        self.url = found.group(1)

    def stop(self) -> int:
        import os
        import signal

        try:
            os.killpg(self.proc.pid, signal.SIGINT)
            return self.proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            return self.proc.wait(timeout=10)


class EditorPage:
    """The editor's page in a headless chromium."""

    def __init__(self, url: str, width: int = 1800, height: int = 1000) -> None:
        opts = webdriver.ChromeOptions()
        self.profile = tempfile.mkdtemp(prefix="gidabot-chromium-")
        for flag in (*CHROME_FLAGS, f"--user-data-dir={self.profile}", f"--window-size={width},{height}"):
            opts.add_argument(flag)
        self.driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        self.driver.get(url)
        self.settle(30)

    def close(self) -> None:
        import shutil

        self.driver.quit()
        shutil.rmtree(self.profile, ignore_errors=True)

    # -- the page's state ----------------------------------------------------------------------------------------
    def js(self, script: str, *args):
        return self.driver.execute_script(script, *args)

    def state(self) -> dict:
        return self.js("const s = window.gidabotEditor.state(); return {rev: s.rev, doc: s.doc, check: s.check, "
                       "preview: s.preview, floor: s.floor, mode: s.mode, selected: s.selected};")

    def revision(self) -> int:
        return int(self.js("return window.gidabotEditor.state().rev;"))

    def settle(self, timeout: float = 20.0) -> None:
        """Wait until the page shows the check of its current revision."""
        wait_for(lambda: self.js("return !!(window.gidabotEditor && window.gidabotEditor.ready());"), timeout,
                 "the page to show the check of its revision")

    def changed(self, before: int, timeout: float = 20.0) -> None:
        wait_for(lambda: self.revision() > before, timeout, "the change to reach the server")
        self.settle(timeout)

    def message(self) -> str:
        return self.driver.find_element(By.ID, "message").text

    def status(self) -> str:
        return self.driver.find_element(By.ID, "status").text

    def shot(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.driver.save_screenshot(str(path))

    # -- clicks --------------------------------------------------------------------------------------------------
    def button(self, text: str, within: str | None = None):
        root = self.driver.find_element(By.ID, within) if within else self.driver
        for b in root.find_elements(By.TAG_NAME, "button"):
            if b.is_displayed() and b.text.strip() == text:
                return b
        raise AssertionError(f"no button {text!r}")

    def click(self, text: str, within: str | None = None, change: bool = False) -> None:
        before = self.revision()
        self.button(text, within).click()
        if change:
            self.changed(before)

    def press(self, element_id: str, change: bool = False) -> None:
        """Click the button whose id is ``element_id`` (the header's: undo, redo, save, save-draft...)."""
        before = self.revision()
        self.driver.find_element(By.ID, element_id).click()
        if change:
            self.changed(before)

    def mode(self, name: str) -> None:
        self.driver.find_element(By.CSS_SELECTOR, f'button[data-mode="{name}"]').click()
        wait_for(lambda: self.js("return window.gidabotEditor.state().mode;") == name, 5, f"mode {name}")

    def tab(self, name: str) -> None:
        self.driver.find_element(By.CSS_SELECTOR, f'button[data-tab="{name}"]').click()

    def floor(self, index: int) -> None:
        self.driver.find_element(By.CSS_SELECTOR, f'#floors li[data-index="{index}"]').click()
        wait_for(lambda: self.js("return window.gidabotEditor.floorIndex();") == index, 5, f"floor {index}")

    def _offset(self, canvas_id: str, x: float, y: float) -> tuple[object, int, int]:
        canvas = self.driver.find_element(By.ID, canvas_id)
        sx, sy = self.js("return window.gidabotEditor.toScreen(arguments[0], arguments[1], arguments[2]);",
                         canvas_id, x, y)
        w, h = canvas.size["width"], canvas.size["height"]
        if not (0 <= sx < w and 0 <= sy < h):
            raise AssertionError(f"({x}, {y}) is drawn at ({sx:.0f}, {sy:.0f}), off the {w}x{h} canvas {canvas_id}")
        return canvas, round(sx - w / 2), round(sy - h / 2)       # selenium 4: offsets from the element's centre

    def click_at(self, canvas_id: str, x: float, y: float, change: bool = False) -> None:
        """Click the point (x, y) of a canvas: map metres on a map, pixels on a blueprint."""
        before = self.revision()
        canvas, dx, dy = self._offset(canvas_id, x, y)
        ActionChains(self.driver).move_to_element_with_offset(canvas, dx, dy).click().perform()
        if change:
            self.changed(before)

    def drag(self, canvas_id: str, a: tuple[float, float], b: tuple[float, float]) -> None:
        """Press at map point ``a``, move to ``b`` in steps, release."""
        before = self.revision()
        canvas, ax, ay = self._offset(canvas_id, *a)
        _, bx, by = self._offset(canvas_id, *b)
        chain = ActionChains(self.driver).move_to_element_with_offset(canvas, ax, ay).click_and_hold()
        for k in range(1, 6):
            chain.move_by_offset(round((bx - ax) * k / 5) - round((bx - ax) * (k - 1) / 5),
                                 round((by - ay) * k / 5) - round((by - ay) * (k - 1) / 5))
        chain.release().perform()
        self.changed(before)

    # -- forms ---------------------------------------------------------------------------------------------------
    def field(self, form: str, name: str):
        return self.driver.find_element(By.CSS_SELECTOR, f'#{form} [name="{name}"]')

    def type(self, form: str, name: str, value: object) -> None:
        """Type ``value`` into a form's field and leave it (the change is sent); waits for it."""
        for _ in range(3):
            try:
                el = self.field(form, name)
                if el.get_attribute("value") == str(value):
                    return
                before = self.revision()
                el.click()
                el.send_keys(Keys.CONTROL, "a")
                el.send_keys(str(value), Keys.TAB)
                self.changed(before)
                return
            except StaleElementReferenceException:
                continue
        raise AssertionError(f"cannot type into {form} {name}")

    def choose(self, form: str, name: str, value: object) -> None:
        el = self.field(form, name)
        if el.get_attribute("value") == str(value):
            return
        before = self.revision()
        Select(el).select_by_value(str(value))
        self.changed(before)

    def tick(self, form: str, name: str, on: bool) -> None:
        el = self.field(form, name)
        if el.is_selected() != on:
            before = self.revision()
            el.click()
            self.changed(before)

    def pose(self, prefix: str, x: float, y: float, yaw: float) -> None:
        self.type("item-form", f"{prefix}-x", x)
        self.type("item-form", f"{prefix}-y", y)
        self.type("item-form", f"{prefix}-z", round(math.degrees(yaw), 2))
