"""The building being edited (ROS-free, web-free): its building file as a round-trip YAML tree, changed only by
edits, every change undoable.

An *edit* is plain data (what the editor's page sends): ``{"op": "set", "path": [...], "value": v}`` (a mapping
key, added in the documented key order when new, or a list item), ``{"op": "delete", "path": [...]}``,
``{"op": "insert", "path": [..., index], "value": v}`` (a list item; the list is made when missing) and
``{"op": "move", "path": [..., index], "to": index}`` (within a list). A path is the keys and list indices from
the top of the document: ``["locations", 3, "pose"]``. :meth:`BuildingDocument.apply` applies a list of edits
as one step (all or none: :class:`~gidabot_web.errors.EditError` names the edit that failed and why), which
:meth:`BuildingDocument.undo` takes back and :meth:`BuildingDocument.redo` does again. Values are plain data
(mappings with string keys, lists, strings, finite numbers, booleans); floats are kept to 4 decimals (0.1 mm,
0.0001 rad). A file a floor names (``map``, ``blueprint``) must be a plain name of a regular file in the building
folder: nothing outside it can be named (the names a building file already has are left as they are).

Comments, key order and layout of the file are kept (:mod:`gidabot_navigation.building.building_file`); the
values an edit adds are written like the rest (documented key order, poses on one line). A folder without a
``building.yaml`` starts from :func:`skeleton`: one floor per map_server map found in it, with the blueprint of
the same name, ready to be aligned.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from ruamel.yaml.comments import CommentedMap, CommentedSeq

from gidabot_navigation.building import building_file as bf
from gidabot_navigation.building.yaml_text import load_yaml
from gidabot_web.errors import EditError

SAFE_FILE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,127}\Z")
FILE_KEYS = ("map", "blueprint")
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".pgm", ".ppm", ".bmp", ".gif", ".webp")
MAX_DEPTH = 8
MAX_ITEMS = 20000
MAX_TEXT = 2000
MAX_HISTORY = 500
DECIMALS = 4

Path_ = tuple[str | int, ...]


@dataclass
class _Step:
    """One primitive change and what undoes it: ``kind`` set/delete/insert/remove/move at ``path``."""

    kind: str
    path: Path_
    value: object = None           # set, insert: the new value (already in YAML form)
    old: object = None             # set (when the key existed), delete, remove: the value taken away
    existed: bool = True           # set: whether the key was there
    position: int = 0              # set (new key), delete: the key's position in its mapping
    to: int = 0                    # move


@dataclass
class _Change:
    label: str
    steps: list[_Step] = field(default_factory=list)


def is_safe_file_name(name: object) -> bool:
    """A plain file name (no directory, no leading dot or dash): what a floor may name."""
    return isinstance(name, str) and bool(SAFE_FILE.match(name)) and name not in (".", "..")


def file_problem(directory: Path, name: object) -> str | None:
    """Why ``name`` cannot be a file the building names (None when it can): a plain name (letters, digits and
    ``_ . -``, not starting with ``.`` or ``-``, no directory) of a regular file of ``directory``, not a link."""
    if not is_safe_file_name(name):
        return "not a plain file name (letters, digits, '_', '.', '-' only, at most 128, not starting with '.' " \
               "or '-', no directory)"
    path = directory / str(name)
    try:
        if path.is_symlink():
            return "a symbolic link, not a file of the building folder"
        if not path.is_file():
            return "no such file in the building folder"
    except OSError as err:
        return f"cannot be read ({err.strerror})"
    return None


def folder_file(directory: Path, name: object) -> Path | None:
    """The regular file ``name`` of ``directory`` (not a symbolic link), or None."""
    return None if file_problem(directory, name) is not None else directory / str(name)


class BuildingDocument:
    """The building file of ``directory`` being edited (see the module docstring)."""

    def __init__(self, directory: Path, doc: CommentedMap, existed: bool) -> None:
        self.directory = directory.resolve()
        self.doc = doc
        self.existed = existed            # building.yaml was there when the editor opened the folder
        self.revision = 0                 # grows with every change (edit, undo, redo)
        self.saved_revision = 0 if existed else -1
        self._undo: list[_Change] = []
        self._redo: list[_Change] = []

    # -- opening ----------------------------------------------------------------------------------------------
    @classmethod
    def open(cls, directory: Path) -> BuildingDocument:
        """The building of ``directory``: its building.yaml, or a :func:`skeleton` of the maps it holds
        (:class:`~gidabot_navigation.errors.BuildingError` when the file is not a YAML mapping)."""
        directory = Path(directory)
        path = directory / bf.FILE_NAME
        if path.exists():
            return cls(directory, bf.read(path), existed=True)
        return cls(directory, bf.to_yaml(skeleton(directory), "building"), existed=False)  # type: ignore[arg-type]

    # -- reading ----------------------------------------------------------------------------------------------
    @property
    def path(self) -> Path:
        return self.directory / bf.FILE_NAME

    def plain(self) -> dict:
        """The document as plain data (what the checks and the page see)."""
        return bf.plain(self.doc)  # type: ignore[return-value]

    def text(self) -> str:
        return bf.dump_text(self.doc)

    @property
    def dirty(self) -> bool:
        return self.revision != self.saved_revision

    def can_undo(self) -> str | None:
        """The label of the change :meth:`undo` would take back, or None."""
        return self._undo[-1].label if self._undo else None

    def can_redo(self) -> str | None:
        return self._redo[-1].label if self._redo else None

    # -- changing ---------------------------------------------------------------------------------------------
    def apply(self, edits: list[dict], label: str) -> None:
        """Apply ``edits`` as one undoable change (all or none)."""
        if not isinstance(edits, list) or not edits:
            raise EditError("expected a non-empty list of edits")
        if len(edits) > 1000:
            raise EditError(f"{len(edits)} edits in one change: at most 1000")
        change = _Change(_label(label))
        try:
            for i, edit in enumerate(edits):
                try:
                    self._edit(edit, change)
                except EditError as err:
                    raise EditError(f"edit {i + 1} of {len(edits)} ({_describe(edit)}): {err}") from err
        except BaseException:
            for step in reversed(change.steps):
                self._undo_step(step)
            raise
        self._undo.append(change)
        del self._undo[:-MAX_HISTORY]
        self._redo.clear()
        self.revision += 1

    def undo(self) -> str | None:
        """Take back the last change; its label, or None when there is nothing to undo."""
        if not self._undo:
            return None
        change = self._undo.pop()
        for step in reversed(change.steps):
            self._undo_step(step)
        self._redo.append(change)
        self.revision += 1
        return change.label

    def redo(self) -> str | None:
        """Do again the change last undone; its label, or None."""
        if not self._redo:
            return None
        change = self._redo.pop()
        for step in change.steps:
            self._do_step(step)
        self._undo.append(change)
        self.revision += 1
        return change.label

    def mark_saved(self) -> None:
        self.saved_revision = self.revision

    # -- edits ------------------------------------------------------------------------------------------------
    def _edit(self, edit: object, change: _Change) -> None:
        if not isinstance(edit, Mapping):
            raise EditError(f"an edit is a mapping with 'op' and 'path', got {_short(edit)}")
        op = edit.get("op")
        path = _path(edit.get("path"))
        if op == "set":
            value = self._value(path, edit.get("value"), "value" in edit)
            parent = self._container(path[:-1])
            key = path[-1]
            if isinstance(parent, CommentedMap):
                if not isinstance(key, str):
                    raise EditError(f"{_show(path)}: a mapping's key is a string")
                existed = key in parent
                step = _Step("set", path, value=value, existed=existed, old=parent.get(key),
                             position=list(parent).index(key) if existed else 0)
            else:
                _index(parent, key, path, len(parent))
                step = _Step("set", path, value=value, old=parent[key])  # type: ignore[index]
        elif op == "delete":
            parent = self._container(path[:-1])
            key = path[-1]
            if isinstance(parent, CommentedMap):
                if key not in parent:
                    raise EditError(f"{_show(path)} is not in the document")
                step = _Step("delete", path, old=parent[key], position=list(parent).index(key))
            else:
                _index(parent, key, path, len(parent))
                step = _Step("remove", path, old=parent[key])  # type: ignore[index]
        elif op == "insert":
            value = self._value(path, edit.get("value"), "value" in edit)
            parent_path = path[:-1]
            if self._find(parent_path) is None:
                self._create_list(parent_path, change)
            parent = self._container(parent_path)
            if not isinstance(parent, CommentedSeq):
                raise EditError(f"{_show(parent_path)} is not a list")
            _index(parent, path[-1], path, len(parent) + 1)
            step = _Step("insert", path, value=value)
        elif op == "move":
            parent = self._container(path[:-1])
            if not isinstance(parent, CommentedSeq):
                raise EditError(f"{_show(path[:-1])} is not a list")
            _index(parent, path[-1], path, len(parent))
            to = edit.get("to")
            _index(parent, to, path, len(parent))
            step = _Step("move", path, to=int(to))  # type: ignore[arg-type]
        else:
            raise EditError(f"unknown op {_short(op)} (set, delete, insert, move)")
        self._do_step(step)
        change.steps.append(step)

    def _create_list(self, path: Path_, change: _Change) -> None:
        """Add the missing list at ``path`` (its parent a mapping that exists) as a step of ``change``."""
        if not path or not isinstance(path[-1], str):
            raise EditError(f"{_show(path)} is not in the document")
        parent = self._container(path[:-1])
        if not isinstance(parent, CommentedMap):
            raise EditError(f"{_show(path[:-1])} is not a mapping")
        step = _Step("set", path, value=bf.to_yaml([]), existed=False)
        self._do_step(step)
        change.steps.append(step)

    def _value(self, path: Path_, value: object, given: bool) -> object:
        if not given:
            raise EditError("no value given")
        checked = _checked(value, 0, [0])
        self._check_files(path, checked)
        return bf.to_yaml(checked, _kind(path))

    def _check_files(self, path: Path_, value: object) -> None:
        """A floor's map or blueprint set by an edit must be a plain name of a file in the building folder."""
        in_floor = len(path) >= 2 and path[0] == "floors"
        targets: list[tuple[str, object]] = []
        if in_floor and len(path) == 3 and path[2] in FILE_KEYS:
            targets.append((str(path[2]), value))
        elif in_floor and len(path) == 2 and isinstance(value, Mapping):
            targets += [(k, value[k]) for k in FILE_KEYS if k in value]
        elif path == ("floors",) and isinstance(value, list):
            targets += [(k, f[k]) for f in value if isinstance(f, Mapping) for k in FILE_KEYS if k in f]
        for key, name in targets:
            problem = file_problem(self.directory, name)
            if problem is not None:
                raise EditError(f"{key} {_short(name)}: not a file of the building folder: {problem}")
            if key == "map":
                problem = _map_problem(self.directory, name)
                if problem is not None:
                    raise EditError(f"map {_short(name)}: {problem}")
            elif Path(str(name)).suffix.lower() not in IMAGE_SUFFIXES:
                raise EditError(f"blueprint {_short(name)}: not an image ({', '.join(IMAGE_SUFFIXES)})")

    def _find(self, path: Path_) -> object | None:
        node: object = self.doc
        for key in path:
            in_map = isinstance(node, CommentedMap) and isinstance(key, str) and key in node
            in_list = isinstance(node, CommentedSeq) and isinstance(key, int) and 0 <= key < len(node)
            if not (in_map or in_list):
                return None
            node = node[key]  # type: ignore[index]
        return node

    def _container(self, path: Path_) -> CommentedMap | CommentedSeq:
        node = self._find(path)
        if not isinstance(node, (CommentedMap, CommentedSeq)):
            raise EditError(f"{_show(path)} is not a mapping or list of the document")
        return node

    # -- primitive steps (no checks: the edits checked them) ----------------------------------------------------
    def _do_step(self, step: _Step) -> None:
        parent = self._find(step.path[:-1])
        key = step.path[-1]
        if step.kind == "set":
            if isinstance(parent, CommentedMap):
                bf.set_key(parent, _kind(step.path[:-1]), str(key), step.value)
            else:
                parent[key] = step.value  # type: ignore[index]
        elif step.kind == "delete":
            del parent[key]  # type: ignore[union-attr]
        elif step.kind == "insert":
            parent.insert(key, step.value)  # type: ignore[union-attr]
        elif step.kind == "remove":
            del parent[key]  # type: ignore[union-attr]
        elif step.kind == "move":
            item = parent.pop(key)  # type: ignore[union-attr]
            parent.insert(step.to, item)  # type: ignore[union-attr]

    def _undo_step(self, step: _Step) -> None:
        parent = self._find(step.path[:-1])
        key = step.path[-1]
        if step.kind == "set":
            if not step.existed:
                del parent[key]  # type: ignore[union-attr]
            else:
                parent[key] = step.old  # type: ignore[index]
        elif step.kind == "delete":
            parent.insert(step.position, key, step.old)  # type: ignore[union-attr]
        elif step.kind == "insert":
            del parent[key]  # type: ignore[union-attr]
        elif step.kind == "remove":
            parent.insert(key, step.old)  # type: ignore[union-attr]
        elif step.kind == "move":
            item = parent.pop(step.to)  # type: ignore[union-attr]
            parent.insert(key, item)  # type: ignore[union-attr]


