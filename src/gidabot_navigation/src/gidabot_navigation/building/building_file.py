"""The building file as people wrote it (ROS-free): read and written back with its comments, key order, quoting
and layout kept (a ruamel.yaml round trip), new keys placed in the documented order, saved atomically with the
previous file kept as a backup. The building editor (``gidabot edit``) reads and writes ``building.yaml`` only
through here; nodes read it with :func:`gidabot_navigation.building.model.load_building`.

YAML 1.1, as PyYAML (and so every node) reads it: ``008`` is the string '008' and ``yes`` is true, as in the
loader; the ``%YAML 1.1`` directive the round trip would add is not written. A file loaded and dumped unchanged
is byte-identical (``maps/faculty/building.yaml`` and its variants are). New values are written as the faculty's
are: mappings in block style, lists of numbers (poses, pixels, polygons' points) in flow style, ``- `` items at
the key's indentation.
"""

from __future__ import annotations

import io
import os
import secrets
import tempfile
from collections.abc import Mapping
from pathlib import Path

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq
from ruamel.yaml.error import YAMLError

from gidabot_navigation.errors import BuildingError, Problem

FILE_NAME = "building.yaml"
BACKUP_SUFFIX = ".bak"
DIRECTIVE = "%YAML 1.1\n---\n"

# The documented key order of each kind of mapping (docs/building-format.md); keys not listed (added by a newer
# format) keep their place and new ones go last.
KEY_ORDER: dict[str, tuple[str, ...]] = {
    "building": ("id", "name", "draft", "floors", "locations", "connectors", "robots"),
    "floor": ("id", "names", "map", "blueprint", "blueprint_transform", "aligned_to", "keep_out"),
    "blueprint_transform": ("scale", "origin_px", "rotation"),
    "aligned_to": ("floor", "pose"),
    "keep_out": ("id", "polygon"),
    "names": ("eu", "en", "es"),
    "location": ("id", "floor", "pose", "names", "category", "featured"),
    "connector": ("id", "kind", "names", "serves", "meeting"),
    "meeting": ("floor", "pose"),
    "robot": ("name", "floor", "master_uri", "drive", "max_linear", "max_angular", "max_linear_accel",
              "max_angular_accel", "radius", "home", "relay_port", "sensors"),
}
# the kind of the mappings under a key (a list of them, or one)
CHILD_KIND = {"floors": "floor", "locations": "location", "connectors": "connector", "robots": "robot",
              "meeting": "meeting", "names": "names", "blueprint_transform": "blueprint_transform",
              "aligned_to": "aligned_to", "keep_out": "keep_out"}


def _yaml() -> YAML:
    y = YAML()
    y.version = (1, 1)
    y.preserve_quotes = True
    y.width = 4096
    y.indent(mapping=2, sequence=2, offset=0)
    return y


def load_text(text: str, source: str = FILE_NAME) -> CommentedMap:
    """The round-trip document of a building file's text; :class:`BuildingError` when it is not YAML or not a
    mapping."""
    try:
        doc = _yaml().load(text)
    except YAMLError as err:
        raise BuildingError([Problem(source, "file", f"not valid YAML: {err}")]) from err
    if doc is None:
        doc = CommentedMap()
    if not isinstance(doc, CommentedMap):
        raise BuildingError([Problem(source, "(top level)", f"expected a mapping, got {type(doc).__name__}")])
    return doc


def read(path: Path) -> CommentedMap:
    """:func:`load_text` of the file at ``path`` (:class:`BuildingError` when it cannot be read)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise BuildingError([Problem(str(path), "file", f"cannot read: {err}")]) from err
    return load_text(text, str(path))


def dump_text(doc: CommentedMap) -> str:
    """The text of ``doc`` as it is written to the file."""
    out = io.StringIO()
    _yaml().dump(doc, out)
    text = out.getvalue()
    return text[len(DIRECTIVE):] if text.startswith(DIRECTIVE) else text


def plain(value: object) -> object:
    """``value`` as plain dicts, lists and scalars (what :func:`~gidabot_navigation.building.model.building_from_doc`
    checks), with the scalars' types as PyYAML would read them."""
    if isinstance(value, Mapping):
        return {plain(k): plain(v) for k, v in value.items()}
    if isinstance(value, list):
        return [plain(v) for v in value]
    if isinstance(value, bool) or value is None:
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    if isinstance(value, str):
        return str(value)
    return value


def to_yaml(value: object, kind: str | None = None) -> object:
    """A plain value made ready to insert: mappings as :class:`CommentedMap` in the documented order of ``kind``
    (their children by :data:`CHILD_KIND`), lists of scalars (and of such lists: a polygon) in flow style. A value
    already in that form (from the document) is returned as it is."""
    if isinstance(value, (CommentedMap, CommentedSeq)):
        return value
    if isinstance(value, Mapping):
        out = CommentedMap()
        order = KEY_ORDER.get(kind or "", ())
        keys = [k for k in order if k in value] + [k for k in value if k not in order]
        for key in keys:
            out[key] = to_yaml(value[key], CHILD_KIND.get(str(key)))
        return out
    if isinstance(value, (list, tuple)):
        seq = CommentedSeq(to_yaml(v, kind) for v in value)
        if value and all(not isinstance(v, (Mapping, list, tuple)) for v in value) or value and all(
                isinstance(v, (list, tuple)) and all(not isinstance(x, (Mapping, list, tuple)) for x in v)
                for v in value):
            seq.fa.set_flow_style()
            for item in seq:
                if isinstance(item, CommentedSeq):
                    item.fa.set_flow_style()
        return seq
    return value


def set_key(mapping: CommentedMap, kind: str, key: str, value: object) -> None:
    """Set ``mapping[key]`` (a mapping of ``kind``): in place when the key is there (its comments kept), else
    inserted after the last key that comes before it in the documented order."""
    new = to_yaml(value, CHILD_KIND.get(key))
    if key in mapping:
        mapping[key] = new
        return
    order = KEY_ORDER.get(kind, ())
    before = order[:order.index(key)] if key in order else tuple(mapping)
    position = 0
    for i, existing in enumerate(mapping):
        if existing in before:
            position = i + 1
    mapping.insert(position, key, new)


def save(directory: Path, doc: CommentedMap) -> Path:
    """Write ``doc`` as ``directory/building.yaml`` atomically (a temporary file in the directory, flushed to disk,
    renamed over the file); the previous file, if any, is kept as ``building.yaml.bak``. Returns the file."""
    return write_atomically(directory / FILE_NAME, dump_text(doc).encode("utf-8"))


def write_atomically(path: Path, data: bytes) -> Path:
    """Replace ``path`` by ``data`` with no moment where it is missing or half written; the previous content is
    kept in ``<path>.bak`` (a hard link to the old file, made atomically too)."""
    directory = path.parent
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=directory)
    try:
        with os.fdopen(fd, "wb") as out:
            out.write(data)
            out.flush()
            os.fsync(out.fileno())
        if path.exists():
            os.chmod(tmp, path.stat().st_mode & 0o777)
            link = directory / f".{path.name}.bak.{secrets.token_hex(8)}"
            os.link(path, link)
            os.replace(link, path.with_name(path.name + BACKUP_SUFFIX))
        else:
            os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    dir_fd = os.open(directory, os.O_RDONLY | os.O_DIRECTORY)
    try:
        os.fsync(dir_fd)
    finally:
        os.close(dir_fd)
    return path
