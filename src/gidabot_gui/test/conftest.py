"""Fixtures of the GUI tests: an offscreen QApplication, compiled catalogs, windows with fake outputs.

No ROS master: the window is fed records (or ROS messages through the adapter's
converters) and what it would publish is recorded.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from gui_fakes import RecordingOutputs

from gidabot_navigation.passwords import hash_record

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
os.environ.setdefault("XDG_RUNTIME_DIR", f"/tmp/gidabot-gui-xdg-{os.getuid()}")
Path(os.environ["XDG_RUNTIME_DIR"]).mkdir(mode=0o700, exist_ok=True)

REPO = Path(__file__).resolve().parents[3]
PKG = REPO / "src" / "gidabot_gui"
FACULTY = REPO / "maps" / "faculty"
SHOTS = Path(os.environ.get("GIDABOT_SCREENSHOT_DIR", REPO / "docs" / "screenshots"))


@pytest.fixture(scope="session")
def faculty():
    from gidabot_navigation.building.model import load_building

    return load_building(FACULTY)


@pytest.fixture(scope="session")
def faculty6():
    """The faculty with two robots on floors 1 and 2 (maps/faculty6)."""
    from gidabot_navigation.building.model import load_building

    return load_building(REPO / "maps" / "faculty6")


@pytest.fixture(scope="session")
def faculty3():
    """The faculty without a robot on floor 2 (maps/faculty3)."""
    from gidabot_navigation.building.model import load_building

    return load_building(REPO / "maps" / "faculty3")


@pytest.fixture(scope="session")
def locale_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The catalogs compiled from the committed .po files (never a stale .mo)."""
    out = tmp_path_factory.mktemp("locale")
    for po in (PKG / "locale").glob("*/LC_MESSAGES/gidabot_gui.po"):
        dest = out / po.parent.relative_to(PKG / "locale") / "gidabot_gui.mo"
        dest.parent.mkdir(parents=True, exist_ok=True)
        subprocess.run(["msgfmt", "--check", "-o", str(dest), str(po)], check=True)
    return out


@pytest.fixture(scope="session")
def qapp():
    from PyQt5.QtWidgets import QApplication

    app = QApplication.instance() or QApplication(sys.argv[:1])
    yield app


class Clock:
    """Wall time the test controls."""

    def __init__(self, t: float = 1000.0) -> None:
        self.t = t

    def __call__(self) -> float:
        return self.t


@dataclass
class Gui:
    window: Any
    out: RecordingOutputs
    speaker: Any
    clock: Clock
    tr: Any
    app: Any

    def process(self) -> None:
        self.app.processEvents()

    def click(self, widget: Any) -> None:
        from PyQt5.QtCore import Qt
        from PyQt5.QtTest import QTest

        assert widget.isVisible(), f"{getattr(widget, 'key', widget)} is not visible"
        assert widget.isEnabled(), f"{getattr(widget, 'key', widget)} is disabled"
        QTest.mouseClick(widget, Qt.LeftButton)
        self.process()

    def overlay_button(self, key: str) -> Any:
        ov = self.window.overlay
        assert ov.showing, "no pop-up is shown"
        assert key in ov.buttons, f"pop-up {ov.name!r} has no button {key!r} (has {sorted(ov.buttons)})"
        return ov.buttons[key]

    def press(self, key: str) -> None:
        self.click(self.overlay_button(key))

    def click_row(self, lst: Any, row: int) -> None:
        from PyQt5.QtCore import Qt
        from PyQt5.QtTest import QTest

        item = lst.item(row)
        lst.scrollToItem(item)
        self.process()
        QTest.mouseClick(lst.viewport(), Qt.LeftButton, pos=lst.visualItemRect(item).center())
        self.process()

    def nav(self, key: str) -> None:
        self.click(self.window.nav_buttons[key])

    def feed_all_status(self, building: Any, state: str = "idle", pending: int = 0, wait: float = 0.0) -> None:
        from gidabot_navigation.guiding.messages import PendingData, RobotStatusData

        for r in building.robots:
            self.window.feed("status", RobotStatusData(r.name, r.floor, r.home.x, r.home.y, r.home.yaw, 0.0, 0.0,
                                                       0.87, state, pending, "", wait))
            self.window.feed("pending", PendingData(r.name, r.floor, pending, wait))
        self.process()

    def shot(self, name: str) -> Path:
        """Save the window as docs/screenshots/<name>.png (256 colours without dithering: small, sharp)."""
        from PIL import Image
        from PyQt5.QtGui import QImage

        self.process()
        SHOTS.mkdir(parents=True, exist_ok=True)
        path = SHOTS / f"{name}.png"
        img = self.window.grab().toImage().convertToFormat(QImage.Format_RGB888)
        ptr = img.constBits()
        ptr.setsize(img.sizeInBytes())
        rgb = Image.frombuffer("RGB", (img.width(), img.height()), bytes(ptr), "raw", "RGB", img.bytesPerLine(), 1)
        rgb.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(path, optimize=True)
        return path


