"""Which recorder of a restarted master stops when (gidabot_sim.runner.recorders)."""

from __future__ import annotations

from pathlib import Path

from gidabot_sim.runner.recorders import obsolete_recorders

T, T1, T2 = Path("Tartalo.bag"), Path("Tartalo.1.bag"), Path("Tartalo.2.bag")


def test_an_old_recorder_records_on_until_a_newer_part_records() -> None:
    """The full chaos run on machines, seed 1: MariSorgin's machine came back after 5 minutes and every floor's
    clock stood still for ~290 s while its floor caught up; Tartalo's master restarted twice meanwhile. Its new
    recorders waited for the clock, the old one was stopped after 5 s: Tartalo.1.bag was never written (the
    report failed: missing bag) and nothing was recorded on Tartalo's master for 280 s."""
    bags = {"Tartalo": [T, T1, T2]}
    retired = {"record_Tartalo": ("Tartalo", 0), "record_Tartalo.1": ("Tartalo", 1)}
    assert obsolete_recorders(retired, bags, {}, now=300.0) == []            # neither new part records yet
    assert obsolete_recorders(retired, bags, {T2: 290.0}, now=294.0) == []  # part 2 records, for 4 s only
    assert obsolete_recorders(retired, bags, {T2: 290.0}, now=295.0) == ["record_Tartalo", "record_Tartalo.1"]


def test_the_next_part_recording_retires_only_the_older_ones() -> None:
    bags = {"Tartalo": [T, T1, T2], "Kbot": [Path("Kbot.bag"), Path("Kbot.1.bag")]}
    retired = {"record_Tartalo": ("Tartalo", 0), "record_Tartalo.1": ("Tartalo", 1), "record_Kbot": ("Kbot", 0)}
    assert obsolete_recorders(retired, bags, {T1: 10.0}, now=20.0) == ["record_Tartalo"]
