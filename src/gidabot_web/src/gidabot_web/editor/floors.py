"""Changes of a whole floor that reach across the building file (ROS-free, web-free): a floor's id changed
everywhere it is named, a floor removed with everything on it.

Both return the edits (:mod:`gidabot_web.editor.document`'s plain form) that :meth:`BuildingDocument.apply`
makes one undoable change of, computed from the document's plain data. A floor's id is named by its own
``id``, every location's, meeting pose's and robot's ``floor``, every connector's ``serves`` and the other
floors' ``aligned_to.floor``; ids are compared as the building model does (within
:data:`~gidabot_navigation.building.model.FLOOR_TOLERANCE`), and may be negative or fractional (a basement
-1, a mezzanine 0.5).
"""

from __future__ import annotations

import math

from gidabot_navigation.building.model import FLOOR_TOLERANCE
from gidabot_web.errors import EditError


def _same(a: object, b: float) -> bool:
    return isinstance(a, (int, float)) and not isinstance(a, bool) and abs(float(a) - b) < FLOOR_TOLERANCE


def _floors(data: dict) -> list[dict]:
    floors = data.get("floors")
    return [f if isinstance(f, dict) else {} for f in floors] if isinstance(floors, list) else []


def _floor_at(data: dict, index: object) -> tuple[int, float]:
    floors = _floors(data)
    if isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(floors):
        raise EditError(f"floor {index!r}: not the index of a floor (0 to {len(floors) - 1})")
    fid = floors[index].get("id")
    if isinstance(fid, bool) or not isinstance(fid, (int, float)):
        raise EditError(f"floors[{index}].id {fid!r}: not a number; set it first")
    return index, float(fid)


def _list(data: dict, key: str) -> list:
    value = data.get(key)
    return value if isinstance(value, list) else []


def renumber_edits(data: dict, index: object, new_id: object) -> list[dict]:
    """The edits that give floor ``index`` the id ``new_id`` and move every reference to its old id along."""
    index, old = _floor_at(data, index)
    if isinstance(new_id, bool) or not isinstance(new_id, (int, float)) or not math.isfinite(new_id):
        raise EditError(f"floor id {new_id!r}: must be a number (negative and fractional allowed: -1, 0.5)")
    value: int | float = int(new_id) if float(new_id).is_integer() else round(float(new_id), 4)
    for i, floor in enumerate(_floors(data)):
        if i != index and _same(floor.get("id"), float(value)):
            raise EditError(f"floor id {value}: floors[{i}] has it already")
    edits: list[dict] = [{"op": "set", "path": ["floors", index, "id"], "value": value}]
    for key in ("locations", "robots"):
        edits += [{"op": "set", "path": [key, i, "floor"], "value": value}
                  for i, item in enumerate(_list(data, key))
                  if isinstance(item, dict) and _same(item.get("floor"), old)]
    for i, conn in enumerate(_list(data, "connectors")):
        if not isinstance(conn, dict):
            continue
        edits += [{"op": "set", "path": ["connectors", i, "meeting", k, "floor"], "value": value}
                  for k, m in enumerate(_list(conn, "meeting")) if isinstance(m, dict) and _same(m.get("floor"), old)]
        edits += [{"op": "set", "path": ["connectors", i, "serves", k], "value": value}
                  for k, s in enumerate(_list(conn, "serves")) if _same(s, old)]
    for i, floor in enumerate(_floors(data)):
        aligned = floor.get("aligned_to")
        if i != index and isinstance(aligned, dict) and _same(aligned.get("floor"), old):
            edits.append({"op": "set", "path": ["floors", i, "aligned_to", "floor"], "value": value})
    return edits


def removal_edits(data: dict, index: object) -> list[dict]:
    """The edits that remove floor ``index`` with its places, robots, meeting poses, its entries in the
    connectors' ``serves`` and the other floors' alignment to it (list items removed from the last, so each
    edit's indices hold when it is applied)."""
    index, fid = _floor_at(data, index)
    edits: list[dict] = []
    for key in ("robots", "locations"):
        items = _list(data, key)
        edits += [{"op": "delete", "path": [key, i]} for i in reversed(range(len(items)))
                  if isinstance(items[i], dict) and _same(items[i].get("floor"), fid)]
    for i, conn in enumerate(_list(data, "connectors")):
        if not isinstance(conn, dict):
            continue
        meeting = _list(conn, "meeting")
        edits += [{"op": "delete", "path": ["connectors", i, "meeting", k]} for k in reversed(range(len(meeting)))
                  if isinstance(meeting[k], dict) and _same(meeting[k].get("floor"), fid)]
        serves = _list(conn, "serves")
        edits += [{"op": "delete", "path": ["connectors", i, "serves", k]} for k in reversed(range(len(serves)))
                  if _same(serves[k], fid)]
    for i, floor in enumerate(_floors(data)):
        aligned = floor.get("aligned_to")
        if i != index and isinstance(aligned, dict) and _same(aligned.get("floor"), fid):
            edits.append({"op": "delete", "path": ["floors", i, "aligned_to"]})
    edits.append({"op": "delete", "path": ["floors", index]})
    return edits
