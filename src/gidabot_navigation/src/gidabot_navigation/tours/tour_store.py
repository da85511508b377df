"""The tour store and tour sharing (ROS-free core of the ``tour_store`` node).

A robot's tours live as files in the paper's format (section 5.2) in one local
directory. :class:`TourStore` is the only writer of that directory: the admin
actions of the GUI (create, edit, delete) and tours arriving from other robots
all go through it. The full description (sharing rule, metadata, ownership,
safety rules) is in ``docs/tours.md``; in short:

- **Versions.** Every tour name has one record ``(version, editor_robot)``:
  ``version`` is the wall-clock time (ns since the epoch) of the edit on the
  editing robot, made strictly larger than any version the editor knew for that
  name. Records are ordered by :attr:`TourRecord.key` ``(version, editor_robot,
  sha256, language)``; the larger record wins everywhere (last writer wins). A
  deletion is a *tombstone* record, so an older copy cannot resurrect a deleted
  tour; tombstones are pruned after ``StoreLimits.tombstone_ttl_ns`` (30 days).
- **Metadata** (versions, editors, origins, tombstones, canonical content and
  its hash, and which file on disk the store owns) is one JSON file in the
  directory, ``.gidabot-tours.json``, always replaced atomically; it is the
  commit point of every change (see :meth:`TourStore._apply`).
- **Ownership.** The store replaces or deletes a file only if it is a regular
  file whose content hash is the one the store last wrote there. New files are
  created with ``link`` (never replacing anything). A hand-placed file, a
  directory, a symlink, a FIFO with a tour's name are never touched: the tour
  is then *blocked* (kept in the metadata, shared, but not in the directory)
  until the name is free.
- **Remote input** is validated exactly like a local file
  (:func:`~gidabot_navigation.tours.tour_file.check_tour_file_name`,
  :func:`~gidabot_navigation.tours.tour_file.parse_tour` against the building) plus the
  message fields (version, robots, floor, language, sizes); a rejected message
  is logged with its reason, counted, and touches nothing.
- **Sharing.** :meth:`TourStore.edit` returns the record to publish;
  :meth:`TourStore.receive` applies records of other robots;
  :meth:`TourStore.peer_index` compares a peer's :class:`IndexEntry` list with
  ours and returns the records the peer lacks or holds in an older version
  (anti-entropy), so a robot that was offline catches up.
"""

from __future__ import annotations

import errno
import fcntl
import json
import math
import os
import unicodedata
from collections import Counter, OrderedDict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

from gidabot_navigation.building.model import Building, format_floor
from gidabot_navigation.errors import TourError, TourNameError, TourRejected, TourStoreError
from gidabot_navigation.interface import DEFAULT_LANGUAGE, LANGUAGES
from gidabot_navigation.logs import Logger, RateLimitedLog
from gidabot_navigation.tours.safe_dir import Entry, SafeDir, sha256
from gidabot_navigation.tours.tour_file import (
    MAX_GOALS,
    MAX_NAME,
    MAX_TOUR_BYTES,
    TOUR_SUFFIX,
    Tour,
    check_tour_file_name,
    format_tour,
    parse_tour,
    tour_from_lines,
)

META_NAME = ".gidabot-tours.json"
LOCK_NAME = ".gidabot-tours.lock"
META_FORMAT = "gidabot-tour-store/1"
SEED_VERSION = 1                # version of the initial tours (editor ""): older than any edit
FLOOR_TOLERANCE = 1e-3
NS = 1_000_000_000


@dataclass(frozen=True)
class StoreLimits:
    """Bounds on what the store accepts (all overridable by ~params of the node)."""

    max_message_bytes: int = 256 * 1024        # a Tour message body; a tour file is at most 64 KiB
    max_tours: int = 500                       # records (tours + tombstones) per directory
    max_index_entries: int = 2000              # entries of a peer's TourIndex
    max_future_ns: int = 24 * 3600 * NS        # a remote version may be at most this far ahead of our clock
    tombstone_ttl_ns: int = 30 * 24 * 3600 * NS  # tombstones older than this are pruned
    resend_period: float = 2.0                 # s between re-sends of one record to one peer
    seen_uids: int = 10000                     # event uids remembered for de-duplication


@dataclass(frozen=True)
class TourMessage:
    """A ``gidabot_msgs/Tour`` (:mod:`gidabot_navigation.ros.convert` converts it); ``stamp``: s, when it was sent."""

    uid: str = ""
    origin_robot: str = ""
    editor_robot: str = ""
    version: int = 0
    deleted: bool = False
    language: str = ""
    floor: float = 0.0
    tour_name: str = ""
    file_name: str = ""
    tour_goals_info: tuple[str, ...] = ()
    stamp: float = 0.0


