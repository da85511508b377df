#!/usr/bin/env python3
"""A real ``gui`` node (rospy + the Qt window, offscreen) remote-controlled through stdin, for system tests.

One JSON command per line on stdin, one JSON answer per line on stdout:
  {"op": "pick", "goal": "223"}          tap a destination
  {"op": "press", "key": "go"}           tap a pop-up button
  {"op": "cancel"} / {"op": "continue"}  the bottom bar buttons
  {"op": "state"}                        what is shown (pop-up, texts, buttons, robots)
  {"op": "quit"}
Arguments: building robot.
"""

from __future__ import annotations

import json
import os
import sys

from gidabot_navigation.interface import Node

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")


def main() -> int:
    building_path, robot = sys.argv[1], sys.argv[2]
    import rospy
    from PyQt5.QtCore import QSocketNotifier, QTimer
    from PyQt5.QtWidgets import QApplication

    from gidabot_gui.core.i18n import Translator
    from gidabot_gui.core.inbox import Inbox
    from gidabot_gui.gui_node import GuiNode, Params
    from gidabot_gui.qt.speech import NullSpeaker
    from gidabot_gui.qt.window import GuiConfig, MainWindow
    from gidabot_navigation.building.model import load_building

    rospy.init_node(Node.GUI, disable_signals=True)
    app = QApplication(sys.argv[:1])
    building = load_building(building_path)
    params = Params(building_path, robot, "en", False, "", False, "null", 150, False, 800, 480, 5.0, 20.0, "")
    inbox = Inbox()
    node = GuiNode(params, inbox, building)
    speaker = NullSpeaker()
    window = MainWindow(building, GuiConfig(robot, visitor_id="guidriver"), Translator("en"), node, speaker,
                        inbox=inbox)
    window.resize(800, 480)
    window.show()

    def state() -> dict:
        ov = window.overlay
        return {"popup": ov.name if ov.showing else "", "title": ov.title.text() if ov.showing else "",
                "body": ov.body.text() if ov.showing else "", "note": ov.note_text.text() if ov.showing else "",
                "buttons": sorted(ov.buttons) if ov.showing else [], "cancel": window.cancel_btn.isVisible(),
                "here": window.info_here.text(), "trip": window.info_trip.text(),
                "tours": [t.file_name for t in window.tours],
                "robots": {n: live.last_status is not None for n, live in window.fleet.robots.items()},
                "pending": {n: live.pending is not None for n, live in window.fleet.robots.items()},
                "said": speaker.said[-1][0] if speaker.said else ""}

    def handle(cmd: dict) -> dict:
        op = cmd.get("op")
        if op == "pick":
            window.visitor.pick_destination(cmd["goal"])
        elif op == "press":
            window.overlay.press(cmd["key"])
        elif op == "cancel":
            window.visitor.press_cancel()
        elif op == "continue":
            window.visitor.press_continue(None)
        elif op == "quit":
            app.quit()
        elif op != "state":
            return {"ok": False, "error": f"unknown op {op!r}"}
        app.processEvents()
        return {"ok": True, **state()}

    def readable() -> None:
        line = sys.stdin.readline()
        if not line:
            app.quit()
            return
        try:
            reply = handle(json.loads(line))
        except (KeyError, ValueError) as err:
            reply = {"ok": False, "error": str(err)}
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()

    notifier = QSocketNotifier(sys.stdin.fileno(), QSocketNotifier.Read)
    notifier.activated.connect(readable)
    ticker = QTimer()
    ticker.timeout.connect(lambda: rospy.is_shutdown() and app.quit())
    ticker.start(200)
    sys.stdout.write(json.dumps({"ok": True, "ready": True}) + "\n")
    sys.stdout.flush()
    rc = app.exec_()
    node.shutdown()
    rospy.signal_shutdown("driver done")
    return rc


if __name__ == "__main__":
    sys.exit(main())
