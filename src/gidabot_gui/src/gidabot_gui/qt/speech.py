"""Speech with espeak-ng (voices eu, en, es), never blocking the GUI.

:class:`EspeakSpeaker` runs one ``espeak-ng`` process at a time through
QProcess (asynchronous): a new sentence stops the one being spoken. The text
goes through stdin (``--stdin``), never through the command line. With
``sink="null"`` the audio is produced and discarded (headless demo, tests).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from typing import Protocol

from PyQt5.QtCore import QObject, QProcess

VOICES = {"eu": "eu", "en": "en-gb", "es": "es"}
MAX_CHARS = 600


class Speaker(Protocol):
    def say(self, text: str, language: str) -> None: ...

    def stop(self) -> None: ...


class NullSpeaker:
    """Speech switched off (``~speech: false``); keeps what it was asked to say (tests)."""

    def __init__(self) -> None:
        self.said: list[tuple[str, str]] = []

    def say(self, text: str, language: str) -> None:
        self.said.append((text, language))

    def stop(self) -> None:
        pass


class EspeakSpeaker(QObject):
    """Speaks through espeak-ng in a QProcess; ``sink`` "" = the audio device, "null" = discard."""

    def __init__(self, command: str = "espeak-ng", rate_wpm: int = 150, sink: str = "",
                 log: Callable[[str], None] | None = None, parent: QObject | None = None) -> None:
        super().__init__(parent)
        self.command = shutil.which(command) or ""
        self.rate = int(rate_wpm)
        self.sink = sink
        self.log = log or (lambda _m: None)
        self.proc: QProcess | None = None
        self.spoken = 0
        self.failed = 0
        if not self.command:
            self.log(f"speech: {command!r} not found; speech is off")

    def say(self, text: str, language: str) -> None:
        text = " ".join(text.split())[:MAX_CHARS]
        if not self.command or not text:
            return
        self.stop()
        proc = QProcess(self)
        proc.setStandardOutputFile(QProcess.nullDevice())
        proc.setStandardErrorFile(QProcess.nullDevice())
        proc.errorOccurred.connect(lambda err, p=proc: self._error(p, err))
        proc.finished.connect(lambda *_a, p=proc: self._finished(p))
        args = ["-v", VOICES.get(language, "en-gb"), "-s", str(self.rate), "--stdin"]
        if self.sink == "null":
            args.append("--stdout")
        proc.start(self.command, args)
        proc.write(text.encode("utf-8"))
        proc.closeWriteChannel()
        self.proc = proc
        self.spoken += 1

    def _error(self, proc: QProcess, err: object) -> None:
        if proc is not self.proc:
            return                 # a sentence we stopped on purpose
        self.failed += 1
        self.log(f"speech: espeak-ng failed ({err}: {proc.errorString()})")

    def _finished(self, proc: QProcess) -> None:
        if proc is self.proc:
            self.proc = None
        proc.deleteLater()

    def stop(self) -> None:
        proc, self.proc = self.proc, None
        if proc is not None and proc.state() != QProcess.NotRunning:
            proc.kill()            # our own child, by its handle; reaped when it signals finished

    def busy(self) -> bool:
        return self.proc is not None and self.proc.state() != QProcess.NotRunning