@dataclass(frozen=True)
class IndexEntry:
    """One element of ``gidabot_msgs/TourIndex``."""

    file_name: str
    version: int
    editor_robot: str
    deleted: bool


@dataclass(frozen=True)
class TourIndexData:
    """A ``gidabot_msgs/TourIndex``: every record ``robot`` holds (tours and tombstones), with versions."""

    robot: str
    entries: tuple[IndexEntry, ...] = ()
    stamp: float = 0.0


@dataclass(frozen=True)
class CatalogData:
    """A ``gidabot_msgs/TourCatalog``: the tours in ``robot``'s directory, sorted by file name."""

    robot: str
    tours: tuple[TourMessage, ...] = ()
    stamp: float = 0.0


@dataclass(frozen=True)
class EditResultData:
    """A ``gidabot_msgs/TourEditResult``: the outcome of one admin action (``reason``: a TourRejected reason,
    ``oversized``, ``encoding`` or ``io`` when refused)."""

    uid: str
    file_name: str
    deleted: bool
    ok: bool
    version: int = 0
    reason: str = ""
    error: str = ""
    stamp: float = 0.0


@dataclass(frozen=True)
class TourRecord:
    """The newest known version of one tour name (a tour or a tombstone)."""

    file_name: str
    version: int
    editor: str                   # robot that wrote this version ("" = seed)
    origin: str                   # robot where the tour was created ("" = seed)
    deleted: bool
    language: str
    content: str                  # canonical file content ("" for a tombstone)
    sha256: str                   # hash of content as UTF-8 ("" for a tombstone)
    disk: str = ""                # hash of the file the store owns at file_name ("" = none)
    tour: Tour | None = field(default=None, compare=False, repr=False)

    @property
    def key(self) -> tuple[int, str, str, str]:
        """Total order of versions: the larger key wins everywhere."""
        return (self.version, self.editor, self.sha256, self.language)

    @property
    def materialised(self) -> bool:
        """A live tour whose file in the directory is the store's copy of this version."""
        return not self.deleted and self.disk == self.sha256

    @property
    def blocked(self) -> bool:
        return not self.deleted and self.disk != self.sha256

    def index_entry(self) -> IndexEntry:
        return IndexEntry(self.file_name, self.version, self.editor, self.deleted)

    def message(self, uid: str) -> TourMessage:
        tour = self.tour
        return TourMessage(uid=uid, origin_robot=self.origin, editor_robot=self.editor, version=self.version,
                           deleted=self.deleted, language=self.language,
                           floor=tour.floor if tour else 0.0,
                           tour_name=tour.display_name if tour else "",
                           file_name=self.file_name,
                           tour_goals_info=tuple(tour.goal_lines()) if tour else ())

    def to_json(self) -> dict:
        return {"version": self.version, "editor": self.editor, "origin": self.origin, "deleted": self.deleted,
                "language": self.language, "content": self.content, "sha256": self.sha256, "disk": self.disk}


@dataclass(frozen=True)
class Outcome:
    """What :meth:`TourStore.receive` did with a message."""

    status: str                   # "accepted", "duplicate", "stale" or "rejected"
    reason: str = ""              # rejection category (counter name) or note
    message: str = ""             # human-readable explanation
    record: TourRecord | None = None

    @property
    def changed(self) -> bool:
        return self.status == "accepted"


