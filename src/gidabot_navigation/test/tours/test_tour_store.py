"""Tour store core: seeding, admin edits, versions, ownership, hostile input, crash recovery (no master)."""

from __future__ import annotations

import json
import os
import re
from dataclasses import replace
from pathlib import Path

import pytest
from tour_support import T0, TOURS, FakeClock, ListLog, open_store, snapshot, tour_msg

from gidabot_navigation.errors import TourRejected, TourStoreError
from gidabot_navigation.tours.safe_dir import SafeDir
from gidabot_navigation.tours.tour_store import (
    META_NAME,
    NS,
    SEED_VERSION,
    IndexEntry,
    StoreLimits,
    TourStore,
    index_entries,
)

VISIT = ["0, 014, Computer Technicians 1", "1, 101, Secretary's Office", "3, 305, RSAIT Lab"]
VISIT_TEXT = b"Tour\n0, 014, Computer Technicians 1\n1, 101, Secretary's Office\n3, 305, RSAIT Lab\n"


@pytest.fixture
def clock() -> FakeClock:
    return FakeClock()


@pytest.fixture
def log() -> ListLog:
    return ListLog()


@pytest.fixture
def store(tmp_path: Path, faculty, clock, log):
    s = open_store(tmp_path / "tours", faculty, clock=clock, log=log, seed_dir=TOURS)
    yield s
    s.close()


# ---------------------------------------------------------------- seeding and adoption
def test_first_start_seeds_the_initial_tours(store: TourStore, tmp_path: Path) -> None:
    files = snapshot(tmp_path / "tours")
    assert files == {p.name: p.read_bytes() for p in sorted(TOURS.glob("*.tour"))}
    rec = store.get("real_world.tour")
    assert (rec.version, rec.editor, rec.origin, rec.deleted) == (SEED_VERSION, "", "", False)
    assert [r.file_name for r in store.catalog()] == ["long_tour.tour", "paper_example.tour", "real_world.tour"]
    meta = json.loads((tmp_path / "tours" / META_NAME).read_text())
    assert meta["tours"]["long_tour.tour"]["version"] == SEED_VERSION


def test_restart_keeps_everything_and_does_not_seed_again(store, tmp_path, faculty, clock) -> None:
    store.edit(tour_msg("visit.tour", VISIT))
    store.edit(tour_msg("long_tour.tour", [], deleted=True))
    before = (snapshot(tmp_path / "tours"), store.index())
    store.close()
    again = open_store(tmp_path / "tours", faculty, clock=clock, seed_dir=TOURS)
    assert (snapshot(tmp_path / "tours"), again.index()) == before
    assert again.get("long_tour.tour").deleted
    again.close()


def test_files_present_without_metadata_are_adopted(tmp_path, faculty, clock, log) -> None:
    d = tmp_path / "tours"
    d.mkdir()
    (d / "mine.tour").write_bytes(b"Tour\n0,014,Lab  \n")          # valid, sloppy spacing
    (d / "broken.tour").write_bytes(b"Tour\n0, 999, Nowhere\n")    # unknown room
    (d / "README.txt").write_bytes(b"notes")
    s = open_store(d, faculty, clock=clock, log=log, seed_dir=TOURS)   # not empty: no seeding
    assert [r.file_name for r in s.catalog()] == ["mine.tour"]
    assert (d / "mine.tour").read_bytes() == b"Tour\n0, 014, Lab\n"    # rewritten canonically
    assert (d / "broken.tour").read_bytes() == b"Tour\n0, 999, Nowhere\n"  # left untouched
    assert (d / "README.txt").read_bytes() == b"notes"
    assert s.get("mine.tour").editor == "Galtxagorri" and s.get("mine.tour").version == T0
    assert "ignoring tour file broken.tour" in log.text("warning") and "unknown room '999'" in log.text()
    s.close()


