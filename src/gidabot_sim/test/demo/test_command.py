"""`gidabot demo`'s arguments: every bad one refused before anything starts."""

from __future__ import annotations

from pathlib import Path

from gidabot_sim.demo.command import main
from gidabot_sim.runner.command_line import EXIT_USAGE


def test_bad_arguments_are_refused_before_anything_starts(tmp_path: Path, capsys) -> None:
    out = tmp_path / "runs"
    cases = [
        (["--goal", "9999"], "is not a location of faculty"),
        (["--tour", str(tmp_path / "missing.tour")], "missing.tour"),
        (["--speed", "0"], "--speed 0: expected a factor"),
        (["--speed", "nan"], "--speed nan"),
        (["--start-floor", "7"], "start floor 7 has no robot"),
        (["--skip", "3:2"], "need 1 <= K < M <= 8"),
        (["--skip", "x"], "expected K:M"),
        (["--secret", str(tmp_path / "nope")], "not a file"),
        (["--net", "0"], "--net 0"),
        (["--clock-rate", "0"], "--clock-rate 0: expected 1..1000"),
        (["--clock-rate", "inf"], "--clock-rate inf"),
        (["--walk", "colour=red"], "--walk: walk 'colour=red': unknown key 'colour'"),
        (["--walk", "speed=nan"], "speed nan m/s must be in 0.5..1.4"),
        (["--walk", "group=9"], "group 9 must be 1..4 bodies"),
        (["--visitors", "3", "--walk", "speed=0.5"], "--walk is the one visitor's"),
    ]
    for argv, expected in cases:
        assert main([*argv, "--out", str(out)]) == EXIT_USAGE, argv
        assert expected in capsys.readouterr().err, argv
    bad = tmp_path / "bad.tour"
    bad.write_text("Tour\n0, 999, Nowhere\n", encoding="utf-8")
    assert main(["--tour", str(bad), "--out", str(out)]) == EXIT_USAGE
    assert "999" in capsys.readouterr().err
    assert not out.exists()   # nothing was started, no run folder


def test_gui_needs_a_display(monkeypatch, tmp_path: Path, capsys) -> None:
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("QT_QPA_PLATFORM", raising=False)
    assert main(["--gui", "--out", str(tmp_path)]) == EXIT_USAGE
    assert "--gui needs a display" in capsys.readouterr().err