@pytest.fixture
def make_gui(qapp: Any, faculty: Any, locale_dir: Path) -> Iterator[Callable[..., Gui]]:
    from gidabot_gui.core.admin import PasswordCheck
    from gidabot_gui.core.i18n import Translator
    from gidabot_gui.qt.speech import NullSpeaker
    from gidabot_gui.qt.window import GuiConfig, MainWindow

    made: list[Any] = []

    def make(robot: str = "Kbot", language: str = "en", size: tuple[int, int] = (800, 480),
             admin_password: str | None = None, building: Any = None, **config: Any) -> Gui:
        b = building or faculty
        clock = Clock()
        out = RecordingOutputs()
        speaker = NullSpeaker()
        tr = Translator(language, locale_dir)
        admin = PasswordCheck(hash_record(admin_password)) if admin_password is not None else None
        cfg = GuiConfig(robot, admin=admin, visitor_id="gui-test", **config)
        w = MainWindow(b, cfg, tr, out, speaker, clock=clock)
        w.drain_timer.stop()
        w.tick_timer.stop()
        w.resize(*size)
        w.show()
        qapp.processEvents()
        made.append(w)
        return Gui(w, out, speaker, clock, tr, qapp)

    yield make
    for w in made:
        w.close()
        w.deleteLater()
    qapp.processEvents()