# -- helpers -------------------------------------------------------------------------------------------------
def _kind(path: Path_) -> str:
    """The kind (building_file.KEY_ORDER) of what lives at ``path``: the mapping there, or the items of the list
    there."""
    if not path:
        return "building"
    for key in reversed(path):
        if isinstance(key, str):
            return bf.CHILD_KIND.get(key, "")
    return ""


def _path(value: object) -> Path_:
    if not isinstance(value, list) or not value or len(value) > MAX_DEPTH:
        raise EditError(f"path {_short(value)}: expected a list of 1 to {MAX_DEPTH} keys and indices")
    out: list[str | int] = []
    for part in value:
        if isinstance(part, bool) or not isinstance(part, (str, int)) or (isinstance(part, str) and len(part) > 64):
            raise EditError(f"path {_short(value)}: {_short(part)} is not a key or an index")
        out.append(part)
    return tuple(out)


def _index(seq: object, key: object, path: Path_, limit: int) -> None:
    if isinstance(key, bool) or not isinstance(key, int) or not 0 <= key < limit:
        raise EditError(f"{_show(path)}: index {_short(key)} out of range (0..{limit - 1})")


def _checked(value: object, depth: int, count: list[int]) -> object:
    """``value`` if it is plain data within the limits (floats rounded to DECIMALS), else EditError."""
    count[0] += 1
    if count[0] > MAX_ITEMS or depth > MAX_DEPTH:
        raise EditError("value too large or too deep")
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise EditError(f"{value!r} is not a finite number")
        return round(value, DECIMALS)
    if isinstance(value, str):
        if len(value) > MAX_TEXT:
            raise EditError(f"a text of {len(value)} characters: at most {MAX_TEXT}")
        return value
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str) or len(k) > 64:
                raise EditError(f"key {_short(k)}: a mapping's keys are short strings")
            out[k] = _checked(v, depth + 1, count)
        return out
    if isinstance(value, (list, tuple)):
        return [_checked(v, depth + 1, count) for v in value]
    raise EditError(f"{_short(value)} is not plain data")


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _show(path: Path_) -> str:
    out = ""
    for key in path:
        out += f"[{key}]" if isinstance(key, int) else (f".{key}" if out else str(key))
    return out or "(top level)"