# ---------------------------------------------------------------- admin actions
def test_create_edit_delete(store: TourStore, tmp_path: Path, clock) -> None:
    d = tmp_path / "tours"
    rec = store.edit(tour_msg("visit.tour", VISIT, name="A visit"))
    assert (d / "visit.tour").read_bytes() == b"Tour: A visit\n" + VISIT_TEXT[5:]
    assert (rec.version, rec.editor, rec.origin, rec.language) == (T0, "Galtxagorri", "Galtxagorri", "en")
    clock.ns -= 5 * NS            # the clock steps back: the next version is still larger
    rec2 = store.edit(tour_msg("visit.tour", VISIT[:2], language="eu"))
    assert rec2.version == T0 + 1 and rec2.language == "eu"
    assert (d / "visit.tour").read_bytes() == b"Tour\n0, 014, Computer Technicians 1\n1, 101, Secretary's Office\n"
    clock.advance(10)
    tomb = store.edit(tour_msg("visit.tour", [], deleted=True))
    assert tomb.deleted and tomb.version == clock.ns and not (d / "visit.tour").exists()
    assert "visit.tour" not in [r.file_name for r in store.catalog()]
    assert IndexEntry("visit.tour", clock.ns, "Galtxagorri", True) in store.index()
    with pytest.raises(TourRejected, match="no tour visit.tour to delete"):
        store.edit(tour_msg("visit.tour", [], deleted=True))


def test_edit_of_a_seeded_tour_keeps_its_origin(store: TourStore) -> None:
    rec = store.edit(tour_msg("real_world.tour", VISIT))
    assert rec.origin == "" and rec.editor == "Galtxagorri" and rec.version > SEED_VERSION


@pytest.mark.parametrize("msg, reason, text", [
    (tour_msg("visit.tour", ["0, 999, Nowhere"]), "content", "unknown room '999'"),
    (tour_msg("visit.tour", ["0, 014"]), "content", "2 column(s)"),
    (tour_msg("../visit.tour", VISIT), "file_name", "path separator"),
    (tour_msg("visit.tour", VISIT, language="fr"), "language", "'fr' is not one of eu, en, es"),
    (tour_msg("visit.tour", VISIT, name="x\n0, 014, injected"), "name", "control characters"),
    (tour_msg("visit.tour", VISIT, floor=float("nan")), "floor", "nan"),
    (tour_msg(".gidabot-tours.json", ["0, 014, A\n9, 999, injected line"]), "file_name", "hidden"),
])
def test_invalid_admin_edits_are_rejected(store, tmp_path, msg, reason, text) -> None:
    before = snapshot(tmp_path / "tours", hidden=True)
    with pytest.raises(TourRejected, match=re.escape(text)) as info:
        store.edit(msg)
    assert info.value.reason == reason
    assert snapshot(tmp_path / "tours", hidden=True) == before
    assert store.stats()["rejected_edit"] == 1      # counted as a rejection (a chaos verdict reads rejected_*)


def test_admin_cannot_create_over_a_file_the_store_does_not_own(store, tmp_path) -> None:
    (tmp_path / "tours" / "stray.tour").write_bytes(b"by hand")
    with pytest.raises(TourRejected, match="stray.tour already exists .* as a file the tour store does not manage"):
        store.edit(tour_msg("stray.tour", VISIT))
    assert (tmp_path / "tours" / "stray.tour").read_bytes() == b"by hand"