def visible_text_problems(window: Any) -> list[str]:
    """Texts that do not fit their widget, and touch targets that are too small (after a paint)."""
    from PyQt5.QtCore import Qt
    from PyQt5.QtGui import QTextDocument
    from PyQt5.QtWidgets import QLabel, QLineEdit, QListWidget, QPushButton

    from gidabot_gui.qt.pages import RowDelegate
    from gidabot_gui.qt.widgets import FitLabel, WrapButton

    window.grab()            # paint everything: the fitting flags are set while painting
    problems = []
    win_rect = window.rect()

    def visible(w: Any) -> bool:
        return w.isVisible() and w.width() > 0 and w.height() > 0

    for b in window.findChildren(QPushButton):
        if not visible(b):
            continue
        if not isinstance(b, WrapButton):
            problems.append(f"plain QPushButton {b.text()!r}")
            continue
        if b.clipped:
            problems.append(f"button {b.key!r} text {b.text()!r} clipped at {b.width()}x{b.height()}")
        minimum = 32 if b.is_key else 50
        if b.height() < minimum:
            problems.append(f"button {b.key!r} ({b.text()!r}) is only {b.height()} px high")
        top_left = b.mapTo(window, b.rect().topLeft())
        bottom_right = b.mapTo(window, b.rect().bottomRight())
        if not (win_rect.contains(top_left) and win_rect.contains(bottom_right)):
            problems.append(f"button {b.key!r} ({b.text()!r}) is outside the window")
    def cut_sideways(w: Any) -> bool:
        """Part of ``w`` hidden left or right by an ancestor (nothing scrolls sideways in this GUI)."""
        left = w.mapTo(window, w.rect().topLeft()).x()
        right = w.mapTo(window, w.rect().topRight()).x()
        p = w.parentWidget()
        while p is not None:
            pl = p.mapTo(window, p.rect().topLeft()).x() if p is not window else 0
            pr = p.mapTo(window, p.rect().topRight()).x() if p is not window else window.width() - 1
            if left < pl - 1 or right > pr + 1:
                return True
            p = p.parentWidget()
        return False

    for w in [*window.findChildren(QPushButton), *window.findChildren(QLabel), *window.findChildren(FitLabel)]:
        if visible(w) and cut_sideways(w):
            problems.append(f"{type(w).__name__} {getattr(w, 'text', lambda: '')()!r} is cut off at the side")
    shown = [b for b in window.findChildren(WrapButton) if visible(b)]
    for i, a in enumerate(shown):
        for b in shown[i + 1:]:
            if a.parentWidget() is b.parentWidget() and a.geometry().intersects(b.geometry()):
                problems.append(f"buttons {a.key!r} and {b.key!r} overlap")
    for f in window.findChildren(FitLabel):
        if visible(f) and f.clipped:
            problems.append(f"label text {f.text()!r} clipped at {f.width()}x{f.height()}")
    for lab in window.findChildren(QLabel):
        if not visible(lab) or not lab.text() or lab.pixmap() is not None and not lab.pixmap().isNull():
            continue
        if lab.wordWrap():
            need = lab.heightForWidth(lab.contentsRect().width())
            if need > lab.contentsRect().height() + 2:
                problems.append(f"label {lab.text()[:60]!r} needs {need} px, has {lab.contentsRect().height()}")
        elif lab.textFormat() == Qt.RichText or (lab.textFormat() == Qt.AutoText and Qt.mightBeRichText(lab.text())):
            doc = QTextDocument()
            doc.setDefaultFont(lab.font())
            doc.setDocumentMargin(0)
            doc.setHtml(lab.text())
            need = doc.idealWidth()
            if need > lab.contentsRect().width() + 1:
                problems.append(f"label {lab.text()!r} needs {need} px wide, has {lab.contentsRect().width()}")
        else:
            need = lab.fontMetrics().horizontalAdvance(lab.text())
            if need > lab.contentsRect().width() + 1:
                problems.append(f"label {lab.text()!r} needs {need} px wide, has {lab.contentsRect().width()}")
    for e in window.findChildren(QLineEdit):
        if visible(e) and e.placeholderText() and not e.text():
            need = e.fontMetrics().horizontalAdvance(e.placeholderText())
            if need > e.width() - 24:
                problems.append(f"placeholder {e.placeholderText()!r} too wide for {e.width()} px")
    for lst in window.findChildren(QListWidget):
        d = lst.itemDelegate()
        if visible(lst) and isinstance(d, RowDelegate) and d.clipped:
            problems.append(f"list rows clipped: {sorted(d.clipped)[:3]}")
            d.clipped.clear()
    return problems


@pytest.fixture
def text_problems() -> Callable[[Any], list[str]]:
    return visible_text_problems


@pytest.fixture(scope="session")
def big_building(tmp_path_factory: pytest.TempPathFactory):
    """The faculty grown to 8 floors and 8 robots (for the 10 Hz x 8 robots test)."""
    import yaml

    from gidabot_navigation.building.model import load_building

    dest = tmp_path_factory.mktemp("big") / "faculty8"
    shutil.copytree(FACULTY, dest)
    doc = yaml.safe_load((dest / "building.yaml").read_text())
    template = doc["floors"][3]
    for i in range(4, 8):
        floor = dict(template, id=i, names={k: f"{v} +{i - 3}" for k, v in template["names"].items()})
        doc["floors"].append(floor)
        for con in doc["connectors"]:
            con["meeting"].append({"floor": i, "pose": con["meeting"][3]["pose"]})
        robot = dict(doc["robots"][3], name=f"Robot{i}", floor=i, master_uri=f"http://127.0.0.{11 + i}:11311/")
        doc["robots"].append(robot)
    (dest / "building.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
    return load_building(dest)