def _describe(edit: object) -> str:
    if isinstance(edit, Mapping):
        path = edit.get("path")
        return f"{edit.get('op')} {_show(tuple(path)) if isinstance(path, list) else _short(path)}"
    return _short(edit)


def _label(label: object) -> str:
    return label[:120] if isinstance(label, str) and label.strip() else "change"


# -- a new building ------------------------------------------------------------------------------------------
FLOOR_NAMES = {"eu": "{n}. solairua", "en": "Floor {n}", "es": "Planta {n}"}


def _map_doc(path: Path) -> dict | None:
    """A map_server map YAML's content, or None when ``path`` is not one."""
    try:
        doc = load_yaml(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return None
    return doc if isinstance(doc, dict) and {"image", "resolution", "origin"} <= set(doc) else None


def _map_problem(directory: Path, name: object) -> str | None:
    """Why the file ``name`` of ``directory`` is not a map the building can name (None when it is)."""
    doc = _map_doc(directory / str(name))
    if doc is None:
        return "not a map_server map (YAML with image, resolution and origin)"
    problem = file_problem(directory, doc["image"])
    return None if problem is None else f"its image {_short(doc['image'])}: {problem}"


def folder_maps(directory: Path) -> list[tuple[str, dict]]:
    """The map_server map files of ``directory`` whose image is a file of it too (name, their YAML), by name."""
    found = []
    for path in sorted(directory.iterdir()):
        if path.suffix not in (".yaml", ".yml") or path.name == bf.FILE_NAME or folder_file(directory, path.name) \
                is None:
            continue
        doc = _map_doc(path)
        if doc is not None and folder_file(directory, doc["image"]) is not None:
            found.append((path.name, doc))
    return found


def folder_images(directory: Path) -> list[str]:
    """The image files of ``directory`` (plain names), by name."""
    return sorted(p.name for p in directory.iterdir()
                  if p.suffix.lower() in IMAGE_SUFFIXES and folder_file(directory, p.name) is not None)


def left_out(directory: Path) -> list[dict]:
    """The images and map YAMLs of ``directory`` the editor cannot offer, each with the reason (a name that is
    not plain, a link, a map whose image is not a file of the folder), to show rather than skip silently."""
    out = []
    for path in sorted(directory.iterdir(), key=lambda p: p.name):
        suffix = path.suffix.lower()
        if suffix not in (*IMAGE_SUFFIXES, ".yaml", ".yml") or path.name == bf.FILE_NAME:
            continue
        problem = file_problem(directory, path.name)
        if problem is None and suffix in (".yaml", ".yml") and _map_doc(path) is not None:
            problem = _map_problem(directory, path.name)
        if problem is not None:
            out.append({"name": path.name[:200], "reason": problem})
    return out


def skeleton(directory: Path) -> dict:
    """A new building for a folder holding only maps and blueprints: one floor per map (id from the number in its
    name, else its position), the blueprint with the map's name (else the next one left), a first guess of the
    blueprint transform (the map fitted into the image), no places, connectors or robots yet."""
    from PIL import Image

    maps = folder_maps(directory)
    map_images = {str(doc.get("image")) for _, doc in maps}
    blueprints = [name for name in folder_images(directory) if name not in map_images]
    floors: list[dict] = []
    used: set[float] = set()
    for i, (name, doc) in enumerate(maps):
        stem = Path(name).stem
        bp = next((b for b in blueprints if Path(b).stem == stem), None) or \
            next((b for b in blueprints if b not in {f["blueprint"] for f in floors}), None)
        numbers = re.findall(r"-?\d+(?:\.\d+)?", stem)
        fid: float = float(numbers[-1]) if numbers else float(i)
        while fid in used:
            fid += 1
        used.add(fid)
        fid_out: int | float = int(fid) if fid.is_integer() else fid
        floor: dict = {"id": fid_out, "names": {k: v.format(n=fid_out) for k, v in FLOOR_NAMES.items()},
                       "map": name, "blueprint": bp or ""}
        floor["blueprint_transform"] = {"scale": 10.0, "origin_px": [0.0, 0.0]}
        if bp is not None:
            try:
                with Image.open(directory / str(doc["image"])) as img:     # a file of the folder (folder_maps)
                    mw, mh = img.size
                with Image.open(directory / bp) as img:
                    bw, bh = img.size
                res = float(doc["resolution"])
                ox, oy = float(doc["origin"][0]), float(doc["origin"][1])
                scale = min(bw / (mw * res), bh / (mh * res))
                floor["blueprint_transform"] = {"scale": round(scale, DECIMALS),
                                                "origin_px": [round(-ox * scale, 2), round(bh + oy * scale, 2)]}
            except (OSError, ValueError, TypeError, KeyError, IndexError, ZeroDivisionError):
                pass
        floors.append(floor)
    name = directory.resolve().name or "building"
    building_id = re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:32].lstrip("._-") or "building"
    return {"id": building_id, "name": name, "floors": floors, "locations": [], "connectors": [], "robots": []}