def _has_control(text: str) -> bool:
    return any(unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp") for ch in text)


def _encodable(text: str) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _short(value: object, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def message_size(msg: TourMessage) -> int:
    """Approximate body size of a Tour message in bytes (string lengths), computed before any parsing."""
    strings = (msg.uid, msg.origin_robot, msg.editor_robot, msg.language, msg.tour_name, msg.file_name)
    total = sum(len(s) for s in strings if isinstance(s, str)) + 64
    goals = msg.tour_goals_info if isinstance(msg.tour_goals_info, (list, tuple)) else ()
    return total + sum(len(g) + 4 if isinstance(g, str) else 4 for g in goals)


def make_record(file_name: str, version: int, editor: str, origin: str, language: str,
                tour: Tour | None) -> TourRecord:
    if tour is None:
        return TourRecord(file_name, version, editor, origin, True, language, "", "")
    content = format_tour(tour)
    return TourRecord(file_name, version, editor, origin, False, language, content,
                      sha256(content.encode("utf-8")), tour=tour)


class TourStore:
    """One robot's tour directory plus the sharing rule; see the module docstring.

    ``wall_ns`` is the wall clock in ns (versions); ``log`` has info/warning/error.
    Not thread-safe: the node calls it from one thread.
    """

    def __init__(self, directory: str | os.PathLike[str], building: Building, robot: str, *,
                 wall_ns: Callable[[], int], log: Logger, seed_dir: str | os.PathLike[str] | None = None,
                 default_language: str = DEFAULT_LANGUAGE, limits: StoreLimits | None = None) -> None:
        if building.find_robot(robot) is None:
            raise TourStoreError(f"robot {robot!r} is not in building {building.id} "
                                 f"({', '.join(r.name for r in building.robots)})")
        if default_language not in LANGUAGES:
            raise TourStoreError(f"default language {default_language!r} is not one of {', '.join(LANGUAGES)}")
        self.directory = Path(directory)
        self.building = building
        self.robot = robot
        self.robots = frozenset(r.name for r in building.robots)
        self.wall_ns = wall_ns
        self.log = log
        self.seed_dir = Path(seed_dir) if seed_dir else None
        self.default_language = default_language
        self.limits = limits or StoreLimits()
        self.counters: Counter[str] = Counter()
        self.records: dict[str, TourRecord] = {}
        self.last_rejection = ""
        self._warn = RateLimitedLog(log, lambda: wall_ns() / NS)
        self._seen: OrderedDict[str, None] = OrderedDict()
        self._sent: dict[tuple[str, str], tuple[tuple, float]] = {}
        self.peers: dict[str, list[IndexEntry]] = {}
        self._boot = wall_ns()
        self._seq = 0
        self._dir: SafeDir | None = None
        self._lock_fd = -1
        self._read_limit = MAX_TOUR_BYTES

    # ------------------------------------------------------------------ lifecycle
    def open(self) -> TourStore:
        """Lock the directory, load the metadata, recover from a crash, seed or adopt files."""
        self._dir = SafeDir(self.directory)
        try:
            self._lock()
            for name in self._dir.clean_temps():
                self.log.info(f"removed temporary file {name} left by an interrupted write")
            had_meta = self._load_meta()
            if not had_meta and not any(self._tour_like(n) for n in self._dir.names()):
                self._seed()
            self._reconcile()
            self._save()
        except BaseException:
            self.close()
            raise
        live = sum(1 for r in self.records.values() if not r.deleted)
        self.log.info(f"tour store of {self.robot} in {self.directory}: {live} tour(s), "
                      f"{len(self.records) - live} tombstone(s), {len(self.blocked())} blocked")
        return self

    def close(self) -> None:
        if self._dir is not None:
            self._dir.close()
            self._dir = None
        if self._lock_fd >= 0:
            os.close(self._lock_fd)
            self._lock_fd = -1

    def __enter__(self) -> TourStore:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def dir(self) -> SafeDir:
        if self._dir is None:
            raise TourStoreError(f"tour store {self.directory} is not open")
        return self._dir

    def _lock(self) -> None:
        try:
            self._lock_fd = os.open(LOCK_NAME, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_CLOEXEC, 0o644,
                                    dir_fd=self.dir.fd)
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as err:
            if err.errno in (errno.EWOULDBLOCK, errno.EAGAIN):
                raise TourStoreError(f"another tour store is using {self.directory}") from err
            raise TourStoreError(f"cannot lock {self.directory / LOCK_NAME}: {err.strerror}") from err

    @staticmethod
    def _tour_like(name: str) -> bool:
        return not name.startswith(".") and name.endswith(TOUR_SUFFIX)

    # ------------------------------------------------------------------ metadata
    def _load_meta(self) -> bool:
        entry = self.dir.lookup(META_NAME, 1 << 30)
        if entry.kind == "absent":
            return False
        doc: object = None
        if entry.is_file and entry.data is not None:
            try:
                doc = json.loads(entry.data.decode("utf-8"))
            except (UnicodeDecodeError, ValueError) as err:
                self.log.error(f"{self.directory / META_NAME} is unreadable ({err})")
        if not isinstance(doc, dict) or doc.get("format") != META_FORMAT or not isinstance(doc.get("tours"), dict):
            aside = f"{META_NAME}.corrupt-{self.wall_ns()}"
            if entry.is_file:
                os.rename(META_NAME, aside, src_dir_fd=self.dir.fd, dst_dir_fd=self.dir.fd)
                self.log.error(f"metadata {META_NAME} is not a {META_FORMAT} file; moved it to {aside} and "
                               "adopt the tour files in the directory as new local versions")
                return True
            raise TourStoreError(f"{self.directory / META_NAME} is a {entry.kind}, not the store's metadata file")
        for name, data in doc["tours"].items():
            try:
                self.records[name] = self._record_from_json(name, data)
            except (TourNameError, TourError, KeyError, TypeError, ValueError) as err:
                self.log.error(f"metadata entry {_short(name)} is invalid and was dropped: {err}")
        return True

    def _record_from_json(self, name: str, data: dict) -> TourRecord:
        check_tour_file_name(name)
        version, editor, origin = int(data["version"]), str(data["editor"]), str(data["origin"])
        deleted, language, content = bool(data["deleted"]), str(data["language"]), str(data["content"])
        tour = None if deleted else parse_tour(content, name)
        rec = make_record(name, version, editor, origin, language, tour)
        if rec.sha256 != data["sha256"]:
            raise ValueError(f"content hash {data['sha256']!r} does not match the content")
        disk = str(data["disk"])
        return replace(rec, disk=disk)

    def _save(self) -> None:
        doc = {"format": META_FORMAT, "robot": self.robot,
               "tours": {name: rec.to_json() for name, rec in sorted(self.records.items())}}
        data = json.dumps(doc, ensure_ascii=False, indent=1).encode("utf-8")
        try:
            self.dir.write_atomic(META_NAME, data)
        except OSError as err:
            raise TourStoreError(f"cannot write {self.directory / META_NAME}: {err.strerror or err}") from err

    # ------------------------------------------------------------------ applying records
    def _apply(self, rec: TourRecord, claim: str | None = None) -> TourRecord:
        """Make ``rec`` the record of its name: commit to the metadata, then change the file.

        Two-phase: the metadata is saved first with the old ``disk`` (the file still on
        disk), the file is then created/replaced/removed, and the metadata saved again
        with the new ``disk``. A crash between leaves a file whose hash is either the
        old ``disk`` or the new content, both recognised as the store's own by
        :meth:`_reconcile`. ``claim`` adopts the file currently on disk (its hash).
        On a metadata write error nothing changes and :class:`TourStoreError` is raised.
        """
        old = self.records.get(rec.file_name)
        disk = claim if claim is not None else (old.disk if old else "")
        pending = replace(rec, disk=disk)
        self.records[rec.file_name] = pending
        try:
            self._save()
        except TourStoreError:
            if old is None:
                del self.records[rec.file_name]
            else:
                self.records[rec.file_name] = old
            raise
        done = self._materialise(pending)
        if done.disk != pending.disk:
            self.records[rec.file_name] = done
            try:
                self._save()
            except TourStoreError as err:
                # the file is right; the metadata will say so after the next save or restart
                self.log.error(str(err))
        return done

    def _materialise(self, rec: TourRecord) -> TourRecord:
        """Bring the file of ``rec`` in line with it if the store owns the name; return the new record."""
        name = rec.file_name
        entry = self.dir.lookup(name, self._read_limit)
        owned = entry.is_file and bool(rec.disk) and entry.sha256 == rec.disk
        try:
            if rec.deleted:
                if owned:
                    self.dir.remove(name, rec.disk, self._read_limit)
                    return replace(rec, disk="")
                if rec.disk and entry.kind != "absent":
                    self._warn.warning("not_owned", f"deleted tour {name} left in place: the file there is not "
                                                    "the store's copy (changed by hand?)")
                return replace(rec, disk="") if rec.disk else rec
            data = rec.content.encode("utf-8")
            if entry.is_file and entry.sha256 == rec.sha256:
                return replace(rec, disk=rec.sha256)
            if entry.kind == "absent":
                self.dir.create(name, data)
                return replace(rec, disk=rec.sha256)
            if owned:
                self.dir.replace(name, data, rec.disk, self._read_limit)
                return replace(rec, disk=rec.sha256)
        except FileExistsError:
            entry = self.dir.lookup(name, self._read_limit)
        except PermissionError:
            entry = self.dir.lookup(name, self._read_limit)
        except OSError as err:
            self.counters["io_errors"] += 1
            self.log.error(f"cannot write tour {name} in {self.directory}: {err.strerror or err}; will retry")
            return rec
        self.counters["blocked_writes"] += 1
        self._warn.warning("blocked", f"tour {name} (version {rec.version} by {rec.editor or 'seed'}) is blocked: "
                                      f"a {entry.kind} the store does not own has that name in {self.directory}; "
                                      "it is kept and shared, and written once the name is free")
        return replace(rec, disk="")

    def _reconcile(self) -> None:
        """At start: finish interrupted writes, restore the store's files, adopt new or hand-edited ones."""
        for name in sorted(self.records):
            rec = self.records[name]
            entry = self.dir.lookup(name, self._read_limit)
            if not rec.deleted and rec.disk and entry.is_file and entry.sha256 not in (rec.disk, rec.sha256):
                # the store's file was changed by hand while the store was stopped
                if self._adopt(name, entry, "edited by hand"):
                    continue
                self.records[name] = replace(rec, disk="")
                continue
            if not rec.deleted and rec.disk and entry.kind == "absent":
                self.log.warning(f"tour {name} was missing from {self.directory} and is restored "
                                 "(delete tours from the admin GUI)")
            self.records[name] = self._materialise(rec)
        for name in self.dir.names():
            if name.startswith("."):
                continue
            rec = self.records.get(name)
            if rec is not None and not rec.deleted:
                continue
            entry = self.dir.lookup(name, self._read_limit)
            if not entry.is_file:
                self.log.warning(f"ignoring {name} in {self.directory}: a {entry.kind}, not a tour file")
                continue
            self._adopt(name, entry, "found in the directory")

    def _adopt(self, name: str, entry: Entry, why: str) -> bool:
        """Take over a valid tour file found on disk as a new local version; False if invalid."""
        try:
            check_tour_file_name(name)
            if entry.data is None:
                raise TourError([])
            tour = parse_tour(entry.data, name, self.building, source=str(self.directory / name))
        except TourNameError as err:
            self.log.warning(f"ignoring {name} in {self.directory}: {err}")
            return False
        except TourError as err:
            self.counters["ignored_files"] += 1
            detail = str(err) if err.problems else f"larger than {self._read_limit} bytes"
            self.log.warning(f"ignoring tour file {name} ({why}), left untouched: {detail}")
            return False
        old = self.records.get(name)
        if old is not None and not old.deleted and format_tour(tour) == old.content:
            # the same tour written differently (line endings, spacing, BOM): no new version, the
            # store's canonical file replaces it
            self._apply(old, claim=entry.sha256)
            self.log.info(f"tour file {name} ({why}) holds the stored tour in another form; rewritten in the "
                          "canonical form")
            return True
        version = max(self.wall_ns(), old.version + 1 if old else 0)
        origin = old.origin if old and not old.deleted else self.robot
        language = old.language if old and not old.deleted else self.default_language
        rec = make_record(name, version, self.robot, origin, language, tour)
        self._apply(rec, claim=entry.sha256)
        self.counters["adopted"] += 1
        self.log.info(f"adopted tour file {name} ({why}) as version {version} of {self.robot}")
        return True

    def _seed(self) -> None:
        if self.seed_dir is None:
            return
        if not self.seed_dir.is_dir():
            self.log.warning(f"seed directory {self.seed_dir} does not exist; starting with no tours")
            return
        for path in sorted(self.seed_dir.glob(f"*{TOUR_SUFFIX}")):
            try:
                check_tour_file_name(path.name)
                data = path.read_bytes()
                tour = parse_tour(data, path.name, self.building, source=str(path))
            except (TourNameError, TourError, OSError) as err:
                self.log.warning(f"initial tour {path} skipped: {err}")
                continue
            self._apply(make_record(path.name, SEED_VERSION, "", "", self.default_language, tour))
            self.counters["seeded"] += 1
        self.log.info(f"seeded {self.counters['seeded']} initial tour(s) from {self.seed_dir}")

    # ------------------------------------------------------------------ queries
    def catalog(self) -> list[TourRecord]:
        """The tours in the directory (live and materialised), sorted by file name."""
        return [r for _, r in sorted(self.records.items()) if r.materialised]

    def index(self) -> list[IndexEntry]:
        return [r.index_entry() for _, r in sorted(self.records.items())]

    def blocked(self) -> list[TourRecord]:
        return [r for _, r in sorted(self.records.items()) if r.blocked]

    def get(self, file_name: str) -> TourRecord | None:
        return self.records.get(file_name)

    # ------------------------------------------------------------------ validation
    def validate(self, msg: TourMessage, *, remote: bool) -> TourRecord:
        """The record ``msg`` describes, or :class:`TourRejected`; checks cheap things first."""
        size = message_size(msg)
        if size > self.limits.max_message_bytes:
            raise TourRejected("oversized", f"tour message of about {size} bytes is larger than the "
                                            f"{self.limits.max_message_bytes} bytes allowed")
        for attr in ("uid", "origin_robot", "editor_robot", "language", "tour_name", "file_name"):
            value = getattr(msg, attr)
            if not isinstance(value, str):
                raise TourRejected("field", f"{attr} must be a string, got {_short(value)}")
            if not _encodable(value):
                raise TourRejected("encoding", f"{attr} {_short(value)} is not valid UTF-8 text")
        try:
            name = check_tour_file_name(msg.file_name)
        except TourNameError as err:
            raise TourRejected("file_name", str(err)) from err
        if not isinstance(msg.floor, (int, float)) or not math.isfinite(msg.floor):
            raise TourRejected("floor", f"tour {name}: floor {_short(msg.floor)} is not a finite number")
        if remote:
            version = msg.version
            if not isinstance(version, int) or version < SEED_VERSION:
                raise TourRejected("version", f"tour {name}: version {_short(version)} must be a positive integer")
            horizon = self.wall_ns() + self.limits.max_future_ns
            if version > horizon:
                raise TourRejected("version", f"tour {name}: version {version} is more than "
                                              f"{self.limits.max_future_ns / NS:g} s ahead of this robot's clock")
            if msg.editor_robot not in self.robots and not (msg.editor_robot == "" and version == SEED_VERSION):
                raise TourRejected("robot", f"tour {name}: editor_robot {_short(msg.editor_robot)} is not a robot of "
                                            f"building {self.building.id}")
            if msg.origin_robot not in self.robots and msg.origin_robot != "":
                raise TourRejected("robot", f"tour {name}: origin_robot {_short(msg.origin_robot)} is not a robot of "
                                            f"building {self.building.id}")
        language = msg.language if remote else (msg.language or self.default_language)
        if language not in LANGUAGES and not (remote and msg.deleted and language == ""):
            raise TourRejected("language", f"tour {name}: language {_short(msg.language)} is not one of "
                                           f"{', '.join(LANGUAGES)}")
        if msg.deleted:
            return make_record(name, msg.version, msg.editor_robot, msg.origin_robot, language, None)
        title = msg.tour_name.strip()
        if _has_control(title):
            raise TourRejected("name", f"tour {name}: tour name {_short(title)} contains control characters")
        if len(title) > MAX_NAME:
            raise TourRejected("name", f"tour {name}: tour name is {len(title)} characters; at most {MAX_NAME}")
        goals = msg.tour_goals_info
        if not isinstance(goals, (list, tuple)) or not all(isinstance(g, str) for g in goals):
            raise TourRejected("field", f"tour {name}: tour_goals_info must be a list of strings")
        if len(goals) > MAX_GOALS:
            raise TourRejected("content", f"tour {name}: {len(goals)} goals; a tour may have at most {MAX_GOALS}")
        for i, line in enumerate(goals, start=1):
            if not _encodable(line):
                raise TourRejected("encoding", f"tour {name}: goal {i} {_short(line)} is not valid UTF-8 text")
        try:
            tour = tour_from_lines(name, title, list(goals), self.building)
        except TourError as err:
            details = "; ".join(f"{p.where}: {p.message}" for p in err.problems)
            raise TourRejected("content", f"tour {name}: {details}") from err
        if remote and abs(msg.floor - tour.floor) > FLOOR_TOLERANCE:
            raise TourRejected("floor", f"tour {name}: floor {msg.floor:g} is not the floor of its first goal "
                                        f"({format_floor(tour.floor)})")
        return make_record(name, msg.version, msg.editor_robot, msg.origin_robot, language, tour)

    # ------------------------------------------------------------------ local admin actions
    def edit(self, msg: TourMessage) -> TourRecord:
        """Create, edit or (``deleted``) delete a tour from the admin GUI; return the record to share.

        Raises :class:`TourRejected` (invalid, in the way, unknown, limit) or
        :class:`TourStoreError` (cannot write); nothing changes then.
        """
        try:
            candidate = self.validate(msg, remote=False)
        except TourRejected as err:
            self.counters["rejected_edit"] += 1         # an admin edit refused (a local message)
            self.last_rejection = str(err)
            raise
        name = candidate.file_name
        old = self.records.get(name)
        version = max(self.wall_ns(), old.version + 1 if old else SEED_VERSION + 1)
        if candidate.deleted:
            if old is None or old.deleted:
                raise TourRejected("unknown", f"there is no tour {name} to delete")
            rec = make_record(name, version, self.robot, old.origin, old.language, None)
        else:
            if old is None and len(self.records) >= self.limits.max_tours:
                raise TourRejected("limit", f"the store holds {len(self.records)} tours; at most "
                                            f"{self.limits.max_tours}")
            if old is None or old.deleted or old.blocked:
                entry = self.dir.lookup(name, self._read_limit)
                ours = entry.is_file and entry.sha256 in ((old.disk if old else "") or "-", candidate.sha256)
                if entry.kind != "absent" and not ours:
                    raise TourRejected("in_the_way", f"{name} already exists in {self.directory} as a "
                                                     f"{entry.kind} the tour store does not manage")
            origin = old.origin if old is not None and not old.deleted else self.robot
            rec = replace(candidate, version=version, editor=self.robot, origin=origin)
        done = self._apply(rec)
        self.counters["local_deletes" if rec.deleted else "local_edits"] += 1
        self.log.info(f"{'deleted' if rec.deleted else 'saved'} tour {name} (version {version})")
        return done

    def admin_edit(self, msg: TourMessage) -> tuple[EditResultData, TourMessage | None]:
        """Carry out an admin action (:meth:`edit`): the result to answer the GUI with, and the message that
        shares the new record with the other robots (None when the action was refused, which is logged)."""
        what = "delete" if msg.deleted else "edit"
        try:
            rec = self.edit(msg)
        except TourRejected as err:
            self.log.warning(f"admin {what} of tour {_short(msg.file_name)} refused: {err}")
            return edit_result(msg, None, err.reason, str(err)), None
        except TourStoreError as err:
            self.log.error(f"admin {what} of tour {_short(msg.file_name)} failed: {err}")
            return edit_result(msg, None, "io", str(err)), None
        return edit_result(msg, rec, "", ""), self.outgoing(rec)

    def catalog_data(self) -> CatalogData:
        """The tours of the directory, for the GUI and tour mode."""
        return CatalogData(self.robot, tuple(rec.message("") for rec in self.catalog()))

    def index_data(self) -> TourIndexData:
        """Every record held, for the other robots' anti-entropy."""
        return TourIndexData(self.robot, tuple(self.index()))

    # ------------------------------------------------------------------ remote records
    def next_uid(self) -> str:
        self._seq += 1
        uid = f"{self.robot}/tour/{self._boot}.{self._seq}"
        self._remember(uid)
        return uid

    def outgoing(self, rec: TourRecord) -> TourMessage:
        """The message that shares ``rec`` (fresh uid)."""
        self.counters["published"] += 1
        return rec.message(self.next_uid())

    def _remember(self, uid: str) -> bool:
        """Remember ``uid``; False if it was already seen."""
        if uid in self._seen:
            self._seen.move_to_end(uid)
            return False
        self._seen[uid] = None
        while len(self._seen) > self.limits.seen_uids:
            self._seen.popitem(last=False)
        return True

    def reject(self, reason: str, text: str) -> Outcome:
        """Count and log a rejected remote message (also used by the node for undecodable messages)."""
        self.counters["rejected"] += 1
        self.counters[f"rejected_{reason}"] += 1
        self.last_rejection = text
        self._warn.warning(f"rejected_{reason}", f"rejected tour message: {text}")
        return Outcome("rejected", reason, text)

    def receive(self, msg: TourMessage) -> Outcome:
        """Apply a tour message from another robot (or our own echo) if valid and newer."""
        self.counters["received"] += 1
        if isinstance(msg.uid, str) and msg.uid and not self._remember(msg.uid):
            self.counters["duplicate"] += 1
            return Outcome("duplicate", "uid")
        try:
            rec = self.validate(msg, remote=True)
        except TourRejected as err:
            sender = msg.editor_robot if isinstance(msg.editor_robot, str) else "?"
            return self.reject(err.reason, f"{err} (uid {_short(msg.uid, 80)}, editor {_short(sender, 40)})")
        old = self.records.get(rec.file_name)
        if old is not None and rec.key == old.key:
            self.counters["duplicate"] += 1
            return Outcome("duplicate", "version", record=old)
        if old is not None and rec.key < old.key:
            self.counters["stale"] += 1
            return Outcome("stale", "older", f"version {rec.version} of {rec.editor} is older than "
                                             f"{old.version} of {old.editor}", record=old)
        if old is None and len(self.records) >= self.limits.max_tours:
            return self.reject("limit", f"tour {rec.file_name}: the store already holds {len(self.records)} "
                                        f"records (at most {self.limits.max_tours})")
        try:
            done = self._apply(rec)
        except TourStoreError as err:
            self.counters["io_errors"] += 1
            self.log.error(f"cannot store tour {rec.file_name}: {err}")
            return Outcome("rejected", "io", str(err))
        self.counters["accepted"] += 1
        what = "deletion" if rec.deleted else ("tour" if old is None or old.deleted else "edit")
        self.log.info(f"applied {what} {rec.file_name} version {rec.version} by {rec.editor or 'seed'}"
                      f"{' (blocked)' if done.blocked else ''}")
        return Outcome("accepted", what, record=done)

    def peer_index(self, peer: str, entries: Sequence[IndexEntry], now: float) -> list[TourMessage]:
        """Anti-entropy: records ``peer`` lacks or holds in an older version, to re-publish.

        ``now`` is a monotonic time in s; one record is re-sent to one peer at most every
        ``StoreLimits.resend_period`` s while the peer's index still shows it lacks it.
        """
        if peer == self.robot:
            return []
        if peer not in self.robots:
            self.reject("robot", f"tour index from {_short(peer)}, which is not a robot of building "
                                 f"{self.building.id}")
            return []
        if len(entries) > self.limits.max_index_entries:
            self.reject("oversized", f"tour index from {peer} has {len(entries)} entries; at most "
                                     f"{self.limits.max_index_entries}")
            return []
        self.peers[peer] = list(entries)
        theirs = {e.file_name: (e.version, e.editor_robot) for e in entries if isinstance(e.file_name, str)}
        out: list[TourMessage] = []
        for name, rec in sorted(self.records.items()):
            have = theirs.get(name)
            if have is not None and have >= (rec.version, rec.editor):
                continue
            last = self._sent.get((peer, name))
            if last is not None and last[0] == rec.key and now - last[1] < self.limits.resend_period:
                continue
            self._sent[(peer, name)] = (rec.key, now)
            self.counters["resent"] += 1
            out.append(self.outgoing(rec))
        return out

    # ------------------------------------------------------------------ periodic work
    def step(self) -> bool:
        """Retry blocked or failed writes, prune old tombstones; True if the store changed."""
        changed = False
        for name, rec in list(self.records.items()):
            if not (rec.blocked or (rec.deleted and rec.disk)):
                continue
            entry = self.dir.lookup(name, self._read_limit)
            ours = entry.is_file and entry.sha256 != "" and entry.sha256 in (rec.sha256, rec.disk)
            if rec.deleted or entry.kind == "absent" or ours:   # else: still blocked, nothing to do
                done = self._materialise(rec)
                if done != rec:
                    self.records[name] = done
                    changed = True
        cutoff = self.wall_ns() - self.limits.tombstone_ttl_ns
        for name, rec in list(self.records.items()):
            if rec.deleted and not rec.disk and rec.version < cutoff:
                del self.records[name]
                self.counters["pruned"] += 1
                changed = True
        if changed:
            try:
                self._save()
            except TourStoreError as err:
                self.log.error(str(err))
        return changed

    def stats(self) -> dict[str, int]:
        live = sum(1 for r in self.records.values() if not r.deleted)
        return {"tours": live, "tombstones": len(self.records) - live, "blocked": len(self.blocked()),
                **dict(self.counters)}


def edit_result(msg: TourMessage, rec: TourRecord | None, reason: str, error: str) -> EditResultData:
    """The answer to the admin action ``msg``: stored as ``rec``, or refused for ``reason`` (``error`` says why)."""
    return EditResultData(uid=msg.uid if isinstance(msg.uid, str) else "",
                          file_name=msg.file_name if isinstance(msg.file_name, str) else "", deleted=bool(msg.deleted),
                          ok=rec is not None, version=rec.version if rec else 0, reason=reason, error=error)


def index_entries(file_names: Iterable[object], versions: Iterable[object], editors: Iterable[object],
                  deleted: Iterable[object]) -> list[IndexEntry]:
    """TourIndex parallel arrays as entries; raises ValueError if their lengths differ."""
    cols = [list(file_names), list(versions), list(editors), list(deleted)]
    if len({len(c) for c in cols}) != 1:
        raise ValueError(f"TourIndex arrays have different lengths {[len(c) for c in cols]}")
    out = []
    for name, version, editor, dead in zip(*cols, strict=True):
        if isinstance(name, str) and isinstance(version, int) and isinstance(editor, str):
            out.append(IndexEntry(name, version, editor, bool(dead)))
    return out
