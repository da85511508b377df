"""Speech through espeak-ng: asynchronous, one sentence at a time, the voice of each language."""

from __future__ import annotations

import shutil
import time

import pytest
from gui_fakes import wait_until

from gidabot_gui.qt.speech import VOICES, EspeakSpeaker, NullSpeaker

pytestmark = pytest.mark.skipif(shutil.which("espeak-ng") is None, reason="espeak-ng is not installed")


def test_espeak_speaks_without_blocking_and_interrupts(qapp) -> None:
    logs: list[str] = []
    sp = EspeakSpeaker(sink="null", log=logs.append)
    t0 = time.monotonic()
    sp.say("Kaixo, Kbot naiz. Sakatu Jarraitu hemen zaudenean. " * 5, "eu")
    assert time.monotonic() - t0 < 0.2                 # returns at once; espeak-ng runs on its own
    first = sp.proc
    assert first is not None and sp.busy()
    sp.say("Hola, soy Kbot.", "es")                   # a new sentence stops the one being spoken
    assert sp.proc is not first
    assert wait_until(qapp, lambda: not sp.busy(), 10.0)
    assert sp.spoken == 2 and sp.failed == 0 and not logs


def test_voices_exist() -> None:
    import subprocess

    listed = subprocess.run(["espeak-ng", "--voices"], capture_output=True, text=True, check=True).stdout
    names = {line.split()[1] for line in listed.splitlines()[1:] if line.split()}
    for lang, voice in VOICES.items():
        assert voice in names, f"no espeak-ng voice {voice} for {lang}"


def test_null_speaker_records() -> None:
    sp = NullSpeaker()
    sp.say("hello", "en")
    assert sp.said == [("hello", "en")]