def test_an_admin_action_is_answered_and_shared_or_refused(store, tmp_path, log, monkeypatch) -> None:
    result, shared = store.admin_edit(tour_msg("visit.tour", VISIT, uid="Galtxagorri/gui/tour-edit/1"))
    assert (result.uid, result.file_name, result.ok, result.version, result.reason) == (
        "Galtxagorri/gui/tour-edit/1", "visit.tour", True, store.get("visit.tour").version, "")
    assert shared is not None and shared.file_name == "visit.tour" and shared.uid.startswith("Galtxagorri/tour/")
    assert [t.file_name for t in store.catalog_data().tours] == [r.file_name for r in store.catalog()]
    assert store.index_data().entries == tuple(store.index()) and store.index_data().robot == "Galtxagorri"
    result, shared = store.admin_edit(tour_msg("gone.tour", [], deleted=True, uid="Galtxagorri/gui/tour-edit/2"))
    assert (result.ok, result.deleted, result.reason, shared) == (False, True, "unknown", None)
    assert any("admin delete of tour 'gone.tour' refused" in line for _level, line in log.lines)

    def full(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(SafeDir, "write_atomic", full)
    result, shared = store.admin_edit(tour_msg("other.tour", VISIT))
    assert (result.ok, result.reason, shared) == (False, "io", None) and "No space left" in result.error


def test_metadata_write_failure_changes_nothing(store, tmp_path, monkeypatch) -> None:
    before = snapshot(tmp_path / "tours", hidden=True)

    def full(*_a, **_k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(SafeDir, "write_atomic", full)
    with pytest.raises(TourStoreError, match="No space left on device"):
        store.edit(tour_msg("visit.tour", VISIT))
    assert store.get("visit.tour") is None
    assert snapshot(tmp_path / "tours", hidden=True) == before


def test_second_store_on_the_same_directory_is_refused(store, tmp_path, faculty) -> None:
    with pytest.raises(TourStoreError, match="another tour store is using"):
        open_store(tmp_path / "tours", faculty)


# ---------------------------------------------------------------- remote records and versions
def remote(file_name: str, goals, version: int, editor: str = "Kbot", **kw):
    return tour_msg(file_name, goals, version=version, editor=editor, origin=kw.pop("origin", editor), **kw)


def test_newer_wins_older_is_ignored(store: TourStore, tmp_path: Path) -> None:
    d = tmp_path / "tours"
    assert store.receive(remote("visit.tour", VISIT, T0 + 10)).status == "accepted"
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT
    assert store.receive(remote("visit.tour", VISIT[:1], T0 + 5)).status == "stale"
    assert store.receive(remote("visit.tour", VISIT, T0 + 10)).status == "duplicate"
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT
    # a tombstone beats the tour; the old copy arriving late cannot resurrect it
    assert store.receive(remote("visit.tour", [], T0 + 20, deleted=True)).status == "accepted"
    assert not (d / "visit.tour").exists()
    assert store.receive(remote("visit.tour", VISIT, T0 + 10, uid="Kbot/tour/late")).status == "stale"
    assert not (d / "visit.tour").exists()
    # a newer version re-creates it
    assert store.receive(remote("visit.tour", VISIT, T0 + 30, editor="MariSorgin")).status == "accepted"
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT


def test_equal_versions_tie_break_on_the_editor(faculty, tmp_path) -> None:
    a = remote("t.tour", VISIT[:1], T0, editor="Kbot")
    b = remote("t.tour", VISIT[1:], T0, editor="Tartalo")
    results = []
    for i, order in enumerate(([a, b], [b, a])):
        s = open_store(tmp_path / f"s{i}", faculty)
        for m in order:
            s.receive(m)
        results.append(((tmp_path / f"s{i}" / "t.tour").read_bytes(), s.get("t.tour").editor))
        s.close()
    assert results[0] == results[1] and results[0][1] == "Tartalo"


def test_uid_duplicates_are_ignored_before_any_work(store) -> None:
    m = remote("visit.tour", VISIT, T0, uid="Kbot/tour/1")
    assert store.receive(m).status == "accepted"
    assert store.receive(replace(m, version=T0 + 1)).status == "duplicate"
    assert store.get("visit.tour").version == T0


def test_own_messages_round_trip(store, faculty, tmp_path) -> None:
    rec = store.edit(tour_msg("visit.tour", VISIT, name="A visit", language="es"))
    msg = store.outgoing(rec)
    assert msg.uid.startswith("Galtxagorri/tour/") and msg.floor == 0 and msg.tour_name == "A visit"
    assert store.receive(msg).status == "duplicate"       # our own echo
    other = open_store(tmp_path / "other", faculty, robot="Kbot")
    assert other.receive(msg).status == "accepted"
    assert (tmp_path / "other" / "visit.tour").read_bytes() == (tmp_path / "tours" / "visit.tour").read_bytes()
    assert other.get("visit.tour").key == store.get("visit.tour").key
    other.close()


# ---------------------------------------------------------------- tours as people write them
VARIANT_GOALS = [" 0 ,014,  Computer Technicians 1 ", "1.0,101,Secretary's Office\t", "3.00 , 305 , RSAIT Lab"]
VARIANTS = [  # the same tour as VISIT_TEXT, written by a text editor or a phone
    VISIT_TEXT.replace(b"\n", b"\r\n"),
    VISIT_TEXT.replace(b"\n", b"\r"),
    b"\xef\xbb\xbf" + VISIT_TEXT + b"\n\n",
    b"Tour :  Visit\n" + b"\n".join(g.encode() for g in VARIANT_GOALS),
]


def test_a_remote_tour_in_a_tolerated_form_is_stored_canonically_and_compares_equal(store, faculty,
                                                                                     tmp_path) -> None:
    sloppy = remote("visit.tour", VARIANT_GOALS, T0, name=" Visit ")
    assert store.receive(sloppy).status == "accepted"
    assert (tmp_path / "tours" / "visit.tour").read_bytes() == VISIT_TEXT
    other = open_store(tmp_path / "other", faculty, robot="Kbot", seed_dir=TOURS)
    assert other.receive(remote("visit.tour", VISIT, T0, uid="Kbot/tour/canonical")).status == "accepted"
    assert other.get("visit.tour") == store.get("visit.tour")                # same record, same digest
    assert other.get("visit.tour").key == store.get("visit.tour").key
    assert (tmp_path / "other" / "visit.tour").read_bytes() == VISIT_TEXT
    # either form arriving again is the record held: nothing written, nothing re-sent
    assert store.receive(remote("visit.tour", VISIT, T0, uid="Kbot/tour/again")).status == "duplicate"
    assert other.receive(replace(sloppy, uid="Kbot/tour/sloppy-again")).status == "duplicate"
    assert store.peer_index("Kbot", other.index(), 0.0) == [] and other.peer_index("Galtxagorri", store.index(),
                                                                                     0.0) == []
    other.close()


def test_a_hand_written_tour_reaches_another_robot_as_the_same_bytes(tmp_path, faculty, clock) -> None:
    """The file says "Tour: Open day" (the name its file name gives anyway) with Windows line endings;
    the message carries the display name: both robots must hold one record, byte for byte."""
    d = tmp_path / "tours"
    d.mkdir()
    (d / "open_day.tour").write_bytes(b"Tour: Open day\r\n0, 014, Lab\r\n\r\n")
    here = open_store(d, faculty, clock=clock)
    there = open_store(tmp_path / "kbot", faculty, robot="Kbot", clock=clock)
    assert there.receive(here.outgoing(here.get("open_day.tour"))).status == "accepted"
    assert there.get("open_day.tour") == here.get("open_day.tour")
    assert (tmp_path / "kbot" / "open_day.tour").read_bytes() == (d / "open_day.tour").read_bytes() == \
        b"Tour\n0, 014, Lab\n"
    here.close()
    there.close()


@pytest.mark.parametrize("variant", range(len(VARIANTS)))
def test_tour_files_in_tolerated_forms_are_adopted_and_rewritten_canonically(tmp_path, faculty, clock,
                                                                             variant) -> None:
    d = tmp_path / "tours"
    d.mkdir()
    (d / "visit.tour").write_bytes(VARIANTS[variant])
    s = open_store(d, faculty, clock=clock)
    assert [r.file_name for r in s.catalog()] == ["visit.tour"]
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT
    s.close()


def test_a_seed_in_a_tolerated_form_is_seeded_canonically(tmp_path, faculty, clock) -> None:
    seeds = tmp_path / "seeds"
    seeds.mkdir()
    (seeds / "visit.tour").write_bytes(VARIANTS[0])
    stores = [open_store(tmp_path / r, faculty, robot=r, clock=clock, seed_dir=seeds) for r in ("Kbot", "Tartalo")]
    assert [(tmp_path / r / "visit.tour").read_bytes() for r in ("Kbot", "Tartalo")] == [VISIT_TEXT] * 2
    assert stores[0].get("visit.tour") == stores[1].get("visit.tour")
    for st in stores:
        st.close()


def test_the_same_tour_rewritten_by_hand_in_another_form_is_not_a_new_version(store, tmp_path, faculty, clock,
                                                                              log) -> None:
    rec = store.edit(tour_msg("visit.tour", VISIT))
    store.close()
    d = tmp_path / "tours"
    (d / "visit.tour").write_bytes(VARIANTS[0])                # opened and saved on Windows
    clock.advance(100)
    again = open_store(d, faculty, clock=clock, log=log, seed_dir=TOURS)
    assert again.get("visit.tour") == rec                        # no new version to share
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT
    assert "rewritten in the canonical form" in log.text("info")
    again.close()


# ---------------------------------------------------------------- hostile and malformed remote tours
TEN_MB = "x" * (10 * 1024 * 1024)
HOSTILE = [
    ("path traversal", remote("../../etc/evil.tour", VISIT, T0), "file_name"),
    ("absolute path", remote("/etc/passwd.tour", VISIT, T0), "file_name"),
    ("NUL in name", remote("a\x00b.tour", VISIT, T0), "file_name"),
    ("hidden name", remote(".gidabot-tours.json", VISIT, T0), "file_name"),
    ("device name", remote("con.tour", VISIT, T0), "file_name"),
    ("overlong name", remote("x" * 200 + ".tour", VISIT, T0), "file_name"),
    ("not a .tour", remote("real_world.txt", VISIT, T0), "file_name"),
    ("10 MB body", remote("real_world.tour", [f"0, 014, {TEN_MB}"], T0), "oversized"),
    ("10 MB name", remote("real_world.tour", VISIT, T0, name=TEN_MB), "oversized"),
    ("wrong columns", remote("real_world.tour", ["0, 014"], T0), "content"),
    ("unknown room", remote("real_world.tour", ["0, 999, Nowhere"], T0), "content"),
    ("unknown floor", remote("real_world.tour", ["7, 014, Lab"], T0), "content"),
    ("NaN floor line", remote("real_world.tour", ["nan, 014, Lab"], T0, floor=0.0), "content"),
    ("NaN floor field", remote("real_world.tour", VISIT, T0, floor=float("nan")), "floor"),
    ("floor mismatch", remote("real_world.tour", VISIT, T0, floor=3.0), "floor"),
    ("NUL in goal", remote("real_world.tour", ["0, 014, L\x00ab"], T0), "content"),
    ("line injection", remote("real_world.tour", ["0, 014, Lab\n0, 008, Injected"], T0), "content"),
    ("name injection", remote("real_world.tour", VISIT, T0, name="x\n0, 008, Injected"), "name"),
    ("huge name", remote("real_world.tour", VISIT, T0, name="n" * 500), "name"),
    ("empty tour", remote("real_world.tour", [], T0), "content"),
    ("too many goals", remote("real_world.tour", ["0, 014, Lab"] * 101, T0), "content"),
    ("unknown editor", remote("real_world.tour", VISIT, T0, editor="zzzz"), "robot"),
    ("unknown origin", remote("real_world.tour", VISIT, T0, origin="Mallory"), "robot"),
    ("version zero", remote("real_world.tour", VISIT, 0), "version"),
    ("version far future", remote("real_world.tour", VISIT, 2**64 - 1), "version"),
    ("bad language", remote("real_world.tour", VISIT, T0, language="klingon"), "language"),
    ("hostile room", remote("real_world.tour", ["0, ../../x, Lab"], T0), "content"),
    ("delete with bad name", remote("../real_world.tour", [], T0, deleted=True), "file_name"),
    ("delete from unknown robot", remote("real_world.tour", [], T0, editor="Mallory", deleted=True), "robot"),
]


@pytest.mark.parametrize("label, msg, reason", HOSTILE, ids=[h[0] for h in HOSTILE])
def test_hostile_remote_tours_are_rejected_and_touch_nothing(store, tmp_path, log, label, msg, reason) -> None:
    before = snapshot(tmp_path / "tours", hidden=True)
    outside = snapshot(tmp_path)
    out = store.receive(msg)
    assert (out.status, out.reason) == ("rejected", reason), out
    assert store.counters["rejected"] == 1 and store.counters[f"rejected_{reason}"] == 1
    assert "rejected tour message" in log.text("warning")
    assert snapshot(tmp_path / "tours", hidden=True) == before
    assert snapshot(tmp_path) == outside
    assert len(log.text()) < 20000               # a 10 MB value is never echoed into the log


def test_rejected_stale_and_duplicate_messages_write_nothing(store, monkeypatch) -> None:
    """Only an accepted record writes: a rejected, stale or duplicate one costs no write, not even a
    rewrite of the metadata with the same bytes (which a byte-for-byte comparison would not see)."""
    store.receive(remote("visit.tour", VISIT, T0 + 10))
    writes: list[str] = []
    for op in ("create", "replace", "remove", "write_atomic"):
        real = getattr(SafeDir, op)
        monkeypatch.setattr(SafeDir, op, lambda self, name, *a, _op=op, _real=real: (writes.append(f"{_op} {name}"),
                                                                                   _real(self, name, *a))[1])
    for _, msg, _ in HOSTILE:
        assert store.receive(msg).status == "rejected"
    assert store.receive(remote("visit.tour", VISIT, T0 + 5)).status == "stale"
    assert store.receive(remote("visit.tour", VISIT, T0 + 10, uid="Kbot/tour/dup")).status == "duplicate"
    assert store.peer_index("Kbot", [], 0.0) and not store.step()
    assert writes == []
    assert store.receive(remote("visit.tour", VISIT[:1], T0 + 20)).status == "accepted"
    assert writes == ["write_atomic .gidabot-tours.json", "replace visit.tour", "write_atomic .gidabot-tours.json"]


def test_rejection_logs_are_rate_limited(store, log, clock) -> None:
    for _ in range(50):
        store.receive(remote("real_world.tour", ["0, 014"], T0))
    assert log.text("warning").count("rejected tour message") == 10
    clock.advance(61)
    store.receive(remote("real_world.tour", ["0, 014"], T0))
    assert "40 more 'rejected_content' warning(s) suppressed" in log.text("warning")
    assert store.counters["rejected_content"] == 51


def test_tour_limit(faculty, tmp_path) -> None:
    s = open_store(tmp_path / "t", faculty, limits=StoreLimits(max_tours=2))
    assert s.receive(remote("a.tour", VISIT, T0)).status == "accepted"
    assert s.receive(remote("b.tour", VISIT, T0)).status == "accepted"
    assert s.receive(remote("c.tour", VISIT, T0)).reason == "limit"
    assert s.receive(remote("a.tour", VISIT[:1], T0 + 1)).status == "accepted"   # edits still apply
    s.close()


# ---------------------------------------------------------------- ownership
def test_stray_file_is_never_overwritten_and_the_tour_waits(store, tmp_path) -> None:
    d = tmp_path / "tours"
    (d / "visit.tour").write_bytes(b"placed by hand\n")
    out = store.receive(remote("visit.tour", VISIT, T0))
    assert out.status == "accepted" and out.record.blocked
    assert (d / "visit.tour").read_bytes() == b"placed by hand\n"
    assert "visit.tour" in [e.file_name for e in store.index()]          # known and shared
    assert "visit.tour" not in [r.file_name for r in store.catalog()]    # not in the directory
    assert store.step() is False and (d / "visit.tour").read_bytes() == b"placed by hand\n"
    # a remote delete does not remove the stray file either
    store.receive(remote("visit.tour", [], T0 + 1, deleted=True))
    assert (d / "visit.tour").read_bytes() == b"placed by hand\n"
    store.receive(remote("visit.tour", VISIT, T0 + 2))
    (d / "visit.tour").unlink()
    assert store.step() is True
    assert (d / "visit.tour").read_bytes() == VISIT_TEXT


@pytest.mark.parametrize("kind", ["dir", "symlink", "dangling symlink", "fifo"])
def test_directories_symlinks_fifos_are_never_written(store, tmp_path, kind) -> None:
    d = tmp_path / "tours"
    target = tmp_path / "outside.tour"
    target.write_bytes(b"outside\n")
    if kind == "dir":
        (d / "visit.tour").mkdir()
    elif kind == "symlink":
        (d / "visit.tour").symlink_to(target)
    elif kind == "dangling symlink":
        (d / "visit.tour").symlink_to(tmp_path / "nowhere.tour")
    else:
        os.mkfifo(d / "visit.tour")
    before = snapshot(d)
    assert store.receive(remote("visit.tour", VISIT, T0)).record.blocked
    assert store.receive(remote("visit.tour", [], T0 + 1, deleted=True)).status == "accepted"
    assert snapshot(d) == before
    assert target.read_bytes() == b"outside\n" and not (tmp_path / "nowhere.tour").exists()


def test_seeded_file_replaced_through_symlink_is_not_followed(store, tmp_path) -> None:
    d = tmp_path / "tours"
    target = tmp_path / "secret"
    target.write_bytes(b"secret\n")
    (d / "real_world.tour").unlink()
    (d / "real_world.tour").symlink_to(target)
    out = store.receive(remote("real_world.tour", VISIT, T0))
    assert out.record.blocked and target.read_bytes() == b"secret\n"
    assert (d / "real_world.tour").is_symlink()


def test_file_changed_by_hand_while_running_is_not_replaced(store, tmp_path, log) -> None:
    d = tmp_path / "tours"
    (d / "real_world.tour").write_bytes(b"Tour\n0, 014, My own edit\n")
    assert store.receive(remote("real_world.tour", VISIT, T0)).record.blocked
    assert (d / "real_world.tour").read_bytes() == b"Tour\n0, 014, My own edit\n"
    assert "real_world.tour (version" in log.text("warning") and "is blocked" in log.text("warning")


# ---------------------------------------------------------------- restart, crash recovery
class Crash(BaseException):
    """Stands for the process dying in the middle of a write."""


def reopen(store: TourStore, faculty, clock, log=None) -> TourStore:
    store.close()
    return open_store(store.directory, faculty, clock=clock, log=log, seed_dir=TOURS)


@pytest.mark.parametrize("op", ["create", "replace", "remove"])
def test_crash_between_metadata_and_file_is_finished_at_restart(store, tmp_path, faculty, clock, monkeypatch,
                                                               op) -> None:
    d = tmp_path / "tours"
    store.edit(tour_msg("visit.tour", VISIT))
    edits = {"create": tour_msg("new.tour", VISIT[:1]), "replace": tour_msg("visit.tour", VISIT[:1]),
             "remove": tour_msg("visit.tour", [], deleted=True)}
    name = edits[op].file_name
    old_file = (d / name).read_bytes() if (d / name).exists() else None

    def die(*_a, **_k):
        raise Crash

    with monkeypatch.context() as m:
        m.setattr(SafeDir, op, die)
        with pytest.raises(Crash):
            store.edit(edits[op])
    assert ((d / name).read_bytes() if (d / name).exists() else None) == old_file   # file not yet changed
    clock.advance(1)
    again = reopen(store, faculty, clock)
    if op == "remove":
        assert not (d / name).exists() and again.get(name).deleted
    else:
        assert (d / name).read_bytes() == b"Tour\n0, 014, Computer Technicians 1\n"
        assert again.get(name).materialised and again.get(name).editor == "Galtxagorri"
    again.close()


def test_crash_after_temp_write_leaves_old_file_and_temp_is_cleaned(store, tmp_path, faculty, clock,
                                                                   monkeypatch) -> None:
    d = tmp_path / "tours"
    before = (d / "real_world.tour").read_bytes()

    def die(*_a, **_k):
        raise Crash

    with monkeypatch.context() as m:
        m.setattr(os, "rename", die)
        with pytest.raises(Crash):
            store.edit(tour_msg("real_world.tour", VISIT))     # dies writing the metadata
    assert (d / "real_world.tour").read_bytes() == before
    (d / ".gidabot-tmp-0123456789abcdef").write_bytes(b"half a tour")   # what a killed process leaves
    again = reopen(store, faculty, clock)
    assert not any(n.startswith(".gidabot-tmp-") for n in os.listdir(d))
    assert (d / "real_world.tour").read_bytes() == before and again.get("real_world.tour").version == SEED_VERSION
    again.close()


def test_hand_edit_while_stopped_is_adopted_and_hand_delete_is_restored(store, tmp_path, faculty, clock,
                                                                        log) -> None:
    d = tmp_path / "tours"
    store.close()
    (d / "real_world.tour").write_bytes(b"Tour\n0, 008, Caretakers\n")
    (d / "long_tour.tour").unlink()
    (d / "paper_example.tour").write_bytes(b"Tour\n0, 999, broken by hand\n")
    clock.advance(100)
    again = open_store(d, faculty, clock=clock, log=log, seed_dir=TOURS)
    rec = again.get("real_world.tour")
    assert (rec.editor, rec.version, rec.content) == ("Galtxagorri", clock.ns, "Tour\n0, 008, Caretakers\n")
    assert (d / "long_tour.tour").read_bytes() == (TOURS / "long_tour.tour").read_bytes()
    assert (d / "paper_example.tour").read_bytes() == b"Tour\n0, 999, broken by hand\n"   # not destroyed
    assert again.get("paper_example.tour").blocked
    assert "was missing" in log.text("warning") and "unknown room '999'" in log.text("warning")
    again.close()


def test_corrupt_metadata_is_moved_aside_and_tours_kept(store, tmp_path, faculty, clock, log) -> None:
    d = tmp_path / "tours"
    store.edit(tour_msg("visit.tour", VISIT))
    files = snapshot(d)
    store.close()
    (d / META_NAME).write_bytes(b'{"format": "gidabot-tour-store/1", "tou')
    again = open_store(d, faculty, clock=clock, log=log, seed_dir=TOURS)
    assert snapshot(d) == files
    assert sorted(r.file_name for r in again.catalog()) == sorted(files)
    assert any(n.startswith(META_NAME + ".corrupt-") for n in os.listdir(d))
    again.close()


def test_tombstones_are_pruned_after_the_ttl(faculty, tmp_path, clock) -> None:
    s = open_store(tmp_path / "t", faculty, clock=clock, seed_dir=TOURS, limits=StoreLimits(tombstone_ttl_ns=10 * NS))
    s.edit(tour_msg("long_tour.tour", [], deleted=True))
    clock.advance(5)
    assert s.step() is False and s.get("long_tour.tour").deleted
    clock.advance(6)
    assert s.step() is True and s.get("long_tour.tour") is None
    s.close()


# ---------------------------------------------------------------- anti-entropy
def test_peer_index_resends_what_the_peer_lacks(store) -> None:
    store.edit(tour_msg("visit.tour", VISIT))
    peer = [IndexEntry("long_tour.tour", SEED_VERSION, "", False),
            IndexEntry("paper_example.tour", T0 + 99, "Kbot", False),       # newer there: theirs to send
            IndexEntry("real_world.tour", SEED_VERSION, "", False)]
    out = store.peer_index("Kbot", peer, now=100.0)
    assert [m.file_name for m in out] == ["visit.tour"]
    assert store.peer_index("Kbot", peer, now=101.0) == []                 # not again within resend_period
    assert [m.file_name for m in store.peer_index("Kbot", peer, now=102.5)] == ["visit.tour"]
    assert [m.file_name for m in store.peer_index("Tartalo", [], now=102.5)] == [
        "long_tour.tour", "paper_example.tour", "real_world.tour", "visit.tour"]
    assert store.peer_index("Galtxagorri", [], now=1.0) == []             # ourselves
    assert store.peer_index("Mallory", [], now=1.0) == []
    assert store.counters["rejected_robot"] == 1


def test_index_arrays_must_match() -> None:
    assert index_entries(["a.tour"], [3], ["Kbot"], [False]) == [IndexEntry("a.tour", 3, "Kbot", False)]
    with pytest.raises(ValueError, match="different lengths"):
        index_entries(["a.tour", "b.tour"], [3], ["Kbot"], [False])


def test_unknown_robot_or_language_at_construction(faculty, tmp_path) -> None:
    with pytest.raises(TourStoreError, match="robot 'R2D2' is not in building faculty"):
        TourStore(tmp_path, faculty, "R2D2", wall_ns=FakeClock(), log=ListLog())
    with pytest.raises(TourStoreError, match="default language 'fr'"):
        TourStore(tmp_path, faculty, "Kbot", wall_ns=FakeClock(), log=ListLog(), default_language="fr")


def test_lone_surrogates_are_rejected(store) -> None:
    out = store.receive(remote("real_world.tour", ["0, 014, L\udcffab"], T0))
    assert (out.status, out.reason) == ("rejected", "encoding")
    out = store.receive(remote("real_world.tour", VISIT, T0, name="\udcff"))
    assert (out.status, out.reason) == ("rejected", "encoding")
